"""Long training survives interruption: checkpoints, `resume=True` / `uav-bench train --resume`."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from conftest import RL_EXTRA

pytest.importorskip("stable_baselines3", reason=RL_EXTRA)

from sb3_helpers import baselines_plugins, tiny_run  # noqa: F401 (a fixture)

import baselines.run
from baselines import train_agent
from baselines.artifacts import ModelFiles
from baselines.resume import read_resume_state
from baselines.run import EVALUATION_COLUMNS
from uav_penetration_env.benchmark.cli import main

# Rollouts of 64 steps x 2 envs = 128 steps: evaluations and checkpoints at every rollout start.
RUN = {"total_timesteps": 512, "eval_freq": 128, "checkpoint_freq": 128}


def without_wall(row):
    return {k: v for k, v in row.items() if k != "wall_seconds"}


def read_curve(path):
    with path.open() as handle:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(handle)]


def interrupt_at_evaluation(monkeypatch, number):
    """Ctrl-C during the ``number``-th evaluation (1-based)."""
    real, calls = baselines.run.evaluate_agent, []

    def evaluate(*args, **kwargs):
        calls.append(1)
        if len(calls) == number:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(baselines.run, "evaluate_agent", evaluate)
    return lambda: monkeypatch.setattr(baselines.run, "evaluate_agent", real)


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    return train_agent("ppo", out=tmp_path_factory.mktemp("whole") / "ppo.zip", **tiny_run(**RUN))


def test_an_interrupted_run_resumes_and_its_curve_runs_on_to_the_end(uninterrupted, tmp_path, monkeypatch):
    out = tmp_path / "ppo.zip"
    restore = interrupt_at_evaluation(monkeypatch, 3)  # evaluations at 128, 256, then Ctrl-C at 384
    with pytest.raises(KeyboardInterrupt):
        train_agent("ppo", out=out, **tiny_run(**RUN))
    restore()
    files = ModelFiles.of(out)
    state = read_resume_state(files)
    assert state.timesteps == 256 and not state.finished  # the checkpoint before the cut
    assert [row["timesteps"] for row in state.evaluations] == [128, 256]

    resumed = train_agent("ppo", out=out, resume=True, **tiny_run(**RUN))
    rows = resumed.evaluations
    assert [int(r["timesteps"]) for r in rows] == [128, 256, 384, 512]
    # Up to the checkpoint the curve is the uninterrupted run's, exactly; after it, a continuation
    # (fresh sub-env episodes and generator states: not bit-identical to the uninterrupted run).
    assert [without_wall(r) for r in rows[:2]] == [without_wall(r) for r in uninterrupted.evaluations[:2]]
    walls = [r["wall_seconds"] for r in rows]
    assert walls == sorted(walls)
    written = read_curve(files.evaluations)
    assert len(written) == 4 and all(w == pytest.approx(r) for w, r in zip(written, rows, strict=True))
    assert list(read_curve(files.evaluations)[0]) == list(EVALUATION_COLUMNS)

    sidecar = json.loads(files.sidecar.read_text())
    assert sidecar["timesteps_done"] == 512 and sidecar["total_timesteps"] == 512
    assert sidecar["interrupted"] is False and sidecar["resumed_at_timesteps"] == [256]
    assert sidecar["wall_seconds"] >= state.wall_seconds
    model = resumed.model
    assert model.num_timesteps == 512 and model._total_timesteps == 512  # one schedule, 0 -> 512
    assert model._n_updates == uninterrupted.model._n_updates == 4 * 2  # 4 rollouts x 2 epochs
    final = read_resume_state(files)
    assert final.finished and final.timesteps == 512 and final.segments == [0, 256]


def test_resuming_a_finished_run_trains_nothing_and_a_larger_total_extends_it(uninterrupted, tmp_path):
    out = tmp_path / "ppo.zip"
    first = train_agent("ppo", out=out, **tiny_run(total_timesteps=256, eval_freq=128, checkpoint_freq=128))
    again = train_agent(
        "ppo", out=out, resume=True, **tiny_run(total_timesteps=256, eval_freq=128, checkpoint_freq=128)
    )
    assert again.model is None and again.sidecar == first.sidecar
    assert [r["timesteps"] for r in again.evaluations] == [128, 256]

    longer = train_agent("ppo", out=out, resume=True, **tiny_run(**RUN))
    assert [int(r["timesteps"]) for r in longer.evaluations] == [128, 256, 384, 512]
    assert longer.sidecar["timesteps_done"] == 512 and longer.sidecar["resumed_at_timesteps"] == [256]


def test_resume_refuses_another_configuration_and_fewer_steps(tmp_path):
    out = tmp_path / "ppo.zip"
    train_agent("ppo", out=out, **tiny_run(total_timesteps=256, eval_freq=128, checkpoint_freq=128))
    with pytest.raises(ValueError, match="trained with other seed"):
        train_agent("ppo", out=out, resume=True, **tiny_run(seed=1, **RUN))
    with pytest.raises(ValueError, match="trained with other hyperparams"):
        train_agent(
            "ppo",
            out=out,
            resume=True,
            **tiny_run(hyperparams={"n_steps": 64, "batch_size": 64, "n_epochs": 3}, **RUN),
        )
    with pytest.raises(
        ValueError, match=r"total_timesteps: got 128, but the checkpoint .* already holds 256 steps"
    ):
        train_agent(
            "ppo", out=out, resume=True, **tiny_run(total_timesteps=128, eval_freq=128, checkpoint_freq=128)
        )


def test_a_fresh_run_forgets_an_older_checkpoint(tmp_path):
    out = tmp_path / "ppo.zip"
    train_agent("ppo", out=out, **tiny_run(total_timesteps=256, eval_freq=128, checkpoint_freq=128))
    assert read_resume_state(ModelFiles.of(out)).timesteps == 256
    train_agent("ppo", out=out, **tiny_run(total_timesteps=128, eval_freq=128, checkpoint_freq=0))
    assert read_resume_state(ModelFiles.of(out)) is None
    # Without a checkpoint, resume=True trains from scratch.
    fresh = train_agent(
        "ppo", out=out, resume=True, **tiny_run(total_timesteps=128, eval_freq=128, checkpoint_freq=0)
    )
    assert fresh.sidecar["resumed_at_timesteps"] == []


def test_an_off_policy_run_resumes_with_its_replay_buffer(tmp_path):
    out = tmp_path / "sac.zip"
    small = {
        "learning_starts": 64,
        "batch_size": 32,
        "gradient_steps": 1,
        "policy_kwargs": {"net_arch": [16]},
    }
    run = {"hyperparams": small, "eval_freq": 0, "checkpoint_freq": 128}
    first = train_agent("sac", out=out, **tiny_run(total_timesteps=256, **run))
    files = ModelFiles.of(out)
    state = read_resume_state(files)
    assert state.replay_buffer.name == "sac-256steps.replay.npz"
    assert [p.name for p in files.checkpoints.glob("*.replay.npz")] == [
        state.replay_buffer.name
    ]  # newest only
    saved = first.model.replay_buffer
    assert saved.pos == 256 // 2

    resumed = train_agent("sac", out=out, resume=True, **tiny_run(total_timesteps=384, **run))
    buffer = resumed.model.replay_buffer
    assert resumed.model.num_timesteps == 384 and buffer.pos == 384 // 2
    # The first 128 rows of the buffer are the first run's transitions, restored exactly.
    for name in ("observations", "next_observations", "actions", "rewards", "dones"):
        np.testing.assert_array_equal(getattr(buffer, name)[:128], getattr(saved, name)[:128])
    assert [p.name for p in files.checkpoints.glob("*.replay.npz")] == ["sac-384steps.replay.npz"]


def test_cli_train_resume(tmp_path, capsys, baselines_plugins):  # noqa: F811
    from conftest import tiny_scenario

    tiny_scenario().to_yaml(tmp_path / "tiny.yaml")
    (tmp_path / "hp.yaml").write_text("n_steps: 64\nbatch_size: 64\nn_epochs: 2\n")
    out = tmp_path / "cli.zip"
    argv = ["train", "--scenario", str(tmp_path / "tiny.yaml"), "--n-envs", "2", "--out", str(out),
            "--eval-freq", "128", "--eval-episodes", "2", "--checkpoint-freq", "128",
            "--hyperparams", str(tmp_path / "hp.yaml"), "--no-progress", "--resume"]  # fmt: skip
    assert main([*argv, "--timesteps", "128"]) == 0
    assert "no checkpoint to resume" in capsys.readouterr().out
    assert main([*argv, "--timesteps", "256"]) == 0
    assert "resuming from the checkpoint at 128 steps" in capsys.readouterr().out
    assert main([*argv, "--timesteps", "256"]) == 0
    assert "already trained (256 steps); nothing to do" in capsys.readouterr().out
    assert main([*argv, "--timesteps", "256", "--seed", "3"]) == 2
    assert "trained with other seed" in capsys.readouterr().err
