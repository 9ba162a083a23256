"""Payoff-table constants for the ``paper`` profile's normalisation (eq. 39; model.md §7).

:func:`provisional_payoff` derives stand-in constants from sampled rollouts of the greedy and
random floors, so ``UAVPenetrationPaper-v0`` runs before anyone has calibrated;
:func:`payoff_table` (the harness's ``uav-bench calibrate``) replaces them with the paper's §4.2
procedure.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Iterable
from dataclasses import replace
from typing import Any

import numpy as np

from uav_penetration_env import __version__
from uav_penetration_env.benchmark.policies import MPC_DEFAULTS, GreedyPolicy, RandomPolicy
from uav_penetration_env.env import UAVPenetrationEnv
from uav_penetration_env.scenario import PayoffConstants, PayoffNormalisation, Scenario

RAW_TERMS = ("terrain_threat", "radar_threat", "third_term")


def raw_term_scenario(scenario: Scenario) -> Scenario:
    """The scenario under the paper profile's physics with analytic normalisation.

    Calibration records raw terms, which do not depend on the normalisation, so it must run
    before any payoff constants exist.
    """
    paper = scenario.updated(
        {"profile": "paper", "normalisation": {"mode": "analytic"}, "cost": {"crash_penalty_per_step": 1.0}}
    )
    return paper


def record_raw_terms(
    scenario: Scenario, policies: Iterable[tuple[str, Any]], seeds: Iterable[int]
) -> dict[str, np.ndarray]:
    """Raw per-step terms at the executed track points of every (policy, seed) episode."""
    env = UAVPenetrationEnv(raw_term_scenario(scenario))
    records: dict[str, list[float]] = {term: [] for term in RAW_TERMS}
    for _, policy in policies:
        for seed in seeds:
            observation, info = env.reset(seed=int(seed))
            policy.reset(env.model, int(seed))
            done = False
            while not done:
                observation, _, terminated, truncated, info = env.step(policy.act(observation, info))
                done = terminated or truncated
                for term in RAW_TERMS:
                    records[term].append(float(info[term]))
    return {term: np.array(values) for term, values in records.items()}


def constants_from_records(
    records: dict[str, np.ndarray], weights: tuple[float, float, float]
) -> PayoffConstants:
    """(min, max) per raw term and the largest J(k) seen (the paper profile's crash penalty per step)."""
    bounds = []
    for term in RAW_TERMS:
        low, high = float(records[term].min()), float(records[term].max())
        if high <= low:
            high = low + 1.0  # a term that never varied: keep eq. 39 defined
        bounds.append((low, high))
    normalised = [(records[t] - lo) / (hi - lo) for t, (lo, hi) in zip(RAW_TERMS, bounds, strict=True)]
    largest = float(np.max(sum(w * n for w, n in zip(weights, normalised, strict=True))))
    return PayoffConstants(
        terrain=bounds[0], radar=bounds[1], third=bounds[2], crash_penalty_per_step=largest
    )


def provisional_payoff(scenario: Scenario, seeds: Iterable[int] = range(10)) -> PayoffNormalisation:
    """Stand-in payoff constants from greedy and random floor rollouts (model.md §7b).

    DECISION (model.md §7b): until ``uav-bench calibrate`` has run, ``paper.yaml`` carries these,
    marked as provisional in their provenance.
    """
    seeds = list(seeds)
    records = record_raw_terms(scenario, [("greedy", GreedyPolicy()), ("random", RandomPolicy())], seeds)
    constants = constants_from_records(records, scenario.cost.weights)
    provenance = (
        ("method", "provisional: min/max of raw per-step terms over greedy and random floor rollouts"),
        ("policies", "greedy, random"),
        ("seeds", f"{seeds[0]}-{seeds[-1]}" if seeds else ""),
        ("track_points", len(records["terrain_threat"])),
        ("package_version", __version__),
        ("date", dt.date.today().isoformat()),
    )
    return PayoffNormalisation(constants=constants, provenance=provenance)


CALIBRATION_CRASH_PENALTY = 1.0e6  # per remaining step: a single-objective MPC must never prefer a crash
SINGLE_OBJECTIVE_WEIGHTS = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


class CalibrationFailed(RuntimeError):
    """Some episodes of the payoff table ended in an error, so no constants can be derived."""


def payoff_table(
    scenario: Scenario,
    optimizer: str,
    *,
    max_evals: int = MPC_DEFAULTS.max_evals,
    runs: int = 20,
    horizon: int = 10,
    n_jobs: int | None = 1,
    imports: tuple[str, ...] = (),
    progress: bool = True,
    command: str | None = None,
) -> PayoffNormalisation:
    """The paper's payoff-table normalisation constants (§4.2 steps 2-3; model.md §7, A29).

    For each single-objective weight vector (1,0,0), (0,1,0), (0,0,1): ``runs`` MPC episodes with
    horizon ``horizon`` and the reference ``optimizer``, whose window cost is that raw per-step
    term alone (analytic normalisation is affine, so it does not change the optimum). Raw terms
    are recorded at executed track points; x_min^j is the minimum over the runs optimising j and
    x_max^j the maximum over the runs optimising the other two. The paper profile's crash
    penalty per step is the largest J(k) (paper weights, these constants) seen in any run.

    DECISION (model.md §7): the calibration MPC has no terminal cost (form ``none``: the
    objective is the raw term alone, as §4.2 says) and a prohibitive crash penalty, so a
    single-objective planner never ends an episode on purpose; constants are calibrated once
    per scenario and frozen in its file (A29).
    """
    from optimizers import get_optimizer
    from uav_penetration_env.benchmark.policies import MPCPolicy
    from uav_penetration_env.mpc import MPCSettings, Terminal

    settings = MPCSettings(horizon=horizon, max_evals=max_evals, terminal=Terminal("none"))
    policy = MPCPolicy(get_optimizer(optimizer), settings, name=optimizer)
    per_objective = _single_objective_terms(
        scenario, policy, runs, n_jobs=n_jobs, imports=imports, progress=progress, command=command
    )
    bounds = []
    for j, term in enumerate(RAW_TERMS):
        low = float(per_objective[j][term].min())
        high = float(max(per_objective[i][term].max() for i in range(3) if i != j))
        if high <= low:
            high = low + max(abs(low), 1.0) * 1e-6  # degenerate table: keep eq. 39 finite
        bounds.append((low, high))
    everything = {term: np.concatenate([p[term] for p in per_objective]) for term in RAW_TERMS}
    normalised = [(everything[t] - lo) / (hi - lo) for t, (lo, hi) in zip(RAW_TERMS, bounds, strict=True)]
    largest = float(np.max(sum(w * n for w, n in zip(scenario.cost.weights, normalised, strict=True))))
    from uav_penetration_env.benchmark.provenance import git_commit

    provenance = (
        ("method", "payoff table, paper section 4.2 steps 2-3 (model.md section 7)"),
        ("optimizer", optimizer),
        ("max_evals", int(max_evals)),
        ("runs", int(runs)),
        ("horizon", int(horizon)),
        ("seeds", f"0-{runs - 1}"),
        ("track_points", int(sum(len(p["terrain_threat"]) for p in per_objective))),
        ("commit", git_commit()),
        ("package_version", __version__),
        ("date", dt.date.today().isoformat()),
    )
    constants = PayoffConstants(
        terrain=bounds[0], radar=bounds[1], third=bounds[2], crash_penalty_per_step=largest
    )
    return PayoffNormalisation(constants=constants, provenance=provenance)


def _single_objective_terms(
    scenario: Scenario, policy: Any, runs: int, **evaluate_options: Any
) -> list[dict[str, np.ndarray]]:
    """The raw per-step terms of :func:`payoff_table`'s runs, one dict per single-objective weight vector.

    Raises:
        CalibrationFailed: some of the runs ended in an error.
    """
    import tempfile
    from pathlib import Path

    from uav_penetration_env.benchmark.evaluate import evaluate
    from uav_penetration_env.benchmark.store import ResultsStore

    base = raw_term_scenario(scenario)
    per_objective: list[dict[str, np.ndarray]] = []
    with tempfile.TemporaryDirectory() as folder:
        store_path = Path(folder) / "calibration.sqlite"
        for index, weights in enumerate(SINGLE_OBJECTIVE_WEIGHTS):
            single = base.updated(
                {
                    "name": f"{scenario.name}-calibrate-{RAW_TERMS[index]}",
                    "cost": {"weights": list(weights), "crash_penalty_per_step": CALIBRATION_CRASH_PENALTY},
                }
            )
            evaluate(
                {f"calibrate-{RAW_TERMS[index]}": policy},
                [single],
                range(runs),
                store=store_path,
                **evaluate_options,
            )
            with ResultsStore(store_path) as store:
                episodes = store.episodes()
                ids = episodes.loc[episodes["scenario_hash"] == single.hash, "episode_id"]
                errors = episodes.loc[episodes["scenario_hash"] == single.hash, "error"]
                if (errors != "").any():
                    raise CalibrationFailed(
                        f"{int((errors != '').sum())} of {len(errors)} calibration episodes failed; "
                        f"first error: {errors[errors != ''].iloc[0].splitlines()[0]}"
                    )
                steps = store.steps(ids)
            per_objective.append({term: steps[term].to_numpy() for term in RAW_TERMS})
    return per_objective


def with_payoff(scenario: Scenario, payoff: PayoffNormalisation) -> Scenario:
    """The scenario with ``payoff`` stored in its normalisation block."""
    return replace(scenario, normalisation=replace(scenario.normalisation, payoff=payoff))
