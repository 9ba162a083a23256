"""Where one native vector-env step spends its time, per row, beside the single env (same run).

On the paper scenario at ``--envs`` sub-envs (default 256), on one compiled thread, this script
prints microseconds per row of:

* each piece of the physics, timed by a compiled loop over the batch's rows that calls the same
  scalar functions the kernels inline (``uav_penetration_env/kernels.py``): the kinematics, the
  segment's terrain samples and goal test, the terrain threat, the radars (range, aspect, RCS,
  detection, horizon, the masking floor's lookup), the fuel and third term, the fusion; then the
  observation's terrain patch and its nearest-radar features;
* the compiled kernels as the model calls them (the transition, the observation, and the fused
  step-and-observe kernel the vector env runs), and the Python around them: the model's argument
  checks and output arrays, the info dicts, the env's bookkeeping;
* the vector env's whole step, the single env's step (``gym.make``, with its wrappers, and the
  unwrapped env) and their ratio, measured in the same run.

Each figure is the best of ``--repeats`` windows (a busy machine slows some windows, not the
code). ``--load N`` starts N busy processes (one core each) for the whole run.

``--compare TREE`` (a checkout of another commit, e.g. ``git archive REV | tar -x -C TREE``) then
measures the vector env's and the single env's step in fresh processes of that tree and of this
one, alternating, idle and beside ``--load`` busy processes (2 if not given), and prints both
trees' rates, their ratios, and this tree's speed-up: before and after in one run.

Usage: ``python benchmarks/bench_vector_breakdown.py [--envs 256] [--load 2] [--repeats 5]
[--compare TREE [--rounds 3]]``
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import gymnasium as gym
import numba
import numpy as np
from numba import njit

import uav_penetration_env  # noqa: F401  (registers the ids)
from uav_penetration_env import kernels
from uav_penetration_env.env import batched_info, validate_action
from uav_penetration_env.kernels import (
    P_DT,
    fuel_burned,
    fuse,
    grid_value,
    kinematics,
    radar_threats,
    segment_events,
    terrain_threat,
    third_term,
)
from uav_penetration_env.observation import TERRAIN_ACROSS_M, TERRAIN_AHEAD_M
from uav_penetration_env.vector_env import _vector_info

BUSY = "while True:\n    pass\n"
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# The two steps timed in a fresh process of one tree (self-contained: the other tree has no helpers).
RATES = """
import json, time
import gymnasium as gym, numba, numpy as np
import uav_penetration_env
numba.set_num_threads(1)
n, steps, windows = {n}, {steps}, {windows}
envs = gym.make_vec("UAVPenetration-v0", num_envs=n, vectorization_mode="vector_entry_point")
env = gym.make("UAVPenetration-v0")
high = envs.single_action_space.high.astype(np.float64)
rng = np.random.default_rng(0)
actions = rng.uniform(-high, high, size=(steps, n, 3)) * [0.2, 0.3, 0.05]
single_actions = rng.uniform(-high, high, size=(2000, 3)) * [0.2, 0.3, 0.05]
envs.reset(seed=0)
envs.step(actions[0])
env.reset(seed=0)
env.step(single_actions[0])
vector = single = float("inf")
for _ in range(windows):  # alternating windows, the best of each kept
    start = time.perf_counter()
    for action in actions:
        envs.step(action)
    vector = min(vector, (time.perf_counter() - start) / steps)
    start = time.perf_counter()
    for action in single_actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    single = min(single, (time.perf_counter() - start) / len(single_actions))
print(json.dumps({{"vector_us": vector * 1e6, "single_us": single * 1e6}}))
"""


@njit
def _kinematics(arrays, states, controls):
    total = 0.0
    for b in range(states.shape[0]):
        s = states[b]
        x, y, z, v, h, pt = kinematics(
            s[0], s[1], s[2], s[3], s[4], s[5], controls[b, 0], controls[b, 1], controls[b, 2], arrays.params
        )
        total += x + y + z + v + h + pt
    return total


@njit
def _segment(arrays, index, states, next_states):
    total = 0.0
    for b in range(states.shape[0]):
        reached, collided, out, ground = segment_events(arrays, index[b], states[b], next_states[b])
        total += ground + reached + collided + out
    return total


@njit
def _terrain_threat(arrays, index, next_states):
    total = 0.0
    for b in range(next_states.shape[0]):
        s = next_states[b]
        total += terrain_threat(arrays, index[b], s[0], s[1], 100.0)
    return total


@njit
def _radars(arrays, index, next_states, per_radar, visible):
    total = 0.0
    for b in range(next_states.shape[0]):
        s = next_states[b]
        total += radar_threats(arrays, index[b], s[0], s[1], s[2], s[4], s[5], per_radar[b], visible[b])
    return total


@njit
def _floors(arrays, index, next_states):
    """The masking part of the radars alone: one floor lookup per radar."""
    total = 0.0
    for b in range(next_states.shape[0]):
        p = index[b]
        s = next_states[b]
        for m in range(arrays.radar_xyz.shape[1]):
            total += grid_value(arrays.floors, arrays.floor_layer[p, m], s[0], s[1], arrays.params)
    return total


@njit
def _fuel_and_fusion(arrays, next_states, per_radar):
    total = 0.0
    for b in range(next_states.shape[0]):
        fuel = fuel_burned(next_states[b, 5], arrays.params)
        third = third_term(arrays.options[kernels.O_THIRD], fuel, next_states[b, 3] * arrays.params[P_DT],
                           1000.0, 990.0, arrays.params)  # fmt: skip
        total += third + fuse(per_radar[b], arrays.options[kernels.O_FUSION])
    return total


@njit
def _terrain_patch(arrays, index, next_states, ahead, across):
    """The observation's 5 x 5 terrain samples ahead of each row."""
    total = 0.0
    for b in range(next_states.shape[0]):
        x, y, h = next_states[b, 0], next_states[b, 1], next_states[b, 4]
        cos_h, sin_h = np.cos(h), np.sin(h)
        for a in range(ahead.shape[0]):
            for c in range(across.shape[0]):
                px = x + ahead[a] * cos_h - across[c] * sin_h
                py = y + ahead[a] * sin_h + across[c] * cos_h
                total += grid_value(arrays.terrain, index[b], px, py, arrays.params)
    return total


def best_us(function, repeat: int, windows: int) -> float:
    """Best-of-``windows`` microseconds per call of ``function`` over ``repeat`` calls."""
    function()
    best = np.inf
    for _ in range(windows):
        start = time.perf_counter()
        for _ in range(repeat):
            function()
        best = min(best, (time.perf_counter() - start) / repeat)
    return best * 1e6


def single_step_us(env, steps: int, windows: int) -> float:
    """Best-of-``windows`` microseconds per single-env step (random actions, resets when done)."""
    rng = np.random.default_rng(0)
    high = env.action_space.high.astype(np.float64)
    actions = rng.uniform(-high, high, size=(steps, 3)) * [0.2, 0.3, 0.05]
    env.reset(seed=0)
    best = np.inf
    for _ in range(windows):
        start = time.perf_counter()
        for action in actions:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
        best = min(best, (time.perf_counter() - start) / steps)
    return best * 1e6


def vector_step_us(envs, actions: np.ndarray, windows: int) -> float:
    """Best-of-``windows`` microseconds per vector-env step over the ``actions`` (T, n, 3)."""
    envs.reset(seed=0)
    envs.step(actions[0])
    best = np.inf
    for _ in range(windows):
        start = time.perf_counter()
        for action in actions:
            envs.step(action)
        best = min(best, (time.perf_counter() - start) / len(actions))
    return best * 1e6


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=256, help="sub-envs of the vector env (default 256)")
    parser.add_argument("--load", type=int, default=0, help="busy processes during the run (default 0)")
    parser.add_argument("--repeats", type=int, default=5, help="timing windows, the best kept (default 5)")
    parser.add_argument("--steps", type=int, default=100, help="vector-env steps per window (default 100)")
    parser.add_argument("--compare", metavar="TREE", help="another checkout to measure against, in one run")
    parser.add_argument(
        "--rounds", type=int, default=3, help="fresh processes per tree and condition (default 3)"
    )
    args = parser.parse_args(argv)
    if args.compare:
        return compare(args)
    workers = [subprocess.Popen([sys.executable, "-c", BUSY]) for _ in range(args.load)]
    try:
        time.sleep(0.5 if workers else 0.0)
        return measure(args)
    finally:
        for worker in workers:
            worker.kill()
            worker.wait()


def tree_rates(tree: str, args: argparse.Namespace) -> dict[str, float]:
    """The vector env's and the single env's step [us] in a fresh process importing the package of ``tree``."""
    code = RATES.format(n=args.envs, steps=args.steps, windows=args.repeats)
    env = {**os.environ, "PYTHONPATH": tree}
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, cwd=tree, capture_output=True, text=True, check=True
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def compare(args: argparse.Namespace) -> dict[str, float]:
    """Both trees' rates idle and loaded, alternating fresh processes; the best of ``--rounds`` each."""
    trees = {"before": os.path.abspath(args.compare), "after": ROOT}
    load = args.load or 2
    out: dict[str, float] = {}
    print(f"{args.envs} envs; before = {trees['before']}, after = {trees['after']}; cores: {os.cpu_count()}")
    for loaded in (False, True):
        workers = [subprocess.Popen([sys.executable, "-c", BUSY]) for _ in range(load if loaded else 0)]
        try:
            time.sleep(0.5 if workers else 0.0)
            best: dict[str, dict[str, float]] = {}
            for _ in range(args.rounds):
                for name, tree in trees.items():
                    rates = tree_rates(tree, args)
                    kept = best.setdefault(name, rates)
                    for key, value in rates.items():
                        kept[key] = min(kept[key], value)
        finally:
            for worker in workers:
                worker.kill()
                worker.wait()
        label = f"with {load} busy processes" if loaded else "idle"
        print(f"== {label} ==")
        for name, rates in best.items():
            vector, single = rates["vector_us"], rates["single_us"]
            ratio = single * args.envs / vector
            print(
                f"  {name:<7} vector env {args.envs}: {vector:8.1f} us a step ({vector / args.envs:.3f} us a row,"
                f" {args.envs / vector * 1e6:,.0f} env-steps/s); single env {single:6.2f} us"
                f" ({1e6 / single:,.0f} steps/s); ratio x{ratio:.1f}"
            )
            out[f"{label}, {name}, ratio"] = ratio
            out[f"{label}, {name}, vector_us"] = vector
            out[f"{label}, {name}, single_us"] = single
        speedup = best["before"]["vector_us"] / best["after"]["vector_us"]
        print(f"  the vector env's step: x{speedup:.2f} faster after")
        out[f"{label}, speed-up"] = speedup
    return out


def measure(args: argparse.Namespace) -> dict[str, float]:
    numba.set_num_threads(1)
    n, windows = args.envs, args.repeats
    envs = gym.make_vec("UAVPenetration-v0", num_envs=n, vectorization_mode="vector_entry_point")
    vector = envs.unwrapped
    high = envs.single_action_space.high.astype(np.float64)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-high, high, size=(args.steps, n, 3)) * [0.2, 0.3, 0.05]
    envs.reset(seed=0)
    for action in actions[:20]:  # states spread over an episode's first steps
        envs.step(action)
    model = vector.model
    arrays = model.arrays
    states = vector.states.copy()
    steps = vector.step_indices.copy()
    controls = np.clip(actions[0], -high, high)
    index = np.zeros(n, dtype=np.int64)
    result = model.step(states, controls, steps)
    next_states = result.state
    per_radar = np.empty((n, model.radar_slots))
    visible = np.empty((n, model.radar_slots))
    calls = max(20, 20_000 // n)

    def per_row(function) -> float:
        return best_us(function, calls, windows) / n

    rows = {
        "kinematics": per_row(lambda: _kinematics(arrays, states, controls)),
        f"segment: {model.segment_samples} terrain samples + goal": per_row(
            lambda: _segment(arrays, index, states, next_states)
        ),
        "terrain threat (peaks)": per_row(lambda: _terrain_threat(arrays, index, next_states)),
        f"radars ({model.radar_slots}): range, aspect, RCS, P_d, masking": per_row(
            lambda: _radars(arrays, index, next_states, per_radar, visible)
        ),
        "  of which the masking floors' lookups": per_row(lambda: _floors(arrays, index, next_states)),
        "fuel, third term, fusion": per_row(lambda: _fuel_and_fusion(arrays, next_states, per_radar)),
        "observation: 5 x 5 terrain patch": per_row(
            lambda: _terrain_patch(arrays, index, next_states, TERRAIN_AHEAD_M, TERRAIN_ACROSS_M)
        ),
    }
    k_next = steps + 1
    out_states = np.empty((n, 6))
    scalars = np.empty((n, kernels.N_SCALARS))
    flags = np.empty((n, kernels.N_FLAGS), dtype=np.bool_)
    fraction = k_next / float(model.max_steps)
    obs = np.empty((n, 67), dtype=np.float32)
    transition_kernel = per_row(
        lambda: kernels.transition_rows(
            arrays, states, controls, True, k_next, index, (out_states, per_radar, visible, scalars, flags)
        )
    )
    scratch = np.empty((n, kernels.observe_scratch_width(model.radar_slots)))
    observe_kernel = per_row(
        lambda: kernels.observe_rows(
            arrays, next_states, fraction, index, result.radar_threat_per_radar, result.visibility,
            TERRAIN_AHEAD_M, TERRAIN_ACROSS_M, scratch, obs,
        )
    )  # fmt: skip
    rows["transition kernel (all of the above but the patch)"] = transition_kernel
    rows["observation kernel (patch + nearest radars)"] = observe_kernel
    every = np.arange(n, dtype=np.int64)
    rows["fused step + observe kernel (the vector env's)"] = per_row(
        lambda: kernels.step_observe_rows(
            arrays, every, states, controls, k_next, index, fraction, TERRAIN_AHEAD_M, TERRAIN_ACROSS_M,
            out_states, per_radar, visible, scalars, flags, scratch, obs,
        )
    )  # fmt: skip
    none = np.zeros(0, dtype=np.int64)
    rows["model._step_observe_rows (the vector env's call)"] = per_row(
        lambda: model._step_observe_rows(states, controls, steps, index, every, none)
    )
    rows["model.step (checks, output arrays, StepResult)"] = per_row(
        lambda: model.step(states, controls, steps)
    )
    rows["model.observe (checks, output array)"] = per_row(lambda: model.observe(next_states, k_next, result))
    rows["info: batched_info + vector layout"] = per_row(lambda: _vector_info(batched_info(result)))
    rows["action check and clip (validate_action)"] = per_row(
        lambda: validate_action(actions[0], high, shape=(n, 3))
    )
    # Autoresets: the share of rows that finish per step in this workload, and their cost.
    envs.reset(seed=0)
    done_rows = sum(int(np.sum(t | u)) for _, _, t, u, _ in (envs.step(a) for a in actions))
    share = max(1, round(done_rows / len(actions)))  # rows reset per step, on average
    some = np.arange(0, n, max(1, n // share), dtype=np.int64)[:share]
    rest = np.setdiff1d(every, some)
    rows[f"reset draws of {share} rows (_reset_rows), per row of the batch"] = per_row(
        lambda: vector._reset_rows(some, [None] * len(some))
    )
    rows[f"_step_observe_rows with {share} rows reset, per row of the batch"] = per_row(
        lambda: model._step_observe_rows(states, controls, steps, index, rest, some)
    )
    vector_us = vector_step_us(envs, actions, windows)
    rows["vector env step, whole"] = vector_us / n
    print(f"paper scenario, {n} envs, 1 compiled thread, best of {windows} windows; per row:")
    print(
        f"  (this workload's episodes end after {n * len(actions) / max(done_rows, 1):.1f} steps on average)"
    )
    for name, value in rows.items():
        print(f"  {name:<58}{value:8.3f} us")
    wrapped = single_step_us(gym.make("UAVPenetration-v0"), 2000, windows)
    bare = single_step_us(gym.make("UAVPenetration-v0").unwrapped, 2000, windows)
    print(f"single env step: {wrapped:.2f} us (gym.make, wrappers), {bare:.2f} us (unwrapped)")
    ratio = wrapped * n / vector_us
    print(
        f"vector env {n}: {n / vector_us * 1e6:,.0f} env-steps/s; single env {1e6 / wrapped:,.0f} steps/s;"
        f" ratio x{ratio:.1f} (x{bare * n / vector_us:.1f} against the unwrapped env)"
    )
    rows["single env step"] = wrapped
    rows["single env step, unwrapped"] = bare
    rows["ratio"] = ratio
    return rows


if __name__ == "__main__":
    main()
