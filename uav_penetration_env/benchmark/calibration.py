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
from uav_penetration_env.benchmark.policies import GreedyPolicy, RandomPolicy
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


def with_payoff(scenario: Scenario, payoff: PayoffNormalisation) -> Scenario:
    """The scenario with ``payoff`` stored in its normalisation block."""
    return replace(scenario, normalisation=replace(scenario.normalisation, payoff=payoff))
