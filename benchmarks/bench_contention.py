"""Speed beside other work: each figure idle and with busy processes, on one thread and on every thread.

Users rarely have an idle machine (RL training beside the env, ``uav-bench run --jobs 2``, CI). This
script measures, in one run, on the paper scenario:

* ``rollout_cost`` particle-steps per second at batch 100 and 10 000 (H = 5): the MPC planners'
  batch and a large one;
* the single env (``gym.make``) and the native vector env at 256 envs, in steps per second;

each in a fresh process (the OpenMP runtime reads its wait policy when it loads), on one compiled
thread and on every thread (alternating, three windows each, the median kept), first idle and then
with ``--load`` busy processes (pure Python loops, one core each) running. It prints every rate, the ratio of every thread to one thread, and the
vector env's ratio to the single env. ``--wait-policy active`` adds the same runs with spinning
OpenMP threads (the OpenMP default the package overrides, model.md §8).

Usage: ``python benchmarks/bench_contention.py [--load 2] [--seconds 1.5] [--wait-policy active]``
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

MEASURE = """
import json, sys, time
import numba, numpy as np, gymnasium as gym
sys.path.insert(0, {benchmarks!r})
from bench_env import single_env_rate, vector_env_rate
import uav_penetration_env
from uav_penetration_env import PenetrationModel, paper_scenario

seconds = {seconds}
model = PenetrationModel(paper_scenario())
state = model.initial_state()
high = model.limits.action_high
env = gym.make("UAVPenetration-v0")
vector_env_rate(256, 2)  # warm: the first steps load the compiled code
single_env_rate(env, 50)
samples = {{}}
# One thread and every thread alternate, three times each, and the median is kept: on a busy
# machine one window's rate varies by a quarter between repeats of the same code.
for threads in (1, numba.config.NUMBA_NUM_THREADS) * 3:
    numba.set_num_threads(threads)
    for batch in (100, 10_000):
        controls = np.random.default_rng(0).uniform(-high, high, size=(batch, 5, 3)) * [1.0, 1.0, 0.3]
        model.rollout_cost(state, controls, step=0)
        calls, start = 0, time.perf_counter()
        while time.perf_counter() - start < seconds:
            model.rollout_cost(state, controls, step=0)
            calls += 1
        samples.setdefault(f"rollout {{batch}} x 5, {{threads}} thr", []).append(
            calls * batch * 5 / (time.perf_counter() - start))
    samples.setdefault(f"vector env 256, {{threads}} thr", []).append(vector_env_rate(256, max(5, int(40 * seconds))))
    samples.setdefault(f"single env, {{threads}} thr", []).append(single_env_rate(env, int(4000 * seconds)))
print(json.dumps({{key: float(np.median(values)) for key, values in samples.items()}}))
"""

BUSY = "while True:\n    pass\n"


def measure(policy: str, seconds: float) -> dict[str, float]:
    """Every figure in a fresh process with ``OMP_WAIT_POLICY=policy``."""
    code = MEASURE.format(benchmarks=str(ROOT / "benchmarks"), seconds=seconds)
    env = {**os.environ, "OMP_WAIT_POLICY": policy, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def busy_processes(count: int) -> list[subprocess.Popen]:
    return [subprocess.Popen([sys.executable, "-c", BUSY]) for _ in range(count)]


def report(label: str, rates: dict[str, float]) -> dict[str, float]:
    """Print one condition's rates and ratios; returns the ratios."""
    threads = max(int(k.rsplit(", ", 1)[1].split()[0]) for k in rates)
    print(f"\n== {label} ==")
    ratios = {}
    for figure in ("rollout 100 x 5", "rollout 10000 x 5", "vector env 256", "single env"):
        one, many = rates[f"{figure}, 1 thr"], rates[f"{figure}, {threads} thr"]
        ratios[figure] = many / one
        print(f"{figure:<20}{one:>14,.0f}/s on 1 thread{many:>14,.0f}/s on {threads}   x{many / one:5.2f}")
    for threads_used in (1, threads):
        vector, single = rates[f"vector env 256, {threads_used} thr"], rates[f"single env, {threads_used} thr"]
        ratios[f"vector/single, {threads_used} thr"] = vector / single
        print(f"vector env 256 / single env, {threads_used} thread(s): x{vector / single:6.1f}")
    return ratios


def main(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--load", type=int, default=2, help="busy processes in the loaded runs (default 2)")
    parser.add_argument("--seconds", type=float, default=1.5, help="seconds per figure (default 1.5)")
    parser.add_argument("--wait-policy", choices=["active"], action="append", default=[],
                        help="also measure with spinning OpenMP threads")  # fmt: skip
    args = parser.parse_args(argv)
    policies = ["PASSIVE", *(p.upper() for p in args.wait_policy)]
    print(f"cores: {os.cpu_count()}, busy processes when loaded: {args.load}, load average now: {os.getloadavg()[0]:.2f}")
    results = {}
    for loaded in (False, True):
        workers = busy_processes(args.load) if loaded else []
        try:
            time.sleep(0.5 if loaded else 0.0)  # let the busy processes take their cores
            for policy in policies:
                label = f"{'with ' + str(args.load) + ' busy processes' if loaded else 'idle'}, OMP_WAIT_POLICY={policy}"
                results[label] = report(label, measure(policy, args.seconds))
        finally:
            for worker in workers:
                worker.kill()
                worker.wait()
    return results


if __name__ == "__main__":
    main()
