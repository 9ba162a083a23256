"""Gymnasium's own conventions on every id: the time limit in the spec, make_vec in every
mode and with max_episode_steps, vector seeding, exception types, and Gymnasium's common wrappers.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from conftest import tiny_scenario
from gymnasium.envs.registration import EnvSpec
from gymnasium.vector import AutoresetMode

from uav_penetration_env import ENV_IDS

CLIMB_THEN_LEVEL = [np.array([0.0, 0.0, np.radians(5)]), np.array([0.0, 0.0, -np.radians(5)])]


def fly_level(env, steps: int):
    """Climb ~260 m, level off, fly straight: survives the tiny scenario's first 11 steps."""
    env.reset(seed=0)
    records = []
    for k in range(steps):
        action = CLIMB_THEN_LEVEL[k] if k < 2 else np.zeros(3)
        _, _, terminated, truncated, info = env.step(action)
        records.append((terminated, truncated, int(info["step"])))
        if terminated or truncated:
            break
    return records


# --- the time limit in the spec -------------------------------------------------------------------


def test_the_registered_k_max_is_each_default_scenarios_own():
    from uav_penetration_env import REGISTERED_MAX_STEPS
    from uav_penetration_env.catalogue import resolve_scenario
    from uav_penetration_env.scenario import TimeConfig, load_bundled

    for name, k_max in REGISTERED_MAX_STEPS.items():
        if name is None:
            expected = TimeConfig().max_steps
        elif name == "paper-dynamic":  # the paper file with threats added in code (docs/dynamic.md §5)
            expected = resolve_scenario(name).time.max_steps
        else:
            expected = load_bundled(f"{name}.yaml").time.max_steps
        assert k_max == expected, name
    assert {kwargs.get("default_scenario") for *_, kwargs in ENV_IDS.values()} == set(REGISTERED_MAX_STEPS)


@pytest.mark.parametrize("env_id", list(ENV_IDS))
def test_the_spec_registers_k_max(env_id):
    assert gym.spec(env_id).max_episode_steps == 150  # time.max_steps of every catalogue scenario
    env = gym.make(env_id)
    assert env.spec.max_episode_steps == 150
    assert len(range(env.spec.max_episode_steps)) == 150


@pytest.mark.parametrize("env_id", list(ENV_IDS))
def test_the_spec_round_trips_through_json(env_id):
    spec = gym.spec(env_id)
    assert EnvSpec.from_json(spec.to_json()) == spec


def test_the_env_and_time_limit_truncate_once_at_the_same_step():
    scenario = tiny_scenario(time={"max_steps": 10})
    # Registered limit 150 > K_max = 10: the env truncates itself at 10, the TimeLimit never fires.
    records = fly_level(gym.make("UAVPenetration-v0", scenario=scenario), 40)
    assert records[-1] == (False, True, 10) and [r for r in records if r[1]] == [records[-1]]
    # A limit equal to K_max: both agree on step 10, one truncation.
    records = fly_level(gym.make("UAVPenetration-v0", scenario=scenario, max_episode_steps=10), 40)
    assert records[-1] == (False, True, 10) and len(records) == 10
    # A shorter limit: TimeLimit truncates at its own step.
    records = fly_level(gym.make("UAVPenetration-v0", scenario=scenario, max_episode_steps=4), 40)
    assert records[-1] == (False, True, 4) and len(records) == 4


def test_time_aware_observation_works_on_the_registered_ids():
    env = gym.wrappers.TimeAwareObservation(gym.make("UAVPenetration-v0", scenario=tiny_scenario()))
    observation, _ = env.reset(seed=0)
    assert observation.shape == (68,)
    observation, *_ = env.step(np.zeros(3))
    assert observation[-1] == 1  # one elapsed step


# --- make_vec --------------------------------------------------------------------------------------

MODES = ("sync", "async", "vector_entry_point")


def _make_vec(env_id, mode, autoreset, **kwargs):
    if mode == "vector_entry_point":
        return gym.make_vec(env_id, num_envs=3, vectorization_mode=mode, autoreset_mode=autoreset, **kwargs)
    return gym.make_vec(
        env_id, num_envs=3, vectorization_mode=mode, vector_kwargs={"autoreset_mode": autoreset}, **kwargs
    )


def _rollout(envs, steps: int, seed: int):
    rng = np.random.default_rng(seed)
    high = envs.single_action_space.high
    observation, _ = envs.reset(seed=seed)
    out = [observation]
    for _ in range(steps):
        # Small actions: long episodes, and the max_episode_steps limit does the resetting.
        actions = rng.uniform(-0.3, 0.3, size=(envs.num_envs, 3)) * high
        observation, reward, terminated, truncated, _ = envs.step(actions)
        out.append(np.concatenate([observation.ravel(), reward, terminated, truncated]))
    envs.close()
    return out


@pytest.mark.parametrize("autoreset", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_sync_async_and_native_agree_with_max_episode_steps(autoreset):
    kwargs = {"scenario": tiny_scenario(), "max_episode_steps": 5}
    runs = [_rollout(_make_vec("UAVPenetration-v0", mode, autoreset, **kwargs), 110, 7) for mode in MODES]
    for other in runs[1:]:
        assert len(other) == len(runs[0])
        for a, b in zip(runs[0], other, strict=True):
            np.testing.assert_array_equal(a, b)
    truncations = np.array([step[-3:] for step in runs[0][1:]])  # the last sub-env's flags
    assert truncations[:, 2].sum() >= 8  # the limit of 5 steps did truncate, many times


def test_the_native_vector_env_takes_the_registered_limit():
    envs = gym.make_vec("UAVPenetration-v0", num_envs=2, vectorization_mode="vector_entry_point")
    assert envs.unwrapped.max_episode_steps == 150
    envs = gym.make_vec(
        "UAVPenetration-v0", num_envs=2, vectorization_mode="vector_entry_point", max_episode_steps=5
    )
    assert envs.unwrapped.max_episode_steps == 5
    with pytest.raises(ValueError, match="max_episode_steps"):
        gym.make_vec(
            "UAVPenetration-v0", num_envs=2, vectorization_mode="vector_entry_point", max_episode_steps=0
        )


def test_random_id_per_env_pools_equal_sync_mode():
    kwargs = {"pool_size": 2, "max_episode_steps": 3}
    sync = gym.make_vec("UAVPenetrationRandom-v0", num_envs=2, vectorization_mode="sync", **kwargs)
    native = gym.make_vec(
        "UAVPenetrationRandom-v0",
        num_envs=2,
        vectorization_mode="vector_entry_point",
        pool="per_env",
        **kwargs,
    )
    for a, b in zip(_rollout(sync, 30, 11), _rollout(native, 30, 11), strict=True):
        np.testing.assert_array_equal(a, b)


def test_random_id_shared_pool_is_documented_and_refuses_unknown_modes():
    from uav_penetration_env import vector_env

    assert 'pool="per_env"' in vector_env.__doc__ and "sync mode" in vector_env.__doc__
    with pytest.raises(ValueError, match="pool"):
        gym.make_vec(
            "UAVPenetrationRandom-v0", num_envs=2, vectorization_mode="vector_entry_point", pool="each"
        )


# --- seeding and exception types --------------------------------------------------------------------


def test_np_random_seed_as_sync_mode():
    sync = gym.make_vec("UAVPenetration-v0", num_envs=3, vectorization_mode="sync", scenario=tiny_scenario())
    native = gym.make_vec(
        "UAVPenetration-v0", num_envs=3, vectorization_mode="vector_entry_point", scenario=tiny_scenario()
    )
    for envs in (sync, native):
        envs.reset(seed=42)
        assert envs.np_random_seed == (42, 43, 44)
        envs.reset()  # a seedless reset keeps the sub-envs' generators, hence their seeds
        assert envs.np_random_seed == (42, 43, 44)
    fresh = gym.make_vec("UAVPenetration-v0", num_envs=2, vectorization_mode="vector_entry_point")
    fresh.reset()
    assert all(isinstance(s, int) and s >= 0 for s in fresh.np_random_seed)


@pytest.mark.parametrize(
    ("mask", "error"),
    [([True, False, True], TypeError), (np.array([1, 0, 1]), TypeError), (np.array([True]), ValueError)],
)
def test_reset_mask_errors_have_sync_modes_types(mask, error):
    for mode in ("sync", "vector_entry_point"):
        envs = gym.make_vec(
            "UAVPenetration-v0", num_envs=3, vectorization_mode=mode, scenario=tiny_scenario()
        )
        envs.reset(seed=0)
        with pytest.raises(error):
            envs.reset(options={"reset_mask": mask})


def test_a_scalar_action_is_a_type_error_as_in_sync_mode():
    for mode in ("sync", "vector_entry_point"):
        envs = gym.make_vec(
            "UAVPenetration-v0", num_envs=2, vectorization_mode=mode, scenario=tiny_scenario()
        )
        envs.reset(seed=0)
        with pytest.raises(TypeError):
            envs.step(0.0)


# --- Gymnasium's common wrappers --------------------------------------------------------------------


def _make(env_id):
    return gym.make(env_id, **({"pool_size": 2} if "Random" in env_id else {"scenario": tiny_scenario()}))


@pytest.mark.parametrize("env_id", list(ENV_IDS))
@pytest.mark.parametrize(
    "wrap",
    [
        lambda e: gym.wrappers.TimeAwareObservation(e),
        lambda e: gym.wrappers.RecordEpisodeStatistics(e),
        lambda e: gym.wrappers.NormalizeObservation(e),
        lambda e: gym.wrappers.NormalizeReward(e),
        lambda e: gym.wrappers.ClipAction(e),
        lambda e: gym.wrappers.RescaleAction(e, np.full(3, -1, np.float32), np.full(3, 1, np.float32)),
        lambda e: gym.wrappers.FlattenObservation(e),
    ],
    ids=[
        "TimeAware",
        "RecordEpisodeStatistics",
        "NormalizeObservation",
        "NormalizeReward",
        "ClipAction",
        "RescaleAction",
        "Flatten",
    ],
)
def test_common_wrappers(env_id, wrap):
    env = wrap(_make(env_id))
    observation, _ = env.reset(seed=0)
    assert env.observation_space.contains(observation.astype(env.observation_space.dtype))
    ended = 0
    for _ in range(12):
        observation, reward, terminated, truncated, info = env.step(env.action_space.sample() * 0.1)
        assert np.isfinite(reward) and np.all(np.isfinite(observation))
        if terminated or truncated:
            ended += 1
            if isinstance(env, gym.wrappers.RecordEpisodeStatistics):
                assert "episode" in info and info["episode"]["l"] >= 1
            env.reset()
    env.close()


def test_record_episode_statistics_counts_the_same_episodes_in_sync_and_native():
    counts = []
    for mode in ("sync", "vector_entry_point"):
        envs = gym.wrappers.vector.RecordEpisodeStatistics(
            gym.make_vec(
                "UAVPenetration-v0",
                num_envs=2,
                vectorization_mode=mode,
                scenario=tiny_scenario(),
                max_episode_steps=4,
            )
        )
        envs.reset(seed=3)
        rng = np.random.default_rng(3)
        for _ in range(40):
            envs.step(rng.uniform(-0.2, 0.2, (2, 3)) * envs.single_action_space.high)
        counts.append(envs.episode_count)
        envs.close()
    assert counts[0] == counts[1] >= 16
