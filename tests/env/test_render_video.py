"""Every id renders frames for Gymnasium's video tools: RenderCollection always, RecordVideo with moviepy (extra video)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from conftest import tiny_scenario
from gymnasium.wrappers import RecordVideo, RenderCollection

import uav_penetration_env
from uav_penetration_env.benchmark import GreedyPolicy

ENV_IDS = list(uav_penetration_env.ENV_IDS)
STEPS = 3


def make(env_id):
    kwargs = {"difficulty": 0.0, "pool_size": 2} if "Random" in env_id else {"scenario": tiny_scenario()}
    return gym.make(env_id, render_mode="rgb_array", **kwargs)


def fly(env, steps=STEPS):
    policy = GreedyPolicy()
    observation, info = env.reset(seed=0)
    policy.reset(env.unwrapped.model, seed=0)
    for _ in range(steps):
        observation, _, terminated, truncated, info = env.step(policy.act(observation, info))
        if terminated or truncated:
            break


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_every_id_gives_rgb_frames_to_the_frame_capture_wrapper(env_id):
    env = RenderCollection(make(env_id), pop_frames=False, reset_clean=True)
    fly(env)
    frames = env.render()
    env.close()
    assert len(frames) == STEPS + 1  # the reset frame and one per step
    for frame in frames:
        assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert not np.array_equal(frames[0], frames[-1])  # the track grew


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_record_video_records_a_short_episode(env_id, tmp_path):
    pytest.importorskip("moviepy", reason="RecordVideo needs moviepy: pip install -e '.[video]'")
    env = RecordVideo(
        make(env_id),
        video_folder=str(tmp_path / "videos"),
        episode_trigger=lambda episode: True,
        disable_logger=True,
    )
    fly(env)
    env.close()  # closing ends the recording of the unfinished episode
    videos = sorted((tmp_path / "videos").glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000
