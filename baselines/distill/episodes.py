"""One DAgger episode: the learner (or, with probability beta, the expert) flies; the expert labels every state.

The expert is a harness policy driven exactly as the evaluator drives it
(:func:`uav_penetration_env.benchmark.evaluate.run_episode`): ``reset(model, seed)`` once, then
``act(observation, info)`` at every step. It is asked at every state the episode visits, whoever
flies it, so its label is its action from that exact state (``info["state"]``, ``info["step"]``);
a stateful expert (an MPC planner's warm start) follows the flown trajectory as it would its own.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium.wrappers.utils import rescale_box

from baselines.distill.features import learner_input
from uav_penetration_env.env import UAVPenetrationEnv, action_space
from uav_penetration_env.model import PenetrationModel

# Per-step arrays of an episode, saved under these names (episode files and round files alike).
FIELDS = ("observations", "actions", "states", "steps", "expert_flew", "flown")


@dataclass(frozen=True)
class EpisodeData:
    """What one episode adds to the data set (one row per visited state).

    Attributes:
        arrays: ``observations`` (n, 67 + feature widths): the network's inputs, ``actions`` (n, 3): the expert's label normalised to
            [-1, 1], ``states`` (n, 6) and ``steps`` (n,): the exact state labelled,
            ``expert_flew`` (n,): whether the expert's action was applied, ``flown`` (n, 3): the
            normalised action applied.
        summary: total J, steps, outcome.
    """

    arrays: dict[str, np.ndarray]
    summary: dict[str, Any]


def normalisers(model: PenetrationModel) -> tuple[Callable[[np.ndarray], np.ndarray], Callable[[np.ndarray], np.ndarray]]:
    """Physical action -> [-1, 1] and back, by the model's action box (the map SB3Policy uses back)."""
    box = action_space(model.limits)
    ones = np.ones(box.shape, dtype=box.dtype)
    _, _, to_physical = rescale_box(box, -ones, ones)
    low, high = box.low.astype(np.float64), box.high.astype(np.float64)

    def to_unit(action: np.ndarray) -> np.ndarray:
        return np.clip(2.0 * (np.asarray(action, dtype=np.float64) - low) / (high - low) - 1.0, -1.0, 1.0)

    def from_unit(unit: np.ndarray) -> np.ndarray:
        return np.asarray(to_physical(np.asarray(unit, dtype=np.float32)), dtype=np.float64)

    return to_unit, from_unit


def _outcome(info: dict[str, Any], truncated: bool) -> str:
    for flag in ("reached_goal", "collided", "out_of_area"):
        if info.get(flag):
            return {"reached_goal": "success"}.get(flag, flag)
    return "truncated" if truncated else "unknown"


def fly_episode(
    env: UAVPenetrationEnv,
    expert: Any,
    learner: Callable[[PenetrationModel, np.ndarray, np.ndarray], np.ndarray] | None,
    beta: float,
    seeds: np.random.SeedSequence,
    features: tuple[str, ...] = (),
) -> tuple[EpisodeData, int]:
    """Fly one episode and label every visited state by the expert; returns the data and label count.

    Args:
        env: the env of the training scenario.
        expert: the expert policy (copied: each episode starts from the same expert state).
        learner: (model, observation, exact state) -> physical action
            (:func:`baselines.distill.heads.learner_of`); ``None`` (round 0): the expert flies.
        beta: the probability that the expert's action is applied at a step.
        seeds: spawns the env's reset seed, the expert's seed and the mixing generator.
        features: feature sets recorded after each observation (:mod:`baselines.distill.features`):
            the saved ``observations`` are the network's inputs.
    """
    env_seed, policy_seed, mix_seed = seeds.spawn(3)
    mixing = np.random.default_rng(mix_seed)
    expert = copy.deepcopy(expert)
    observation, info = env.reset(seed=int(env_seed.generate_state(1)[0]))
    expert.reset(env.model, policy_seed)
    to_unit, from_unit = normalisers(env.model)
    rows: dict[str, list[Any]] = {name: [] for name in FIELDS}
    total_j, done, truncated = 0.0, False, False
    while not done:
        label = to_unit(expert.act(observation, info))
        expert_flies = learner is None or mixing.random() < beta
        flown = label if expert_flies else to_unit(learner(env.model, observation, info["state"]))
        for name, value in zip(
            FIELDS, (learner_input(features, env.model, observation, info["state"]), label, info["state"], info["step"], expert_flies, flown), strict=True
        ):
            rows[name].append(np.copy(value))
        observation, _, terminated, truncated, info = env.step(from_unit(flown))
        total_j += float(info["J"])
        done = terminated or truncated
    arrays = {
        "observations": np.asarray(rows["observations"], dtype=np.float32),
        "actions": np.asarray(rows["actions"], dtype=np.float32),
        "states": np.asarray(rows["states"], dtype=np.float64),
        "steps": np.asarray(rows["steps"], dtype=np.int32),
        "expert_flew": np.asarray(rows["expert_flew"], dtype=bool),
        "flown": np.asarray(rows["flown"], dtype=np.float32),
    }
    summary = {"total_J": total_j, "steps": len(rows["steps"]), "outcome": _outcome(info, truncated)}
    return EpisodeData(arrays, summary), len(rows["steps"])


def fly_learner(
    env: UAVPenetrationEnv, learner: Callable[[PenetrationModel, np.ndarray, np.ndarray], np.ndarray], seeds: np.random.SeedSequence
) -> dict[str, Any]:
    """Fly one episode with the learner alone, no expert asked; returns its total J, penalty, steps, outcome."""
    observation, info = env.reset(seed=int(seeds.generate_state(1)[0]))
    total_j, steps, done, truncated = 0.0, 0, False, False
    while not done:
        action = learner(env.model, observation, info["state"])
        observation, _, terminated, truncated, info = env.step(action)
        total_j += float(info["J"])
        steps += 1
        done = terminated or truncated
    penalty = float(info["penalty"])
    return {"total_J": total_j, "penalty": penalty, "cost": total_j + penalty, "steps": steps, "outcome": _outcome(info, truncated)}
