"""What the argument checks of the model's entry points cost (api.md §2.5).

For each hot entry point (``step`` and ``observe`` of a single env, ``step`` of a 256-row batch,
``rollout_cost`` on an MPC batch, ``height``) it prints the median time of the public call, the
time of the same checks called alone, and their share of the call. Run from the repository root:

    python benchmarks/bench_checks.py            # about 10 s
    python benchmarks/bench_checks.py --quick    # a smoke run

On a tree without ``uav_penetration_env.checks`` (a version before the checks) it prints the
public calls alone, for a before/after comparison.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from uav_penetration_env import PenetrationModel, paper_scenario

try:
    from uav_penetration_env import checks
except ImportError:  # a tree before the checks: public calls only
    checks = None


def per_call_us(function: Callable[[], object], repeats: int, rounds: int = 15) -> float:
    """Best over ``rounds`` of the mean time of ``repeats`` calls, in microseconds (the least disturbed)."""
    function()  # compile / warm caches
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        for _ in range(repeats):
            function()
        times.append((time.perf_counter() - start) / repeats * 1e6)
    return min(times)


def _distance_terminal(model: PenetrationModel) -> object:
    """The distance form at c_T = 0.06, as ``rollout_cost`` takes it (a number on a tree before issue 41)."""
    try:
        from uav_penetration_env.mpc import Terminal
        from uav_penetration_env.terminal import terminal_cost
    except ImportError:
        return 0.06
    return terminal_cost(model, Terminal("distance", 0.06))


def cases(model: PenetrationModel) -> dict[str, tuple[Callable[[], object], Callable[[], object] | None]]:
    """Name -> (public call, the checks it runs, called alone)."""
    k_max = model.max_steps
    state = model.initial_state()
    states1, controls1 = state[None].copy(), np.zeros((1, 3))
    result1 = model.step(states1, controls1, 0)
    rng = np.random.default_rng(0)
    states256 = np.repeat(state[None], 256, axis=0)
    controls256 = rng.uniform(-1.0, 1.0, (256, 3)) * model.limits.action_high
    plans = rng.uniform(-1.0, 1.0, (100, 5, 3)) * model.limits.action_high
    x, y = np.array([1000.0]), np.array([2000.0])
    distance = _distance_terminal(model)
    table = {
        "step, 1 row (single env)": (lambda: model.step(states1, controls1, 3), None),
        "observe, 1 row (single env)": (lambda: model.observe(result1.state, 1, result1), None),
        "step, 256 rows (vector env)": (lambda: model.step(states256, controls256, 3), None),
        "rollout_cost, 100 x H=5 (MPC)": (
            lambda: model.rollout_cost(state, plans, step=3, discount=0.95, terminal_cost=distance),
            None,
        ),
        "height, 1 point": (lambda: model.height(x, y), None),
    }
    if checks is None:
        return table

    def step_checks(states: np.ndarray, controls: np.ndarray) -> None:
        model._batch(states, "states", 6)
        model._batch(controls, "controls", 3)
        model._step_indices(3, len(states), k_max - 1)
        model._rows(None, len(states))

    def observe_checks() -> None:
        model._batch(result1.state, "states", 6)
        model._step_indices(1, 1, k_max)
        model._rows(None, 1)

    def rollout_checks() -> None:
        checks.finite_array(plans, "controls", (None, None, 3), "")
        checks.finite_array(state, "state", (6,), "")
        checks.integer_scalar(3, "step", 0, k_max, "")
        checks.real_scalar(0.95, "discount", 0.0, 1.0, "", open_low=True)
        model._terminal(distance)
        checks.integer_scalar(0, "scenario_index", 0, model.pool_size - 1, "")

    def height_checks() -> None:  # the broadcast was there before the checks: not counted
        checks.as_float_array(x, "x_m", ""), checks.as_float_array(y, "y_m", "")
        checks.all_finite(np.ascontiguousarray(x)), checks.all_finite(np.ascontiguousarray(y))

    checked = {
        "step, 1 row (single env)": lambda: step_checks(states1, controls1),
        "observe, 1 row (single env)": observe_checks,
        "step, 256 rows (vector env)": lambda: step_checks(states256, controls256),
        "rollout_cost, 100 x H=5 (MPC)": rollout_checks,
        "height, 1 point": height_checks,
    }
    return {name: (call, checked[name]) for name, (call, _) in table.items()}


def main(argv: Sequence[str] | None = None) -> dict[str, float]:
    """Print the table; return ``{name: checks_us}`` (or public-call times on a tree without checks)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="few repeats (a smoke run)")
    args = parser.parse_args(argv)
    repeats = 50 if args.quick else 2_000
    model = PenetrationModel(paper_scenario())
    print(
        f"argument checks of PenetrationModel (paper scenario, K_max = {model.max_steps}); best of 15 rounds"
    )
    print(f"{'entry point':<32}{'public call':>14}{'checks alone':>15}{'share':>8}")
    results = {}
    for name, (call, checked) in cases(model).items():
        public = per_call_us(call, repeats)
        if checked is None:
            print(f"{name:<32}{public:>11.1f} us{'-':>15}{'-':>8}")
            results[name] = public
            continue
        alone = per_call_us(checked, repeats)
        print(f"{name:<32}{public:>11.1f} us{alone:>12.1f} us{alone / public:>8.0%}")
        results[name] = alone
    return results


if __name__ == "__main__":
    main()
