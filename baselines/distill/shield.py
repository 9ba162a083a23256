"""A verified fallback for a distilled network: ``distill-shield:PATH`` (docs/rl.md §4.8).

Before each step the shield flies the network's own policy forward with the model
(:meth:`PenetrationModel.step`, the env's transition, and :meth:`PenetrationModel.observe`, the
env's observation) for ``horizon`` steps from the exact state. If that rollout collides with the
terrain or leaves the area, the step is flown by the greedy floor instead
(:func:`~uav_penetration_env.benchmark.policies.greedy_action`); so is every step after the
episode has used its step budget (``budget`` times the steps a straight flight at v_max would
take), which ends a network's circling before the step limit truncates the episode. After an
override for a failure ahead the greedy floor keeps the controls for ``hold`` steps, and it flies
every step within ``homing`` straight steps of the goal.

One candidate is checked and one fixed action replaces it: nothing is searched, so the decision
costs ``horizon`` network evaluations and model steps, not an optimisation.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from baselines.distill.heads import network_action
from uav_penetration_env.benchmark.policies import greedy_action
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.types import FloatArray

FLOOR_CLEARANCE_M = 100.0  # greedy_action's default: the floor's own clearance
# Why a step was overridden, as counted in ``last_record["shield"]``.
KEPT, FAILS_AHEAD, OVER_BUDGET, HOLDING, HOMING = 0, 1, 2, 3, 4


@dataclass(frozen=True)
class Shield:
    """The shield's settings.

    Attributes:
        horizon: steps of the network's own rollout checked before each step.
        budget: the episode's step budget as a multiple of a straight flight's steps at v_max
            from the start to the goal; past it the greedy floor flies.
        hold: steps the greedy floor keeps flying after an override for a failure ahead, so the
            network, handed back the controls at once, does not steer straight back toward it.
        homing: within this many straight steps at v_max of the goal the greedy floor flies (it
            turns onto the goal; a network that passes beside it flies on toward the edge).
    """

    horizon: int = 5
    budget: float = 2.0
    hold: int = 5
    homing: float = 4.0

    def __post_init__(self) -> None:
        if not (isinstance(self.horizon, int) and not isinstance(self.horizon, bool) and self.horizon >= 1):
            raise ValueError(f"shield horizon: got {self.horizon!r}, expected an integer >= 1")
        if not (isinstance(self.hold, int) and not isinstance(self.hold, bool) and self.hold >= 0):
            raise ValueError(f"shield hold: got {self.hold!r}, expected an integer >= 0")
        if not (isinstance(self.homing, (int, float)) and math.isfinite(self.homing) and self.homing >= 0):
            raise ValueError(f"shield homing: got {self.homing!r}, expected a number >= 0")
        if not (isinstance(self.budget, (int, float)) and math.isfinite(self.budget) and self.budget > 0):
            raise ValueError(f"shield budget: got {self.budget!r}, expected a positive number")


def straight_steps(model: PenetrationModel, state: FloatArray) -> float:
    """The steps a straight flight at v_max takes from ``state`` to the goal (horizontal distance)."""
    distance = float(model.goal_distance(np.asarray(state, dtype=np.float64)[None])[0])
    return distance / (model.limits.speed_max * model.limits.dt)


def rollout_fails(
    model: PenetrationModel,
    act: Callable[[np.ndarray, FloatArray], FloatArray],
    observation: np.ndarray,
    state: FloatArray,
    step: int,
    first: FloatArray,
    horizon: int,
) -> bool:
    """Whether flying ``first``, then ``act(observation, state)`` at each state, collides or leaves the area within ``horizon`` steps."""
    states = np.asarray(state, dtype=np.float64)[None]
    action = np.asarray(first, dtype=np.float64)
    for k in range(step, min(step + horizon, model.max_steps)):
        result = model.step(states, action[None], k)
        if result.collided[0] or result.out_of_area[0]:
            return True
        if result.terminated[0] or result.truncated[0]:
            return False
        states = result.state
        observation = model.observe(states, k + 1, result)[0]
        action = act(observation, states[0])
    return False


def _homing_action(
    model: PenetrationModel, observation: np.ndarray, state: FloatArray, step: int, shield: Shield, clearance_m: float
) -> FloatArray:
    """The greedy floor's homing step at ``clearance_m``, or at the floor's own 100 m if that one's rollout fails.

    The homing rule is checked as the network is: ``shield.horizon`` steps of the greedy rule at
    ``clearance_m`` flown with the model; a collision or an exit ahead (rough terrain that a low
    target cannot follow, the DEM member's coast) hands the step to the floor itself.
    """
    low = greedy_action(model, state, clearance_m)
    if clearance_m == FLOOR_CLEARANCE_M:
        return low

    def follow(_: np.ndarray, at: FloatArray) -> FloatArray:
        return greedy_action(model, np.asarray(at, dtype=np.float64), clearance_m)

    if rollout_fails(model, follow, observation, state, step, low, shield.horizon):
        return greedy_action(model, state)
    return low


def shielded_action(
    arrays: Mapping[str, np.ndarray],
    model: PenetrationModel,
    from_unit: Callable[[np.ndarray], np.ndarray],
    observation: np.ndarray,
    state: FloatArray,
    step: int,
    shield: Shield,
    step_budget: float,
    held_until: int = -1,
    clearance_m: float = 100.0,
) -> tuple[FloatArray, int]:
    """The network's action, or the greedy floor's; returns it and why (KEPT, FAILS_AHEAD, ..., HOMING).

    ``held_until``: the greedy floor flies every step before it (the hold after an override).
    ``clearance_m``: the height above the terrain the greedy floor aims at when homing (the
    network's own flight clearance; the floor's 100 m by default), itself checked by a rollout
    (:func:`_homing_action`). Every other fallback (a
    failure ahead, the hold after it, the spent budget) is the floor itself at its 100 m: a
    fallback for a failure must be no less safe than the floor.
    """
    state = np.asarray(state, dtype=np.float64)
    if step >= step_budget:
        return greedy_action(model, state), OVER_BUDGET
    if step < held_until:
        return greedy_action(model, state), HOLDING
    if straight_steps(model, state) < shield.homing:
        return _homing_action(model, observation, state, step, shield, clearance_m), HOMING

    def act(obs: np.ndarray, at: FloatArray) -> FloatArray:
        return network_action(arrays, model, obs, at, from_unit)

    proposed = act(observation, state)
    if rollout_fails(model, act, observation, state, step, proposed, shield.horizon):
        return greedy_action(model, state), FAILS_AHEAD
    return proposed, KEPT
