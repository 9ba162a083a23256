"""Fuel, progress, normalisation, the weighted step cost J(k) and the failure penalty.

Model.md §6-7: the third objective C(k) is the fuel burned on the step plus a potential-based
progress term (paper eqs. 16-18 resolved, A22-A25); every term is normalised (analytic bounds or
the paper's payoff table, eq. 39) and weighted into J(k) = w_e Th_e^n + w_r Th_r^n + w_C C^n
(eq. 19). Here: the constants as frozen dataclasses and the analytic bounds; the per-step
formulas are compiled in ``kernels.py`` (``fuel_burned``, ``third_term``, ``failure_penalty``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from uav_penetration_env.scenario import Scenario

GRAVITY = 9.80665  # [m/s^2]


@dataclass(frozen=True)
class FuelParams:
    """Point-mass thrust and fuel constants, SI (model.md §6.1)."""

    weight_n: float  # W = m g [N]
    level_thrust_n: float  # T_level = W / E [N]
    idle_thrust_n: float  # T_idle [N]
    max_thrust_n: float  # T_max = W (1/E + sin theta_max) [N]
    tsfc: float  # eta [kg N^-1 s^-1]
    dt: float  # [s]
    speed_max: float  # [m/s]

    @classmethod
    def from_scenario(cls, scenario: Scenario) -> FuelParams:
        """Convert the scenario's fuel fields to SI."""
        fuel = scenario.uav.fuel
        weight = fuel.mass_kg * GRAVITY
        level = weight / fuel.lift_to_drag
        return cls(
            weight_n=weight,
            level_thrust_n=level,
            idle_thrust_n=fuel.idle_thrust_fraction * level,
            max_thrust_n=weight
            * (1.0 / fuel.lift_to_drag + math.sin(math.radians(scenario.uav.pitch_max_deg))),
            tsfc=fuel.tsfc_kg_per_n_s,
            dt=scenario.time.dt_s,
            speed_max=scenario.uav.speed_m_s[1],
        )

    @property
    def potential_per_m(self) -> float:
        """Progress potential per metre of goal distance, eta T_level / v_max [kg/m] (model.md §6.2)."""
        return self.tsfc * self.level_thrust_n / self.speed_max


def third_term_bounds(third: str, params: FuelParams) -> tuple[float, float]:
    """Analytic per-step bounds of C (model.md §6.2)."""
    if third == "length":
        return 0.0, 2.0 * params.speed_max * params.dt
    scale = params.tsfc * params.dt
    return (
        scale * (params.idle_thrust_n - params.level_thrust_n),
        scale * (params.max_thrust_n + params.level_thrust_n),
    )


@dataclass(frozen=True)
class Normalisation:
    """Affine maps x^n = (x - lo) / (hi - lo) for the three raw terms (eq. 39 or analytic bounds)."""

    terrain: tuple[float, float]
    radar: tuple[float, float]
    third: tuple[float, float]

    @classmethod
    def from_scenario(cls, scenario: Scenario, params: FuelParams) -> Normalisation:
        """Analytic bounds (``benchmark``) or the scenario's payoff constants (``paper``, eq. 39).

        DECISION (model.md §7, A30): payoff-normalised values are not clipped, so they can leave
        [0, 1] as in the paper's Fig. 15. Under ``analytic`` bounds, the ratio D (unbounded) passes
        through unchanged.
        """
        if scenario.normalisation_mode == "payoff":
            constants = scenario.normalisation.payoff.constants
            return cls(constants.terrain, constants.radar, constants.third)
        return cls((0.0, 1.0), (0.0, 1.0), third_term_bounds(scenario.cost.third_term, params))
