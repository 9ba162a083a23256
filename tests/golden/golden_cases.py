"""The golden cases: what the pinned values are computed from (shared by the test and the writer).

Run ``python -m tests.golden.golden_cases`` from the repository root to (re)write
``tests/golden/*.json``. Do that only for an intended change of results, in a commit of its own
that says why: these files pin the numbers every refactor must keep bit-identical.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).parent
OPTIMIZER_FILE = HERE / "optimizers.json"
PLANNER_FILE = HERE / "planners.json"
SCENARIO_FILE = HERE / "scenario_hashes.json"

DIMENSION = 5
OPTIMIZER_BUDGET = 1_500
OPTIMIZER_SEEDS = (0, 1)
PLANNER_SEEDS = (0, 1)
PLANNER_BUDGET = 200  # evaluations per MPC step: small, so 2 seeds x every planner stay fast
PLANNER_HORIZON = 5

# Optimisers whose results depend on the platform's linear algebra: the cmaes library
# eigendecomposes its covariance matrix with LAPACK (numpy.linalg.eigh), whose last digits differ
# between CPUs and builds, and CMA-ES amplifies them over its generations. Their golden values are
# compared at the outcome level (test_golden.py); every other optimiser is bit-exact everywhere.
PLATFORM_DEPENDENT = frozenset({"cmaes", "cmaes-default"})


def sphere(x: np.ndarray) -> np.ndarray:
    return np.sum((x - 1.25) ** 2, axis=1)


def rastrigin(x: np.ndarray) -> np.ndarray:
    return 10.0 * x.shape[1] + np.sum(x**2 - 10.0 * np.cos(2.0 * np.pi * x), axis=1)


def rosenbrock(x: np.ndarray) -> np.ndarray:
    return np.sum(100.0 * (x[:, 1:] - x[:, :-1] ** 2) ** 2 + (1.0 - x[:, :-1]) ** 2, axis=1)


FUNCTIONS = {"sphere": (sphere, 5.0), "rastrigin": (rastrigin, 5.12), "rosenbrock": (rosenbrock, 2.048)}


def optimizer_case(name: str, function: str, seed: int) -> dict[str, Any]:
    """One optimiser run on one function: exact ``x`` (as float hex), ``fun`` and ``nfev``."""
    from optimizers import get_optimizer

    fun, half_width = FUNCTIONS[function]
    result = get_optimizer(name).minimize(
        fun, [(-half_width, half_width)] * DIMENSION, rng=np.random.default_rng(seed), max_evals=OPTIMIZER_BUDGET
    )
    return {
        "x": [float(v).hex() for v in np.asarray(result.x, dtype=np.float64)],
        "fun": float(result.fun).hex(),
        "nfev": int(result.nfev),
    }


def planner_names() -> list[str]:
    from optimizers import available_optimizers

    return ["greedy", "random", *available_optimizers(), "ihpso-eq37"]


def planner_case(name: str, seed: int) -> dict[str, Any]:
    """One paper-scenario episode of one planner: exact totals (as float hex), steps and outcome."""
    from uav_penetration_env import paper_scenario
    from uav_penetration_env.benchmark.evaluate import EpisodeTask, policy_hash, run_episode
    from uav_penetration_env.benchmark.policies import make_policy

    # The pinned episodes fly the straight-line cost-to-go they were written with (model.md §7e).
    policy = make_policy(name, horizon=PLANNER_HORIZON, max_evals=PLANNER_BUDGET, terminal="distance")
    task = EpisodeTask(name, policy, policy_hash(policy), paper_scenario(), seed)
    row, steps = run_episode(task)
    if row["outcome"] == "error":
        raise RuntimeError(f"golden planner {name} seed {seed}: {row['error']}")
    return {
        "outcome": row["outcome"],
        "steps": int(row["steps"]),
        "nfev": int(row["nfev"]),
        "total_J": float(row["total_J"]).hex(),
        "total_cost": float(row["total_cost"]).hex(),
        "final_xyz": [float(steps[-1][k]).hex() for k in ("x_km", "y_km", "z_m")],
    }


def scenario_hashes() -> dict[str, str]:
    """Hashes of the scenarios that read no file: each seeds every episode flown on it."""
    from uav_penetration_env import paper_scenario, random_scenario

    hashes = {"paper-w1": paper_scenario("w1").hash, "paper-w2": paper_scenario("w2").hash}
    for seed, difficulty in ((0, 0.5), (10_000, 0.5), (7, 0.25), (7, 0.75)):
        scenario = random_scenario(np.random.default_rng(seed), difficulty)
        hashes[f"random-{seed}-d{difficulty}"] = scenario.hash
    return hashes


def write() -> None:  # pragma: no cover - run by hand
    from optimizers import available_optimizers

    optimizers = {
        f"{name}/{function}/{seed}": optimizer_case(name, function, seed)
        for name in available_optimizers()
        for function in FUNCTIONS
        for seed in OPTIMIZER_SEEDS
    }
    OPTIMIZER_FILE.write_text(json.dumps(optimizers, indent=1, sort_keys=True) + "\n")
    planners = {f"{name}/{seed}": planner_case(name, seed) for name in planner_names() for seed in PLANNER_SEEDS}
    PLANNER_FILE.write_text(json.dumps(planners, indent=1, sort_keys=True) + "\n")
    SCENARIO_FILE.write_text(json.dumps(scenario_hashes(), indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":  # pragma: no cover
    write()
