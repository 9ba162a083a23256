"""UAV point-mass kinematics (paper eq. 1, corrected to action-then-move; model.md §1).

State ``(x, y, z, v, phi, theta)`` in m, m, m, m/s, rad, rad; control ``(dv, dphi, dtheta)``.
Heading phi is counter-clockwise from +x (east) and wrapped to (-pi, pi]; pitch theta is the
flight-path angle, positive nose-up. No roll. The step itself is compiled in ``kernels.py``
(``kinematics``); this module holds the limits and the heading wrap.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uav_penetration_env import kernels
from uav_penetration_env.scenario import Scenario
from uav_penetration_env.types import FloatArray

X, Y, Z, SPEED, HEADING, PITCH = range(6)
STATE_DIM = 6
ACTION_DIM = 3


@dataclass(frozen=True)
class UAVLimits:
    """Flight envelope and per-step control limits, SI units."""

    speed_min: float = 5.0  # [m/s] DECISION (model.md §1)
    speed_max: float = 10.0  # [m/s] paper §5
    dv_max: float = 2.0  # [m/s per step] DECISION
    dheading_max: float = math.radians(15.0)  # [rad per step] paper §5
    dpitch_max: float = math.radians(15.0)  # [rad per step] paper §5
    pitch_max: float = math.radians(15.0)  # [rad] DECISION
    dt: float = 300.0  # [s] paper §5

    @classmethod
    def from_scenario(cls, scenario: Scenario) -> UAVLimits:
        """Convert the scenario's UAV and time fields to SI."""
        uav = scenario.uav
        return cls(
            speed_min=uav.speed_m_s[0],
            speed_max=uav.speed_m_s[1],
            dv_max=uav.dv_max_m_s,
            dheading_max=math.radians(uav.dheading_max_deg),
            dpitch_max=math.radians(uav.dpitch_max_deg),
            pitch_max=math.radians(uav.pitch_max_deg),
            dt=scenario.time.dt_s,
        )

    @property
    def action_high(self) -> FloatArray:
        """Upper bound of the action box (dv, dphi, dtheta); the lower bound is its negative."""
        return np.array([self.dv_max, self.dheading_max, self.dpitch_max])

    @property
    def max_step_length(self) -> float:
        """Longest distance flown in one step, v_max dt [m]."""
        return self.speed_max * self.dt


def wrap_angle(angle: FloatArray) -> FloatArray:
    """Wrap angles to (-pi, pi] (the compiled ``kernels.wrap_angle`` the model steps with)."""
    return kernels.wrap_angles(angle)
