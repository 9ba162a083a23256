"""The benchmark harness: policies (MPC planners, floors), the evaluator, results, leaderboards, CLI.

The public names are imported on first use (PEP 562), so that the CLI's parser, which lives in this
package, answers ``--help`` and argument errors without loading the physics.
"""

from __future__ import annotations

from uav_penetration_env.lazy import exported_modules, lazy_exports

_EXPORTS = {
    ".evaluate": ("evaluate", "policy_hash"),
    ".policies": ("GreedyPolicy", "MPCPolicy", "Policy", "RandomPolicy", "make_policy", "policy_label"),
    ".policy_spec": ("PolicySpec",),
    ".policy_names": ("parse_policy",),
    ".store": ("ResultsStore", "StoreError"),
}

__all__ = sorted(exported_modules(_EXPORTS))


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
