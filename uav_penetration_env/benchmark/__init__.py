"""The benchmark harness: policies (MPC planners, floors), the evaluator, results, leaderboards, CLI.

The public names are imported on first use (PEP 562), so that the CLI's parser, which lives in this
package, answers ``--help`` and argument errors without loading the physics.
"""

from __future__ import annotations

from uav_penetration_env.lazy import lazy_exports

_EXPORTS = {
    "evaluate": "uav_penetration_env.benchmark.evaluate",
    "policy_hash": "uav_penetration_env.benchmark.evaluate",
    "GreedyPolicy": "uav_penetration_env.benchmark.policies",
    "MPCPolicy": "uav_penetration_env.benchmark.policies",
    "Policy": "uav_penetration_env.benchmark.policies",
    "RandomPolicy": "uav_penetration_env.benchmark.policies",
    "make_policy": "uav_penetration_env.benchmark.policies",
    "policy_label": "uav_penetration_env.benchmark.policies",
    "PolicySpec": "uav_penetration_env.benchmark.policy_spec",
    "parse_policy": "uav_penetration_env.benchmark.policy_names",
    "ResultsStore": "uav_penetration_env.benchmark.store",
    "StoreError": "uav_penetration_env.benchmark.store",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
