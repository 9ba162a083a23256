"""The native vector env equals N single envs (Gymnasium's SyncVectorEnv) step by step."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from conftest import tiny_scenario
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import uav_penetration_env  # noqa: F401  (registers the ids)
from uav_penetration_env.env import UAVPenetrationEnv, UAVPenetrationRandomEnv
from uav_penetration_env.vector_env import UAVPenetrationRandomVectorEnv, UAVPenetrationVectorEnv

# Every info entry (api.md): the native env fills the rows it autoresets itself (NEXT_STEP), so each
# entry of those rows is compared, not only the ones a learner reads.
COMPARED_INFO = (
    "J",
    "penalty",
    "terrain_threat",
    "radar_threat",
    "third_term",
    "fuel_kg",
    "progress",
    "terrain_threat_n",
    "radar_threat_n",
    "third_term_n",
    "radar_threat_per_radar",
    "detection_prob",
    "detected",
    "position",
    "altitude_agl",
    "distance_to_goal",
    "reached_goal",
    "collided",
    "out_of_area",
    "step",
    "state",
)


def action_schedule(num_envs, steps, seed=0):
    """Per-env behaviours that end episodes at different times: dive (crash), loiter, wander, cruise."""
    rng = np.random.default_rng(seed)
    actions = rng.uniform(-1, 1, size=(steps, num_envs, 3)) * [2.0, 0.26, 0.26]
    actions[:, 0::4] = [0.0, 0.0, -0.26]  # dive into the terrain: short episodes
    actions[:, 1::4] = [-2.0, 0.26, 0.0]  # loiter in circles: truncation at max_steps
    actions[:, 3::4] = [0.0, 0.0, 0.0]  # cruise straight toward the goal
    return actions


def assert_same(native, reference, mode, steps_checked):
    assert ("final_obs" in native[4]) == ("final_obs" in reference[4])
    np.testing.assert_array_equal(native[0], reference[0])  # observations
    np.testing.assert_array_equal(native[1], reference[1])  # rewards
    np.testing.assert_array_equal(native[2], reference[2])  # terminated
    np.testing.assert_array_equal(native[3], reference[3])  # truncated
    info_native, info_ref = native[4], reference[4]
    for key in COMPARED_INFO:
        np.testing.assert_array_equal(
            info_native[key], info_ref[key], err_msg=f"info[{key!r}] ({mode}, step {steps_checked})"
        )
        np.testing.assert_array_equal(info_native[f"_{key}"], info_ref[f"_{key}"])
    if mode == AutoresetMode.SAME_STEP and "final_obs" in info_ref:
        np.testing.assert_array_equal(info_native["_final_obs"], info_ref["_final_obs"])
        for i in np.flatnonzero(info_ref["_final_obs"]):
            np.testing.assert_array_equal(info_native["final_obs"][i], info_ref["final_obs"][i])
        for key in COMPARED_INFO:
            finished = info_ref["final_info"][f"_{key}"]
            np.testing.assert_array_equal(info_native["final_info"][f"_{key}"], finished)
            np.testing.assert_array_equal(
                info_native["final_info"][key][finished], info_ref["final_info"][key][finished]
            )


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_vector_env_equals_single_envs(mode):
    scenario = tiny_scenario(time={"max_steps": 12}, start={"jitter": {"xy_km": 1.0, "heading_deg": 5.0}})
    n = 8
    native = UAVPenetrationVectorEnv(n, scenario=scenario, autoreset_mode=mode)
    reference = SyncVectorEnv([lambda: UAVPenetrationEnv(scenario) for _ in range(n)], autoreset_mode=mode)
    obs_n, info_n = native.reset(seed=11)
    obs_r, info_r = reference.reset(seed=11)
    np.testing.assert_array_equal(obs_n, obs_r)
    for key in COMPARED_INFO:
        np.testing.assert_array_equal(info_n[key], info_r[key])
    finished = 0
    for t, actions in enumerate(action_schedule(n, 30)):
        out_n = native.step(actions)
        out_r = reference.step(actions)
        assert_same(out_n, out_r, mode, t)
        finished += int(np.sum(out_r[2] | out_r[3]))
    assert finished >= n  # every sub-env finished at least once: autoresets were exercised


def test_random_vector_env_shares_one_pool_and_equals_single_envs():
    n, pool_seed = 3, 21
    kwargs = {"difficulty": 0.0, "pool_size": 2}
    native = UAVPenetrationRandomVectorEnv(
        n, pool_seed=pool_seed, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs
    )
    reference = SyncVectorEnv(
        [lambda: UAVPenetrationRandomEnv(pool_seed=pool_seed, **kwargs) for _ in range(n)],
        autoreset_mode=AutoresetMode.SAME_STEP,
    )
    np.testing.assert_array_equal(native.reset(seed=pool_seed)[0], reference.reset(seed=pool_seed)[0])
    assert native.model.radar_slots == 8
    actions = np.tile([0.0, 0.0, -0.26], (n, 1))  # dive: every episode ends within a few steps
    resets = 0
    for t in range(12):
        out_n, out_r = native.step(actions), reference.step(actions)
        assert_same(out_n, out_r, AutoresetMode.SAME_STEP, t)
        resets += int(np.sum(out_r[2] | out_r[3]))
    assert resets >= 2 * n
    pool = set(native.source.pool_seeds())
    assert {s.name for s in native._scenarios} <= {f"random-{p}" for p in pool}


def test_make_vec_uses_the_native_vector_env():
    envs = gym.make_vec(
        "UAVPenetration-v0", num_envs=4, vectorization_mode="vector_entry_point", scenario=tiny_scenario()
    )
    assert isinstance(envs.unwrapped, UAVPenetrationVectorEnv)
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    obs, _ = envs.reset(seed=0)
    assert obs.shape == (4, 67) and obs.dtype == np.float32
    obs, rewards, *_ = envs.step(envs.action_space.sample())
    assert rewards.shape == (4,)
    same = gym.make_vec(
        "UAVPenetration-v0",
        num_envs=2,
        vectorization_mode="vector_entry_point",
        scenario=tiny_scenario(),
        autoreset_mode="SAME_STEP",
    )
    assert same.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP


def test_seed_list_matches_single_envs_with_those_seeds():
    scenario = tiny_scenario(start={"jitter": {"xy_km": 2.0, "heading_deg": 0.0}})
    envs = UAVPenetrationVectorEnv(3, scenario=scenario)
    obs, info = envs.reset(seed=[7, 3, 9])
    for i, seed in enumerate([7, 3, 9]):
        single_obs, single_info = UAVPenetrationEnv(scenario).reset(seed=seed)
        np.testing.assert_array_equal(obs[i], single_obs)
        np.testing.assert_array_equal(info["state"][i], single_info["state"])
    with pytest.raises(ValueError, match="seed"):
        envs.reset(seed=[1, 2])


def test_bad_actions_are_rejected():
    envs = UAVPenetrationVectorEnv(2, scenario=tiny_scenario())
    envs.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        envs.step(np.array([[0, 0, 0], [np.nan, 0, 0]]))
    with pytest.raises(ValueError, match="shape"):
        envs.step(np.zeros((3, 3)))


def test_disabled_autoreset_requires_a_masked_reset():
    envs = UAVPenetrationVectorEnv(2, scenario=tiny_scenario(), autoreset_mode=AutoresetMode.DISABLED)
    envs.reset(seed=0)
    dive = np.array([[0.0, 0.0, -0.26], [0.0, 0.0, 0.0]])
    for _ in range(10):
        _, _, terminated, truncated, _ = envs.step(dive)
        if terminated[0] or truncated[0]:
            break
    assert terminated[0]
    with pytest.raises(RuntimeError, match="reset_mask"):
        envs.step(dive)
    steps_before = envs._steps[1]
    _obs, info = envs.reset(options={"reset_mask": np.array([True, False])})
    assert info["_state"].tolist() == [True, False]
    assert envs._steps[0] == 0 and envs._steps[1] == steps_before
    envs.step(dive)


def test_rgb_array_render_gives_one_frame_per_env():
    envs = UAVPenetrationVectorEnv(2, scenario=tiny_scenario(), render_mode="rgb_array")
    envs.reset(seed=0)
    envs.step(np.zeros((2, 3)))
    frames = envs.render()
    assert len(frames) == 2 and frames[0].shape[2] == 3 and frames[0].shape[0] >= 400
