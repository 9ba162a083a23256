"""``uav-bench calibrate``: payoff-table normalisation constants (paper §4.2) written into a scenario file."""

from __future__ import annotations

import argparse
import inspect
import sys
from pathlib import Path

from uav_penetration_env.atomic import NotRegularFileError, check_replaceable
from uav_penetration_env.benchmark.commands.common import (
    CLIError,
    Command,
    check_writable_folder,
    command_line,
    int_at_least,
    path_argument,
    resolve_scenarios,
    split_list,
)
from uav_penetration_env.suggest import did_you_mean


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench calibrate``."""
    from uav_penetration_env.catalogue import SCENARIO_HELP

    parser.add_argument("--scenario", default="paper", help=f"{SCENARIO_HELP} (default: paper)")
    parser.add_argument("--optimizer", required=True, help="reference optimiser, e.g. ihpso")
    # Defaults are payoff_table's own (api.md: --runs 20 --horizon 10; the MPC budget per step).
    defaults = _payoff_defaults()
    parser.add_argument(
        "--max-evals",
        dest="max_evals",
        type=int_at_least(1),
        default=defaults["max_evals"],
        help=f"objective evaluations per planning step (default: {defaults['max_evals']})",
    )
    parser.add_argument(
        "--runs",
        type=int_at_least(1),
        default=defaults["runs"],
        help=f"episodes per objective (default: {defaults['runs']})",
    )
    parser.add_argument(
        "--horizon",
        type=int_at_least(1),
        default=defaults["horizon"],
        help=f"MPC horizon H (default: {defaults['horizon']})",
    )
    parser.add_argument("--jobs", type=int, default=None, help="worker processes (default: all cores)")
    parser.add_argument(
        "--import", dest="imports", action="append", help="a plug-in module to import (repeatable)"
    )
    parser.add_argument("--out", type=path_argument, required=True, help="scenario YAML to write")


def _payoff_defaults() -> dict[str, int]:
    from uav_penetration_env.benchmark.calibration import payoff_table

    parameters = inspect.signature(payoff_table).parameters
    return {name: parameters[name].default for name in ("max_evals", "runs", "horizon")}


def run(args: argparse.Namespace) -> int:
    """Run the payoff table's episodes and write the calibrated scenario."""
    from optimizers import available_optimizers
    from uav_penetration_env.benchmark.calibration import CalibrationFailed, payoff_table, with_payoff
    from uav_penetration_env.benchmark.evaluate import import_plugins

    imports = split_list(args.imports)
    try:
        import_plugins(imports)
    except ImportError as error:
        raise CLIError(f"--import: {error}") from None
    known = available_optimizers()
    if args.optimizer not in known:
        raise CLIError(
            f"--optimizer: unknown optimizer {args.optimizer!r} — {did_you_mean(args.optimizer, known)}"
            f"known: {', '.join(known)}"
        )
    (scenario,) = resolve_scenarios([args.scenario], flag="--scenario")
    out = Path(args.out)
    check_writable_folder(out.parent, "--out")
    try:  # refused before the minutes of calibration, not after them
        check_replaceable(out)
    except NotRegularFileError as error:
        raise CLIError(f"--out {args.out}: {error.strerror}") from None
    try:
        payoff = payoff_table(
            scenario, args.optimizer, max_evals=args.max_evals, runs=args.runs, horizon=args.horizon,
            n_jobs=args.jobs, imports=tuple(imports), command=command_line(args),
        )  # fmt: skip
    except CalibrationFailed as error:  # the work failed, not the input: exit status 1, nothing written
        print(f"uav-bench calibrate: FAILED, no scenario written: {error}", file=sys.stderr)
        return 1
    with_payoff(scenario, payoff).to_yaml(out)
    constants = payoff.constants
    print(
        f"terrain {constants.terrain}, radar {constants.radar}, third {constants.third}, crash penalty/step {constants.crash_penalty_per_step:.6g}"
    )
    print(f"calibrated scenario written to {out}")
    return 0


COMMAND = Command(
    name="calibrate",
    help="payoff-table normalisation constants (paper §4.2) into a scenario file",
    add_arguments=add_arguments,
    run=run,
)
