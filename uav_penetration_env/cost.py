"""Fuel, progress, normalisation, the weighted step cost J(k) and the failure penalty.

Model.md §6-7: the third objective C(k) is the fuel burned on the step plus a potential-based
progress term (paper eqs. 16-18 resolved, A22-A25); every term is normalised (analytic bounds or
the paper's payoff table, eq. 39) and weighted into J(k) = w_e Th_e^n + w_r Th_r^n + w_C C^n
(eq. 19). Pure functions; constants arrive as frozen dataclasses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uav_penetration_env.scenario import Scenario
from uav_penetration_env.types import FloatArray

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


def thrust(pitch: FloatArray, params: FuelParams) -> FloatArray:
    """Steady-flight thrust T = W (1/E + sin theta) clipped to [T_idle, T_max] [N] (model.md §6.1).

    theta > 0 is eq. 17's ascent state, theta = 0 level flight and theta < 0 descent down to idle.
    """
    raw = params.level_thrust_n + params.weight_n * np.sin(pitch)
    return np.clip(raw, params.idle_thrust_n, params.max_thrust_n)


def fuel_burned(pitch: FloatArray, params: FuelParams) -> FloatArray:
    """Fuel for one step, C_fuel = eta T dt [kg]."""
    return params.tsfc * params.dt * thrust(pitch, params)


def third_term(
    third: str,
    fuel_kg: FloatArray,
    step_length_m: FloatArray,
    goal_distance_before_m: FloatArray,
    goal_distance_after_m: FloatArray,
    params: FuelParams,
) -> FloatArray:
    """The third objective C(k) with its progress (cost-to-go) shaping (model.md §6.2, A22/A24).

    ``fuel``: C = C_fuel + G(p_{k+1}) - G(p_k) with G = eta T_level d_goal / v_max, so straight level
    flight at v_max toward the goal costs 0. ``length``: C = s + d_goal(p_{k+1}) - d_goal(p_k) >= 0.
    Either way the sum over an episode telescopes: shaping never changes which complete
    trajectory is cheaper among those ending at the same distance from the goal.
    """
    change = goal_distance_after_m - goal_distance_before_m
    if third == "length":
        return step_length_m + change
    return fuel_kg + params.potential_per_m * change


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


def normalise(value: FloatArray, bounds: tuple[float, float]) -> FloatArray:
    """(x - lo) / (hi - lo)."""
    low, high = bounds
    return (value - low) / (high - low)


def weighted_cost(
    terrain_n: FloatArray, radar_n: FloatArray, third_n: FloatArray, weights: tuple[float, float, float]
) -> FloatArray:
    """J(k) = w_e Th_e^n + w_r Th_r^n + w_C C^n (eq. 19)."""
    return weights[0] * terrain_n + weights[1] * radar_n + weights[2] * third_n


def failure_penalty(
    failed: FloatArray, step_index: FloatArray, max_steps: int, per_step: float
) -> FloatArray:
    """Penalty for ending the episode by failure at step k: per_step (K_max - k + 1) (model.md §7a).

    DECISION: charging every remaining step (the + 1 counts the failing step itself) makes an early
    crash never cheaper than flying on, since J(k) <= per_step in the benchmark profile.
    """
    remaining = np.maximum(max_steps - np.asarray(step_index) + 1, 0)
    return np.where(failed, per_step * remaining, 0.0)


def terminal_cost_to_go(goal_distance_m: FloatArray, step_length_m: float, per_step: float) -> FloatArray:
    """MPC cost-to-go: c_T d_goal / (v_max dt), the remaining steps at full speed (model.md §7)."""
    return per_step * goal_distance_m / step_length_m
