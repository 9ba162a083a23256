"""Where a trained model's files live, and reading its ``.json`` sidecar (api.md, ``baselines``).

A model saved as ``DIR/NAME.zip`` comes with ``DIR/NAME.json`` (how it was trained),
``DIR/NAME.vecnormalize.pkl`` (observation statistics, when used), ``DIR/NAME.evaluations.csv``
(the learning curve) and ``DIR/NAME.checkpoints/`` (intermediate models, each with its own
sidecars). No torch here: the evaluator's parent process reads sidecars without it.

The sidecar records the SHA-256 of every file an agent needs: ``model_sha256`` (the ``.zip``),
``vecnormalize_sha256`` (the observation statistics; ``None`` when not normalised) and
``hyperparameters_sha256`` (its own ``hyperparameters`` block, canonical JSON), checked by
:func:`verify_artifacts` when a model is loaded. The ``.zip`` and ``.vecnormalize.pkl`` are
pickles: loading one runs code it contains, so they must come from trusted sources.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from collections.abc import Callable
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
# The JSON types of the keys read before a model is loaded; a hand-edited or foreign sidecar with
# another type is refused naming the key, not met later as an AttributeError.
SIDECAR_TYPES: dict[str, tuple[type, ...]] = {
    "format": (int,),
    "algorithm": (str,),
    "env_id": (str,),
    "profile": (str,),
    "observation_space": (dict,),
    "action_space": (dict,),
    "vecnormalize": (str, type(None), bool),
    "timesteps_done": (int,),
    "wall_seconds": (int, float),
}


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


def hyperparameters_sha256(hyperparameters: Any) -> str:
    """Hex SHA-256 of hyper-parameters as canonical JSON (sorted keys, no spaces).

    The value is first passed through JSON as the sidecar writes it (``default=str``), so the
    hash taken at save time equals the one taken from the loaded sidecar.
    """
    plain = json.loads(json.dumps(hyperparameters, default=str))
    text = json.dumps(plain, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


class UnverifiedArtifactWarning(UserWarning):
    """A model was loaded from a sidecar written before it recorded every file's hash."""


def _hold_to_record(
    recorded: str | None, actual: str, name: str, unverified: list[str], mismatch: Callable[[str], str]
) -> None:
    """Check one hash against its sidecar record: none recorded adds ``name`` to ``unverified``.

    Raises:
        ValueError: ``mismatch(recorded)`` when a recorded hash differs from ``actual``.
    """
    if recorded is None:
        unverified.append(name)
    elif recorded != actual:
        raise ValueError(mismatch(recorded))


def artifact_hashes(files: ModelFiles, hyperparameters: Any, normalised: bool) -> dict[str, str | None]:
    """The sidecar's hash keys for the files as they are now on disk (:func:`verify_artifacts`)."""
    return {
        "model_sha256": sha256_file(files.model),
        "vecnormalize_sha256": sha256_file(files.vecnormalize) if normalised else None,
        "hyperparameters_sha256": hyperparameters_sha256(hyperparameters),
    }


def verify_artifacts(files: ModelFiles, sidecar: dict[str, Any]) -> tuple[str, str | None]:
    """Check the model, its observation statistics and hyper-parameters against the sidecar's hashes.

    DECISION (api.md §5, unsealed sidecars): a sidecar written before the statistics and hyper-parameter hashes were
    recorded (``format`` 1 without ``vecnormalize_sha256``/``hyperparameters_sha256``, as version 1's
    published models, ``leaderboards/models/`` before the v2 install, were) is accepted with an
    :class:`UnverifiedArtifactWarning` naming what cannot be checked and how to seal it
    (:func:`seal_sidecar`), and what it does record (``model_sha256``) is still checked. Refusing
    it would break every such model, and sealing those sidecars in place would change
    their bytes and so the policy hash under which their results are stored (``sidecar_sha256`` is
    part of an SB3 policy's store key). A sidecar that records a hash is held to it: no warning
    there, a mismatch is an error.

    Args:
        files: the model's files.
        sidecar: its parsed sidecar (:func:`read_sidecar`).

    Returns:
        The SHA-256 of the model ``.zip`` and of the ``.vecnormalize.pkl`` (``None``: not normalised).

    Raises:
        FileNotFoundError: the sidecar says the model uses observation statistics and there are none.
        ValueError: a file whose hash differs from the one recorded, naming the file.
    """
    unverified: list[str] = []
    model = sha256_file(files.model)
    _hold_to_record(
        sidecar.get("model_sha256"), model, files.model.name, unverified,
        lambda recorded: f"{files.model} is not the model its sidecar {files.sidecar} describes (hash differs: "
        f"SHA-256 {model[:16]}..., recorded {recorded[:16]}...); was one of them overwritten by another run?",
    )  # fmt: skip
    statistics = None
    if sidecar["vecnormalize"]:
        if not files.vecnormalize.is_file():
            raise FileNotFoundError(
                f"{files.vecnormalize}: missing observation statistics (the sidecar {files.sidecar} says the model uses them)"
            )
        statistics = sha256_file(files.vecnormalize)
        _hold_to_record(
            sidecar.get("vecnormalize_sha256"), statistics, files.vecnormalize.name, unverified,
            lambda recorded: f"{files.vecnormalize}: not the observation statistics its sidecar {files.sidecar} "
            f"records (SHA-256 {statistics[:16]}..., recorded {recorded[:16]}...); was it replaced by another "
            "run's file? The agent would see differently scaled observations",
        )  # fmt: skip
    _hold_to_record(
        sidecar.get("hyperparameters_sha256"), hyperparameters_sha256(sidecar.get("hyperparameters")),
        "hyperparameters", unverified,
        lambda _: f"{files.sidecar}: its hyperparameters are not those it was sealed with "
        "(hyperparameters_sha256 differs); the sidecar was edited after training",
    )  # fmt: skip
    if unverified:
        warnings.warn(
            f"{files.sidecar} records no SHA-256 of {', '.join(unverified)} (a sidecar written before "
            "hashes were recorded), so they are loaded unverified; if these files are the trusted ones, "
            f"`python -c \"from baselines.artifacts import seal_sidecar; seal_sidecar('{files.model}')\"` "
            "records their hashes (this changes the policy's results-store key)",
            UnverifiedArtifactWarning,
            stacklevel=3,
        )
    return model, statistics


def seal_sidecar(path: str | Path) -> dict[str, Any]:
    """Record in a model's sidecar the hashes of its files as they are now (an older sidecar).

    Use only on files from a trusted source: sealing declares the present files the right ones.
    The sidecar's bytes change, and with them the policy hash its results are stored under.

    Args:
        path: the model ``.zip`` (the suffix may be omitted).

    Returns:
        The sealed sidecar.

    Raises:
        FileNotFoundError: no model file, sidecar or (when used) observation statistics.
        ValueError: a corrupt sidecar.
    """
    from uav_penetration_env.atomic import write_text_atomic

    files = ModelFiles.of(path)
    if not files.model.is_file():
        raise FileNotFoundError(f"{files.model}: no such SB3 model file")
    sidecar = read_sidecar(files.sidecar)
    if sidecar["vecnormalize"] and not files.vecnormalize.is_file():
        raise FileNotFoundError(f"{files.vecnormalize}: missing observation statistics")
    sidecar.update(artifact_hashes(files, sidecar.get("hyperparameters"), bool(sidecar["vecnormalize"])))
    write_text_atomic(files.sidecar, json.dumps(sidecar, indent=2, sort_keys=False, default=str) + "\n")
    return sidecar


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
    for key, kinds in SIDECAR_TYPES.items():
        value = data[key]
        if not isinstance(value, kinds) or (isinstance(value, bool) and bool not in kinds):
            expected = " or ".join("null" if k is type(None) else k.__name__ for k in kinds)
            raise ValueError(f"{path}: corrupt sidecar, {key}: got {value!r}, expected {expected}")
    shape = data["observation_space"].get("shape")
    if not (isinstance(shape, list) and all(isinstance(n, int) and not isinstance(n, bool) for n in shape)):
        raise ValueError(f"{path}: corrupt sidecar, observation_space.shape: got {shape!r}, expected a list of integers")
    if data["format"] != SIDECAR_FORMAT:
        raise ValueError(f"{path}: sidecar format {data['format']!r}, expected {SIDECAR_FORMAT}")
    return data
