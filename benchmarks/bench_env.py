"""Environment speed, measured in one run on the paper scenario (the speed targets as ratios).

Prints, side by side with the numpy formulation (the test oracle tests/numpy_model.py):
* the compiled kernels' first-call cost in a fresh process, cold (empty compile cache) and warm;
* ``rollout_cost`` particle-steps per second at batch 100, 1 000 and 10 000 (H = 5), compiled on
  one thread and on every thread, against the numpy model (target: >= 1.5 M at 100 x 5, one
  thread);
* single-env steps per second, compiled against numpy (target: >= 10x);
* single-env steps per second (``gym.make``, and the unwrapped env);
* native vector-env env-steps per second at 1, 16, 256 and 1024 envs, and the ratio to the
  single env (target: >= 30x at 256 envs);
* ``rollout_cost`` particle-steps per second for 100 particles x 5 steps, and the ratio of one
  call to 500 single-env steps (target: >= 50x) and to 500 ``model.step`` calls on a batch of one;
* scenario build time, cold (fresh cache folder) and cached, for the paper, DEM and random
  scenarios with 4 and 8 radars (target: <= 2 s per 4 radars on one core).

Usage: ``python benchmarks/bench_env.py [--quick]`` (``--quick`` skips the cold compile).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import gymnasium as gym
import numba
import numpy as np

import uav_penetration_env  # noqa: F401  (registers the ids)
from uav_penetration_env import PenetrationModel, cache, dem_scenario, paper_scenario, random_scenario
from uav_penetration_env.build import build_scenario
from uav_penetration_env.env import batched_info, unbatch, validate_action
from uav_penetration_env.mpc import Terminal
from uav_penetration_env.terminal import terminal_cost

ROOT = Path(__file__).resolve().parents[1]
sys.path.append(str(ROOT / "tests"))  # appended: tests/optimizers must not shadow optimizers
from numpy_model import NumpyPenetrationModel  # noqa: E402  (the oracle lives under tests/)

FIRST_CALLS = """
import time
start = time.perf_counter()
import numpy as np
from uav_penetration_env import PenetrationModel, paper_scenario
model = PenetrationModel(paper_scenario())
imported = time.perf_counter()
state = model.initial_state()
result = model.step(state[None], np.zeros((1, 3)), 0)
model.observe(result.state, result.step_index, result)
model.observe(state[None], 0)
model.rollout_cost(state, np.zeros((4, 5, 3)), step=0)
print(imported - start, time.perf_counter() - imported)
"""


def first_call_seconds(cache_folder: str | None) -> tuple[float, float]:
    """(import + build, first step/observe/rollout calls) seconds in a fresh process.

    ``cache_folder``: numba's compile cache for that process (``None``: the default, next to the
    sources).
    """
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    if cache_folder is not None:
        environment["NUMBA_CACHE_DIR"] = cache_folder
    output = subprocess.run(
        [sys.executable, "-c", FIRST_CALLS], env=environment, capture_output=True, text=True, check=True
    ).stdout
    setup, calls = (float(value) for value in output.split())
    return setup, calls


def timed(function, repeat: int) -> float:
    """Best-of-3 seconds per call of ``function`` over ``repeat`` calls."""
    best = np.inf
    for _ in range(3):
        start = time.perf_counter()
        for _ in range(repeat):
            function()
        best = min(best, (time.perf_counter() - start) / repeat)
    return best


def single_env_rate(env, steps: int) -> float:
    rng = np.random.default_rng(0)
    high = env.action_space.high.astype(np.float64)
    actions = rng.uniform(-high, high, size=(steps, 3)) * [0.2, 0.3, 0.05]
    env.reset(seed=0)
    start = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - start)


def oracle_env_rate(model, steps: int) -> float:
    """Single-env steps per second of the numpy oracle, stepped as an env steps (model.md §7a).

    The env itself only runs the compiled model, so the oracle's env step is rebuilt here from its
    public methods: the action check, ``step``, ``observe`` and the info of one row.
    """
    rng = np.random.default_rng(0)
    high = model.limits.action_high
    actions = rng.uniform(-high, high, size=(steps, 3)) * [0.2, 0.3, 0.05]
    state, k = model.initial_state(), 0
    start = time.perf_counter()
    for action in actions:
        control = validate_action(action, high)
        result = model.step(state[None], control[None], k)
        model.observe(result.state, result.step_index, result)
        unbatch(batched_info(result), 0)
        state, k = result.state[0].copy(), k + 1
        if result.terminated[0] or result.truncated[0]:
            state, k = model.initial_state(), 0
    return steps / (time.perf_counter() - start)


def vector_env_rate(num_envs: int, steps: int) -> float:
    envs = gym.make_vec("UAVPenetration-v0", num_envs=num_envs, vectorization_mode="vector_entry_point")
    rng = np.random.default_rng(0)
    high = envs.single_action_space.high.astype(np.float64)
    actions = rng.uniform(-high, high, size=(steps, num_envs, 3)) * [0.2, 0.3, 0.05]
    envs.reset(seed=0)
    envs.step(actions[0])  # warm-up
    start = time.perf_counter()
    for action in actions:
        envs.step(action)
    return steps * num_envs / (time.perf_counter() - start)


def build_times(name: str, scenario) -> tuple[float, float, float]:
    """(cold incl. RCS table, cold with the RCS table cached, cached) seconds."""
    with tempfile.TemporaryDirectory() as folder:
        os.environ[cache.ENV_VAR] = folder
        cache.clear_memory()
        start = time.perf_counter()
        build_scenario(scenario)
        cold_all = time.perf_counter() - start
        for path in os.listdir(folder):
            if not path.startswith("rcs-"):
                os.remove(os.path.join(folder, path))
        cache.clear_memory()
        start = time.perf_counter()
        build_scenario(scenario)
        cold = time.perf_counter() - start
        cache.clear_memory()
        start = time.perf_counter()
        build_scenario(scenario)
        cached = time.perf_counter() - start
    return cold_all, cold, cached


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--quick", action="store_true", help="few repetitions (a smoke run, not a measurement)"
    )
    args = parser.parse_args(argv)
    steps = 200 if args.quick else 3000
    results: dict[str, float] = {}

    print("== build times (one process, numpy single-threaded) ==")
    print(f"{'scenario':<28}{'radars':>7}{'cold+RCS [s]':>14}{'cold [s]':>10}{'cached [s]':>12}")
    builds = [
        ("paper", paper_scenario()),
        ("dem", dem_scenario()),
        ("random d=0.33 (4 radars)", random_scenario(np.random.default_rng(1), 1 / 3)),
        ("random d=1.0 (8 radars)", random_scenario(np.random.default_rng(1), 1.0)),
    ]
    saved = os.environ.get(cache.ENV_VAR)
    try:
        for name, scenario in builds:
            cold_all, cold, cached = build_times(name, scenario)
            results[f"build_cold_{name}"] = cold
            print(f"{name:<28}{len(scenario.radars):>7}{cold_all:>14.3f}{cold:>10.3f}{cached:>12.4f}")
    finally:
        if saved is None:
            os.environ.pop(cache.ENV_VAR, None)
        else:
            os.environ[cache.ENV_VAR] = saved
        cache.clear_memory()

    print("\n== compiled kernels: first calls in a fresh process (step, observe x2, rollout_cost) ==")
    if args.quick:  # the package's own cache, filled by whoever ran first
        setup, warm = first_call_seconds(None)
    else:
        with tempfile.TemporaryDirectory() as folder:
            setup, cold = first_call_seconds(folder)
            results["compile_cold_s"] = cold
            print(f"cold (empty compile cache)  {cold:7.2f} s   (import + scenario {setup:5.2f} s)")
            setup, warm = first_call_seconds(folder)
    results["compile_warm_s"] = warm
    print(f"warm (compile cache filled) {warm:7.2f} s   (import + scenario {setup:5.2f} s)")

    print("\n== rollout_cost particle-steps/s (H = 5), compiled against numpy in this process ==")
    compiled = PenetrationModel(paper_scenario())
    oracle = NumpyPenetrationModel(compiled.built)
    start_state = compiled.initial_state()
    distance = terminal_cost(compiled, Terminal("distance", 0.06))  # the oracle prices it alike
    high = compiled.limits.action_high
    threads = numba.get_num_threads()
    print(f"{'batch':>7}{'numpy':>12}{'1 thread':>12}{'x numpy':>9}{f'{threads} threads':>12}{'x numpy':>9}")
    for batch in (100, 1_000, 10_000):
        sequences = np.random.default_rng(0).uniform(-high, high, size=(batch, 5, 3)) * [1.0, 1.0, 0.3]
        repeat = max(1, (3 if args.quick else 30) * 100 // batch)

        def call(model, sequences=sequences):
            return lambda: model.rollout_cost(start_state, sequences, step=0, terminal_cost=distance)

        slow = batch * 5 / timed(call(oracle), repeat)
        numba.set_num_threads(1)
        one = batch * 5 / timed(call(compiled), repeat)
        numba.set_num_threads(threads)
        many = batch * 5 / timed(call(compiled), repeat)
        results[f"rollout_{batch}_numpy"] = slow
        results[f"rollout_{batch}_1thread"] = one
        results[f"rollout_{batch}_threads"] = many
        print(
            f"{batch:>7}{slow / 1e6:>11.3f}M{one / 1e6:>11.3f}M{one / slow:>8.1f}x{many / 1e6:>11.3f}M{many / slow:>8.1f}x"
        )

    print("\n== single env, compiled against numpy (paper scenario, unwrapped, 1 thread) ==")
    numba.set_num_threads(1)
    fast_env = gym.make("UAVPenetration-v0").unwrapped
    fast = single_env_rate(fast_env, steps)
    slow = oracle_env_rate(NumpyPenetrationModel(fast_env.model.built), max(50, steps // 5))
    numba.set_num_threads(threads)
    results["single_env_compiled"] = fast
    results["single_env_numpy"] = slow
    print(f"numpy {slow:10.0f} steps/s   compiled {fast:10.0f} steps/s   {fast / slow:6.1f}x")

    print("\n== single env (paper scenario) ==")
    wrapped = single_env_rate(gym.make("UAVPenetration-v0"), steps)
    bare = single_env_rate(gym.make("UAVPenetration-v0").unwrapped, steps)
    results["single_env_steps_per_s"] = wrapped
    print(f"gym.make env      {wrapped:10.0f} steps/s  ({1e6 / wrapped:6.1f} us/step)")
    print(f"unwrapped env     {bare:10.0f} steps/s  ({1e6 / bare:6.1f} us/step)")

    print("\n== native vector env ==")
    print(f"{'num_envs':>9}{'env-steps/s':>14}{'x single env':>14}")
    for num_envs in (1, 16, 256, 1024):
        rate = vector_env_rate(num_envs, max(5, steps // max(1, num_envs // 16)) if not args.quick else 5)
        results[f"vector_{num_envs}"] = rate
        print(f"{num_envs:>9}{rate:>14.0f}{rate / wrapped:>14.1f}")

    print("\n== rollout_cost (100 particles x 5 steps, every thread) ==")
    model = PenetrationModel(paper_scenario())
    state = model.initial_state()
    rng = np.random.default_rng(0)
    high = model.limits.action_high
    controls = rng.uniform(-high, high, size=(100, 5, 3)) * [1.0, 1.0, 0.3]
    built = terminal_cost(model, Terminal("distance", 0.06))
    rollout = timed(
        lambda: model.rollout_cost(state, controls, step=0, terminal_cost=built), 20 if args.quick else 300
    )
    env = gym.make("UAVPenetration-v0")
    env_500 = 500 / single_env_rate(env, 500)
    one = controls[:1, 0]
    step_500 = 500 * timed(lambda: model.step(state[None], one, 0), 50 if args.quick else 1000)
    results["rollout_ms"] = rollout * 1e3
    results["rollout_vs_env"] = env_500 / rollout
    print(f"one call          {rollout * 1e3:8.3f} ms  ({500 / rollout:,.0f} particle-steps/s)")
    print(f"500 env steps     {env_500 * 1e3:8.3f} ms  -> rollout_cost is {env_500 / rollout:6.1f}x faster")
    print(f"500 model.step(1) {step_500 * 1e3:8.3f} ms  -> rollout_cost is {step_500 / rollout:6.1f}x faster")
    return results


if __name__ == "__main__":
    main()
