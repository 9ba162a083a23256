"""UAV kinematics (model.md §1): action-then-move, clipping, heading wrap, batching.

The batched formulas tested here are the numpy oracle (tests/numpy_model.py); test_kernels.py checks
the compiled model against it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from numpy_model import clip_action, step_kinematics

from uav_penetration_env.kinematics import UAVLimits, wrap_angle
from uav_penetration_env.scenario import paper_scenario

LIMITS = UAVLimits()  # the spec's defaults: v in [5, 10] m/s, 2 m/s, 15°, 15°, |θ| <= 15°, dt = 300 s
DEG15 = math.radians(15.0)


def _state(x=0.0, y=0.0, z=500.0, v=10.0, heading=0.0, pitch=0.0) -> np.ndarray:
    return np.array([x, y, z, v, heading, pitch])


def test_limits_from_the_paper_scenario_are_si():
    limits = UAVLimits.from_scenario(paper_scenario())
    assert limits == LIMITS
    assert (limits.speed_min, limits.speed_max, limits.dv_max, limits.dt) == (5.0, 10.0, 2.0, 300.0)
    assert limits.dheading_max == pytest.approx(math.pi / 12, rel=1e-15)
    assert limits.dpitch_max == pytest.approx(math.pi / 12, rel=1e-15)
    assert limits.pitch_max == pytest.approx(math.pi / 12, rel=1e-15)
    assert limits.max_step_length == 3000.0  # 10 m/s for 300 s
    np.testing.assert_array_equal(limits.action_high, [2.0, DEG15, DEG15])


def test_level_step_at_10_m_s_covers_3_km():
    for heading in (0.0, math.pi / 4, math.pi / 2, -2.0, math.pi):
        new = step_kinematics(_state(x=1000.0, y=-500.0, heading=heading), np.zeros(3), LIMITS)
        assert math.hypot(new[0] - 1000.0, new[1] + 500.0) == pytest.approx(3000.0, rel=1e-12)
        assert new[2] == 500.0
        assert new[0] - 1000.0 == pytest.approx(3000.0 * math.cos(heading), abs=1e-9)
        assert new[1] + 500.0 == pytest.approx(3000.0 * math.sin(heading), abs=1e-9)


def test_heading_convention_is_counter_clockwise_from_east():
    east = step_kinematics(_state(heading=0.0), np.zeros(3), LIMITS)
    north = step_kinematics(_state(heading=math.pi / 2), np.zeros(3), LIMITS)
    assert east[:2] == pytest.approx([3000.0, 0.0], abs=1e-9)
    assert north[:2] == pytest.approx([0.0, 3000.0], abs=1e-9)


def test_a_15_degree_climb_gains_776_m():
    new = step_kinematics(_state(z=100.0), np.array([0.0, 0.0, DEG15]), LIMITS)
    gain = 300.0 * 10.0 * math.sin(DEG15)
    assert gain == pytest.approx(776.457, abs=1e-3)
    assert new[2] - 100.0 == pytest.approx(gain, rel=1e-12)
    assert new[0] == pytest.approx(3000.0 * math.cos(DEG15), rel=1e-12)
    assert new[5] == pytest.approx(DEG15, rel=1e-15)


def test_action_then_move_the_control_acts_on_this_step():
    # Paper eq. 1 would move with the old heading, speed and pitch; the spec moves with the new ones.
    new = step_kinematics(_state(v=8.0), np.array([2.0, DEG15, -DEG15]), LIMITS)
    step = 10.0 * 300.0
    assert new[:3] == pytest.approx(
        [
            step * math.cos(DEG15) * math.cos(DEG15),
            step * math.cos(DEG15) * math.sin(DEG15),
            500.0 - step * math.sin(DEG15),
        ],
        rel=1e-12,
    )
    assert new[3:] == pytest.approx([10.0, DEG15, -DEG15], rel=1e-15)


def test_speed_is_clipped_to_the_envelope():
    fast = step_kinematics(_state(v=9.0), np.array([2.0, 0.0, 0.0]), LIMITS)
    slow = step_kinematics(_state(v=6.0), np.array([-2.0, 0.0, 0.0]), LIMITS)
    assert fast[3] == 10.0 and fast[0] == pytest.approx(3000.0)
    assert slow[3] == 5.0 and slow[0] == pytest.approx(1500.0)


def test_pitch_is_clipped_to_pitch_max():
    up = step_kinematics(_state(pitch=math.radians(10.0)), np.array([0.0, 0.0, DEG15]), LIMITS)
    down = step_kinematics(_state(pitch=math.radians(-10.0)), np.array([0.0, 0.0, -DEG15]), LIMITS)
    assert up[5] == pytest.approx(DEG15, rel=1e-15)
    assert down[5] == pytest.approx(-DEG15, rel=1e-15)
    assert up[2] - 500.0 == pytest.approx(3000.0 * math.sin(DEG15), rel=1e-12)


def test_actions_are_clipped_to_the_box():
    high = np.array([2.0, DEG15, DEG15])
    np.testing.assert_array_equal(clip_action(np.array([5.0, -1.0, 0.1]), LIMITS), [2.0, -DEG15, 0.1])
    np.testing.assert_array_equal(clip_action(np.array([[-9.0, 9.0, -9.0]]), LIMITS), [[-2.0, DEG15, -DEG15]])
    # Inside the box nothing changes.
    inside = np.array([1.0, 0.1, -0.2])
    np.testing.assert_array_equal(clip_action(inside, LIMITS), inside)
    # In a step: dv = 5 from v = 5 is clipped to +2 -> 7 m/s (not 10); dθ = 30° from -15° -> 0 (not 15°);
    # dφ = 90° -> 15°.
    new = step_kinematics(_state(v=5.0, pitch=-DEG15), np.array([5.0, math.pi / 2, 2 * DEG15]), LIMITS)
    assert new[3] == pytest.approx(7.0)
    assert new[4] == pytest.approx(DEG15)
    assert new[5] == pytest.approx(0.0, abs=1e-15)
    assert np.all(np.abs(clip_action(np.array([1e9, -1e9, 1e9]), LIMITS)) <= high)


# --- heading wrap to (-π, π] ---------------------------------------------------------------------


def test_wrap_keeps_pi_and_maps_minus_pi_to_pi():
    assert wrap_angle(np.array(math.pi)) == math.pi
    assert wrap_angle(np.array(-math.pi)) == math.pi
    assert wrap_angle(np.array(3 * math.pi)) == pytest.approx(math.pi, rel=1e-15)
    assert wrap_angle(np.array(-3 * math.pi)) == pytest.approx(math.pi, rel=1e-15)
    np.testing.assert_allclose(
        wrap_angle(np.array([0.0, 1.0, -1.0, 2 * math.pi, 7.0])), [0, 1, -1, 0, 7 - 2 * math.pi], atol=1e-15
    )


def test_heading_wraps_in_a_step():
    # π stays π; -π becomes π; turning left past π comes back near -π.
    assert step_kinematics(_state(heading=math.pi), np.zeros(3), LIMITS)[4] == math.pi
    assert step_kinematics(_state(heading=-math.pi), np.zeros(3), LIMITS)[4] == math.pi
    turned = step_kinematics(_state(heading=math.pi - 0.1), np.array([0.0, 0.2, 0.0]), LIMITS)
    assert turned[4] == pytest.approx(-math.pi + 0.1, abs=1e-12)
    # The displacement follows the true direction whatever the wrap: heading -π flies west.
    west = step_kinematics(_state(heading=-math.pi), np.zeros(3), LIMITS)
    assert west[:2] == pytest.approx([-3000.0, 0.0], abs=1e-9)


@given(st.floats(-1e4, 1e4, allow_nan=False))
def test_wrap_range_and_equivalence(angle):
    wrapped = float(wrap_angle(np.array(angle)))
    assert -math.pi < wrapped <= math.pi
    turns = (angle - wrapped) / (2 * math.pi)
    assert turns == pytest.approx(round(turns), abs=1e-9)


# --- properties over random states and controls ----------------------------------------------------

states = st.tuples(
    st.floats(-1e5, 1e5),
    st.floats(-1e5, 1e5),
    st.floats(0.0, 3000.0),
    st.floats(5.0, 10.0),
    st.floats(-math.pi, math.pi),
    st.floats(-DEG15, DEG15),
).map(np.array)
controls = st.tuples(st.floats(-5.0, 5.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)).map(np.array)


@given(states, controls)
def test_step_length_is_new_speed_times_dt_and_state_stays_in_bounds(state, control):
    new = step_kinematics(state, control, LIMITS)
    assert 5.0 <= new[3] <= 10.0
    assert -DEG15 <= new[5] <= DEG15
    assert -math.pi < new[4] <= math.pi
    assert np.linalg.norm(new[:3] - state[:3]) == pytest.approx(new[3] * 300.0, rel=1e-9)
    # The new speed and pitch are the clipped sums, written out by hand.
    dv = min(max(control[0], -2.0), 2.0)
    dtheta = min(max(control[2], -DEG15), DEG15)
    assert new[3] == pytest.approx(min(max(state[3] + dv, 5.0), 10.0), abs=1e-12)
    assert new[5] == pytest.approx(min(max(state[5] + dtheta, -DEG15), DEG15), abs=1e-12)
    # Direction of flight is (cos φ' cos θ', sin φ' cos θ', sin θ').
    direction = (new[:3] - state[:3]) / (new[3] * 300.0)
    expected = [math.cos(new[4]) * math.cos(new[5]), math.sin(new[4]) * math.cos(new[5]), math.sin(new[5])]
    assert direction == pytest.approx(expected, abs=1e-9)


@given(
    hnp.arrays(np.float64, (3, 4, 6), elements=st.floats(-1.0, 1.0)),
    hnp.arrays(np.float64, (3, 4, 3), elements=st.floats(-3.0, 3.0)),
)
def test_leading_batch_axes_equal_the_loop_over_rows(unit_states, unit_controls):
    # Map [-1, 1] onto plausible ranges (speeds may start outside the envelope: they are clipped).
    states = unit_states * np.array([5e4, 5e4, 1000.0, 4.0, math.pi, DEG15]) + np.array(
        [0, 0, 1000.0, 7.5, 0, 0]
    )
    batched = step_kinematics(states, unit_controls, LIMITS)
    assert batched.shape == (3, 4, 6)
    for index in np.ndindex(3, 4):
        np.testing.assert_array_equal(
            batched[index], step_kinematics(states[index], unit_controls[index], LIMITS)
        )


def test_broadcast_one_state_many_controls():
    controls = np.array([[0.0, 0.0, 0.0], [0.0, DEG15, 0.0], [0.0, -DEG15, 0.0]])
    out = step_kinematics(_state(), controls, LIMITS)
    assert out.shape == (3, 6)
    assert out[1, 1] == pytest.approx(-out[2, 1])  # symmetric turns


def test_custom_dt_scales_the_step():
    limits = UAVLimits(dt=60.0)
    new = step_kinematics(_state(v=10.0), np.zeros(3), limits)
    assert new[0] == pytest.approx(600.0)
