"""Where a trained model's files live, and reading its ``.json`` sidecar (api.md, ``baselines``).

A model saved as ``DIR/NAME.zip`` comes with ``DIR/NAME.json`` (how it was trained),
``DIR/NAME.vecnormalize.pkl`` (observation statistics, when used), ``DIR/NAME.evaluations.csv``
(the learning curve) and ``DIR/NAME.checkpoints/`` (intermediate models, each with its own
sidecars). No torch here: the evaluator's parent process reads sidecars without it.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

SIDECAR_FORMAT = 1  # bump when the sidecar's keys change meaning
REQUIRED_SIDECAR_KEYS = (
    "format",
    "algorithm",
    "env_id",
    "profile",
    "observation_space",
    "action_space",
    "vecnormalize",
    "timesteps_done",
    "wall_seconds",
)


@dataclass(frozen=True)
class ModelFiles:
    """The files of one saved model, derived from the ``.zip`` path."""

    model: Path
    sidecar: Path
    vecnormalize: Path
    evaluations: Path
    checkpoints: Path

    @classmethod
    def of(cls, out: str | Path) -> ModelFiles:
        """The files of the model saved at ``out`` (``.zip`` is appended when missing, as SB3 does)."""
        model = Path(out)
        if model.suffix != ".zip":
            model = model.with_name(model.name + ".zip")
        stem = model.with_suffix("")
        return cls(
            model=model,
            sidecar=stem.with_name(stem.name + ".json"),
            vecnormalize=stem.with_name(stem.name + ".vecnormalize.pkl"),
            evaluations=stem.with_name(stem.name + ".evaluations.csv"),
            checkpoints=stem.with_name(stem.name + ".checkpoints"),
        )


def sha256_file(path: Path) -> str:
    """Hex SHA-256 of a file's bytes."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def read_sidecar(path: Path) -> dict[str, Any]:
    """The sidecar of a model, checked for the keys :mod:`baselines.policy` relies on.

    Raises:
        FileNotFoundError: no sidecar at ``path``.
        ValueError: the file is not valid JSON or lacks a required key.
    """
    if not path.is_file():
        raise FileNotFoundError(
            f"{path}: no sidecar (expected the .json written beside the model by baselines.train_agent / "
            "`uav-bench train`)"
        )
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise ValueError(f"{path}: corrupt sidecar, expected JSON ({error})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: corrupt sidecar, expected a JSON object, got {type(data).__name__}")
    missing = [key for key in REQUIRED_SIDECAR_KEYS if key not in data]
    if missing:
        raise ValueError(f"{path}: corrupt sidecar, missing key(s) {', '.join(missing)}")
    if data["format"] != SIDECAR_FORMAT:
        raise ValueError(f"{path}: sidecar format {data['format']!r}, expected {SIDECAR_FORMAT}")
    return data
