"""The Gymnasium API of every registered id: checkers, determinism, reward identity, bad input."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from conftest import RL_EXTRA, tiny_scenario
from gymnasium.utils.env_checker import check_env

import uav_penetration_env
from uav_penetration_env import Scenario, ScenarioError
from uav_penetration_env.benchmark import GreedyPolicy
from uav_penetration_env.env import UAVPenetrationEnv

ENV_IDS = list(uav_penetration_env.ENV_IDS)
INFO_KEYS = {
    "J", "penalty", "terrain_threat", "radar_threat", "third_term", "fuel_kg", "progress", "terrain_threat_n",
    "radar_threat_n", "third_term_n", "radar_threat_per_radar", "detection_prob", "detected", "position",
    "altitude_agl", "distance_to_goal", "reached_goal", "collided", "out_of_area", "step", "state",
}  # fmt: skip


def make(env_id, **kwargs):
    if env_id != "UAVPenetrationRandom-v0":
        kwargs.setdefault("scenario", tiny_scenario())
    else:
        kwargs.setdefault("difficulty", 0.0)
        kwargs.setdefault("pool_size", 2)
    return gym.make(env_id, **kwargs)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_gymnasium_check_env(env_id):
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*symmetric and normalized.*")
        check_env(gym.make(env_id).unwrapped, skip_render_check=True)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_stable_baselines3_check_env(env_id):
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker", reason=RL_EXTRA)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*symmetric and normalized.*")
        sb3_checker.check_env(gym.make(env_id), warn=True)


def test_ids_register_their_k_max_as_the_time_limit():
    # The spec says where the env truncates itself (tests/env/test_gym_conventions.py).
    for env_id in ENV_IDS:
        assert gym.spec(env_id).max_episode_steps == 150
        assert "TimeLimit" in repr(
            gym.make(env_id, **({} if "Random" in env_id else {"scenario": tiny_scenario()}))
        )


def test_profile_precedence():
    # The id's profile overrides the file's; the keyword overrides both.
    paper_file = tiny_scenario(
        profile="paper", normalisation={"mode": "analytic"}, cost={"crash_penalty_per_step": 1.0}
    )
    assert gym.make("UAVPenetration-v0", scenario=paper_file).unwrapped.scenario.profile == "benchmark"
    assert gym.make("UAVPenetrationPaper-v0").unwrapped.scenario.profile == "paper"
    env = gym.make("UAVPenetration-v0", scenario=paper_file, profile="paper")
    assert env.unwrapped.model.detection == "ratio"
    assert UAVPenetrationEnv(paper_file).scenario.profile == "paper"


def test_scenario_accepts_path_dict_and_object(tmp_path):
    scenario = tiny_scenario()
    path = scenario.to_yaml(tmp_path / "tiny.yaml")
    for source in (scenario, scenario.to_dict(), path, str(path)):
        assert gym.make("UAVPenetration-v0", scenario=source).unwrapped.scenario == scenario
    with pytest.raises(ScenarioError, match="radars"):
        gym.make("UAVPenetration-v0", scenario={**scenario.to_dict(), "radar": []})


def run_episode(env, seed, actions):
    obs, info = env.reset(seed=seed)
    trace = [(obs, 0.0, False, False, info)]
    for action in actions:
        obs, reward, terminated, truncated, info = env.step(action)
        trace.append((obs, reward, terminated, truncated, info))
        if terminated or truncated:
            break
    return trace


def assert_same_trace(a, b):
    assert len(a) == len(b)
    for (oa, ra, ta, ua, ia), (ob, rb, tb, ub, ib) in zip(a, b, strict=True):
        np.testing.assert_array_equal(oa, ob)
        assert (ra, ta, ua) == (rb, tb, ub)
        for key in ia:
            np.testing.assert_array_equal(ia[key], ib[key])


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_same_seed_and_actions_give_identical_episodes(env_id):
    actions = np.random.default_rng(1).uniform(-1, 1, size=(12, 3)) * [2.0, 0.26, 0.26]
    assert_same_trace(run_episode(make(env_id), 5, actions), run_episode(make(env_id), 5, actions))


def test_start_jitter_comes_from_the_seed():
    scenario = tiny_scenario(start={"jitter": {"xy_km": 2.0, "heading_deg": 10.0}})
    env = UAVPenetrationEnv(scenario)
    first = env.reset(seed=1)[1]["state"]
    assert not np.array_equal(first, env.reset(seed=2)[1]["state"])
    np.testing.assert_array_equal(first, env.reset(seed=1)[1]["state"])
    assert abs(first[0]) <= 2000.0 and abs(first[1]) <= 2000.0


def test_random_id_seeds_give_different_scenarios():
    env = make("UAVPenetrationRandom-v0")
    env.reset(seed=1)
    first = env.unwrapped.scenario
    env.reset(seed=2)
    assert env.unwrapped.scenario.hash != first.hash
    env.reset(seed=1)
    assert env.unwrapped.scenario == first
    # Seedless resets draw from the pool (seeds derived from the first reset's seed).
    pool = {
        s.hash for s in (env.unwrapped.source.scenario_of_seed(p) for p in env.unwrapped.source.pool_seeds())
    }
    for _ in range(4):
        env.reset()
        assert env.unwrapped.scenario.hash in pool
    assert len(env.step(np.zeros(3))[4]["radar_threat_per_radar"]) == 8


def test_reward_identity_on_every_step_including_goal_and_crash():
    env = UAVPenetrationEnv(tiny_scenario())
    policy = GreedyPolicy()
    outcomes = set()
    for dive in (False, True):
        obs, info = env.reset(seed=0)
        policy.reset(env.model)
        done = False
        while not done:
            action = np.array([0.0, 0.0, -0.26]) if dive else policy.act(obs, info)
            obs, reward, terminated, truncated, info = env.step(action)
            assert reward == -(info["J"] + info["penalty"])
            assert set(info) >= INFO_KEYS
            done = terminated or truncated
            if not done:
                assert info["penalty"] == 0.0
        outcomes.add("collided" if info["collided"] else "success" if info["reached_goal"] else "other")
        if info["collided"]:
            assert info["penalty"] == pytest.approx(1.0 * (30 - info["step"] + 1))
    assert outcomes == {"success", "collided"}


def test_truncates_itself_at_max_steps():
    env = UAVPenetrationEnv(tiny_scenario(time={"max_steps": 4}, start={"z_agl_m": 900}))
    env.reset(seed=0)
    flags = [env.step(np.array([-2.0, 0.26, 0.0]))[2:4] for _ in range(4)]
    assert flags == [(False, False)] * 3 + [(False, True)]
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(3))


@pytest.mark.parametrize(
    "action",
    [
        np.array([np.nan, 0, 0]),
        np.array([0, np.inf, 0]),
        np.zeros(2),
        np.zeros((1, 3)),
        np.zeros(4),
        "fast",
        [[0, 0, 0]],
    ],
)
def test_bad_actions_raise_value_error(action):
    env = UAVPenetrationEnv(tiny_scenario())
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(action)


def test_actions_are_clipped_to_the_box_in_float64():
    env = UAVPenetrationEnv(tiny_scenario())
    env.reset(seed=0)
    state = env.state.copy()
    big = env.step(np.array([50.0, 3.0, -3.0], dtype=np.float32))[4]["state"]
    env.set_state(state, 0)
    limit = env.step(np.array([2.0, math.radians(15), -math.radians(15)]))[4]["state"]
    np.testing.assert_array_equal(big, limit)


def test_set_state_and_its_validation():
    env = UAVPenetrationEnv(tiny_scenario())
    env.reset(seed=0)
    state = np.array([1000.0, 2000.0, 700.0, 8.0, 0.3, 0.0])
    _obs, info = env.set_state(state, 7)
    np.testing.assert_array_equal(info["state"], state)
    assert env.unwrapped.step_index == 7 and info["step"] == 7
    assert env.step(np.zeros(3))[4]["step"] == 8
    with pytest.raises(ValueError, match="state"):
        env.set_state(np.array([0.0, 0, np.nan, 10, 0, 0]), 0)
    with pytest.raises(ValueError, match="state"):
        env.set_state(np.zeros(5), 0)
    with pytest.raises(ValueError, match="step_index"):
        env.set_state(state, 30)


def test_unwrapped_exposes_scenario_model_state():
    env = gym.make("UAVPenetration-v0", scenario=tiny_scenario())
    env.reset(seed=3)
    inner = env.unwrapped
    assert isinstance(inner.scenario, Scenario)
    assert isinstance(inner.model, uav_penetration_env.PenetrationModel)
    assert inner.state.dtype == np.float64 and inner.state.shape == (6,) and inner.step_index == 0


@pytest.mark.parametrize("env_id", ["UAVPenetration-v0", "UAVPenetrationDEM-v0"])
def test_rgb_array_render(env_id):
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    env.step(np.zeros(3))
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert frame.shape[0] >= 400 and frame.shape[1] >= 400
    assert frame.std() > 10  # a drawn scene, not a blank canvas
    env.close()


def test_human_render_runs_headless(monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    import matplotlib

    matplotlib.use("Agg")
    env = gym.make("UAVPenetration-v0", scenario=tiny_scenario(), render_mode="human")
    env.reset(seed=0)
    env.step(np.zeros(3))
    assert env.render() is None
    env.close()


def test_bad_render_mode_is_rejected():
    with pytest.raises(ValueError, match="render_mode"):
        UAVPenetrationEnv(tiny_scenario(), render_mode="ansi")


@pytest.mark.parametrize("profile", ["benchmark", "paper"])
def test_render_coverage_is_the_models_coverage_level(profile):
    """The envelope drawn is the model's own detection rule, at the given altitude and heading."""
    from uav_penetration_env.render import coverage_grid

    model = UAVPenetrationEnv(tiny_scenario(profile=profile)).model
    xs, ys, level = coverage_grid(model, 600.0, 0.4, nodes=7)
    gx, gy = np.meshgrid(xs * 1000.0, ys * 1000.0, indexing="ij")
    states = np.column_stack(
        (gx.ravel(), gy.ravel(), np.full(gx.size, 600.0), np.full(gx.size, model.limits.speed_max))
    )
    states = np.column_stack((states, np.full(gx.size, 0.4), np.zeros(gx.size)))
    np.testing.assert_array_equal(level, model.coverage_level(states).reshape(7, 7))


def test_reset_refuses_options_it_would_ignore(tiny):
    from uav_penetration_env.env import UAVPenetrationEnv

    env = UAVPenetrationEnv(tiny)
    with pytest.raises(ValueError, match=r"options: got the key\(s\) 'state', expected none"):
        env.reset(seed=0, options={"state": [0, 0, 100, 10, 0, 0]})
    with pytest.raises(TypeError, match=r"options: got str 'not a dict', expected None or an empty dict"):
        env.reset(seed=0, options="not a dict")
    env.reset(seed=0, options={})  # what Gymnasium's vector envs pass after taking their own keys
    env.reset(seed=0, options=None)
    # Gymnasium's vector env takes its reset_mask and hands the sub-envs what is left.
    envs = gym.vector.SyncVectorEnv([lambda: UAVPenetrationEnv(tiny)] * 2)
    envs.reset(seed=0)
    envs.reset(options={"reset_mask": np.array([True, False])})
