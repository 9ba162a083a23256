"""Threat dynamics (docs/dynamic.md): the schema, the draws, truth and belief, and what planners may read."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import uav_penetration_env  # noqa: F401  (registers the ids)
from uav_penetration_env.benchmark.information import BeliefFeed, OraclePolicy, planning_model
from uav_penetration_env.benchmark.policies import GreedyPolicy, LatticePolicy, ValueGreedyPolicy
from uav_penetration_env.catalogue import resolve_scenario
from uav_penetration_env.dynamic_env import UAVPenetrationDynamicEnv
from uav_penetration_env.env import UAVPenetrationEnv
from uav_penetration_env.scenario import Radar, Scenario, ScenarioError
from uav_penetration_env.threats import ThreatState, draw_threats, route_position

PAPER_HASH = "cb71b7b881715851"  # the paper scenario's hash in the committed v2/v3 rows


def paper_with(*radars: dict, sensing: dict | None = None, max_steps: int | None = None) -> Scenario:
    """The paper scenario with ``radars`` (file-unit mappings) added."""
    paper = resolve_scenario("paper")
    changes: dict = {"radars": [*paper.to_dict()["radars"], *radars]}
    if sensing is not None:
        changes["sensing"] = sensing
    if max_steps is not None:
        changes["time"] = {"max_steps": max_steps}
    return paper.updated(changes)


def fly(env: UAVPenetrationEnv, policy, seed: int = 0, steps: int | None = None):
    """Fly ``policy`` through the harness's belief feed; the (observation, reward, info) of each step."""
    observation, info = env.reset(seed=seed)
    policy.reset(planning_model(env, policy), seed)
    feed = BeliefFeed(env, policy)
    out, done = [(observation, 0.0, info)], False
    while not done and (steps is None or len(out) <= steps):
        observation, reward, terminated, truncated, info = env.step(feed.act(observation, info))
        out.append((observation, reward, info))
        done = terminated or truncated
    return out


# --- schema ------------------------------------------------------------------------------------------


def test_a_static_scenario_keeps_its_file_and_hash():
    paper = resolve_scenario("paper")
    assert paper.hash == PAPER_HASH
    assert not paper.is_dynamic
    assert "sensing" not in paper.to_dict()
    assert all(set(r) <= {"name", "x_km", "y_km", "z_m", "mast_m", "ref_range_km", "ref_rcs_m2"} for r in paper.to_dict()["radars"])


def test_dynamic_fields_round_trip_through_yaml(tmp_path):
    from uav_penetration_env.scenario import load_scenario

    scenario = resolve_scenario("paper-dynamic")
    assert scenario.is_dynamic
    again = load_scenario(scenario.to_yaml(tmp_path / "dynamic.yaml"))
    assert again == scenario and again.hash == scenario.hash


@pytest.mark.parametrize(
    ("radar", "field"),
    [
        ({"prior": "uncertain"}, "position_error_km"),
        ({"position_error_km": 2.0}, "position_error_km"),
        ({"presence_prob": 0.5}, "presence_prob"),
        ({"prior": "unknown", "presence_prob": 0.0}, "presence_prob"),
        ({"route_km": [[60.0, 60.0]]}, "speed_m_s"),
        ({"on_step": [5, 4]}, "on_step"),
        ({"on_step": [3, 6], "trigger_range_km": 10.0}, "trigger_range_km"),
        ({"prior": "seen"}, "prior"),
    ],
)
def test_a_broken_threat_is_refused_naming_its_field(radar, field):
    with pytest.raises(ScenarioError, match=rf"radars\[4\]\.{field}"):
        paper_with({"name": "X", "x_km": 60.0, "y_km": 60.0, "mast_m": 10.0, **radar})


def test_a_moving_or_uncertain_radar_needs_a_mast_and_a_route_inside_the_map():
    with pytest.raises(ScenarioError, match=r"radars\[4\]\.z_m.*mast_m"):
        paper_with({"name": "X", "x_km": 60.0, "y_km": 60.0, "z_m": 500.0, "route_km": [[60, 70]], "speed_m_s": 5})
    with pytest.raises(ScenarioError, match=r"radars\[4\]\.route_km\[1\]\.x_km"):
        paper_with({"name": "X", "x_km": 60.0, "y_km": 60.0, "mast_m": 10.0, "route_km": [[60, 70], [500, 70]], "speed_m_s": 5})
    with pytest.raises(ScenarioError, match=r"radars\[4\]\.on_step.*max_steps = 20"):
        paper_with({"name": "X", "x_km": 60.0, "y_km": 60.0, "mast_m": 10.0, "on_step": [5, 20]}, max_steps=20)


def test_the_static_copy_of_a_radar_clears_every_dynamic_field():
    from uav_penetration_env.scenario.schema import DYNAMIC_FIELDS

    radar = Radar("M", 0.0, 0.0, mast_m=10.0, route_km=((3.0, 4.0),), speed_m_s=10.0, prior="uncertain", position_error_km=1.0, on_step=(1, 2))
    static = radar.at(1.5, 2.0)
    assert (static.x_km, static.y_km, static.mast_m) == (1.5, 2.0, 10.0)
    assert radar.is_dynamic and not static.is_dynamic
    assert all(getattr(static, name) is None for name in DYNAMIC_FIELDS)


# --- draws and motion -----------------------------------------------------------------------------------


def test_a_static_scenario_draws_nothing_and_a_seed_fixes_the_draw():
    rng = np.random.default_rng(3)
    before = rng.bit_generator.state
    draw_threats(resolve_scenario("paper"), rng)
    assert rng.bit_generator.state == before
    dynamic = resolve_scenario("paper-dynamic")
    assert draw_threats(dynamic, np.random.default_rng(5)) == draw_threats(dynamic, np.random.default_rng(5))


def test_presence_and_switch_on_steps_follow_their_declared_laws():
    scenario = paper_with(
        {"name": "X", "x_km": 60.0, "y_km": 60.0, "mast_m": 10.0, "prior": "unknown", "presence_prob": 0.3},
        {"name": "Y", "x_km": 70.0, "y_km": 60.0, "mast_m": 10.0, "on_step": [4, 7]},
        {"name": "Z", "x_km": 80.0, "y_km": 60.0, "mast_m": 10.0, "prior": "uncertain", "position_error_km": 2.0},
    )
    rng = np.random.default_rng(11)
    draws = [draw_threats(scenario, rng) for _ in range(4000)]
    present = np.mean([d.exists[4] for d in draws])
    assert abs(present - 0.3) < 4 * math.sqrt(0.3 * 0.7 / 4000)  # a 4-sigma binomial bound
    assert {d.on_step[5] for d in draws} == {4, 5, 6, 7}
    offsets = np.array([np.subtract(d.prior_site_km[6], (80.0, 60.0)) for d in draws])
    assert np.all(np.abs(offsets.std(axis=0) - 2.0) < 4 * 2.0 / math.sqrt(2 * 4000))  # sigma's standard error
    assert all(d.prior_site_km[4] is None and d.prior_site_km[0] == (11.0, 55.0) for d in draws[:5])


def test_a_mobile_radar_runs_out_and_back_along_its_route():
    # From (0, 0) through (3, 4): one 5 km leg, at 10 m/s (hand-computed positions).
    radar = Radar("M", 0.0, 0.0, mast_m=10.0, route_km=((3.0, 4.0),), speed_m_s=10.0)
    assert route_position(radar, 250.0) == pytest.approx((1.5, 2.0))  # 2.5 km out
    assert route_position(radar, 600.0) == pytest.approx((2.4, 3.2))  # 6 km: 1 km back from the end
    assert route_position(radar, 1000.0) == pytest.approx((0.0, 0.0))  # 10 km: home again
    assert route_position(Radar("S", 5.0, 6.0, z_m=100.0), 1e6) == (5.0, 6.0)


def test_reveals_need_line_of_sight_within_the_warning_range_or_a_detection():
    scenario = paper_with(
        {"name": "X", "x_km": 60.0, "y_km": 60.0, "mast_m": 10.0, "prior": "unknown"},
        sensing={"warning_range_km": 10.0, "reveal_on_detection": False},
    )
    state = ThreatState(scenario, draw_threats(scenario, np.random.default_rng(0)))
    assert state.belief_indices() == (0, 1, 2, 3) and state.truth_indices() == (0, 1, 2, 3, 4)
    seen, detection = np.ones(5), np.ones(5)
    assert state.advance((60.0, 75.0), seen, detection) == ()  # 15 km away: out of range, detection ignored
    assert state.advance((60.0, 65.0), np.array([1, 1, 1, 1, 0.2]), detection) == ()  # masked
    assert state.advance((60.0, 65.0), seen, detection) == ("X",)
    assert state.belief_indices() == (0, 1, 2, 3, 4) and state.step == 3


def test_pop_ups_switch_on_by_time_or_by_range():
    scenario = paper_with(
        {"name": "T", "x_km": 60.0, "y_km": 60.0, "mast_m": 10.0, "on_step": [2, 2]},
        {"name": "R", "x_km": 80.0, "y_km": 60.0, "mast_m": 10.0, "trigger_range_km": 5.0},
    )
    state = ThreatState(scenario, draw_threats(scenario, np.random.default_rng(0)))
    assert state.truth_indices() == (0, 1, 2, 3)
    assert state.belief_indices() == (0, 1, 2, 3, 4, 5)  # known sites are planned around before they switch on
    state.advance((0.0, 0.0), np.zeros(4), np.zeros(4))
    assert state.truth_indices() == (0, 1, 2, 3)
    state.advance((78.0, 58.0), np.zeros(4), np.zeros(4))  # step 2: T on by time, R triggered by range
    assert state.truth_indices() == (0, 1, 2, 3, 4, 5)


# --- the env ---------------------------------------------------------------------------------------------


def _same_episode(a, b) -> None:
    assert len(a) == len(b)
    for (obs_a, r_a, info_a), (obs_b, r_b, info_b) in zip(a, b, strict=True):
        assert np.array_equal(obs_a, obs_b) and r_a == r_b
        assert np.array_equal(info_a["state"], info_b["state"]) and info_a["J"] == info_b["J"]
        per_radar_b = info_b["radar_threat_per_radar"]
        assert np.array_equal(info_a["radar_threat_per_radar"][: len(per_radar_b)], per_radar_b)


def test_the_dynamic_id_reproduces_the_static_id_where_every_threat_is_known():
    static = fly(UAVPenetrationEnv("paper"), GreedyPolicy(), seed=4)
    assert static[-1][2]["reached_goal"]
    _same_episode(fly(UAVPenetrationDynamicEnv("paper"), GreedyPolicy(), seed=4), static)
    # Through the dynamic path: an unknown radar that does not exist in this episode changes nothing.
    absent = paper_with({"name": "X", "x_km": 60.0, "y_km": 60.0, "mast_m": 10.0, "prior": "unknown", "presence_prob": 1e-12})
    env = UAVPenetrationDynamicEnv(absent)
    episode = fly(env, GreedyPolicy(), seed=4)
    assert env.threats is not None and env.threats.draw.exists[4] is False
    _same_episode(episode, static)


def test_the_id_passes_gymnasiums_checker():
    from gymnasium.utils.env_checker import check_env

    env = gym.make("UAVPenetrationDynamic-v0")
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_a_planner_never_reads_an_unrevealed_threat():
    # X sits 2 km off the value-greedy route (at step ~27), visible to the warning receiver only within 5 km, detection does
    # not reveal it: the belief planner flies exactly the track it flies without X until the reveal.
    hidden = {"name": "X", "x_km": 62.0, "y_km": 45.0, "mast_m": 10.0, "prior": "unknown"}
    sensing = {"warning_range_km": 5.0, "reveal_on_detection": False}
    with_x = fly(UAVPenetrationDynamicEnv(paper_with(hidden, sensing=sensing)), ValueGreedyPolicy(), seed=0)
    without = fly(UAVPenetrationDynamicEnv(paper_with(sensing=sensing)), ValueGreedyPolicy(), seed=0)
    reveal = next(i for i, (_, _, info) in enumerate(with_x) if info["revealed"])
    assert reveal > 3
    # The same states up to the one that reveals X, the same observations before it (that one shows X).
    for (obs_a, _, info_a), (obs_b, _, info_b) in zip(with_x[: reveal + 1], without[: reveal + 1], strict=True):
        assert np.array_equal(info_a["state"], info_b["state"])
        assert np.array_equal(obs_a, obs_b) or info_a["revealed"] == ("X",)
    assert not np.array_equal(with_x[reveal][0], without[reveal][0])
    assert any(info["radar_threat_per_radar"][4] > 0 for _, _, info in with_x[:reveal])  # X did score


def test_the_oracle_pays_less_where_a_threat_is_unknown_and_the_same_where_none_is():
    hidden = {"name": "X", "x_km": 62.0, "y_km": 45.0, "mast_m": 10.0, "prior": "unknown"}
    sensing = {"warning_range_km": 5.0, "reveal_on_detection": False}
    unknown = paper_with(hidden, sensing=sensing)
    # The lattice planner (J + V one move ahead); the one-step value-greedy rule is not a planner whose
    # J falls with more information in every episode (docs/dynamic.md §6).
    belief = fly(UAVPenetrationDynamicEnv(unknown), LatticePolicy(), seed=0)
    oracle = fly(UAVPenetrationDynamicEnv(unknown), OraclePolicy(LatticePolicy()), seed=0)
    cost = lambda episode: sum(info["J"] + info["penalty"] for _, _, info in episode[1:])  # noqa: E731
    assert oracle[-1][2]["reached_goal"] and cost(oracle) < cost(belief)
    known = paper_with({**hidden, "prior": "known"})
    _same_episode(
        fly(UAVPenetrationDynamicEnv(known), OraclePolicy(LatticePolicy()), seed=0),
        fly(UAVPenetrationDynamicEnv(known), LatticePolicy(), seed=0),
    )


# --- information modes in policy names ---------------------------------------------------------------------


def test_oracle_and_offline_names_read_once_and_label_every_table():
    from uav_penetration_env.benchmark.evaluate import policy_hash
    from uav_penetration_env.benchmark.information import OfflinePolicy
    from uav_penetration_env.benchmark.policies import make_policy, parse_policy
    from uav_penetration_env.benchmark.policy_spec import PolicyValueError

    spec = parse_policy("oracle:lattice-c60")
    assert (spec.label, spec.canonical(), spec.information) == ("oracle:lattice-c60", "oracle:lattice[clearance=60]", "oracle")
    assert parse_policy("offline:lattice[clearance=60]").label == "offline:lattice-c60"
    with pytest.raises(PolicyValueError, match="at most one of the prefixes"):
        parse_policy("oracle:offline:lattice")
    oracle, offline, plain = make_policy("oracle:lattice"), make_policy("offline:lattice"), make_policy("lattice")
    assert isinstance(oracle, OraclePolicy) and isinstance(offline, OfflinePolicy)
    assert len({policy_hash(oracle), policy_hash(offline), policy_hash(plain)}) == 3


def test_the_offline_floor_flies_its_plan_open_loop():
    from uav_penetration_env.benchmark.information import OfflinePolicy

    # Where nothing is revealed the prior map is the truth: the open-loop plan of a deterministic
    # planner is its closed-loop episode, step for step.
    _same_episode(fly(UAVPenetrationEnv("paper"), OfflinePolicy(GreedyPolicy()), seed=1), fly(UAVPenetrationEnv("paper"), GreedyPolicy(), seed=1))
    # Where a threat is revealed, the floor keeps its prior plan: its track is the one it flies without X.
    hidden = paper_with({"name": "X", "x_km": 62.0, "y_km": 45.0, "mast_m": 10.0, "prior": "unknown"})
    floor = fly(UAVPenetrationDynamicEnv(hidden), OfflinePolicy(LatticePolicy()), seed=0)
    assert any(info["revealed"] for _, _, info in floor)
    blind = fly(UAVPenetrationDynamicEnv("paper"), LatticePolicy(), seed=0)
    assert len(floor) == len(blind)
    assert all(np.array_equal(a[2]["state"], b[2]["state"]) for a, b in zip(floor, blind, strict=True))


# --- procedural dynamic scenarios and their suites ---------------------------------------------------------


def test_the_knobs_set_what_is_hidden_and_the_mobile_radars_cross_the_route():
    from uav_penetration_env.dynamic_catalogue import DynamicKnobs, random_dynamic_scenario

    knobs = DynamicKnobs(unknown_fraction=0.5, lateness=0.5, mobile=2, position_error_km=3.0)
    scenario = random_dynamic_scenario(np.random.default_rng(123), 0.5, knobs)
    assert scenario == random_dynamic_scenario(np.random.default_rng(123), 0.5, knobs)  # one generator, one scenario
    fixed, mobile = scenario.radars[:-2], scenario.radars[-2:]
    unknown = [r for r in fixed if r.prior == "unknown"]
    assert len(unknown) == round(0.5 * len(fixed))
    assert all(r.prior == "uncertain" and r.position_error_km == 3.0 for r in fixed if r.prior != "unknown")
    start, goal = np.array([scenario.start.x_km, scenario.start.y_km]), np.array([scenario.goal.x_km, scenario.goal.y_km])
    steps = np.hypot(*(goal - start)) / (scenario.uav.speed_m_s[1] * scenario.time.dt_s / 1000.0)
    assert all(r.on_step == (round(0.25 * steps), round(0.5 * steps)) for r in unknown)
    route = goal - start
    side = lambda p: np.sign(route[0] * (p[1] - start[1]) - route[1] * (p[0] - start[0]))  # noqa: E731
    for radar in mobile:
        assert radar.prior == "unknown" and 5.0 <= radar.speed_m_s <= 10.0
        assert side((radar.x_km, radar.y_km)) == -side(radar.route_km[0])
    with pytest.raises(ScenarioError, match="lateness"):
        DynamicKnobs(lateness=1.5)


def test_a_dynamic_recipe_round_trips_and_names_a_bad_knob():
    from uav_penetration_env.suites.schema import Recipe, SuiteError

    data = {"difficulty": 0.5, "seed": 7, "dynamic": {"unknown_fraction": 0.25, "lateness": 0.0, "mobile": 0, "position_error_km": 2.0}}
    recipe = Recipe.from_dict(data, "members[0]")
    assert Recipe.from_dict(recipe.to_dict(), "again") == recipe and recipe.group == "d0.50-u0.25-l0.00-m0-e2"
    assert Recipe.from_dict({"difficulty": 0.5, "seed": 7}, "m").dynamic is None
    with pytest.raises(SuiteError, match=r"members\[0\]\.dynamic: .*unknown_fraction"):
        Recipe.from_dict({**data, "dynamic": {"unknowns": 1}}, "members[0]")
    with pytest.raises(SuiteError, match=r"members\[0\]\.dynamic\.mobile: got 9"):
        Recipe.from_dict({**data, "dynamic": {"mobile": 9}}, "members[0]")


def test_the_price_of_information_pairs_each_planner_with_its_oracle_and_its_floor(tmp_path):
    import pandas as pd

    from uav_penetration_env.benchmark.leaderboard.information import _information_tables, information_table
    from uav_penetration_env.benchmark.leaderboard.registry import TableContext

    rows = []
    costs = {"lattice": [10.0, 12.0, 11.0, 9.0], "oracle:lattice": [9.0, 11.5, 11.0, 8.0], "offline:lattice": [13.0, 12.0, 15.0, 9.5]}
    for policy, values in costs.items():
        for seed, cost in enumerate(values):
            rows.append({"policy": policy, "scenario_hash": "h", "seed": seed, "outcome": "success", "total_cost": cost})
    rows.append({"policy": "oracle:ps2o", "scenario_hash": "h", "seed": 0, "outcome": "success", "total_cost": 1.0})  # no partner
    episodes = pd.DataFrame(rows)
    table = information_table(episodes, n_resamples=200)
    assert list(table["policy"]) == ["lattice", "lattice"]
    price, replanning = table.iloc[0], table.iloc[1]
    assert price["pairs"] == 4 and price["mean_difference"] == pytest.approx((1.0 + 0.5 + 0.0 + 1.0) / 4)
    assert price["median_difference"] == pytest.approx(0.75)
    assert replanning["mean_difference"] == pytest.approx((3.0 + 0.0 + 4.0 + 0.5) / 4)
    assert price["ci_low"] <= price["mean_difference"] <= price["ci_high"]
    assert price["wilcoxon_p_holm"] == price["wilcoxon_p"]  # one planner per comparison: Holm changes nothing
    context = TableContext(tmp_path, tmp_path, episodes, pd.DataFrame(), "lattice", 0, "uav-bench leaderboard", 200, "today")
    written = _information_tables(context)
    assert [p.name for p in written] == ["information.csv", "information.md"]
    assert "| price of information (P - oracle:P) | lattice" in written[1].read_text()
    assert _information_tables(TableContext(tmp_path, tmp_path, episodes[episodes["policy"] == "lattice"], pd.DataFrame(), "lattice", 0, "c", 200, "d")) == []


def test_gymnasiums_vector_env_runs_the_dynamic_id_each_env_its_own_threats():
    envs = gym.make_vec("UAVPenetrationDynamic-v0", num_envs=2, vectorization_mode="sync")
    observations, infos = envs.reset(seed=[0, 2])
    assert observations.shape == (2, 67)
    single = UAVPenetrationDynamicEnv()
    for index, seed in enumerate((0, 2)):
        observation, info = single.reset(seed=seed)
        assert np.array_equal(observations[index], observation)
        assert tuple(infos["known_threats"][index]) == info["known_threats"]
    action = np.zeros((2, 3), dtype=np.float32)
    observations, rewards, *_ = envs.step(action)
    assert observations.shape == (2, 67) and np.all(np.isfinite(rewards))
    envs.close()


def test_a_reveal_rebuilds_v_incrementally_to_the_full_builds_values():
    from uav_penetration_env.build import build_scenario
    from uav_penetration_env.model import PenetrationModel
    from uav_penetration_env.value_function import value_function

    hidden = {"name": "X", "x_km": 62.0, "y_km": 45.0, "mast_m": 10.0, "prior": "unknown"}
    env = UAVPenetrationDynamicEnv(paper_with(hidden, sensing={"warning_range_km": 5.0, "reveal_on_detection": False}))
    policy = LatticePolicy()
    episode = fly(env, policy, seed=0)
    assert any(info["revealed"] == ("X",) for _, _, info in episode)
    assert policy.model is env.model and env.model.radar_slots == 5  # the policy plans on the last belief
    fresh = PenetrationModel(build_scenario(env.model.scenario))  # the same belief, built from nothing
    full = value_function(fresh).table
    assert policy._value is not None and policy._value.table.shape == full.shape
    finite = np.isfinite(full)
    assert np.array_equal(finite, np.isfinite(policy._value.table))
    assert np.allclose(policy._value.table[finite], full[finite], rtol=1e-8, atol=1e-12)
