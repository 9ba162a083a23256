"""The benchmark harness: policies (MPC planners, floors), the evaluator, results, leaderboards, CLI."""

from __future__ import annotations

from uav_penetration_env.benchmark.evaluate import evaluate, policy_hash
from uav_penetration_env.benchmark.policies import GreedyPolicy, MPCPolicy, Policy, RandomPolicy, make_policy
from uav_penetration_env.benchmark.store import ResultsStore, StoreError

__all__ = [
    "GreedyPolicy",
    "MPCPolicy",
    "Policy",
    "RandomPolicy",
    "ResultsStore",
    "StoreError",
    "evaluate",
    "make_policy",
    "policy_hash",
]
