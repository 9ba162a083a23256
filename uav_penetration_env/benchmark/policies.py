"""Policies: the Protocol every planner meets, and the greedy and random floors (api.md).

A policy is anything with ``reset(model, seed)`` and ``act(observation, info) -> action``.
Planners read the exact state from ``info["state"]`` and the step index from ``info["step"]``;
they never parse the observation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from uav_penetration_env.kinematics import HEADING, PITCH, SPEED, wrap_angle
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.types import FloatArray


@runtime_checkable
class Policy(Protocol):
    """The interface the evaluator scores: MPC planners, floors, RL agents."""

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None) -> None:
        """Prepare for an episode on ``model``'s scenario; ``seed`` drives any randomness."""

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """The action (3,) for the current step."""


@dataclass
class GreedyPolicy:
    """Floor: turn toward the goal at the maximum rate, fly v_max, hold ``clearance_m`` above the terrain.

    The altitude target is ``clearance_m`` above the highest terrain under the next ``lookahead_steps``
    steps of flight along the new heading (api.md: 100 m, two steps); the pitch is the one that
    would reach it in one step, limited by the pitch bounds.
    """

    clearance_m: float = 100.0
    lookahead_steps: int = 2
    model: PenetrationModel | None = field(default=None, repr=False)

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None = None) -> None:
        """Bind the model (the policy is deterministic; ``seed`` is unused)."""
        del seed
        self.model = model

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """Greedy control from the exact state in ``info``."""
        if self.model is None:
            raise RuntimeError("GreedyPolicy.act() before reset(model, seed)")
        return greedy_action(
            self.model, np.asarray(info["state"], dtype=np.float64), self.clearance_m, self.lookahead_steps
        )


def greedy_action(
    model: PenetrationModel, state: FloatArray, clearance_m: float = 100.0, lookahead_steps: int = 2
) -> FloatArray:
    """The greedy floor's action for one state (see :class:`GreedyPolicy`)."""
    limits = model.limits
    x, y, z = state[:3]
    goal = model.goal[0]
    bearing = math.atan2(goal[1] - y, goal[0] - x)
    dphi = float(np.clip(wrap_angle(bearing - state[HEADING]), -limits.dheading_max, limits.dheading_max))
    dv = float(np.clip(limits.speed_max - state[SPEED], -limits.dv_max, limits.dv_max))
    heading = state[HEADING] + dphi
    speed = min(limits.speed_max, state[SPEED] + dv)
    reach = lookahead_steps * limits.max_step_length
    distance = np.linspace(0.0, reach, max(2, math.ceil(reach / (0.5 * model.grid.dx_m)) + 1))
    ground = model.height(x + distance * math.cos(heading), y + distance * math.sin(heading))
    target = float(ground.max()) + clearance_m
    climb = np.clip((target - z) / (speed * limits.dt), -1.0, 1.0)
    pitch = float(np.clip(math.asin(climb), -limits.pitch_max, limits.pitch_max))
    dtheta = float(np.clip(pitch - state[PITCH], -limits.dpitch_max, limits.dpitch_max))
    return np.array([dv, dphi, dtheta])


@dataclass
class RandomPolicy:
    """Floor: actions uniform in the action box, drawn from the episode's policy seed."""

    model: PenetrationModel | None = field(default=None, repr=False)
    rng: np.random.Generator | None = field(default=None, repr=False)

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None = None) -> None:
        """Bind the model and seed the generator."""
        self.model = model
        self.rng = np.random.default_rng(seed)

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """A uniform draw in [-u_max, u_max]."""
        if self.model is None or self.rng is None:
            raise RuntimeError("RandomPolicy.act() before reset(model, seed)")
        high = self.model.limits.action_high
        return self.rng.uniform(-high, high)
