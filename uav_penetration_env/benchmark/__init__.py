"""The benchmark harness: policies (MPC planners, floors), the evaluator, results, leaderboards, CLI."""

from __future__ import annotations

from uav_penetration_env.benchmark.policies import GreedyPolicy, Policy, RandomPolicy

__all__ = ["GreedyPolicy", "Policy", "RandomPolicy"]
