"""The benchmark harness: policies (MPC planners, floors), the evaluator, results, leaderboards, CLI.

The public names are imported on first use (PEP 562), so that the CLI's parser, which lives in this
package, answers ``--help`` and argument errors without loading the physics.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "evaluate": "uav_penetration_env.benchmark.evaluate",
    "policy_hash": "uav_penetration_env.benchmark.evaluate",
    "GreedyPolicy": "uav_penetration_env.benchmark.policies",
    "MPCPolicy": "uav_penetration_env.benchmark.policies",
    "Policy": "uav_penetration_env.benchmark.policies",
    "RandomPolicy": "uav_penetration_env.benchmark.policies",
    "make_policy": "uav_penetration_env.benchmark.policies",
    "ResultsStore": "uav_penetration_env.benchmark.store",
    "StoreError": "uav_penetration_env.benchmark.store",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'uav_penetration_env.benchmark' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
