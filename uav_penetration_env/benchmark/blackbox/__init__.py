"""The benchmark's problems for black-box optimisation libraries (docs/blackbox.md).

:mod:`.problems` defines the problems (the full-path problem and the MPC window problem of any
scenario or suite member; the core's dependencies only); :mod:`.adapters` registers them with
IOHprofiler and nevergrad, and :mod:`.ioh_export` writes stored window runs in IOHprofiler's
file format (extra ``blackbox``, imported when used).
"""

from __future__ import annotations

from uav_penetration_env.benchmark.blackbox.adapters import ioh_problem, nevergrad_function
from uav_penetration_env.benchmark.blackbox.ioh_export import export_window_runs
from uav_penetration_env.benchmark.blackbox.problems import (
    BlackBoxProblem,
    offline_problem,
    suite_problems,
    window_problem,
)

__all__ = [
    "BlackBoxProblem",
    "export_window_runs",
    "ioh_problem",
    "nevergrad_function",
    "offline_problem",
    "suite_problems",
    "window_problem",
]
