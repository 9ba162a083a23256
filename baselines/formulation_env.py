"""Gymnasium wrappers of the training formulations on a single env (docs/rl.md §6).

The pieces they apply, on one state, are in :mod:`baselines.formulation`; the batched training env's
wrapper is :class:`baselines.vec_env.FormulationVecEnv`. Nothing here needs SB3.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from baselines.formulation import (
    Formulation,
    learner_observation,
    learner_observation_space,
    shaping_terms,
    turn_control,
    value_potential,
)
from uav_penetration_env.model import PenetrationModel

# --- single Gymnasium envs --------------------------------------------------------------------------


def _unwrapped_model(env: gym.Env[Any, Any]) -> PenetrationModel:
    model = getattr(env.unwrapped, "model", None)
    if not isinstance(model, PenetrationModel):
        raise TypeError(f"env: got {env!r}, expected a UAV penetration env (its unwrapped env has a model)")
    return model


class ValueShaping(gym.Wrapper[Any, Any, Any, Any]):
    """Add F = γ Φ(s') − Φ(s) to a single env's reward, for training only (docs/rl.md §6).

    Φ is :func:`value_potential` of ``info["state"]`` (0 after a terminating step). ``info["J"]``,
    ``info["penalty"]`` and every other entry stay the env's; the unshaped reward is kept in
    ``info["reward_env"]`` and the term in ``info["shaping"]``.

    Args:
        env: a UAV penetration env (one scenario).
        gamma: the learner's discount, in (0, 1].
    """

    def __init__(self, env: gym.Env[Any, Any], gamma: float) -> None:
        super().__init__(env)
        if not (isinstance(gamma, (int, float)) and 0.0 < gamma <= 1.0):
            raise ValueError(f"gamma: got {gamma!r}, expected a number in (0, 1]")
        self.gamma = float(gamma)
        self._phi = 0.0

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        """Reset the env and remember Φ of its first state."""
        obs, info = self.env.reset(**kwargs)
        self._phi = float(value_potential(_unwrapped_model(self.env), info["state"])[0])
        return obs, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Step the env; the reward returned is the env's plus F."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        phi_next = float(value_potential(_unwrapped_model(self.env), info["state"])[0])
        term = float(
            shaping_terms(np.array([self._phi]), np.array([phi_next]), np.array([terminated]), self.gamma)[0]
        )
        self._phi = phi_next
        info = {**info, "reward_env": float(reward), "shaping": term}
        return obs, float(reward) + term, terminated, truncated, info


class TurnAction(gym.Wrapper[Any, Any, Any, Any]):
    """A single env whose action is a lattice turn, flown by the candidate control (docs/rl.md §6).

    With ``formulation.features == "value"`` the observation carries the six value inputs too.

    Args:
        env: a UAV penetration env (one scenario).
        formulation: with ``action="turn"`` (its ``turn_space`` and ``clearance_m``).
    """

    def __init__(self, env: gym.Env[Any, Any], formulation: Formulation) -> None:
        super().__init__(env)
        formulation.check()
        if formulation.action != "turn":
            raise ValueError(f"formulation.action: got {formulation.action!r}, expected 'turn'")
        self.formulation = formulation
        base = env.action_space
        if not isinstance(base, spaces.Box):
            raise TypeError(f"env: expected a Box action space, got {base}")
        self.action_space = formulation.policy_action_space(base)
        obs_space = env.observation_space
        if not isinstance(obs_space, spaces.Box):
            raise TypeError(f"env: expected a Box observation space, got {obs_space}")
        self.observation_space = learner_observation_space(formulation, obs_space)
        self._state: np.ndarray | None = None

    def _observe(self, obs: Any, info: Mapping[str, Any]) -> Any:
        self._state = np.asarray(info["state"], dtype=np.float64).copy()
        return learner_observation(self.formulation, _unwrapped_model(self.env), obs, self._state)

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        """Reset the env (the state the next turn is flown from is ``info["state"]``)."""
        obs, info = self.env.reset(**kwargs)
        return self._observe(obs, info), info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Fly the turn's candidate control from the current exact state."""
        if self._state is None:
            raise RuntimeError("TurnAction.step() before reset()")
        physical = turn_control(_unwrapped_model(self.env), self._state, self.formulation, action)
        obs, reward, terminated, truncated, info = self.env.step(physical)
        return self._observe(obs, info), reward, terminated, truncated, info
