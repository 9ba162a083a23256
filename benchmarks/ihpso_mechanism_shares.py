"""How often IHPSO's reverse switch and adaptive termination happen, and when (optimizers.md §5.6).

On MPC window states of the paper scenario (a greedy episode's states, the windows of
:func:`~uav_penetration_env.benchmark.windows.window_at`, warm-started with the episode's next H
controls, as ``benchmarks/ihpso_mechanisms.py`` builds them) the script runs the default ``ihpso``
for every (state, seed) at each budget and reads its trace (docs/swarm.md §6):

* reverse switch: the share of runs with at least one (accurate -> broad, eq. 33 false at a zero
  slope), and the first one's iteration relative to the budget's planned iteration count T
  (``planned_iterations``: 19, 49, 99 for 2 000, 5 000, 10 000 evaluations and 100 particles);
* adaptive termination: the share of runs that stopped by eq. 33, and the stop iteration / T;
* for context: the first broad -> accurate switch iteration, the number of eq. 33 tests per run and
  the evaluations used (share of the budget).

Iterations are given as median [quartiles] over the runs in which the event happened. Nothing is
tuned: the readings and the slope tolerance are IHPSO's defaults (optimizers.md D15, D16, D19).

Usage: ``python benchmarks/ihpso_mechanism_shares.py [--steps 3 9 ...] [--seeds 8]
[--budgets 2000 5000 10000] [--episode-seed 2]``.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DEFAULT_STEPS = (3, 9, 15, 21, 27, 33, 39, 45)  # spread over the greedy episode (47 steps)
DEFAULT_BUDGETS = (2_000, 5_000, 10_000)


def _mechanisms_module():
    """benchmarks/ihpso_mechanisms.py (its window collection), loaded by path."""
    spec = importlib.util.spec_from_file_location("ihpso_mechanisms", HERE / "ihpso_mechanisms.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def quartiles(values: list[float]) -> str:
    """``median [q1, q3]`` of ``values`` with two decimals, or ``-`` for none."""
    if not values:
        return "-"
    q1, median, q3 = np.percentile(values, [25, 50, 75])
    return f"{median:.2f} [{q1:.2f}, {q3:.2f}]"


def share_row(budget: int, traces: list[dict], nits: list[int], nfevs: list[int]) -> dict[str, str]:
    """One table row: the shares of runs with each event and when it happened (relative to T)."""
    from optimizers.swarm import planned_iterations

    planned = planned_iterations(budget, 100)
    runs = len(traces)
    reverse = [
        trace["reverse_switch_iterations"][0] / planned
        for trace in traces
        if trace["reverse_switch_iterations"]
    ]
    terminated = [
        nit / planned for trace, nit in zip(traces, nits, strict=True) if trace["stopped_by"] == "termination"
    ]
    switch = [trace["switch_iterations"][0] / planned for trace in traces if trace["switch_iterations"]]
    tests = [len(trace["termination_tests"]) for trace in traces]
    return {
        "budget": f"{budget:,}",
        "T": str(planned),
        "runs": str(runs),
        "reverse switch": f"{len(reverse)}/{runs} ({len(reverse) / runs:.0%})",
        "first reverse / T": quartiles(reverse),
        "termination": f"{len(terminated)}/{runs} ({len(terminated) / runs:.0%})",
        "stop / T": quartiles(terminated),
        "first switch / T": quartiles(switch),
        "eq. 33 tests/run": f"{np.mean(tests):.2f}",
        "evals used": f"{np.mean(nfevs) / budget:.0%}",
    }


def print_table(rows: list[dict[str, str]]) -> None:
    """A fixed-width table of ``rows`` (same keys)."""
    columns = list(rows[0])
    widths = [max(len(column), *(len(row[column]) for row in rows)) for column in columns]
    print("  ".join(column.rjust(width) for column, width in zip(columns, widths, strict=True)))
    for row in rows:
        print("  ".join(row[column].rjust(width) for column, width in zip(columns, widths, strict=True)))


def main(argv: list[str] | None = None) -> list[dict[str, str]]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, nargs="+", default=list(DEFAULT_STEPS), help="window steps")
    parser.add_argument("--seeds", type=int, default=8, help="seeds 0..N-1 per window state")
    parser.add_argument("--budgets", type=int, nargs="+", default=list(DEFAULT_BUDGETS), help="evaluations")
    parser.add_argument("--episode-seed", type=int, default=2, help="env seed of the greedy episode")
    args = parser.parse_args(argv)
    if args.seeds < 1 or any(b < 100 for b in args.budgets):
        parser.error(f"--seeds {args.seeds}, --budgets {args.budgets}: expected >= 1 seed and budgets >= 100")

    from optimizers import get_optimizer

    mechanisms = _mechanisms_module()
    start = time.perf_counter()
    windows = mechanisms.collect_windows(len(args.steps), max(args.budgets), args.episode_seed, args.steps)
    ihpso = get_optimizer("ihpso")
    print(
        f"IHPSO (defaults: slope_rtol {ihpso.slope_rtol:g}, level {ihpso.level}, spread {ihpso.spread}) on "
        f"paper-scenario windows: greedy episode (env seed {args.episode_seed}) steps {[w.step for w in windows]}, "
        f"seeds 0..{args.seeds - 1}, H = {mechanisms.HORIZON}"
    )
    rows = []
    for budget in args.budgets:
        traces, nits, nfevs = [], [], []
        for window in windows:
            for seed in range(args.seeds):
                result = mechanisms.run(ihpso, window, seed, budget)
                traces.append(result.trace)
                nits.append(int(result.nit))
                nfevs.append(int(result.nfev))
        rows.append(share_row(budget, traces, nits, nfevs))
    print_table(rows)
    print(f"({time.perf_counter() - start:.0f} s)")
    return rows


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
