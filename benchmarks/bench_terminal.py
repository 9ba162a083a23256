"""What each MPC terminal-cost form costs per rollout, as ratios measured in one run (model.md §7e).

The planners spend almost all their time in ``PenetrationModel.rollout_cost``; the terminal cost is
evaluated once per row at the window's end. This prints, on the paper scenario, particle-steps per
second of ``rollout_cost`` (H = 5, batches of 100 and 1 000 rows, one compiled thread) for each form
(``none``, ``distance``, ``dubins``, ``value``) and its ratio to ``distance`` (the v2 default),
interleaving the forms over repeats so a machine's load falls on all of them alike. Run it idle and
beside other work (``--load N`` starts N busy processes for the measurement) to see both.

Usage: ``python benchmarks/bench_terminal.py [--repeat 30] [--load 2]``
"""

from __future__ import annotations

import argparse
import multiprocessing
import sys
import time

import numba
import numpy as np

from uav_penetration_env import PenetrationModel, paper_scenario
from uav_penetration_env.mpc import Terminal
from uav_penetration_env.terminal import terminal_cost

FORMS = ("none", "distance", "dubins", "value")
BATCHES = (100, 1000)
HORIZON = 5


def _spin(stop) -> None:  # a busy process: the contention a training job beside the planner makes
    while not stop.is_set():
        sum(i * i for i in range(10_000))


def rates(model: PenetrationModel, repeat: int, seed: int = 0) -> dict[tuple[str, int], float]:
    """Best-of-``repeat`` particle-steps per second per (form, batch)."""
    terminals = {form: terminal_cost(model, Terminal(form)) for form in FORMS}
    rng = np.random.default_rng(seed)
    state = model.initial_state()
    best = {(f, b): np.inf for f in FORMS for b in BATCHES}
    high = model.limits.action_high  # the planners' search box (a gentle climb, as bench_env.py flies)
    controls = {b: rng.uniform(-high, high, (b, HORIZON, 3)) * [1.0, 1.0, 0.3] for b in BATCHES}
    for form in FORMS:  # compile and warm every specialisation first
        for b in BATCHES:
            model.rollout_cost(state, controls[b], step=0, terminal_cost=terminals[form])
    for _ in range(repeat):
        for b in BATCHES:
            for form in FORMS:
                start = time.perf_counter()
                model.rollout_cost(state, controls[b], step=0, terminal_cost=terminals[form])
                best[(form, b)] = min(best[(form, b)], time.perf_counter() - start)
    return {key: key[1] * HORIZON / seconds for key, seconds in best.items()}


def main(argv: list[str] | None = None) -> dict[tuple[str, int], float]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=30, help="timed calls per form and batch (best kept)")
    parser.add_argument("--load", type=int, default=0, help="busy processes running during the measurement")
    args = parser.parse_args(argv)
    numba.set_num_threads(1)
    model = PenetrationModel(paper_scenario())
    stop = multiprocessing.Event()
    load = [multiprocessing.Process(target=_spin, args=(stop,), daemon=True) for _ in range(args.load)]
    for process in load:
        process.start()
    try:
        measured = rates(model, args.repeat)
    finally:
        stop.set()
        for process in load:
            process.join()
    print(f"rollout_cost, paper scenario, H = {HORIZON}, one thread, {args.load} busy processes beside it")
    for b in BATCHES:
        reference = measured[("distance", b)]
        for form in FORMS:
            rate = measured[(form, b)]
            print(f"  batch {b:5d}  {form:8s} {rate / 1e6:6.2f} M particle-steps/s   x{rate / reference:5.2f} of distance")
    return measured


if __name__ == "__main__":
    main(sys.argv[1:])
