"""TrainConfig, the one description of a training run, and the default model path (no torch needed)."""

from __future__ import annotations

import dataclasses
import inspect
from pathlib import Path

import pytest
from conftest import tiny_scenario

from baselines import train
from baselines.plan import TrainConfig, default_model_path


def test_unknown_fields_are_refused_with_a_suggestion():
    with pytest.raises(TypeError, match="unknown argument 'n_env' — did you mean 'n_envs'"):
        TrainConfig.of(algo="ppo", n_env=2)
    assert TrainConfig.of(algo="sac", seed=3) == TrainConfig(algo="sac", seed=3)


def test_train_agent_has_no_second_copy_of_the_settings():
    # train_agent takes TrainConfig's fields; its own signature lists none of them.
    parameters = inspect.signature(train.train_agent).parameters
    assert list(parameters) == ["algo", "fields"]
    assert {f.name for f in dataclasses.fields(TrainConfig)} >= {"env_id", "total_timesteps", "n_envs", "out"}


def test_default_model_path_names_the_scenario_as_given():
    assert default_model_path("PPO", "UAVPenetration-v0", None, 0) == Path(
        "results/models/ppo-paper-s0.zip"
    )
    assert default_model_path("sac", "UAVPenetrationRandom-v0", None, 2).name == "sac-random-s2.zip"
    assert default_model_path("ppo", "UAVPenetration-v0", "random:7", 1).name == "ppo-random-7-s1.zip"
    assert default_model_path("ppo", "UAVPenetration-v0", "maps/my map.yaml", 0).name == "ppo-my-map-s0.zip"
    assert default_model_path("ppo", "UAVPenetration-v0", tiny_scenario(), 0).name == "ppo-tiny-s0.zip"
