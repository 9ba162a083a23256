"""PenetrationModel: rollout_cost == the env's summed costs, batches == loops, property bounds."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import tiny_scenario
from hypothesis import given
from hypothesis import strategies as st

from uav_penetration_env import PenetrationModel
from uav_penetration_env.env import UAVPenetrationEnv
from uav_penetration_env.kinematics import wrap_angle
from uav_penetration_env.mpc import Terminal
from uav_penetration_env.observation import (
    OBSERVATION_SIZE,
    SLOTS,
    TERRAIN_ACROSS_M,
    TERRAIN_AHEAD_M,
    radar_block,
    terrain_block,
)
from uav_penetration_env.terminal import terminal_cost


def distance_terminal(model, c_t: float):
    """The ``distance`` form of the terminal cost at ``c_t``, built as ``rollout_cost`` takes it."""
    return terminal_cost(model, Terminal("distance", c_t))


@pytest.fixture(scope="module")
def model(tiny):
    return PenetrationModel(tiny)


@pytest.fixture(scope="module")
def env(tiny):
    return UAVPenetrationEnv(tiny)


def env_window_cost(env, state, step, controls, discount=1.0):
    """Fly ``controls`` (H, 3) from ``state`` at step k in the single env; sum gamma^j * -(reward)."""
    env.set_state(state, step)
    total, weight = 0.0, 1.0
    for control in controls:
        _, reward, terminated, truncated, _ = env.step(control)
        total += weight * -reward
        weight *= discount
        if terminated or truncated:
            break
    return total


def flying_state(model, x_km, y_km, agl=150.0, heading_deg=45.0, speed=10.0, pitch_deg=0.0):
    x, y = x_km * 1000.0, y_km * 1000.0
    z = float(model.height(np.array([x]), np.array([y]))[0]) + agl
    return np.array([x, y, z, speed, math.radians(heading_deg), math.radians(pitch_deg)])


CASES = {
    # name: (state builder args, step k, control sequence)
    "cruise": (
        (0.0, 0.0),
        0,
        [[0.0, 0.1, 0.0], [1.0, -0.2, 0.1], [-2.0, 0.0, -0.1], [0.0, 0.0, 0.0], [0.5, 0.26, 0.0]],
    ),
    "reaches goal": ((20.0, 20.0), 3, [[0.0, 0.0, 0.0]] * 5),
    "crashes": ((5.0, 5.0), 2, [[0.0, 0.0, -0.26]] * 5),
    "leaves map": ((45.0, 10.0), 1, [[2.0, 0.0, 0.0]] * 5),
    "above ceiling": ((0.0, 0.0), 0, [[0.0, 0.0, 0.26]] * 5),
    "K_max inside window": ((-10.0, -10.0), 27, [[0.0, 0.2, 0.0]] * 5),
}


@pytest.mark.parametrize("case", list(CASES))
def test_rollout_cost_equals_single_env_summed_costs(model, env, case):
    (x, y), step, controls = CASES[case]
    heading = 0.0 if case == "leaves map" else 45.0
    agl = 2800.0 if case == "above ceiling" else (60.0 if case == "crashes" else 150.0)
    state = flying_state(model, x, y, agl=agl, heading_deg=heading)
    controls = np.array(controls, dtype=np.float64)
    expected = env_window_cost(env, state, step, controls)
    got = model.rollout_cost(state, controls[None], step=step)
    assert got.shape == (1,)
    assert got[0] == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_each_case_ends_as_named(model, env):
    """The rollout cases above really exercise goal, crash, out-of-area and K_max."""
    seen = {}
    for case, ((x, y), step, controls) in CASES.items():
        heading = 0.0 if case == "leaves map" else 45.0
        agl = 2800.0 if case == "above ceiling" else (60.0 if case == "crashes" else 150.0)
        env.set_state(flying_state(model, x, y, agl=agl, heading_deg=heading), step)
        for control in controls:
            _, _, terminated, truncated, info = env.step(np.array(control))
            if terminated or truncated:
                seen[case] = (info["reached_goal"], info["collided"], info["out_of_area"], truncated)
                break
    assert seen["reaches goal"][0]
    assert seen["crashes"][1]
    assert seen["leaves map"][2]
    assert seen["above ceiling"][2]
    assert seen["K_max inside window"][3]
    assert "cruise" not in seen


def test_rollout_batch_equals_loop_of_single_rollouts(model):
    rng = np.random.default_rng(4)
    high = model.limits.action_high
    controls = rng.uniform(-high, high, size=(64, 5, 3))
    state = flying_state(model, 3.0, 1.0, agl=80.0)
    batch = model.rollout_cost(state, controls, step=4, discount=0.9, terminal_cost=distance_terminal(model, 0.06))
    loop = np.array(
        [model.rollout_cost(state, c[None], step=4, discount=0.9, terminal_cost=distance_terminal(model, 0.06))[0] for c in controls]
    )
    np.testing.assert_array_equal(batch, loop)


def test_discount_weights_each_step(model, env):
    state = flying_state(model, 0.0, 0.0)
    controls = np.zeros((5, 3))
    expected = env_window_cost(env, state, 0, controls, discount=0.5)
    assert model.rollout_cost(state, controls[None], step=0, discount=0.5)[0] == pytest.approx(
        expected, rel=1e-12
    )


def test_terminal_cost_added_only_to_flying_rows_before_k_max(model):
    state = flying_state(model, 0.0, 0.0, agl=600.0)  # high enough to clear the mountain at (12, 14) km
    controls = np.zeros((1, 5, 3))
    plain = model.rollout_cost(state, controls, step=0)[0]
    with_terminal = model.rollout_cost(state, controls, step=0, terminal_cost=distance_terminal(model, 0.06))[0]
    # Flying straight at 10 m/s toward the goal for 5 steps: the end point is 15 km closer.
    remaining = math.hypot(25.0, 25.0) * 1000.0 - 5 * 3000.0
    assert with_terminal - plain == pytest.approx(0.06 * remaining / 3000.0, rel=1e-9)
    # A crashed row gets no cost-to-go.
    crash_state = flying_state(model, 5.0, 5.0, agl=60.0)
    dive = np.tile([0.0, 0.0, -0.26], (1, 5, 1))
    assert (
        model.rollout_cost(crash_state, dive, step=0, terminal_cost=distance_terminal(model, 0.06))[0]
        == model.rollout_cost(crash_state, dive, step=0)[0]
    )
    # The window reaching K_max ends the episode: no cost-to-go either.
    late = model.max_steps - 5
    assert (
        model.rollout_cost(state, controls, step=late, terminal_cost=distance_terminal(model, 0.06))[0]
        == model.rollout_cost(state, controls, step=late)[0]
    )


@pytest.mark.parametrize("bare", [0.06, 0, np.float64(0.06), "distance", None])
def test_a_terminal_cost_is_a_built_object_never_a_bare_number(model, bare):
    """A number used to mean the distance form's c_T while every planner defaulted to ``value`` (issue 41)."""
    state = flying_state(model, 0.0, 0.0, agl=600.0)
    with pytest.raises(TypeError) as caught:
        model.rollout_cost(state, np.zeros((1, 5, 3)), step=0, terminal_cost=bare)
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"terminal_cost: got {bare!r}, expected a TerminalCost")
    with pytest.raises(TypeError, match=r"^terminal_cost: got 0\.06, expected a TerminalCost"):
        model.rollout_function(state, step=0, terminal_cost=0.06)


def test_rollout_rejects_bad_shapes(model):
    state = flying_state(model, 0.0, 0.0)
    with pytest.raises(ValueError, match="controls"):
        model.rollout_cost(state, np.zeros((5, 3)), step=0)
    with pytest.raises(ValueError, match="state"):
        model.rollout_cost(state[:5], np.zeros((1, 5, 3)), step=0)


def test_rollout_after_k_max_costs_nothing(model):
    state = flying_state(model, 0.0, 0.0)
    assert model.rollout_cost(state, np.zeros((3, 5, 3)), step=model.max_steps).tolist() == [0.0, 0.0, 0.0]


def test_pool_model_equals_one_scenario_models(tiny):
    other = tiny_scenario(
        name="tiny-other",
        goal={"x_km": 24, "y_km": 26},
        radars=[{"name": "C", "x_km": 10, "y_km": 10, "mast_m": 20}],
        terrain={"seed": 9, "mountains": []},
    )
    third = tiny_scenario(
        name="tiny-three",
        radars=[*tiny.to_dict()["radars"], {"name": "D", "x_km": 0, "y_km": 30, "z_m": 400}],
    )
    scenarios = [tiny, other, third]
    pool = PenetrationModel(scenarios)
    singles = [PenetrationModel(s, radar_slots=3) for s in scenarios]
    rng = np.random.default_rng(0)
    index = np.array([0, 1, 2, 2, 1, 0])
    states = np.stack(
        [flying_state(singles[i], *rng.uniform(-5, 20, 2), agl=rng.uniform(40, 600)) for i in index]
    )
    controls = rng.uniform(-pool.limits.action_high, pool.limits.action_high, size=(len(index), 3))
    pooled = pool.step(states, controls, 3, index)
    obs = pool.observe(pooled.state, pooled.step_index, pooled, index)
    for row, i in enumerate(index):
        single = singles[i].step(states[row : row + 1], controls[row : row + 1], 3)
        assert pooled.J[row] == single.J[0]
        assert pooled.penalty[row] == single.penalty[0]
        np.testing.assert_array_equal(pooled.radar_threat_per_radar[row], single.radar_threat_per_radar[0])
        np.testing.assert_array_equal(
            obs[row], singles[i].observe(single.state, single.step_index, single)[0]
        )
    # Rollouts of a pool member equal the member's own model.
    plan = rng.uniform(-pool.limits.action_high, pool.limits.action_high, size=(8, 5, 3))
    np.testing.assert_array_equal(
        pool.rollout_cost(states[1], plan, step=0, scenario_index=1),
        singles[1].rollout_cost(states[1], plan, step=0),
    )


def test_pool_rejects_incompatible_scenarios(tiny):
    from uav_penetration_env import ScenarioError

    with pytest.raises(ScenarioError, match=r"pool\[1\]\.cost"):
        PenetrationModel([tiny, tiny_scenario(cost={"weights": [0.3, 0.5, 0.2]})])


def test_observation_slots_are_what_the_spec_says(model):
    state = flying_state(model, 2.0, 3.0, agl=120.0, heading_deg=30.0, speed=7.5, pitch_deg=5.0)
    result = model.step(state[None], np.zeros((1, 3)), 6)
    obs = model.observe(result.state, result.step_index, result)[0]
    s = result.state[0]
    x, y, z, v, phi, theta = s
    assert obs.shape == (OBSERVATION_SIZE,) and obs.dtype == np.float32
    position = obs[SLOTS["position"]]
    assert position[0] == np.float32((x + 25e3) / 75e3) and position[1] == np.float32((y + 25e3) / 75e3)
    ground = model.height(np.array([x]), np.array([y]))[0]
    assert obs[SLOTS["altitude_agl"]][0] == pytest.approx((z - ground) / 1000.0, abs=1e-6)
    assert obs[SLOTS["altitude_ceiling"]][0] == pytest.approx(z / 3000.0, abs=1e-6)
    assert obs[SLOTS["speed"]][0] == pytest.approx((v - 5.0) / 5.0, abs=1e-6)
    np.testing.assert_allclose(obs[SLOTS["heading"]], [math.cos(phi), math.sin(phi)], atol=1e-6)
    assert obs[SLOTS["pitch"]][0] == pytest.approx(theta / math.radians(15), abs=1e-6)
    gx, gy = 25e3 - x, 25e3 - y
    assert obs[SLOTS["goal_offset"]][0] == pytest.approx(gx / 75e3, abs=1e-6)
    assert obs[SLOTS["goal_distance"]][0] == pytest.approx(math.hypot(gx, gy) / 75e3, abs=1e-6)
    rel = math.atan2(gy, gx) - phi
    np.testing.assert_allclose(obs[SLOTS["goal_bearing"]], [math.cos(rel), math.sin(rel)], atol=1e-6)
    # Terrain ahead: terrain[a, c] is ahead TERRAIN_AHEAD_M[a], across TERRAIN_ACROSS_M[c] (left positive).
    for a, c in [(0, 2), (4, 0), (2, 4)]:
        px = x + TERRAIN_AHEAD_M[a] * math.cos(phi) - TERRAIN_ACROSS_M[c] * math.sin(phi)
        py = y + TERRAIN_AHEAD_M[a] * math.sin(phi) + TERRAIN_ACROSS_M[c] * math.cos(phi)
        h = model.height(np.array([px]), np.array([py]))[0]
        assert terrain_block(obs)[a, c] == pytest.approx((h - z) / 1000.0, abs=1e-6)
    # Radars: nearest first; two present radars, the last two slots are "missing".
    radars = model.built[0].radar_xyz
    ranges = np.linalg.norm(radars - s[:3], axis=1)
    nearest = int(np.argmin(ranges))
    block = radar_block(obs)
    assert block[0, 0] == 1.0 and block[1, 0] == 1.0
    assert block[0, 1] == pytest.approx(min(ranges[nearest] / 100e3, 5.0), abs=1e-6)
    bearing = math.atan2(radars[nearest, 1] - y, radars[nearest, 0] - x) - phi
    assert block[0, 2] == pytest.approx(math.cos(bearing), abs=1e-6)
    assert block[0, 4] == pytest.approx((radars[nearest, 2] - z) / 1000.0, abs=1e-6)
    assert block[0, 6] == pytest.approx(result.radar_threat_per_radar[0, nearest], abs=1e-6)
    np.testing.assert_array_equal(block[2:], [[0, 5, 0, 0, 0, 0, 0]] * 2)
    assert obs[SLOTS["step_fraction"]][0] == pytest.approx(7 / 30)


def test_observe_without_result_equals_observe_with_it(model):
    state = flying_state(model, 8.0, 9.0)
    result = model.step(state[None], np.array([[0.0, 0.1, 0.1]]), 2)
    np.testing.assert_array_equal(model.observe(result.state, 3, result), model.observe(result.state, 3))


STATE_FIELDS = (
    "terrain_threat",
    "radar_threat",
    "radar_threat_per_radar",
    "visibility",
    "detection_prob",
    "altitude_agl",
    "goal_distance",
)
TRANSITION_FIELDS = (
    "J",
    "penalty",
    "third_term",
    "terrain_threat_n",
    "radar_threat_n",
    "third_term_n",
    "fuel_kg",
    "progress_km",
)


@pytest.mark.parametrize("profile", ["benchmark", "paper"])
def test_reset_result_describes_a_state_as_the_step_into_it_did(profile):
    """A state's own quantities do not depend on how it was reached; a transition's are 0 at reset."""
    model = PenetrationModel(tiny_scenario(profile=profile))
    states = np.array(
        [flying_state(model, x, y, agl) for x, y, agl in ((0, 0, 150), (6, 22, 400), (20, 8, 60))]
    )
    stepped = model.step(states, np.array([[0.5, 0.1, 0.05], [0.0, -0.2, 0.0], [-1.0, 0.0, 0.1]]), 4)
    described = model.reset_result(stepped.state, step_index=5)
    for name in STATE_FIELDS:
        np.testing.assert_array_equal(getattr(described, name), getattr(stepped, name), err_msg=name)
    for name in TRANSITION_FIELDS:
        assert not getattr(described, name).any(), name
    assert described.step_index.tolist() == [5, 5, 5]
    assert not (described.terminated | described.truncated | described.collided).any()
    np.testing.assert_array_equal(described.state, stepped.state)


def test_env_reset_info_is_the_models_reset_result(tiny):
    env = UAVPenetrationEnv(tiny)
    _, info = env.reset(seed=11)
    described = env.model.reset_result(info["state"][None])
    assert info["terrain_threat"] == described.terrain_threat[0]
    assert info["radar_threat"] == described.radar_threat[0]
    np.testing.assert_array_equal(info["radar_threat_per_radar"], described.radar_threat_per_radar[0])
    assert info["J"] == 0.0 and info["step"] == 0


@pytest.mark.parametrize(("profile", "fusion"), [("benchmark", "max"), ("benchmark", "or"), ("paper", "max")])
def test_coverage_level_is_the_fused_probability_or_the_ratio_detection(profile, fusion):
    # Short reference ranges, so the grid holds detected and undetected states in every mode.
    radars = [{"name": "A", "x_km": 5, "y_km": 25, "z_m": 300, "ref_range_km": 15}]
    radars += [{"name": "B", "x_km": 25, "y_km": 5, "mast_m": 15, "ref_range_km": 15}]
    model = PenetrationModel(tiny_scenario(profile=profile, radar_model={"fusion": fusion}, radars=radars))
    xs = np.linspace(-20e3, 45e3, 9)
    states = np.array([[x, y, z, 10.0, 0.3, 0.0] for x in xs for y in xs for z in (100.0, 900.0, 2500.0)])
    level = model.coverage_level(states)
    result = model.reset_result(states)
    assert np.all((level >= 0.0) & (level <= 1.0))
    if model.detection == "ratio":
        # D is no probability: the level says whether some radar detects (D >= 1 in range and sight).
        np.testing.assert_array_equal(level, result.detection_prob)
        assert set(np.unique(level)) == {0.0, 1.0}
    else:
        np.testing.assert_array_equal(level, result.radar_threat)
        if fusion == "or":
            p = result.radar_threat_per_radar
            np.testing.assert_allclose(level, 1.0 - (1.0 - p[:, 0]) * (1.0 - p[:, 1]), rtol=1e-12)


# --- property tests: random states, actions and scenarios -----------------------------------------

finite = st.floats(allow_nan=False, allow_infinity=False)
scenario_variants = st.fixed_dictionaries(
    {
        "radar_model": st.fixed_dictionaries(
            {
                "detection": st.sampled_from(["swerling1", "ratio"]),
                "masking": st.sampled_from(["soft", "hard", "off"]),
                "fusion": st.just("max"),
                "masking_softness_m": st.floats(0.0, 300.0),
            }
        ),
        "cost": st.fixed_dictionaries({"third_term": st.sampled_from(["fuel", "length"])}),
        "terrain": st.fixed_dictionaries(
            {
                "threat_altitude_scale_m": st.one_of(st.none(), st.floats(10.0, 1000.0)),
                "seed": st.integers(0, 3),
            }
        ),
        "radars": st.lists(
            st.fixed_dictionaries(
                {
                    "x_km": st.floats(-20.0, 45.0),
                    "y_km": st.floats(-20.0, 45.0),
                    "mast_m": st.floats(0.0, 50.0),
                    "ref_range_km": st.floats(20.0, 150.0),
                    "ref_rcs_m2": st.floats(0.01, 2.0),
                }
            ),
            min_size=0,
            max_size=4,
        ),
    }
)

_models: dict[str, PenetrationModel] = {}


def variant_model(variant):
    radars = [dict(r, name=f"R{i}") for i, r in enumerate(variant["radars"])]
    scenario = tiny_scenario(**{**variant, "radars": radars})
    if scenario.hash not in _models:
        _models[scenario.hash] = PenetrationModel(scenario)
    return _models[scenario.hash]


@given(
    variant=scenario_variants,
    xy=st.tuples(st.floats(-24e3, 49e3), st.floats(-24e3, 49e3)),
    agl=st.floats(-100.0, 3500.0),
    speed=st.floats(5.0, 10.0),
    heading=st.floats(-4.0, 4.0),
    pitch=st.floats(-0.26, 0.26),
    control=st.tuples(finite, finite, finite),
    step=st.integers(0, 29),
)
def test_model_terms_stay_within_documented_bounds(variant, xy, agl, speed, heading, pitch, control, step):
    model = variant_model(variant)
    x, y = xy
    z = float(model.height(np.array([x]), np.array([y]))[0]) + agl
    state = np.array([[x, y, z, speed, heading, pitch]])
    control = np.clip(np.array([control]), -1e6, 1e6)
    result = model.step(state, control, step)
    obs = model.observe(result.state, result.step_index, result)
    for field in dataclasses.fields(result):  # every number of the transition, the state included
        value = getattr(result, field.name)
        if value.dtype.kind == "f":
            assert np.all(np.isfinite(value)), field.name
    assert np.all(np.isfinite(obs)) and np.all(np.abs(obs) <= 10.0)
    assert 0.0 <= result.terrain_threat[0] <= 1.0
    assert 0.0 <= result.detection_prob[0] <= 1.0
    assert np.all((result.visibility >= 0.0) & (result.visibility <= 1.0))
    assert np.all(result.radar_threat_per_radar >= 0.0)
    assert result.penalty[0] >= 0.0
    if model.detection == "swerling1":
        assert np.all(result.radar_threat_per_radar <= 1.0)
        # Analytic normalisation: every term and J in [0, 1] (model.md §7).
        for term in (result.terrain_threat_n, result.radar_threat_n, result.third_term_n, result.J):
            assert -1e-12 <= term[0] <= 1.0 + 1e-12
    flags = [result.reached_goal[0], result.collided[0], result.out_of_area[0]]
    assert sum(flags) <= 1 and result.terminated[0] == any(flags)
    assert not (result.terminated[0] and result.truncated[0])
    assert result.state[0, 4] == pytest.approx(float(wrap_angle(result.state[0, 4])))


@given(
    variant=scenario_variants,
    plan=st.lists(
        st.tuples(st.floats(-2, 2), st.floats(-0.3, 0.3), st.floats(-0.3, 0.3)), min_size=1, max_size=6
    ),
    step=st.integers(0, 30),
    terminal=st.floats(0.0, 1.0),
)
def test_rollout_cost_is_finite_and_non_negative_for_any_scenario(variant, plan, step, terminal):
    model = variant_model(variant)
    state = model.initial_state()
    costs = model.rollout_cost(state, np.array(plan)[None], step=step, terminal_cost=distance_terminal(model, terminal))
    assert np.isfinite(costs[0])
    if model.detection == "swerling1":
        assert costs[0] >= -1e-12
