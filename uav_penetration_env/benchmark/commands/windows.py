"""``uav-bench windows``: rerun optimisers on MPC window states of stored episodes (api.md §4.8).

``uav-bench windows --store S --from-policy greedy --scenario paper --steps 4,10,16 --optimizers
ihpso hpso --seeds 20 --max-evals 10000`` replays the stored episode of ``greedy`` on ``paper``,
takes its states at steps 4, 10 and 16, and runs each optimiser on each state's MPC objective with
seeds 0..19, writing one ``window_runs`` row per run with its per-iteration history. A rerun skips
the runs already stored. ``uav-bench leaderboard`` and ``plot`` then add the fixed-target tables
and the runtime-ECDF figure (:mod:`uav_penetration_env.benchmark.fixedtarget`).
"""

from __future__ import annotations

import argparse

from uav_penetration_env.benchmark.commands.common import (
    CLIError,
    Command,
    add_store_argument,
    command_line,
    existing_store,
    parse_seeds,
    split_list,
)
from uav_penetration_env.benchmark.commands.mpc_flags import add_mpc_arguments, mpc_settings, setting_error
from uav_penetration_env.mpc import MPCSettings, SettingError
from uav_penetration_env.suggest import did_you_mean


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench windows``."""
    add_store_argument(parser)
    parser.add_argument(
        "--from-policy",
        default="greedy",
        help="policy whose stored episodes give the states (default: greedy)",
    )
    parser.add_argument(
        "--scenario", default="paper", help="stored scenario name or hash prefix (default: paper)"
    )
    parser.add_argument(
        "--steps", required=True, help="window step indices, e.g. 4,10,16 (0 = the start state)"
    )
    parser.add_argument(
        "--episode-seeds", help="seeds of the source episodes, N or START:STOP (default: the smallest stored)"
    )
    parser.add_argument(
        "--optimizers", nargs="+", default=["ihpso", "hpso"], help="optimiser names (default: ihpso hpso)"
    )
    parser.add_argument("--seeds", default="20", help="run seeds per window, N or START:STOP (default: 20)")
    add_mpc_arguments(parser)  # the budget is per run; the windows' objectives are the planner's


def window_settings(args: argparse.Namespace) -> MPCSettings:
    """The one :class:`MPCSettings` of every window's objective and run, from the MPC flags.

    Raises:
        CLIError: a flag outside its domain, or a c_T with a form that has none (``--terminal-cost: ...``).
    """
    settings = mpc_settings(args)
    try:
        settings.check_terminal_pair()
    except SettingError as error:
        raise setting_error(error) from None
    return settings


def parse_steps(text: str) -> list[int]:
    """``4,10,16`` -> [4, 10, 16] (sorted, unique).

    Raises:
        CLIError: not comma-separated integers >= 0.
    """
    try:
        steps = sorted({int(part) for part in split_list(text)})
    except ValueError:
        steps = []
    if not steps or steps[0] < 0:
        raise CLIError(f"--steps: got {text!r}, expected comma-separated step indices >= 0, e.g. 4,10,16")
    return steps


def _check_one_scenario(spec: str) -> None:
    """Refuse a ``random:A-B`` range: ``--scenario`` names ONE stored scenario.

    Checked on the seeds' count, before any scenario is generated (a range of 100 000 used to be
    generated whole before the store was read).
    """
    from uav_penetration_env.catalogue import RANDOM_PREFIX, random_seeds
    from uav_penetration_env.scenario import ScenarioError

    if not spec.startswith(RANDOM_PREFIX):
        return
    try:
        count = len(random_seeds(spec))
    except ScenarioError:
        return  # not a random: form; collect_windows may still find it as a stored name
    if count != 1:
        raise CLIError(
            f"--scenario: got {spec!r}, expected one stored scenario: a name, a hash prefix or random:SEED "
            f"(this range names {count} scenarios)"
        )


def run(args: argparse.Namespace) -> int:
    """Collect the windows, run the optimisers, store the rows and print one line per window."""
    from optimizers import available_optimizers
    from uav_penetration_env.benchmark.provenance import provenance
    from uav_penetration_env.benchmark.store import ResultsStore
    from uav_penetration_env.benchmark.windows import collect_windows, run_windows
    from uav_penetration_env.catalogue import UnknownScenarioError
    from uav_penetration_env.catalogue import resolve_scenarios as resolve_catalogue
    from uav_penetration_env.scenario import ScenarioError

    steps = parse_steps(args.steps)
    seeds = parse_seeds(args.seeds)
    episode_seeds = parse_seeds(args.episode_seeds, "--episode-seeds") if args.episode_seeds else None
    optimizers = split_list(args.optimizers)
    known = available_optimizers()
    for name in optimizers:
        if name not in known:
            raise CLIError(
                f"--optimizers: unknown optimiser {name!r} — {did_you_mean(name, known)}known: {', '.join(known)}"
            )
    mpc = window_settings(args)
    _check_one_scenario(args.scenario)
    with ResultsStore(existing_store(args.store)) as store:
        scenario = args.scenario
        if scenario not in set(store.episodes()["scenario"].astype(str)):
            # A catalogue name (``paper``) stands for the name of the scenario it resolves to.
            try:
                (resolved,) = resolve_catalogue(scenario)
                scenario = resolved.name
            except (UnknownScenarioError, ScenarioError, ValueError):
                pass  # not a catalogue name: a stored hash prefix, or an error collect_windows words
        try:
            windows = collect_windows(
                store,
                source_policy=args.from_policy,
                scenario=scenario,
                steps=steps,
                episode_seeds=episode_seeds,
                settings=mpc,
            )
        except ValueError as error:
            raise CLIError(str(error)) from None
        settings = {
            "command": "windows",
            "from_policy": args.from_policy,
            "scenario": args.scenario,
            "steps": steps,
            "optimizers": optimizers,
            "seeds": seeds,
            "max_evals": mpc.max_evals,
            "horizon": mpc.horizon,
        }
        run_id = store.start_run(provenance(command_line(args)), settings)
        rows = run_windows(
            windows,
            optimizers,
            seeds,
            done=store.done_window_keys(),
            write=store.write_window_runs,
            progress=print,
            run_id=run_id,
        )
    print(f"{len(rows)} window runs written to {args.store}")
    return 0


COMMAND = Command(
    name="windows",
    help="rerun optimisers on MPC window states of stored episodes (fixed-target analysis)",
    add_arguments=add_arguments,
    run=run,
)
