"""Shared by the SB3 test modules: one tiny PPO model, trained once per session (few hundred steps)."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import tiny_scenario

# Short rollouts and few epochs: the smoke tests check plumbing, not learning.
TINY_PPO = {"n_steps": 64, "batch_size": 64, "n_epochs": 2}
TINY_RUN = {
    "scenario": None,  # filled with tiny_scenario() at call time
    "total_timesteps": 256,
    "seed": 0,
    "n_envs": 2,
    "hyperparams": TINY_PPO,
    "eval_freq": 128,
    "eval_episodes": 2,
    "checkpoint_freq": 128,
}
_TRAINED: dict[str, object] = {}


def tiny_run(**changes: object) -> dict[str, object]:
    """Keywords of train_agent for a tiny PPO run, with ``changes``."""
    return {**TINY_RUN, "scenario": tiny_scenario(), **changes}


def trained_tiny_ppo(root: Path):
    """The session's tiny PPO model (a TrainResult), trained on first use under ``root``."""
    from baselines import train_agent

    if "ppo" not in _TRAINED:
        _TRAINED["ppo"] = train_agent("ppo", out=root / "ppo-tiny-s0.zip", **tiny_run())
    return _TRAINED["ppo"]


@pytest.fixture
def baselines_plugins(monkeypatch):
    """The harness finds baselines' plug-ins as an installed checkout does, whatever metadata is installed.

    The entry points themselves are checked against pyproject.toml in test_plugin.py; here discovery
    answers from :mod:`baselines.plugin`, so CLI tests do not depend on when ``pip install -e .``
    last ran.
    """
    from baselines import plugin
    from uav_penetration_env.benchmark import plugins

    found = {
        plugins.POLICY_GROUP: {
            "sb3": plugins.Plugin("sb3", plugin.SB3_POLICY_KIND),
            "distill": plugins.Plugin("distill", plugin.DISTILL_POLICY_KIND),
        },
        plugins.COMMAND_GROUP: {
            "train": plugins.Plugin("train", plugin.TRAIN_COMMAND),
            "distill": plugins.Plugin("distill", plugin.DISTILL_COMMAND),
            "tune": plugins.Plugin("tune", plugin.TUNE_COMMAND),
            "plot.models": plugins.Plugin("plot.models", plugin.LEARNING_CURVES),
        },
    }
    monkeypatch.setattr(plugins, "discover", lambda group: found[group])
