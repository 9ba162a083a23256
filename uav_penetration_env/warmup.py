"""Compile (or load from the compile cache) every compiled entry point once, before the real work.

The first call of each compiled kernel compiles it (25-60 s on 2 cores with an empty cache, about
0.1 s to load from a filled one; model.md §8). Doing it once in the main process, before a sweep
starts its workers, makes the workers load the machine code instead of each compiling it, and lets
the command say what it is doing instead of sitting at ``0/45`` with no ETA. ``uav-bench compile``
does the same for images and CI.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from uav_penetration_env import compile_cache


def is_cold() -> bool:
    """Whether the compile cache holds no machine code of the batch kernels yet (a first run)."""
    folder = Path(compile_cache.COMPILE_CACHE_DIR)
    return not any(folder.rglob("kernels.rollout_batch-*.nbi"))


def compile_physics() -> float:
    """Run every compiled entry point once on the paper scenario; returns the seconds it took.

    Covers the single env's step and reset, observation, the serial and the parallel rollout
    kernels (rows below and above ``kernels.SERIAL_BELOW_ROWS``) and the terminal cost's forms,
    including the value function's iteration (its table for the paper scenario is cached too).
    """
    from uav_penetration_env.kernels import SERIAL_BELOW_ROWS
    from uav_penetration_env.model import PenetrationModel
    from uav_penetration_env.mpc import Terminal
    from uav_penetration_env.scenario import paper_scenario
    from uav_penetration_env.terminal import terminal_cost

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
    return time.perf_counter() - start


def cache_size_bytes() -> int:
    """The bytes the compile cache's folder holds."""
    folder = Path(compile_cache.COMPILE_CACHE_DIR)
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file()) if folder.is_dir() else 0
