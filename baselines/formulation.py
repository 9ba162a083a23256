"""Training formulations beside today's: value shaping, a route-level turn action, value inputs (docs/rl.md §6).

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

The batched training env is wrapped by :class:`baselines.formulation_env.FormulationVecEnv` (an SB3
``VecEnvWrapper``), and a single Gymnasium env by :class:`~baselines.formulation_env.ValueShaping` and
:class:`~baselines.formulation_env.TurnAction`; this module stays light (no physics, no SB3 at
import), as the CLI parser reads it; the evaluator's adapter
(:class:`baselines.policy.SB3Policy`) reads the formulation from the sidecar and applies the same
action mapping and inputs. The env's reward, its ``info["J"]`` and the harness's total J are never
changed: shaping is added to the reward the learner sees, after the env has returned it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from gymnasium import spaces

    from uav_penetration_env.model import PenetrationModel
    from uav_penetration_env.types import FloatArray
    from uav_penetration_env.value_function import LatticeGuidance

SHAPINGS = ("none", "value")
ACTIONS = ("physical", "turn")
FEATURES = ("none", "value")
DISCRETE_ALGORITHMS = ("ppo", "a2c")  # SB3 algorithms with Discrete action spaces; the others get Box(1)
# The lattice's turns (LATTICE_GUIDANCE.turns; a test checks they agree), fractions of dphi_max.
TURNS = (-1.0, -0.5, 0.0, 0.5, 1.0)
OBSERVATION_VALUES = 67  # the env's observation (uav_penetration_env.model.OBSERVATION_SIZE; a test checks)
LOOKAHEAD_STEPS = 2.0  # the candidate control's look-ahead (LATTICE_GUIDANCE.lookahead_steps; a test checks)
DEFAULT_CLEARANCE_M = 40.0  # the lattice-c40 expert's terrain-following height (docs/rl.md §4.9)
POTENTIAL_CAP = 50.0  # [J] V is capped here in Φ, as in the distill features' VALUE_CAP (docs/rl.md §6)
FEATURE_WIDTH = 1 + len(TURNS)


@dataclass(frozen=True)
class Formulation:
    """What the learner sees and acts in (docs/rl.md §6); the default is today's formulation.

    Attributes:
        shaping: ``none`` or ``value`` (potential-based shaping from V, training only).
        action: ``physical`` (the env's box, rescaled to [-1, 1]) or ``turn`` (a lattice turn).
        clearance_m: [m] the turn controller's terrain-following height (``action="turn"`` only).
        features: ``none`` or ``value`` (six value inputs after the observation).

    DECISION (docs/rl.md §6, the controller's clearance): 40 m by default, the ``lattice-c40``
    expert's (docs/rl.md §4.9): the collision floor plus 10 m, where the lattice planner is 3.70 J
    below greedy on the validation maps; 100 m (the lattice's) is one flag away.
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
    def tag(self) -> str:
        """A name part for default model files (empty for today's formulation).

        ``shaped``, ``turn`` (``turn-c100`` at another clearance) and ``value``, joined by ``-``.
        """
        parts = []
        if self.shaping == "value":
            parts.append("shaped")
        if self.action == "turn":
            parts.append("turn" if self.clearance_m == DEFAULT_CLEARANCE_M else f"turn-c{self.clearance_m:g}")
        if self.features == "value":
            parts.append("value")
        return "-".join(parts)

    @property
    def observation_size(self) -> int:
        """The learner's input width: 67, plus 6 with ``features="value"``."""
        return OBSERVATION_VALUES + (FEATURE_WIDTH if self.features == "value" else 0)

    @property
    def guidance(self) -> LatticeGuidance:
        """The turn controller's settings: the lattice's, at ``clearance_m``."""
        from uav_penetration_env.value_function import LatticeGuidance

        return LatticeGuidance(clearance_m=float(self.clearance_m))

    def policy_action_space(self, physical: spaces.Box) -> spaces.Space[Any]:
        """The learner's action space: ``Box(-1, 1)`` of the physical box's shape, ``Discrete(5)`` or ``Box(1)``."""
        from gymnasium import spaces

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
        data["lookahead_steps"] = LOOKAHEAD_STEPS
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
        # The controller this version flies must be the one the model was trained with.
        if "lookahead_steps" in data and float(data["lookahead_steps"]) != LOOKAHEAD_STEPS:
            raise ValueError(
                f"formulation.lookahead_steps: got {data['lookahead_steps']!r}, expected {LOOKAHEAD_STEPS}"
            )
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

    DECISION (docs/rl.md §6, turn space): PPO and A2C choose among the five turns (``Discrete(5)``,
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
    """(n,) Φ(s) = −min(V(x, y, ψ), 50) [J] of (n, 6) exact states of ``model``'s scenario (docs/rl.md §6).

    V is the scenario's lattice value function (:func:`~uav_penetration_env.value_function.value_function`,
    built once per scenario and cached). An infinite or missing V (a pose off the lattice, a node
    every move of which crashes or leaves the map) counts as the cap.

    DECISION (docs/rl.md §6, the cap): V is capped at 50 J, the distill features' cap: V of a pose
    off the lattice or beside a crash-priced node is the crash price (~100 J), and uncapped, one
    step there would add a shaping term as large as the crash penalty itself, counting the crash
    twice in the learner's reward during exploration. Any Φ that is a function of the state keeps
    the optimal policy, so the cap costs no optimality; it bounds |F| by 50 J per step.

    Raises:
        ValueError: ``model`` holds several scenarios (its pool), where the state alone does not say which.
    """
    from uav_penetration_env.kinematics import HEADING
    from uav_penetration_env.value_function import value_function

    if model.pool_size != 1:
        raise ValueError(f"model: got a pool of {model.pool_size} scenarios, expected one (value shaping)")
    states = np.asarray(states, dtype=np.float64).reshape(-1, 6)
    values = value_function(model)(states[:, 0], states[:, 1], states[:, HEADING])
    values = np.nan_to_num(values, nan=POTENTIAL_CAP, posinf=POTENTIAL_CAP, neginf=POTENTIAL_CAP)
    return -np.clip(values, 0.0, POTENTIAL_CAP)


def shaping_terms(phi: np.ndarray, phi_next: np.ndarray, terminated: np.ndarray, gamma: float) -> np.ndarray:
    """(n,) F = γ Φ(s') − Φ(s), with Φ(s') = 0 where the transition ``terminated`` (docs/rl.md §6).

    DECISION (docs/rl.md §6, terminal states): Φ is 0 at every terminal state (goal reached,
    collision, out of the area), the standard treatment of episodic tasks (Ng, Harada & Russell
    1999, where the absorbing state's potential is 0; Grześ 2017, "Reward shaping in episodic
    reinforcement learning", AAMAS, who shows that a non-zero terminal potential changes the optimal
    policy of an episodic task): then the discounted sum of F over any episode is −Φ(s_0), a constant
    of the start state, and the shaped optimum equals the unshaped one. A truncated transition (the
    step limit) keeps Φ(s') of its state: the episode was cut, not ended, and the learner bootstraps
    from s' there (SB3 adds γ V(s') for ``TimeLimit.truncated``), so the shaped value is consistent.
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
    from uav_penetration_env.value_function import candidate_control

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
    from gymnasium import spaces

    if formulation.features == "none":
        return base
    extra = np.full(FEATURE_WIDTH, np.inf, dtype=base.dtype)
    low = np.concatenate([base.low, -extra]).astype(base.dtype)
    high = np.concatenate([base.high, extra]).astype(base.dtype)
    return spaces.Box(low, high, dtype=base.dtype)
