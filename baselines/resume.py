"""Resuming an interrupted training run from its last checkpoint (docs/rl.md §2).

Every checkpoint of :func:`baselines.run.run_training` (every ``checkpoint_freq`` steps, and at
the end) writes, in ``NAME.checkpoints/``: the model ``NAME-Nsteps.zip`` with its sidecars (its
observation statistics included), for SAC and TD3 the replay buffer ``NAME-Nsteps.replay.npz``,
and last, atomically, ``resume.json``: the step count, those files' names, the learning curve so
far, the wall time, and the run's :func:`resume_key`. ``resume.json`` is the commit point: until it
is rewritten the previous checkpoint stays the one a resume starts from, so a run killed while
writing a checkpoint resumes from the one before. Only the newest replay buffer is kept.

No torch at import time.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from baselines.artifacts import ModelFiles
from uav_penetration_env.atomic import atomic_path, write_text_atomic

RESUME_FORMAT = 1
RESUME_FILE = "resume.json"
# Replay-buffer arrays saved (the filled part only); SB3's own pickle writes the whole preallocated
# buffer, 300 000 transitions of a 67-slot observation are ~170 MB even when a tenth is filled.
REPLAY_ARRAYS = ("observations", "next_observations", "actions", "rewards", "dones", "timeouts")


def _plain(value: Any) -> Any:
    from uav_penetration_env.scenario import Scenario

    if isinstance(value, Scenario):
        return value.to_dict()
    return value


def resume_key(plan: Any) -> dict[str, Any]:
    """What a resumed run must share with the one it continues (JSON-able).

    Algorithm, env id and keywords (the scenario in full), seed, sub-envs, hyper-parameters (less
    their provenance text) and the evaluation schedule and seeds (the learning curve must stay one
    curve). Not the total steps (a resume may extend a run), checkpoint frequency, threads,
    verbosity or progress bar.
    """
    hyperparams = {k: v for k, v in plan.hyperparams.items() if k != "provenance"}
    key = {
        "algo": plan.algo,
        "env_id": plan.env_id,
        "env_kwargs": {k: _plain(v) for k, v in plan.env_kwargs.items()},
        "seed": plan.seed,
        "n_envs": plan.n_envs,
        "hyperparams": hyperparams,
        "eval_freq": plan.eval_freq,
        "eval_seeds": list(plan.eval_seeds),
    }
    formulation = getattr(plan, "formulation", None)
    if formulation is not None and not formulation.is_default:
        # Only a new formulation enters the key, so the checkpoints of earlier runs still resume.
        key["formulation"] = formulation.to_json()
    warm = getattr(plan, "warm_start", None)
    if warm is not None:
        key["warm_start"] = warm.to_json()
    return json.loads(json.dumps(key, default=str))


@dataclass(frozen=True)
class ResumeState:
    """A checkpoint a run can continue from (``NAME.checkpoints/resume.json``).

    Attributes:
        folder: the checkpoints folder.
        timesteps: environment steps done at the checkpoint.
        model: the checkpoint's model ``.zip`` (its sidecars beside it).
        replay_buffer: the replay buffer file (``None``: on-policy).
        evaluations: the learning-curve rows up to the checkpoint.
        wall_seconds: training wall time up to the checkpoint (evaluations included).
        eval_seconds: of which evaluating.
        finished: whether the run had reached its total steps.
        key: :func:`resume_key` of the run.
        segments: the step counts at which earlier runs of this model started (0 first).
    """

    folder: Path
    timesteps: int
    model: Path
    replay_buffer: Path | None
    evaluations: list[dict[str, float]]
    wall_seconds: float
    eval_seconds: float
    finished: bool
    key: dict[str, Any]
    segments: list[int]

    @property
    def files(self) -> ModelFiles:
        """The checkpoint model's files."""
        return ModelFiles.of(self.model)


def read_resume_state(files: ModelFiles) -> ResumeState | None:
    """The last checkpoint of the run writing ``files`` (``None``: no checkpoint to resume from).

    Raises:
        ValueError: a ``resume.json`` that is not valid, or names files that are missing.
    """
    path = files.checkpoints / RESUME_FILE
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
        if data["format"] != RESUME_FORMAT:
            raise ValueError(f"format {data['format']!r}, expected {RESUME_FORMAT}")
        state = ResumeState(
            folder=files.checkpoints,
            timesteps=int(data["timesteps"]),
            model=files.checkpoints / data["model"],
            replay_buffer=files.checkpoints / data["replay_buffer"] if data["replay_buffer"] else None,
            evaluations=list(data["evaluations"]),
            wall_seconds=float(data["wall_seconds"]),
            eval_seconds=float(data["eval_seconds"]),
            finished=bool(data["finished"]),
            key=dict(data["key"]),
            segments=[int(s) for s in data.get("segments", [0])],
        )
    except (json.JSONDecodeError, UnicodeDecodeError, KeyError, TypeError, ValueError) as error:
        raise ValueError(
            f"{path}: not a valid resume state ({error}); delete it to train from scratch"
        ) from None
    missing = [
        p
        for p in (state.model, state.files.sidecar, state.replay_buffer)
        if p is not None and not p.is_file()
    ]
    if missing:
        raise ValueError(f"{path}: names {missing[0]}, which is missing; delete {path} to train from scratch")
    return state


def check_resumable(state: ResumeState, key: Mapping[str, Any], total_timesteps: int) -> None:
    """Refuse to continue a checkpoint of another configuration, or to train fewer steps than it holds.

    Raises:
        ValueError: naming the first setting that differs (or the total).
    """
    for name in key:
        if state.key.get(name) != key[name]:
            raise ValueError(
                f"resume: the checkpoint in {state.folder} was trained with other {name} "
                f"({_short(state.key.get(name))} against {_short(key[name])}); train to another --out, "
                "or delete the checkpoints folder to start again"
            )
    if total_timesteps < state.timesteps:
        raise ValueError(
            f"total_timesteps: got {total_timesteps}, but the checkpoint in {state.folder} already holds "
            f"{state.timesteps} steps"
        )


def _short(value: Any) -> str:
    text = json.dumps(value, default=str, sort_keys=True)
    return text if len(text) <= 120 else text[:117] + "..."


def save_replay_buffer(model: Any, path: Path) -> None:
    """Write the filled part of an off-policy model's replay buffer (``.npz``, atomically)."""
    buffer = model.replay_buffer
    filled = buffer.buffer_size if buffer.full else buffer.pos
    arrays = {
        name: getattr(buffer, name)[:filled]
        for name in REPLAY_ARRAYS
        if getattr(buffer, name, None) is not None
    }
    with atomic_path(path) as temporary, temporary.open("wb") as handle:
        np.savez(handle, pos=buffer.pos, full=buffer.full, **arrays)


def load_replay_buffer(model: Any, path: Path) -> int:
    """Refill an off-policy model's (fresh) replay buffer from :func:`save_replay_buffer`'s file.

    Returns:
        The transitions restored per sub-env (rows of the buffer).

    Raises:
        ValueError: a file whose arrays do not fit the model's buffer.
    """
    buffer = model.replay_buffer
    with np.load(path) as data:
        for name in REPLAY_ARRAYS:
            if name not in data.files:
                continue
            target, saved = getattr(buffer, name), data[name]
            if target is None or saved.shape[1:] != target.shape[1:] or len(saved) > len(target):
                raise ValueError(
                    f"{path}: replay buffer array {name} of shape {saved.shape} does not fit {target.shape}"
                )
            target[: len(saved)] = saved
        buffer.pos = int(data["pos"])
        buffer.full = bool(data["full"])
        return len(data["actions"])


def write_resume_state(
    files: ModelFiles,
    checkpoint: ModelFiles,
    replay_buffer: Path | None,
    *,
    timesteps: int,
    evaluations: list[dict[str, float]],
    wall_seconds: float,
    eval_seconds: float,
    finished: bool,
    key: Mapping[str, Any],
    segments: list[int],
) -> None:
    """Commit ``checkpoint`` as the one to resume from; then delete older replay buffers."""
    data = {
        "format": RESUME_FORMAT,
        "timesteps": int(timesteps),
        "model": checkpoint.model.name,
        "replay_buffer": replay_buffer.name if replay_buffer is not None else None,
        "evaluations": evaluations,
        "wall_seconds": wall_seconds,
        "eval_seconds": eval_seconds,
        "finished": finished,
        "segments": segments,
        "key": dict(key),
    }
    write_text_atomic(files.checkpoints / RESUME_FILE, json.dumps(data, indent=1, default=str) + "\n")
    for old in files.checkpoints.glob("*.replay.npz"):
        if replay_buffer is None or old.name != replay_buffer.name:
            old.unlink(missing_ok=True)


def discard_resume_state(files: ModelFiles) -> None:
    """Forget the checkpoint to resume from (a run that starts from scratch); the checkpoint models stay."""
    (files.checkpoints / RESUME_FILE).unlink(missing_ok=True)
    for old in files.checkpoints.glob("*.replay.npz") if files.checkpoints.is_dir() else ():
        old.unlink(missing_ok=True)
