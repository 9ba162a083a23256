"""Compile (or load from the compile cache) every compiled entry point once, before the real work.

The first call of each compiled kernel compiles it (25-60 s on 2 idle cores with an empty cache, 289 s
measured beside two busy processes; about 3 s to load from a filled one in a fresh process; model.md §8). Doing it once in the main process, before a sweep
starts its workers, makes the workers load the machine code instead of each compiling it, and lets
the command say what it is doing instead of sitting at ``0/45`` with no ETA. ``uav-bench compile``
does the same for images and CI.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from uav_penetration_env import compile_cache

_loaded = False  # whether this process has run every compiled entry point once


def is_cold() -> bool:
    """Whether the compile cache holds no machine code of the batch kernels yet (a first run)."""
    folder = Path(compile_cache.COMPILE_CACHE_DIR)
    return not any(folder.rglob("kernels.rollout_batch-*.nbi"))


def compile_physics() -> float:
    """Run every compiled entry point once on the paper scenario; returns the seconds it took.

    Covers the single env's step and reset (through the model and through the env itself), observation, the serial and the parallel rollout
    kernels (rows below and above ``kernels.SERIAL_BELOW_ROWS``) and the terminal cost's forms,
    including the value function's iteration (its table for the paper scenario is cached too).
    """
    from uav_penetration_env.env import UAVPenetrationEnv
    from uav_penetration_env.kernels import SERIAL_BELOW_ROWS
    from uav_penetration_env.model import PenetrationModel
    from uav_penetration_env.mpc import Terminal
    from uav_penetration_env.scenario import paper_scenario
    from uav_penetration_env.terminal import terminal_cost

    global _loaded
    start = time.perf_counter()
    model = PenetrationModel(paper_scenario())
    state = model.initial_state()
    result = model.step(state[None], np.zeros((1, 3)), 0)
    model.observe(result.state, result.step_index, result)
    model.observe(state[None], 0)
    for form in ("none", "distance", "value"):
        built = terminal_cost(model, Terminal(form))
        for rows in (1, 2 * SERIAL_BELOW_ROWS):
            model.rollout_cost(state, np.zeros((rows, 5, 3)), step=0, terminal_cost=built)
    # The env's own calls (its reset and a float32 action's step): their argument types differ from
    # the model calls above, so without them each worker compiled them again in its first episode
    # (20-34 s on 2 cores, measured in a fresh process after the calls above alone).
    env = UAVPenetrationEnv(paper_scenario())
    env.reset(seed=0)
    env.step(np.zeros(3, dtype=np.float32))
    env.close()
    _loaded = True
    return time.perf_counter() - start


def load_once() -> float:
    """:func:`compile_physics` the first time a process calls it (its seconds), then nothing (0).

    DECISION (api.md §4.7, episode clocks): a harness worker loads the compiled code before it
    starts an episode's clock (:func:`~uav_penetration_env.benchmark.evaluate.run_episode`). The
    first call of each kernel in a fresh process loads its machine code from the compile cache:
    3.2 s on 2 cores with a filled cache, against about 0.06 s for the same calls afterwards, and
    a greedy episode of the paper scenario takes well under a second. Timed inside the episode,
    that load made each worker's first episode look several times longer than the rest, and the
    run's first ETA, priced from the first finished episodes, came out 9x too high on a busy
    machine; the stored ``episode_seconds`` and the first step's ``planning_seconds`` held it too.
    """
    return 0.0 if _loaded else compile_physics()


def cache_size_bytes() -> int:
    """The bytes the compile cache's folder holds."""
    folder = Path(compile_cache.COMPILE_CACHE_DIR)
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file()) if folder.is_dir() else 0
