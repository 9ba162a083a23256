"""``uav-bench timing``: planners timed side by side, cold per-map setup and interleaved decisions, in one process.

The only source of a published speed ratio (docs/publishing.md §6; api.md §4.12): every planner is
set up cold on each map and decides on the same states, in rotating order, in this one process
(:mod:`~uav_penetration_env.benchmark.timing`). Prints per planner the setup and per-step CPU and
wall times and the per-step and per-map ratios to the reference with bootstrap intervals;
``--out DIR`` writes ``timing.csv`` (the summary), ``timing-setups.csv`` and ``timing-steps.csv``
(every measurement).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from uav_penetration_env.benchmark.commands.common import (
    CLIError,
    Command,
    check_writable_folder,
    command_line,
    int_at_least,
    parse_seeds,
    path_argument,
    resolve_scenarios,
    write_csv_tables,
)
from uav_penetration_env.benchmark.commands.mpc_flags import add_mpc_arguments, mpc_settings


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench timing``."""
    parser.add_argument("--policies", nargs="+", required=True, metavar="NAME",
                        help="planners to time; the first flies the episode (its actions), the others decide on its states")  # fmt: skip
    parser.add_argument("--reference", default=None, help="the planner the ratios divide by (default: the last of --policies)")
    parser.add_argument("--scenarios", nargs="+", default=["paper"], metavar="SCENARIO",
                        help="maps: catalogue names, random:SEED[-SEED] forms or YAML files (default: paper)")  # fmt: skip
    parser.add_argument("--seeds", default="1", type=str, help="episode seeds per scenario: N (0..N-1) or START:STOP (default 1)")
    parser.add_argument("--max-steps", type=int_at_least(1), default=None, help="decisions timed per map (default: the whole episode)")
    parser.add_argument("--threads", type=int_at_least(1), default=1, help="compiled threads (default 1, as a harness worker)")
    parser.add_argument("--out", type=path_argument, default=None, help="folder of timing.csv and the raw measurements")
    add_mpc_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """Time, print the summary, and write the files with --out."""
    seeds = parse_seeds(args.seeds)
    reference = args.reference or args.policies[-1]
    if reference not in args.policies:
        raise CLIError(f"--reference: got {reference!r}, expected one of --policies ({', '.join(args.policies)})")
    if len(set(args.policies)) != len(args.policies):
        raise CLIError("--policies: a planner is named twice; expected each once")
    if args.out is not None:
        check_writable_folder(Path(args.out), "--out")
    settings = mpc_settings(args)
    scenarios = resolve_scenarios(args.scenarios)
    from uav_penetration_env.benchmark.commands.run import make_policies
    from uav_penetration_env.benchmark.leaderboard.formatting import markdown_table
    from uav_penetration_env.benchmark.timing import summarise, time_planners
    from uav_penetration_env.kernels import limit_worker_threads

    policies = make_policies(args.policies, settings)
    limit_worker_threads(args.threads)
    setups, steps = time_planners(policies, scenarios, seeds, max_steps=args.max_steps)
    table = summarise(setups, steps, reference)
    body = [
        [str(r.policy), str(r.maps), str(r.steps), f"{r.setup_cpu:.3g}", f"{r.step_cpu_ms:.3g}", f"{r.step_wall_ms:.3g}",
         f"{r.step_ratio:.3g} [{r.step_ratio_low:.3g}, {r.step_ratio_high:.3g}]", f"{r.map_cpu:.3g}",
         f"{r.map_ratio:.3g}" + ("" if r.maps < 2 else f" [{r.map_ratio_low:.3g}, {r.map_ratio_high:.3g}]")]
        for r in table.itertuples()
    ]  # fmt: skip
    header = ["policy", "maps", "decisions", "setup [CPU s]", "step [CPU ms]", "step [wall ms]",
              f"step CPU / {reference}", "per map [CPU s]", f"per map / {reference}"]  # fmt: skip
    print(markdown_table(header, body, ["l", "r", "r", "r", "r", "r", "r", "r", "r"]))
    print(f"one process, {args.threads} compiled thread(s); setup cold (empty cache) per map; "
          "decisions interleaved on the first planner's states; 95 % bootstrap intervals over maps "
          "(over steps with one map)")  # fmt: skip
    if args.out is not None:
        tables = [("timing.csv", table.assign(command=command_line(args))),
                  ("timing-setups.csv", setups), ("timing-steps.csv", steps)]  # fmt: skip
        write_csv_tables(Path(args.out), tables)
    return 0


COMMAND = Command(
    name="timing",
    help="planners timed side by side: cold per-map setup and interleaved decisions, one process",
    add_arguments=add_arguments,
    run=run,
)
