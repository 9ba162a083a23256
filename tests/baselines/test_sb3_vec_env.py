"""The SB3 VecEnv adapter equals DummyVecEnv of single envs wrapped in RescaleAction, step by step."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import RL_EXTRA, tiny_scenario

pytest.importorskip("stable_baselines3", reason=RL_EXTRA)

from gymnasium.wrappers import RescaleAction
from stable_baselines3.common.vec_env import DummyVecEnv, VecCheckNan, VecMonitor, VecNormalize

from baselines.vec_env import UAVPenetrationSB3VecEnv
from uav_penetration_env.env import UAVPenetrationEnv

# Short episodes with start jitter, so terminations, truncations and seeded starts all occur.
SCENARIO = tiny_scenario(time={"max_steps": 12}, start={"jitter": {"xy_km": 1.0, "heading_deg": 5.0}})


def policy_actions(num_envs, steps, seed=0):
    """Actions in policy units: dive (crash), loiter (truncation), wander (beyond [-1, 1] too), cruise."""
    rng = np.random.default_rng(seed)
    actions = rng.uniform(-1.3, 1.3, size=(steps, num_envs, 3)).astype(np.float32)
    actions[:, 0::4] = [0.0, 0.0, -1.0]
    actions[:, 1::4] = [-1.0, 1.0, 0.0]
    actions[:, 3::4] = [0.0, 0.0, 0.0]
    return actions


def assert_infos_equal(ours, reference, where):
    assert len(ours) == len(reference)
    for i, (a, b) in enumerate(zip(ours, reference, strict=True)):
        assert set(a) == set(b), f"{where}, env {i}: keys differ: {set(a) ^ set(b)}"
        for key in b:
            np.testing.assert_array_equal(a[key], b[key], err_msg=f"{where}, env {i}, info[{key!r}]")
            assert type(a[key]) is type(b[key]), f"{where}, env {i}, info[{key!r}]"


@pytest.mark.filterwarnings("ignore:.*precision lowered by casting:UserWarning")  # RescaleAction's own Box
def test_adapter_equals_dummy_vec_env_of_rescaled_single_envs():
    n = 8
    ours = UAVPenetrationSB3VecEnv("UAVPenetration-v0", n, scenario=SCENARIO)
    reference = DummyVecEnv([lambda: RescaleAction(UAVPenetrationEnv(SCENARIO), -1.0, 1.0) for _ in range(n)])
    assert ours.action_space == reference.action_space
    assert ours.observation_space == reference.observation_space
    ours.seed(7)
    reference.seed(7)
    np.testing.assert_array_equal(ours.reset(), reference.reset())
    assert_infos_equal(ours.reset_infos, reference.reset_infos, "reset")
    terminated = truncated = 0
    for t, actions in enumerate(policy_actions(n, 30)):
        obs, rewards, dones, infos = ours.step(actions)
        obs_r, rewards_r, dones_r, infos_r = reference.step(actions)
        np.testing.assert_array_equal(obs, obs_r, err_msg=f"observations, step {t}")
        np.testing.assert_array_equal(rewards, rewards_r, err_msg=f"rewards, step {t}")
        assert rewards.dtype == rewards_r.dtype
        np.testing.assert_array_equal(dones, dones_r, err_msg=f"dones, step {t}")
        assert_infos_equal(infos, infos_r, f"step {t}")  # terminal_observation, TimeLimit.truncated too
        assert_infos_equal(ours.reset_infos, reference.reset_infos, f"reset infos, step {t}")
        truncated += sum(info["TimeLimit.truncated"] for info in infos_r)
        terminated += sum(
            done and not info["TimeLimit.truncated"] for done, info in zip(dones_r, infos_r, strict=True)
        )
    assert terminated >= n // 4 and truncated >= n // 4  # both kinds of episode end were compared


def test_spaces_and_nan_check():
    env = VecCheckNan(
        UAVPenetrationSB3VecEnv("UAVPenetration-v0", 3, scenario=SCENARIO), raise_exception=True
    )
    assert env.observation_space.shape == (67,)
    assert env.action_space.shape == (3,)
    np.testing.assert_array_equal(env.action_space.low, -1.0)
    np.testing.assert_array_equal(env.action_space.high, 1.0)
    env.seed(0)
    obs = env.reset()
    assert obs.shape == (3, 67) and obs.dtype == np.float32
    for actions in policy_actions(3, 15):
        obs, rewards, dones, _ = env.step(actions)  # VecCheckNan raises on NaN/inf
        assert rewards.dtype == np.float32 and dones.dtype == bool


def test_extreme_actions_are_clipped_to_the_physical_box():
    env = UAVPenetrationSB3VecEnv("UAVPenetration-v0", 2, scenario=SCENARIO)
    high = env.physical_action_space.high
    np.testing.assert_allclose(
        env.to_physical(np.array([[5.0, -5.0, 1.0], [-1.0, 0.0, 0.0]])), [high * [1, -1, 1], [-high[0], 0, 0]]
    )


def test_seeding():
    env = UAVPenetrationSB3VecEnv("UAVPenetration-v0", 3, scenario=SCENARIO)
    assert list(env.seed(5)) == [5, 6, 7]  # sub-env i gets s + i
    first = env.reset()
    env.seed([5, 6, 7])
    np.testing.assert_array_equal(env.reset(), first)
    env.seed([7, 6, 5])
    np.testing.assert_array_equal(env.reset()[::-1], first)
    single = UAVPenetrationEnv(SCENARIO)
    np.testing.assert_array_equal(single.reset(seed=6)[0], first[1])
    assert not np.array_equal(env.reset(), first)  # seeds are used once, then the generators go on
    with pytest.raises(ValueError, match="got 2 seeds, expected 3"):
        env.seed([1, 2])


def test_attributes_and_methods():
    env = UAVPenetrationSB3VecEnv("UAVPenetration-v0", 3, scenario=SCENARIO)
    env.seed(0)
    env.reset()
    env.step(np.zeros((3, 3)))
    assert env.get_attr("render_mode") == [None, None, None]
    assert [s.name for s in env.get_attr("scenario", [0, 2])] == ["tiny", "tiny"]
    assert env.get_attr("step_index", 1) == [1]
    assert env.get_attr("state")[0].shape == (6,)
    assert env.env_is_wrapped(VecMonitor) == [False, False, False]
    assert env.has_attr("model") and not env.has_attr("no_such_attribute")
    env.set_attr("label", "x")
    assert env.get_attr("label") == ["x", "x", "x"]
    with pytest.raises(ValueError, match="share one batched env"):
        env.set_attr("label", "y", indices=[1])
    assert env.env_method("render") == [None, None, None]  # no render_mode: no frames
    with pytest.raises(ValueError, match="always uses SAME_STEP"):
        UAVPenetrationSB3VecEnv("UAVPenetration-v0", 2, scenario=SCENARIO, autoreset_mode="NEXT_STEP")


def test_wrappers_see_terminal_observations():
    env = VecNormalize(
        VecMonitor(UAVPenetrationSB3VecEnv("UAVPenetration-v0", 2, scenario=SCENARIO)), norm_reward=False
    )
    env.seed(0)
    env.reset()
    episodes = []
    for _ in range(13):
        _, _, dones, infos = env.step(np.array([[-1.0, 1.0, 0.0]] * 2))  # loiter until truncation
        episodes += [info for done, info in zip(dones, infos, strict=True) if done]
    assert len(episodes) == 2
    for info in episodes:
        assert info["TimeLimit.truncated"] and info["episode"]["l"] == 12
        assert info["terminal_observation"].shape == (67,)
        assert np.all(np.abs(info["terminal_observation"]) <= env.clip_obs)  # normalised by VecNormalize


@pytest.mark.slow
def test_random_id_adapter_steps_a_shared_pool():
    env = UAVPenetrationSB3VecEnv("UAVPenetrationRandom-v0", 2, difficulty=0.2, pool_size=2)
    env.seed(3)
    obs = env.reset()
    assert obs.shape == (2, 67)
    names = set()
    for _ in range(160):
        env.step(np.zeros((2, 3)))
        names.update(s.name for s in env.get_attr("scenario"))
    assert {"random-3", "random-4"} <= names
