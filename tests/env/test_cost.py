"""Fuel, progress, normalisation, weighted cost and penalties (model.md §6-7a).

The batched formulas tested here are the numpy oracle (tests/numpy_model.py); test_kernels.py checks
the compiled model against it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy_model import (
    failure_penalty,
    fuel_burned,
    normalise,
    step_kinematics,
    terminal_cost_to_go,
    third_term,
    thrust,
    weighted_cost,
)

from uav_penetration_env.cost import GRAVITY, FuelParams, Normalisation, third_term_bounds
from uav_penetration_env.kinematics import UAVLimits
from uav_penetration_env.scenario import paper_scenario

# Defaults of model.md §6.1, by hand: m = 20 kg, g = 9.80665, E = 10, idle 0.1, η = 1.9e-6, Δt = 300 s.
W = 20.0 * 9.80665  # 196.133 N
T_LEVEL = W / 10.0  # 19.6133 N
T_IDLE = 0.1 * T_LEVEL
T_MAX = W * (0.1 + math.sin(math.radians(15.0)))
ETA, DT, V_MAX = 1.9e-6, 300.0, 10.0
DEG15 = math.radians(15.0)
PARAMS = FuelParams.from_scenario(paper_scenario())


def test_fuel_params_from_the_defaults():
    assert GRAVITY == 9.80665
    assert PARAMS.weight_n == pytest.approx(W, rel=1e-15)
    assert PARAMS.level_thrust_n == pytest.approx(T_LEVEL, rel=1e-15)
    assert PARAMS.idle_thrust_n == pytest.approx(T_IDLE, rel=1e-15)
    assert PARAMS.max_thrust_n == pytest.approx(T_MAX, rel=1e-15)
    assert T_MAX / T_LEVEL == pytest.approx(3.59, abs=5e-3)  # §6.1: T_max = 3.59 T_level
    assert (PARAMS.tsfc, PARAMS.dt, PARAMS.speed_max) == (ETA, DT, V_MAX)
    assert PARAMS.potential_per_m == pytest.approx(ETA * T_LEVEL / V_MAX, rel=1e-15)


def test_thrust_level_climb_and_descent():
    assert thrust(np.array(0.0), PARAMS) == pytest.approx(T_LEVEL, rel=1e-15)
    assert thrust(np.array(DEG15), PARAMS) == pytest.approx(T_MAX, rel=1e-12)  # T_max at +15°
    assert thrust(np.array(-DEG15), PARAMS) == pytest.approx(T_IDLE, rel=1e-15)  # idle on a steep descent
    # A shallow descent is not yet at idle: idle begins at sin θ = (0.1 - 1) / 10, θ = -5.16°.
    five = math.radians(-5.0)
    assert thrust(np.array(five), PARAMS) == pytest.approx(W * (0.1 + math.sin(five)), rel=1e-12)
    assert thrust(np.array(math.radians(-6.0)), PARAMS) == pytest.approx(T_IDLE, rel=1e-15)
    # Climb: more thrust than level, following W (1/E + sin θ).
    assert thrust(np.array(math.radians(5.0)), PARAMS) == pytest.approx(
        W * (0.1 + math.sin(math.radians(5.0))), rel=1e-12
    )
    # Above the pitch limit the thrust stays at T_max (clipped).
    assert thrust(np.array(math.radians(40.0)), PARAMS) == pytest.approx(T_MAX, rel=1e-15)


@given(st.floats(-DEG15, DEG15), st.floats(-DEG15, DEG15))
def test_thrust_is_monotone_and_bounded(a, b):
    low, high = sorted((a, b))
    t_low, t_high = float(thrust(np.array(low), PARAMS)), float(thrust(np.array(high), PARAMS))
    assert T_IDLE - 1e-12 <= t_low <= t_high <= T_MAX + 1e-12


def test_fuel_per_level_step():
    fuel = float(fuel_burned(np.array(0.0), PARAMS))
    assert fuel == pytest.approx(ETA * T_LEVEL * DT, rel=1e-14)
    assert round(fuel, 4) == 0.0112  # ≈ 0.011 kg per level step (§6.1)
    # A 48-step level crossing burns ≈ 0.5 kg.
    assert round(48 * fuel, 1) == 0.5
    np.testing.assert_allclose(
        fuel_burned(np.array([-DEG15, 0.0, DEG15]), PARAMS),
        ETA * DT * np.array([T_IDLE, T_LEVEL, T_MAX]),
        rtol=1e-12,
    )


GOAL = np.array([100e3, 100e3])


def _goal_distance(p):
    return float(np.hypot(*(GOAL - np.asarray(p)[:2])))


def test_straight_level_flight_to_the_goal_at_v_max_costs_zero():
    start = np.array([0.0, 0.0, 200.0, 10.0, math.pi / 4, 0.0])
    new = step_kinematics(start, np.zeros(3), UAVLimits())
    c = third_term(
        "fuel", fuel_burned(new[5], PARAMS), 3000.0, _goal_distance(start), _goal_distance(new), PARAMS
    )
    assert c == pytest.approx(0.0, abs=1e-15)
    # Slower flight toward the goal, or loitering, costs more.
    slow = third_term("fuel", fuel_burned(0.0, PARAMS), 1500.0, 50e3, 50e3 - 1500.0, PARAMS)
    loiter = third_term("fuel", fuel_burned(0.0, PARAMS), 3000.0, 50e3, 50e3, PARAMS)
    assert slow == pytest.approx(ETA * T_LEVEL * DT / 2, rel=1e-12)
    assert loiter == pytest.approx(ETA * T_LEVEL * DT, rel=1e-12)


def test_length_option_is_step_plus_distance_change():
    assert third_term("length", 0.0, 3000.0, 50e3, 47e3, PARAMS) == pytest.approx(0.0, abs=1e-9)
    assert third_term("length", 0.0, 3000.0, 50e3, 53e3, PARAMS) == pytest.approx(6000.0)  # straight away
    # Sideways: s + sqrt(d² + s²) - d.
    expected = 3000.0 + math.hypot(50e3, 3000.0) - 50e3
    assert third_term("length", 0.0, 3000.0, 50e3, math.hypot(50e3, 3000.0), PARAMS) == pytest.approx(
        expected
    )


def test_third_term_bounds_are_the_section_6_2_formulas():
    lo, hi = third_term_bounds("fuel", PARAMS)
    assert lo == pytest.approx(ETA * DT * (T_IDLE - T_LEVEL), rel=1e-12)
    assert hi == pytest.approx(ETA * DT * (T_MAX + T_LEVEL), rel=1e-12)
    assert third_term_bounds("length", PARAMS) == (0.0, 2 * V_MAX * DT)


moves = st.tuples(
    st.floats(-3e4, 1.3e5),  # x [m]
    st.floats(-3e4, 1.3e5),  # y [m]
    st.floats(-math.pi, math.pi),  # direction of the step
    st.floats(0.0, 1.0),  # fraction of v_max dt flown
    st.floats(-DEG15, DEG15),  # pitch
)


@given(moves)
def test_third_term_stays_inside_its_bounds(move):
    x, y, direction, fraction, pitch = move
    length = fraction * V_MAX * DT  # 3-D step length
    horizontal = length * math.cos(pitch)
    after = (x + horizontal * math.cos(direction), y + horizontal * math.sin(direction))
    before_d, after_d = _goal_distance((x, y)), _goal_distance(after)
    fuel = float(fuel_burned(np.array(pitch), PARAMS))
    lo, hi = third_term_bounds("fuel", PARAMS)
    c = float(third_term("fuel", fuel, length, before_d, after_d, PARAMS))
    assert lo - 1e-12 <= c <= hi + 1e-12
    lo, hi = third_term_bounds("length", PARAMS)
    c = float(third_term("length", fuel, length, before_d, after_d, PARAMS))
    assert lo - 1e-6 <= c <= hi + 1e-6


def test_telescoping_sum_over_a_random_trajectory():
    rng = np.random.default_rng(12)
    limits = UAVLimits()
    state = np.array([0.0, 0.0, 300.0, 10.0, math.pi / 4, 0.0])
    start = state.copy()
    costs, fuels = [], []
    for _ in range(40):
        control = rng.uniform(-1.0, 1.0, 3) * limits.action_high
        new = step_kinematics(state, control, limits)
        fuel = float(fuel_burned(new[5], PARAMS))
        step_length = float(np.linalg.norm(new[:3] - state[:3]))
        costs.append(
            float(third_term("fuel", fuel, step_length, _goal_distance(state), _goal_distance(new), PARAMS))
        )
        fuels.append(fuel)
        state = new

    def potential(p):  # G(p) = η T_level d_goal / v_max
        return ETA * T_LEVEL * _goal_distance(p) / V_MAX

    assert sum(costs) == pytest.approx(sum(fuels) - potential(start) + potential(state), rel=1e-9, abs=1e-12)


def test_analytic_normalisation_maps_bounds_to_0_1(tiny):
    norm = Normalisation.from_scenario(tiny, PARAMS)
    assert norm.terrain == (0.0, 1.0) and norm.radar == (0.0, 1.0)
    lo, hi = third_term_bounds("fuel", PARAMS)
    assert norm.third == (lo, hi)
    assert normalise(np.array(lo), norm.third) == 0.0
    assert normalise(np.array(hi), norm.third) == pytest.approx(1.0, rel=1e-15)
    # Straight level flight at v_max (C = 0) has C^n = (T_level - T_idle) / (T_max + 2 T_level - T_idle)
    # = 0.164 with the default fuel model (§7: "costs C^n = 0.164").
    cn = float(normalise(np.array(0.0), norm.third))
    assert cn == pytest.approx((T_LEVEL - T_IDLE) / (T_MAX + 2 * T_LEVEL - T_IDLE), rel=1e-12)
    assert round(cn, 3) == 0.164
    length = Normalisation.from_scenario(tiny.updated({"cost": {"third_term": "length"}}), PARAMS)
    assert length.third == (0.0, 6000.0)


def test_payoff_normalisation_uses_the_stored_constants():
    paper = paper_scenario().with_profile("paper")
    constants = paper.normalisation.payoff.constants
    norm = Normalisation.from_scenario(paper, PARAMS)
    assert (norm.terrain, norm.radar, norm.third) == (constants.terrain, constants.radar, constants.third)
    # Not clipped (A30): a value beyond the calibration maximum normalises above 1.
    assert normalise(np.array(2 * constants.radar[1]), norm.radar) == pytest.approx(2.0)


def test_normalise_is_affine():
    np.testing.assert_allclose(normalise(np.array([2.0, 3.0, 6.0]), (2.0, 6.0)), [0.0, 0.25, 1.0])


def test_weighted_cost():
    assert weighted_cost(1.0, 0.5, 0.2, (0.3, 0.4, 0.3)) == pytest.approx(0.3 + 0.2 + 0.06)
    out = weighted_cost(np.array([0.0, 1.0]), np.array([1.0, 1.0]), np.array([0.0, 1.0]), (0.3, 0.5, 0.2))
    np.testing.assert_allclose(out, [0.5, 1.0])


@given(st.floats(0, 1), st.floats(0, 1), st.floats(0, 1))
def test_weighted_cost_of_normalised_terms_is_in_0_1(a, b, c):
    assert 0.0 <= weighted_cost(a, b, c, (0.3, 0.4, 0.3)) <= 1.0 + 1e-12


def test_failure_penalty_charges_every_remaining_step_plus_one():
    k_max = 150
    assert failure_penalty(True, 150, k_max, 1.0) == 1.0  # a crash on the last step is not free
    assert failure_penalty(True, 1, k_max, 1.0) == 150.0
    assert failure_penalty(True, 100, k_max, 0.5) == pytest.approx(0.5 * 51)
    assert failure_penalty(False, 10, k_max, 1.0) == 0.0
    out = failure_penalty(np.array([True, False, True]), np.array([150, 3, 149]), k_max, 2.0)
    np.testing.assert_array_equal(out, [2.0, 0.0, 4.0])


def test_terminal_cost_to_go():
    # c_T d_goal / (v_max dt): 30 km at 3 km per step is 10 steps at 0.06 each.
    assert terminal_cost_to_go(np.array(30e3), 3000.0, 0.06) == pytest.approx(0.6)
    np.testing.assert_allclose(terminal_cost_to_go(np.array([0.0, 3000.0]), 3000.0, 0.06), [0.0, 0.06])
