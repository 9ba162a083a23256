"""Decision cost as a user's machine sees it: per-map setup and per-step decisions, interleaved in one process.

Speed claims compare planners timed side by side (docs/publishing.md §6, api.md §4.12): rows
flown in different runs, at different commits or under different load cannot be compared. For
each map (a scenario and an episode seed), :func:`time_map`

1. builds each planner's **setup** cold: ``policy.reset(model, seed)`` on a fresh model with an
   empty cache folder and no in-memory artefacts, so the value function V, a network's weights or
   anything else a planner prepares once per scenario is built or loaded as on a new map; the
   environment's own map build (terrain, masking floors), which every planner shares, is not a
   planner's setup;
2. flies one episode with the **driver**'s actions (the first policy) and, at every state, asks
   every planner for its decision, in an order that rotates from step to step, so every planner
   decides on the same states under the same machine load; the non-drivers' actions are discarded.

Every duration is taken twice, CPU and wall seconds (:mod:`~.clock`).

:func:`summarise` turns the measurements into ratios against a reference planner: the per-step
CPU ratio (mean of the planner's step CPU over the reference's) with a percentile-bootstrap
interval over maps (over steps for a single map), and the **per-map amortised** ratio
(setup + the steps of one episode) / (the reference's setup + its steps).
"""

from __future__ import annotations

import copy
import os
import tempfile
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark import stats
from uav_penetration_env.benchmark.clock import timed
from uav_penetration_env.benchmark.seeding import episode_seeds
from uav_penetration_env.env import UAVPenetrationEnv
from uav_penetration_env.scenario import Scenario


class ColdCache:
    """A context in which nothing built per scenario is found cached: an empty cache folder, no memory copies.

    (A value function is memoised per model: a fresh model finds none.) The folder is removed on exit and
    ``$UAV_PENETRATION_CACHE`` restored.
    """

    def __enter__(self) -> ColdCache:
        from uav_penetration_env import cache

        self._folder = tempfile.TemporaryDirectory(prefix="uav-timing-")
        self._saved = os.environ.get(cache.ENV_VAR)
        os.environ[cache.ENV_VAR] = self._folder.name
        cache.clear_memory()
        return self

    def __exit__(self, *exc: object) -> None:
        from uav_penetration_env import cache

        if self._saved is None:
            os.environ.pop(cache.ENV_VAR, None)
        else:
            os.environ[cache.ENV_VAR] = self._saved
        cache.clear_memory()
        self._folder.cleanup()


def time_map(
    policies: Mapping[str, Any], scenario: Scenario, seed: int, *, max_steps: int | None = None
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Cold setups, then every planner's decision on each state of the driver's episode.

    Args:
        policies: name -> policy (``reset(model, seed)``, ``act(observation, info)``); the first
            is the driver, whose actions fly the episode.
        scenario: the map.
        seed: the episode seed (paired seeding, api.md §4.2: every planner gets its episode's
            policy seed).
        max_steps: stop after this many steps (default: the episode's end).

    Returns:
        (setups, steps): one setup row per planner (``policy``, ``setup_cpu``, ``setup_wall``) and
        one row per (step, planner) (``step``, ``policy``, ``order`` of the call at that step,
        ``cpu``, ``wall``).
    """
    names = list(policies)
    env_seed, policy_seed = episode_seeds(seed, scenario.hash)
    models, instances, setups = {}, {}, []
    for name in names:
        env = UAVPenetrationEnv(scenario)  # built with the usual cache: the map is every planner's
        policy = copy.deepcopy(policies[name])
        with ColdCache():
            _, clock = timed(policy.reset, env.model, policy_seed)
        models[name], instances[name] = env, policy
        setups.append({"policy": name, "setup_cpu": clock.cpu, "setup_wall": clock.wall})
    driver = models[names[0]]
    observation, info = driver.reset(seed=env_seed)
    steps, k, done = [], 0, False
    while not done and (max_steps is None or k < max_steps):
        order = names[k % len(names) :] + names[: k % len(names)]  # rotate: no planner always goes first
        action = None
        for position, name in enumerate(order):
            decided, clock = timed(instances[name].act, observation, info)
            if name == names[0]:
                action = decided
            steps.append({"step": k, "policy": name, "order": position, "cpu": clock.cpu, "wall": clock.wall})
        observation, _, terminated, truncated, info = driver.step(np.asarray(action, dtype=np.float64))
        done, k = terminated or truncated, k + 1
    return pd.DataFrame(setups), pd.DataFrame(steps)


def summarise(
    setups: pd.DataFrame, steps: pd.DataFrame, reference: str, *, seed: int = 0, n_resamples: int = 2_000
) -> pd.DataFrame:
    """Per planner: setup and step costs, and their ratios to ``reference`` with bootstrap intervals.

    Args:
        setups: :func:`time_map`'s setups with a ``map`` column (one row per map and planner).
        steps: :func:`time_map`'s steps with a ``map`` column.
        reference: the planner the ratios divide by.
        seed: the bootstraps' base seed.
        n_resamples: bootstrap resamples.

    Returns:
        One row per planner: ``maps``, ``steps`` (decisions timed), ``setup_cpu``, ``setup_wall``
        (mean per map), ``step_cpu_ms``, ``step_wall_ms`` (mean per decision), ``step_ratio``
        (mean step CPU / the reference's, with ``step_ratio_low``/``_high``), ``map_cpu``
        (setup + one episode's steps, CPU, mean per map) and ``map_ratio`` (/ the reference's,
        with ``map_ratio_low``/``_high``). Intervals resample maps, or steps when one map was
        timed; a ratio above 1 means the planner costs more than the reference.
    """
    per_map = steps.groupby(["map", "policy"]).agg(cpu=("cpu", "sum"), wall=("wall", "sum"), n=("cpu", "size"))
    per_map = per_map.join(setups.set_index(["map", "policy"]))
    maps = sorted(set(setups["map"]))
    rows = []
    for name in list(dict.fromkeys(setups["policy"])):
        mine, theirs = per_map.xs(name, level="policy"), per_map.xs(reference, level="policy")
        row: dict[str, Any] = {
            "policy": name,
            "maps": len(mine),
            "steps": int(mine["n"].sum()),
            "setup_cpu": float(mine["setup_cpu"].mean()),
            "setup_wall": float(mine["setup_wall"].mean()),
            "step_cpu_ms": 1000 * float(mine["cpu"].sum() / mine["n"].sum()),
            "step_wall_ms": 1000 * float(mine["wall"].sum() / mine["n"].sum()),
            "map_cpu": float((mine["setup_cpu"] + mine["cpu"]).mean()),
        }
        label = f"{name}|{reference}"
        if len(maps) > 1:
            units = np.column_stack([mine["cpu"] / mine["n"], theirs["cpu"] / theirs["n"],
                                     mine["setup_cpu"] + mine["cpu"], theirs["setup_cpu"] + theirs["cpu"]])  # fmt: skip
        else:  # one map: the steps are the units of the per-step ratio; the map ratio has no interval
            a = steps[steps["policy"] == name].sort_values("step")["cpu"].to_numpy()
            b = steps[steps["policy"] == reference].sort_values("step")["cpu"].to_numpy()
            units = np.column_stack([a, b, np.full(a.size, np.nan), np.full(a.size, np.nan)])
        row.update(_ratios(units, row, theirs, seed=stats.label_seed(seed, label, 40), n_resamples=n_resamples))
        rows.append(row)
    return pd.DataFrame(rows)


def _ratios(units: np.ndarray, row: dict[str, Any], theirs: pd.DataFrame, *, seed: Any, n_resamples: int) -> dict[str, float]:
    """The two ratios and their percentile-bootstrap intervals over the rows of ``units``."""
    step_ratio = (row["step_cpu_ms"] / 1000) / float(theirs["cpu"].sum() / theirs["n"].sum())
    map_ratio = row["map_cpu"] / float((theirs["setup_cpu"] + theirs["cpu"]).mean())
    rng = np.random.default_rng(seed)
    draws = rng.integers(0, len(units), size=(n_resamples, len(units)))
    sums = units[draws].sum(axis=1)  # (n_resamples, 4): resampled totals of each column
    with np.errstate(divide="ignore", invalid="ignore"):
        step_draws, map_draws = sums[:, 0] / sums[:, 1], sums[:, 2] / sums[:, 3]
    interval = {}
    for key, draws_ in (("step_ratio", step_draws), ("map_ratio", map_draws)):
        finite = draws_[np.isfinite(draws_)]
        low, high = (np.quantile(finite, [0.025, 0.975]) if finite.size else (np.nan, np.nan))
        interval[f"{key}_low"], interval[f"{key}_high"] = float(low), float(high)
    return {"step_ratio": step_ratio, "map_ratio": map_ratio, **interval}


def time_planners(
    policies: Mapping[str, Any],
    scenarios: Sequence[Scenario],
    seeds: Sequence[int],
    *,
    max_steps: int | None = None,
    warmup: bool = True,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """:func:`time_map` over every (scenario, seed), after an untimed warm-up on the first.

    The warm-up flies two steps of every planner on the first map with the usual cache, so the
    compiled kernels are loaded (or compiled) before anything is timed.

    Returns:
        (setups, steps) of every map, with a ``map`` column (``SCENARIO/SEED``).
    """
    if warmup:
        time_map(policies, scenarios[0], int(seeds[0]), max_steps=2)
    all_setups, all_steps = [], []
    for scenario in scenarios:
        for seed in seeds:
            setups, steps = time_map(policies, scenario, int(seed), max_steps=max_steps)
            label = f"{scenario.name}/{seed}"
            all_setups.append(setups.assign(map=label))
            all_steps.append(steps.assign(map=label))
    return pd.concat(all_setups, ignore_index=True), pd.concat(all_steps, ignore_index=True)


__all__ = ["ColdCache", "summarise", "time_map", "time_planners"]
