"""MPC window states of stored episodes, and optimiser runs on them (api.md §4.8).

A *window* is one MPC planning problem: the exact state an episode was in at step k, the objective
:class:`~uav_penetration_env.benchmark.policies.MPCPolicy` minimises there
(:func:`~uav_penetration_env.benchmark.policies.mpc_objective`, the one function both use) and a
warm start. Comparing optimisers on identical windows, many seeds each, is what the fixed-target
and fixed-budget analysis (:mod:`uav_penetration_env.benchmark.fixedtarget`) needs; an episode
cannot give it, since two planners leave the start along different tracks.

:func:`replay` rebuilds the exact states of a stored episode from its start (paired seeding,
api.md §4.2) and its stored actions; :func:`window_at` builds a window from a state and the actions
that followed it; :func:`run_window` runs one optimiser on one window; :func:`collect_windows` and
:func:`run_windows` are what ``uav-bench windows`` does with a results store.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import json
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from uav_penetration_env.benchmark.policies import MPCObjective, MPCPolicy, mpc_objective, trace_summary
from uav_penetration_env.benchmark.seeding import episode_seeds
from uav_penetration_env.env import UAVPenetrationEnv
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.mpc import MPC_DEFAULTS, MPCSettings
from uav_penetration_env.scenario import Scenario
from uav_penetration_env.types import FloatArray

ACTION_COLUMNS = ("action_dv", "action_dphi", "action_dtheta")
# Replayed positions must match the stored track to this relative tolerance (km columns are x / 1000).
REPLAY_RTOL = 1e-9


@dataclass(frozen=True, eq=False)
class Window:
    """One MPC window state and where it came from.

    Attributes:
        step: the step index k of the state (the state after k transitions).
        state: (6,) the exact state.
        objective: the MPC objective there (its ``bounds`` are the plan's box; its ``settings``
            the planner's, which enter the optimiser configuration's hash, and the runs' budget).
        x0: (3H,) the warm start: the source episode's next H actions (zeros past its end), clipped
            to the box (DECISION api.md §4.8).
        scenario: the scenario's name; ``scenario_hash``: the hash the episode was seeded with.
        source_policy, source_policy_hash, episode_seed: the stored episode the state comes from.
    """

    step: int
    state: FloatArray
    objective: MPCObjective
    x0: FloatArray
    scenario: str = ""
    scenario_hash: str = ""
    source_policy: str = ""
    source_policy_hash: str = ""
    episode_seed: int = 0


def window_at(
    model: PenetrationModel,
    state: FloatArray,
    step: int,
    following: Sequence[FloatArray],
    settings: MPCSettings = MPC_DEFAULTS,
    *,
    source: Mapping[str, Any] | None = None,
    **changes: Any,
) -> Window:
    """The window at ``state`` (step ``step``), warm-started with the actions that followed it.

    Args:
        model: the scenario's model.
        state: (6,) the exact state.
        step: its step index.
        following: the actions the source episode took from this state on ((3,) each; the first H
            are used, zeros past the episode's end).
        settings: the planner's settings (H, gamma, the terminal form and c_T; the runs' budget).
        source: the :class:`Window`'s provenance fields (``scenario``, ``episode_seed``, ...).
        **changes: settings keys replacing ``settings``' (``horizon=3``, ``terminal="distance"``:
            :meth:`MPCSettings.with_keys`).

    Raises:
        ValueError: a setting outside its domain, or a c_T with a form that has none.
    """
    settings = settings.with_keys(changes)
    settings.check_terminal_pair()  # a window's objective is a planner's: the pair MPCPolicy refuses
    objective = mpc_objective(model, state, step, settings)
    horizon = settings.horizon
    plan = np.zeros((horizon, 3))
    taken = np.asarray(list(following)[:horizon], dtype=np.float64).reshape(-1, 3)
    plan[: len(taken)] = taken
    high = np.asarray(objective.bounds.ub, dtype=np.float64)
    x0 = np.clip(plan.reshape(-1), -high, high)
    return Window(int(step), objective.state, objective, x0, **(source or {}))


def replay(
    scenario: Scenario, seed: int, scenario_hash: str, actions: FloatArray
) -> tuple[PenetrationModel, list[tuple[FloatArray, int]]]:
    """The exact states of a stored episode: its start (paired seeding) stepped through its actions.

    Args:
        scenario: the scenario flown (as read back from the store).
        seed: the episode seed.
        scenario_hash: the hash the episode was seeded with (the store's record).
        actions: (K, 3) the actions of steps 1..K.

    Returns:
        The model and the K + 1 (state, step index) pairs from the start state on (the last one
        is the state the episode ended in).
    """
    env = UAVPenetrationEnv(scenario)
    env_seed, _ = episode_seeds(seed, scenario_hash)
    _, info = env.reset(seed=env_seed)
    states = [(np.asarray(info["state"], dtype=np.float64).copy(), int(info["step"]))]
    for action in np.asarray(actions, dtype=np.float64):
        _, _, terminated, truncated, info = env.step(action)
        states.append((np.asarray(info["state"], dtype=np.float64).copy(), int(info["step"])))
        if terminated or truncated:
            break
    return env.unwrapped.model, states


def collect_windows(
    store: Any,
    *,
    source_policy: str,
    scenario: str,
    steps: Sequence[int],
    episode_seeds: Sequence[int] | None = None,
    settings: MPCSettings = MPC_DEFAULTS,
    **changes: Any,
) -> list[Window]:
    """Window states at ``steps`` of the stored episodes of ``source_policy`` on ``scenario``.

    Args:
        store: an open :class:`~uav_penetration_env.benchmark.store.ResultsStore`.
        source_policy: the policy's name as stored (``greedy``).
        scenario: the scenario's name or its hash (or a prefix of it) as stored.
        steps: window step indices k (0 is the start state); each must be < the episode's K.
        episode_seeds: the episodes' seeds (default: the smallest seed that finished).
        settings: the planner's settings of every window's objective (:func:`window_at`).
        **changes: settings keys replacing ``settings``' (``horizon=3``, ``terminal="distance"``:
            :meth:`MPCSettings.with_keys`).

    Returns:
        One window per (episode seed, step), in that order.

    Raises:
        ValueError: no such episodes, an ambiguous scenario name, a step outside an episode, or a
            replay that does not reproduce the stored track (one line naming the value).
    """
    import yaml

    from uav_penetration_env.scenario import load_scenario

    settings = settings.with_keys(changes)
    settings.check_terminal_pair()  # before any replay: a refused pair costs nothing
    matches, scenario_hash, chosen = _source_episodes(store, source_policy, scenario, episode_seeds)
    name, text = store.scenarios()[scenario_hash]
    flown = load_scenario(yaml.safe_load(text))
    source = {
        "scenario": name,
        "scenario_hash": scenario_hash,
        "source_policy": source_policy,
        "source_policy_hash": str(matches["policy_hash"].iloc[0]),
    }
    windows = []
    for seed in chosen:
        episode = matches[matches["seed"].astype(int) == seed].iloc[0]
        rows = store.steps([int(episode["episode_id"])])
        actions = rows[list(ACTION_COLUMNS)].to_numpy(dtype=np.float64)
        model, states = replay(flown, seed, scenario_hash, actions)
        stored = rows[["x_km", "y_km", "z_m"]].to_numpy(dtype=np.float64)
        replayed = np.array([s[:3] / np.array([1e3, 1e3, 1.0]) for s, _ in states[1:]])
        if replayed.shape != stored.shape or not np.allclose(replayed, stored, rtol=REPLAY_RTOL, atol=1e-9):
            raise ValueError(
                f"--scenario: the replay of {source_policy!r} seed {seed} on {name!r} does not reproduce its "
                "stored track; expected a store written by this version's model"
            )
        bad = [k for k in steps if not 0 <= k < len(actions)]
        if bad:
            raise ValueError(
                f"--steps: got {bad}, expected steps in [0, {len(actions)}) (episode seed {seed} has "
                f"{len(actions)} transitions)"
            )
        for k in steps:
            state, step = states[k]
            windows.append(
                window_at(model, state, step, actions[k:], settings, source={**source, "episode_seed": seed})
            )
    return windows


def _source_episodes(
    store: Any, source_policy: str, scenario: str, episode_seeds: Sequence[int] | None
) -> tuple[Any, str, list[int]]:
    """:func:`collect_windows`' stored episodes: those of the policy on the scenario, one hash, the seeds chosen.

    Returns:
        The matching episode rows, the scenario hash, and the seeds (default: the smallest stored).

    Raises:
        ValueError: as :func:`collect_windows`, for the policy, the scenario or the seeds.
    """
    from uav_penetration_env.suggest import did_you_mean

    episodes = store.episodes(include_errors=False)
    of_policy = episodes[episodes["policy"].astype(str) == source_policy]
    if of_policy.empty:
        names = sorted(set(episodes["policy"].astype(str)))
        raise ValueError(
            f"--from-policy: no finished episodes of {source_policy!r} in the store — "
            f"{did_you_mean(source_policy, names)}stored: {', '.join(names) or 'none'}"
        )
    hashes = of_policy["scenario_hash"].astype(str)
    matches = of_policy[(of_policy["scenario"].astype(str) == scenario) | hashes.str.startswith(scenario)]
    if matches.empty:
        names = sorted(set(of_policy["scenario"].astype(str)))
        raise ValueError(
            f"--scenario: no episodes of {source_policy!r} on {scenario!r} — "
            f"{did_you_mean(scenario, names)}stored: {', '.join(names)}"
        )
    found = sorted(set(matches["scenario_hash"].astype(str)))
    if len(found) > 1:
        raise ValueError(
            f"--scenario: {scenario!r} names {len(found)} scenario hashes ({', '.join(found)}); "
            "expected one: pass a hash prefix"
        )
    seeds = sorted(int(s) for s in matches["seed"])
    chosen = list(episode_seeds) if episode_seeds else seeds[:1]
    missing = [s for s in chosen if s not in seeds]
    if missing:
        raise ValueError(f"--episode-seeds: got {missing}, expected seeds of stored episodes: {seeds}")
    return matches, found[0], chosen


def run_seed(window: Window, seed: int) -> np.random.SeedSequence:
    """The generator seed of run ``seed`` on ``window``, shared by every optimiser (DECISION api.md §4.8)."""
    return np.random.SeedSequence(
        [int(seed), int(window.scenario_hash or "0", 16), int(window.episode_seed), int(window.step)]
    )


def run_window(optimizer: Any, window: Window, rng: Any, max_evals: int | None = None) -> Any:
    """One optimiser run on a window, warm-started with ``window.x0`` when ``minimize`` takes ``x0``.

    ``max_evals`` None spends the window's budget (``window.objective.settings.max_evals``); a
    number overrides it (budget sweeps on the same windows).
    """
    import inspect

    from uav_penetration_env.benchmark.policies import CountedObjective, checked_result

    budget = window.objective.settings.max_evals if max_evals is None else max_evals
    kwargs: dict[str, Any] = {"rng": rng, "max_evals": int(budget)}
    if "x0" in inspect.signature(optimizer.minimize).parameters:
        kwargs["x0"] = window.x0
    counted = CountedObjective(window.objective)
    result = optimizer.minimize(counted, window.objective.bounds, **kwargs)
    # The harness's own count is the run's nfev (a plug-in's claim is not trusted).
    nfev = checked_result(result, counted, window.objective.bounds, int(budget), type(optimizer).__name__)
    if dataclasses.is_dataclass(result):
        return dataclasses.replace(result, nfev=nfev)
    result.nfev = nfev  # scipy's OptimizeResult and other plain results
    return result


def run_windows(
    windows: Sequence[Window],
    optimizers: Sequence[str],
    seeds: Sequence[int],
    *,
    done: set[tuple[Any, ...]] | None = None,
    write: Callable[[list[dict[str, Any]]], None] | None = None,
    progress: Callable[[str], None] | None = None,
    run_id: int | None = None,
) -> list[dict[str, Any]]:
    """Run every optimiser on every window, each seed; rows of the ``window_runs`` table.

    Args:
        windows: from :func:`collect_windows`.
        optimizers: registry names.
        seeds: run seeds (:func:`run_seed`); each run spends its window's budget
            (``objective.settings.max_evals``).
        done: keys (``store.WINDOW_RUN_KEY``) to skip.
        write: called with each window's new rows (one store transaction per window).
        progress: called with one line per window.
        run_id: the provenance row recorded in each row.

    Returns:
        The new rows.
    """
    from optimizers import get_optimizer
    from uav_penetration_env.benchmark.evaluate import policy_hash

    done = done or set()
    all_rows = []
    for window in windows:
        rows = []
        for name in optimizers:
            optimizer = get_optimizer(name)
            config_hash = policy_hash(MPCPolicy(optimizer, window.objective.settings))
            for seed in seeds:
                key = (
                    window.scenario_hash,
                    window.source_policy_hash,
                    window.episode_seed,
                    window.step,
                    config_hash,
                    int(seed),
                )
                if key in done:
                    continue
                start = time.perf_counter()
                result = run_window(optimizer, window, np.random.default_rng(run_seed(window, seed)))
                seconds = time.perf_counter() - start
                rows.append(_window_run_row(window, name, config_hash, int(seed), result, seconds, run_id))
        if rows and write is not None:
            write(rows)
        if progress is not None:
            progress(
                f"window seed {window.episode_seed} step {window.step}: {len(rows)} runs"
                + (f", best J {min(r['fun'] for r in rows):.6g}" if rows else " (all stored)")
            )
        all_rows += rows
    return all_rows


def _window_run_row(
    window: Window, name: str, config_hash: str, seed: int, result: Any, seconds: float, run_id: int | None
) -> dict[str, Any]:
    """One ``window_runs`` row: the window, the optimiser and its configuration hash, the run's result."""
    settings = window.objective.settings
    max_evals = int(settings.max_evals)
    return {
        "scenario": window.scenario,
        "scenario_hash": window.scenario_hash,
        "source_policy": window.source_policy,
        "source_policy_hash": window.source_policy_hash,
        "episode_seed": window.episode_seed,
        "step": window.step,
        "state": json.dumps(np.asarray(window.state).tolist()),
        "optimizer": name,
        "optimizer_hash": config_hash,
        "seed": seed,
        "max_evals": max_evals,
        "horizon": settings.horizon,
        "nfev": int(result.nfev),
        "nit": int(result.nit),
        "fun": float(result.fun),
        **trace_summary(getattr(result, "trace", {}), int(result.nfev), max_evals),
        "history": json.dumps(np.asarray(result.history, dtype=np.float64).tolist()),
        "history_nfev": json.dumps(np.asarray(result.history_nfev, dtype=np.int64).tolist()),
        "message": str(result.message),
        "seconds": seconds,
        "run_id": run_id,
        "finished": dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat(),
    }
