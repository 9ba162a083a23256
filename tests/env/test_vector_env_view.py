"""The native vector env's read-only public view: per-env scenario, state and step, and its scenario source."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import tiny_scenario

from uav_penetration_env.vector_env import UAVPenetrationRandomVectorEnv, UAVPenetrationVectorEnv


def test_the_view_follows_the_env_and_cannot_change_it():
    env = UAVPenetrationVectorEnv(3, tiny_scenario())
    assert env.scenarios == (None, None, None)
    _, info = env.reset(seed=5)
    np.testing.assert_array_equal(env.states, info["state"])
    assert env.step_indices.tolist() == [0, 0, 0] and [s.name for s in env.scenarios] == ["tiny"] * 3
    states = env.states
    with pytest.raises(ValueError, match="read-only"):
        states[0, 0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        env.step_indices[1] = 7
    _, _, _, _, info = env.step(np.zeros((3, 3)))
    # A view, not a snapshot: it shows the state after the step.
    np.testing.assert_array_equal(states, info["state"])
    assert env.step_indices.tolist() == [1, 1, 1]
    assert env.describe_scenarios() == {
        "kind": "fixed",
        "name": "tiny",
        "hash": tiny_scenario().with_profile("benchmark").hash,
        "profile": "benchmark",
    }


def test_the_random_source_is_described_and_its_pool_seed_set_by_the_first_reset():
    env = UAVPenetrationRandomVectorEnv(2, difficulty=0.2, pool_size=4, id_profile="benchmark")
    assert env.describe_scenarios()["pool_seed"] is None
    env.reset(seed=11)
    assert env.describe_scenarios() == {
        "kind": "random",
        "difficulty": 0.2,
        "pool_size": 4,
        "pool_seed": 11,
        "profile": "benchmark",
    }
    assert [s.name for s in env.scenarios] == ["random-11", "random-12"]
