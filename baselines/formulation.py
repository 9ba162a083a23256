"""Training formulations beside today's: value shaping, a route-level turn action, value inputs (docs/rl.md §4.10).

Today's agents act in the env's physical box (Δv, Δφ, Δθ), rescaled to [-1, 1], and learn from the
benchmark reward -(J + penalty). A :class:`Formulation` changes what the agent learns from or acts
in, never what is scored:

- ``shaping="value"``: potential-based shaping (Ng, Harada & Russell 1999) in training only: the
  reward of each transition gets F = γ Φ(s') − Φ(s) with Φ(s) = −min(V(x, y, ψ), 50), V the
  scenario's lattice value function (docs/model.md §7e.2) at the exact state, and Φ = 0 at terminal
  states (:func:`value_potential`, :func:`shaping_terms`);
- ``action="turn"``: the agent chooses one of the lattice's five turns (``Discrete(5)``, for PPO
  and A2C) or a turn in [-1, 1] (``Box(1)``, for SAC, TD3, DDPG), a fraction of dphi_max, and one
  fixed controller turns it into (Δv, Δφ, Δθ): the lattice planner's candidate control
  (:func:`uav_penetration_env.value_function.candidate_control`) following the terrain at
  ``clearance_m`` (40 m by default, the ``lattice-c40`` expert's);
- ``features="value"``: the six value inputs of the distilled planners
  (:func:`baselines.distill.features.value_features`) after the 67-value observation.

The batched training env is wrapped by :class:`FormulationVecEnv` (an SB3 ``VecEnvWrapper``), and a
single Gymnasium env by :class:`ValueShaping` and :class:`TurnAction`; the evaluator's adapter
(:class:`baselines.policy.SB3Policy`) reads the formulation from the sidecar and applies the same
action mapping and inputs. The env's reward, its ``info["J"]`` and the harness's total J are never
changed: shaping is added to the reward the learner sees, after the env has returned it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from uav_penetration_env.kinematics import HEADING
from uav_penetration_env.model import OBSERVATION_SIZE, PenetrationModel
from uav_penetration_env.types import FloatArray
from uav_penetration_env.value_function import (
    LATTICE_GUIDANCE,
    LatticeGuidance,
    candidate_control,
    value_function,
)

SHAPINGS = ("none", "value")
ACTIONS = ("physical", "turn")
FEATURES = ("none", "value")
DISCRETE_ALGORITHMS = ("ppo", "a2c")  # SB3 algorithms with Discrete action spaces; the others get Box(1)
TURNS = tuple(float(t) for t in LATTICE_GUIDANCE.turns)
DEFAULT_CLEARANCE_M = 40.0  # the lattice-c40 expert's terrain-following height (docs/rl.md §4.9)
POTENTIAL_CAP = 50.0  # [J] V is capped here in Φ, as in the distill features' VALUE_CAP (docs/rl.md §4.10)
FEATURE_WIDTH = 1 + len(TURNS)


@dataclass(frozen=True)
class Formulation:
    """What the learner sees and acts in (docs/rl.md §4.10); the default is today's formulation.

    Attributes:
        shaping: ``none`` or ``value`` (potential-based shaping from V, training only).
        action: ``physical`` (the env's box, rescaled to [-1, 1]) or ``turn`` (a lattice turn).
        clearance_m: [m] the turn controller's terrain-following height (``action="turn"`` only).
        features: ``none`` or ``value`` (six value inputs after the observation).
        turn_space: ``discrete`` (``Discrete(5)``) or ``box`` (``Box(-1, 1, (1,))``), from the
            algorithm (:func:`formulation_for`); ignored for ``action="physical"``.
    """

    shaping: str = "none"
    action: str = "physical"
    clearance_m: float = DEFAULT_CLEARANCE_M
    features: str = "none"
    turn_space: str = "discrete"

    @property
    def is_default(self) -> bool:
        """Today's formulation (the sidecars and store keys of older models)."""
        return self.shaping == "none" and self.action == "physical" and self.features == "none"

    @property
    def observation_size(self) -> int:
        """The learner's input width: 67, plus 6 with ``features="value"``."""
        return OBSERVATION_SIZE + (FEATURE_WIDTH if self.features == "value" else 0)

    @property
    def guidance(self) -> LatticeGuidance:
        """The turn controller's settings: the lattice's, at ``clearance_m``."""
        return LatticeGuidance(clearance_m=float(self.clearance_m))

    def policy_action_space(self, physical: spaces.Box) -> spaces.Space[Any]:
        """The learner's action space: ``Box(-1, 1)`` of the physical box's shape, ``Discrete(5)`` or ``Box(1)``."""
        if self.action == "physical":
            ones = np.ones(physical.shape, dtype=physical.dtype)
            return spaces.Box(-ones, ones, dtype=physical.dtype)
        if self.turn_space == "discrete":
            return spaces.Discrete(len(TURNS))
        return spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)

    def to_json(self) -> dict[str, Any]:
        """The sidecar's ``formulation`` entry (everything the evaluator needs to act as in training)."""
        data: dict[str, Any] = asdict(self)
        data["turns"] = list(TURNS)
        data["potential_cap"] = POTENTIAL_CAP
        data["lookahead_steps"] = float(LATTICE_GUIDANCE.lookahead_steps)
        return data

    @classmethod
    def from_json(cls, data: Mapping[str, Any] | None) -> Formulation:
        """The formulation a sidecar records (``None``, an older sidecar: today's).

        Raises:
            ValueError: a recorded value this version does not know (naming the field).
        """
        if data is None:
            return cls()
        formulation = cls(
            shaping=str(data.get("shaping", "none")),
            action=str(data.get("action", "physical")),
            clearance_m=float(data.get("clearance_m", DEFAULT_CLEARANCE_M)),
            features=str(data.get("features", "none")),
            turn_space=str(data.get("turn_space", "discrete")),
        )
        formulation.check()
        if "turns" in data and tuple(float(t) for t in data["turns"]) != TURNS:
            raise ValueError(f"formulation.turns: got {data['turns']!r}, expected {list(TURNS)!r}")
        return formulation

    def check(self) -> None:
        """Raise ``ValueError`` naming the first field outside its values."""
        for name, allowed in (("shaping", SHAPINGS), ("action", ACTIONS), ("features", FEATURES)):
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name}: got {getattr(self, name)!r}, expected one of {', '.join(allowed)}")
        if self.turn_space not in ("discrete", "box"):
            raise ValueError(f"turn_space: got {self.turn_space!r}, expected discrete or box")
        clearance = self.clearance_m
        if (
            isinstance(clearance, bool)
            or not isinstance(clearance, (int, float))
            or not (math.isfinite(clearance) and clearance > 0.0)
        ):
            raise ValueError(f"clearance_m: got {clearance!r}, expected a finite number of metres > 0")


def formulation_for(
    algo: str, shaping: str = "none", action: str = "physical", clearance_m: float = DEFAULT_CLEARANCE_M,
    features: str = "none",
) -> Formulation:  # fmt: skip
    """The checked :class:`Formulation` of a training run of ``algo`` (its turn space from the algorithm).

    DECISION (docs/rl.md §4.10, turn space): PPO and A2C choose among the five turns (``Discrete(5)``,
    a categorical policy, the lattice's own choice set); SAC, TD3 and DDPG, which need a continuous
    box, choose a turn in [-1, 1] (``Box(1)``), flown as that fraction of dphi_max.

    Raises:
        ValueError: an unknown value (naming ``shaping``, ``action``, ``features`` or ``clearance_m``).
    """
    turn_space = "discrete" if str(algo).lower() in DISCRETE_ALGORITHMS else "box"
    formulation = Formulation(shaping, action, clearance_m, features, turn_space)
    formulation.check()
    return formulation


# --- the pieces, on one state ---------------------------------------------------------------------


def value_potential(model: PenetrationModel, states: np.ndarray) -> np.ndarray:
    """(n,) Φ(s) = −min(V(x, y, ψ), 50) [J] of (n, 6) exact states of ``model``'s scenario (docs/rl.md §4.10).

    V is the scenario's lattice value function (:func:`~uav_penetration_env.value_function.value_function`,
    built once per scenario and cached). An infinite or missing V (a pose off the lattice, a node
    every move of which crashes or leaves the map) counts as the cap.

    DECISION (docs/rl.md §4.10, the cap): V is capped at 50 J, the distill features' cap: V of a pose
    off the lattice or beside a crash-priced node is the crash price (~100 J), and uncapped, one
    step there would add a shaping term as large as the crash penalty itself, counting the crash
    twice in the learner's reward during exploration. Any Φ that is a function of the state keeps
    the optimal policy, so the cap costs no optimality; it bounds |F| by 50 J per step.

    Raises:
        ValueError: ``model`` holds several scenarios (its pool), where the state alone does not say which.
    """
    if model.pool_size != 1:
        raise ValueError(f"model: got a pool of {model.pool_size} scenarios, expected one (value shaping)")
    states = np.asarray(states, dtype=np.float64).reshape(-1, 6)
    values = value_function(model)(states[:, 0], states[:, 1], states[:, HEADING])
    values = np.nan_to_num(values, nan=POTENTIAL_CAP, posinf=POTENTIAL_CAP, neginf=POTENTIAL_CAP)
    return -np.clip(values, 0.0, POTENTIAL_CAP)


def shaping_terms(phi: np.ndarray, phi_next: np.ndarray, terminated: np.ndarray, gamma: float) -> np.ndarray:
    """(n,) F = γ Φ(s') − Φ(s), with Φ(s') = 0 where the transition ``terminated`` (docs/rl.md §4.10).

    A truncated transition (the step limit) keeps Φ(s') of its state: the episode was cut, not ended,
    and the learner bootstraps from s' there.
    """
    phi_next = np.where(np.asarray(terminated, dtype=bool), 0.0, np.asarray(phi_next, dtype=np.float64))
    return gamma * phi_next - np.asarray(phi, dtype=np.float64)


def turn_of(formulation: Formulation, action: Any) -> float:
    """The turn, a fraction of dphi_max, of a learner's action (an index of ``TURNS`` or a value in [-1, 1])."""
    if formulation.turn_space == "discrete":
        index = int(np.asarray(action).reshape(-1)[0])
        if not 0 <= index < len(TURNS):
            raise ValueError(f"action: got {index}, expected a turn index in [0, {len(TURNS)})")
        return TURNS[index]
    return float(np.clip(np.asarray(action, dtype=np.float64).reshape(-1)[0], -1.0, 1.0))


def turn_control(
    model: PenetrationModel, state: FloatArray, formulation: Formulation, action: Any
) -> FloatArray:
    """(3,) the physical action [dv m/s, dphi rad, dtheta rad] of a turn action from the exact ``state``.

    The lattice planner's candidate control for :func:`turn_of` ``(formulation, action)`` at
    ``formulation.clearance_m`` (:func:`~uav_penetration_env.value_function.candidate_control`).
    """
    state = np.asarray(state, dtype=np.float64)
    return candidate_control(model, state, turn_of(formulation, action), formulation.guidance)


def learner_observation(
    formulation: Formulation, model: PenetrationModel, observation: Any, state: FloatArray
) -> np.ndarray:
    """(formulation.observation_size,) float32: the observation, then the value inputs when asked."""
    observation = np.asarray(observation, dtype=np.float32).reshape(-1)
    if formulation.features == "none":
        return observation
    from baselines.distill.features import learner_input

    return learner_input(("value",), model, observation, np.asarray(state, dtype=np.float64))


def learner_observation_space(formulation: Formulation, base: spaces.Box) -> spaces.Box:
    """The learner's observation box: ``base`` with unbounded slots for the value inputs."""
    if formulation.features == "none":
        return base
    extra = np.full(FEATURE_WIDTH, np.inf, dtype=base.dtype)
    low = np.concatenate([base.low, -extra]).astype(base.dtype)
    high = np.concatenate([base.high, extra]).astype(base.dtype)
    return spaces.Box(low, high, dtype=base.dtype)


# --- single Gymnasium envs --------------------------------------------------------------------------


def _unwrapped_model(env: gym.Env[Any, Any]) -> PenetrationModel:
    model = getattr(env.unwrapped, "model", None)
    if not isinstance(model, PenetrationModel):
        raise TypeError(f"env: got {env!r}, expected a UAV penetration env (its unwrapped env has a model)")
    return model


class ValueShaping(gym.Wrapper[Any, Any, Any, Any]):
    """Add F = γ Φ(s') − Φ(s) to a single env's reward, for training only (docs/rl.md §4.10).

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
    """A single env whose action is a lattice turn, flown by the candidate control (docs/rl.md §4.10).

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


# --- the batched training env -----------------------------------------------------------------------


def _vec_env_wrapper() -> type:
    """:class:`FormulationVecEnv`'s SB3 base class, imported here so the module loads without SB3."""
    from stable_baselines3.common.vec_env.base_vec_env import VecEnvWrapper

    return VecEnvWrapper


def make_formulation_vec_env(venv: Any, formulation: Formulation, gamma: float | None) -> Any:
    """``venv`` (a :class:`~baselines.vec_env.UAVPenetrationSB3VecEnv`) wrapped for ``formulation``.

    Args:
        venv: the batched SB3 adapter (one fixed scenario).
        formulation: what to apply.
        gamma: the shaping discount (the learner's γ); unused without shaping.

    Returns:
        ``venv`` itself for today's formulation, else a :class:`FormulationVecEnv`.
    """
    if formulation.is_default:
        return venv
    return FormulationVecEnv(venv, formulation, gamma)


class FormulationVecEnv(_vec_env_wrapper()):  # type: ignore[misc]
    """The batched training env with a :class:`Formulation` applied (docs/rl.md §4.10).

    Turn actions are mapped per sub-env by :func:`turn_control` from the sub-env's exact state and
    stepped in physical units; the value inputs are appended to every observation (and to
    ``terminal_observation``); with shaping, each reward gets F of :func:`shaping_terms` (the env's
    reward is kept in ``info["reward_env"]``, F in ``info["shaping"]``; ``info["J"]`` is untouched).

    Args:
        venv: a :class:`~baselines.vec_env.UAVPenetrationSB3VecEnv` over one fixed scenario.
        formulation: what to apply.
        gamma: the shaping discount (required with ``shaping="value"``).

    Raises:
        ValueError: shaping without ``gamma`` in (0, 1].
    """

    def __init__(self, venv: Any, formulation: Formulation, gamma: float | None = None) -> None:
        formulation.check()
        if formulation.shaping == "value" and not (gamma is not None and 0.0 < gamma <= 1.0):
            raise ValueError(f"gamma: got {gamma!r}, expected a number in (0, 1] for value shaping")
        self.formulation = formulation
        self.gamma = float(gamma) if gamma is not None else 1.0
        action_space = (
            formulation.policy_action_space(venv.physical_action_space)
            if formulation.action == "turn"
            else venv.action_space
        )
        super().__init__(
            venv,
            observation_space=learner_observation_space(formulation, venv.observation_space),
            action_space=action_space,
        )
        self._phi = np.zeros(venv.num_envs)
        self._actions: np.ndarray | None = None

    @property
    def _model(self) -> PenetrationModel:
        return self.venv.vector_env.model

    def _states(self) -> np.ndarray:
        return np.array(self.venv.vector_env.states, dtype=np.float64)

    def _observe(self, obs: np.ndarray, states: np.ndarray) -> np.ndarray:
        if self.formulation.features == "none":
            return obs
        model = self._model
        return np.stack(
            [learner_observation(self.formulation, model, o, s) for o, s in zip(obs, states, strict=True)]
        )

    def reset(self) -> np.ndarray:
        """Reset every sub-env; Φ of the first states is remembered for the first step."""
        obs = self.venv.reset()
        states = self._states()
        if self.formulation.shaping == "value":
            self._phi = value_potential(self._model, states)
        return self._observe(obs, states)

    def step_async(self, actions: np.ndarray) -> None:
        """Map turn actions to physical ones (from each sub-env's state now); pass others on."""
        if self.formulation.action != "turn":
            self.venv.step_async(actions)
            return
        model, states = self._model, self._states()
        rows = np.asarray(actions).reshape(self.num_envs, -1)
        physical = np.stack(
            [turn_control(model, s, self.formulation, a) for s, a in zip(states, rows, strict=True)]
        )
        self.venv.step_async_physical(physical)

    def step_wait(self) -> Any:
        """Step; add F to the rewards (shaping), the value inputs to the observations (features)."""
        obs, rewards, dones, infos = self.venv.step_wait()
        model = self._model
        if self.formulation.features == "value":
            for i in np.flatnonzero(dones):
                infos[i]["terminal_observation"] = learner_observation(
                    self.formulation, model, infos[i]["terminal_observation"], infos[i]["state"]
                )
        states = self._states()  # a finished sub-env's is already its next episode's first
        if self.formulation.shaping == "value":
            final = np.stack([np.asarray(info["state"], dtype=np.float64) for info in infos])
            terminated = np.array(
                [bool(d) and not info["TimeLimit.truncated"] for d, info in zip(dones, infos, strict=True)]
            )
            terms = shaping_terms(self._phi, value_potential(model, final), terminated, self.gamma)
            for i, info in enumerate(infos):
                info["reward_env"] = float(rewards[i])
                info["shaping"] = float(terms[i])
            rewards = (rewards.astype(np.float64) + terms).astype(np.float32)
            self._phi = value_potential(model, states)
        return self._observe(obs, states), rewards, dones, infos
