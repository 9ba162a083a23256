"""The typed parameters of the policy kinds ``baselines`` adds, and their published names (api.md §4.1).

``sb3[model=PATH.zip,vecnormalize=STATS.pkl]`` (published ``sb3:PATH.zip?vecnormalize=STATS.pkl``)
and ``distill[run=DIR,guard=shield]`` (published ``distill:DIR``, ``distill-safe:DIR``,
``distill-shield:DIR``). Standard library only: the harness reads these when it checks a name,
before it imports the physics, torch or NumPy.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

STATISTICS_OPTION = "vecnormalize"  # sb3:PATH.zip?vecnormalize=STATS.pkl
NO_STATISTICS = "none"  # ?vecnormalize=none: the model was trained on raw observations
GUARDS = ("none", "safe", "shield")  # distill[guard=...]: docs/rl.md §4, §4.7, §4.8
# The published prefix of each guard: distill-shield:DIR is distill[run=DIR,guard=shield].
GUARD_PREFIXES = {"none": "distill", "safe": "distill-safe", "shield": "distill-shield"}


@dataclass(frozen=True)
class SB3Params:
    """An SB3 agent's parameters (``sb3[...]``).

    Attributes:
        model: the agent's ``.zip`` (the suffix may be omitted).
        vecnormalize: the observation statistics of a model without a sidecar, a ``.pkl`` path or
            ``none`` (raw observations); ``None``: the sidecar's, or found beside the model
            (docs/rl.md §5.2).
    """

    model: str = field(metadata={"expected": "the path of an SB3 .zip"})
    vecnormalize: str | None = field(
        default=None, metadata={"expected": f"the path of a STATS.pkl, or {NO_STATISTICS}"}
    )


@dataclass(frozen=True)
class DistillParams:
    """A distilled network's parameters (``distill[...]``).

    Attributes:
        run: the distillation's run folder (or its ``policy.npz``).
        guard: ``none`` (the network alone), ``safe`` (behind the safety layer on its pitch,
            docs/rl.md §4.7) or ``shield`` (behind the verified fallback to the greedy floor, §4.8).
    """

    run: str = field(metadata={"expected": "a distillation run folder"})
    guard: str = field(default="none", metadata={"choices": GUARDS})


def read_sb3_argument(argument: str) -> dict[str, str]:
    """The parameter texts of the published ``sb3:PATH.zip[?vecnormalize=VALUE]``.

    DECISION (docs/rl.md §5.2, the option syntax): the published form gives the statistics of a
    model without a sidecar as a URL-like query after the path, so a ``?`` in that form's path is
    read as the option's start; ``sb3[model=...,vecnormalize=...]`` has no such limit.

    Raises:
        ValueError: an option other than ``vecnormalize``, or one without a value.
    """
    path, mark, option = argument.partition("?")
    if not mark:
        return {"model": argument}
    key, equals, value = option.partition("=")
    if key != STATISTICS_OPTION or not equals or not value:
        raise ValueError(
            f"{path}: the option after '?' must be {STATISTICS_OPTION}=PATH.pkl or "
            f"{STATISTICS_OPTION}={NO_STATISTICS}, got {option!r}"
        )
    return {"model": path, "vecnormalize": value}


def sb3_label(params: SB3Params) -> str:
    """An agent's name in result tables: its file stem (``sb3:DIR/ppo-paper-s0.zip`` -> ``sb3:ppo-paper-s0``).

    The statistics are not part of the name.
    """
    return f"sb3:{Path(params.model).stem}"


def weights_path(path: str | Path) -> Path:
    """A run folder -> its ``policy.npz``; a file path as given (``.npz`` may be omitted)."""
    path = Path(path)
    if path.is_dir():
        return path / "policy.npz"
    return path if path.suffix == ".npz" else path.with_suffix(".npz")


def distill_label(params: DistillParams) -> str:
    """A distilled policy's name in result tables: its guard's prefix and run folder's name (``distill-shield:NAME``)."""
    weights = weights_path(params.run)
    name = weights.parent.name if weights.stem == "policy" else weights.stem
    return f"{GUARD_PREFIXES[params.guard]}:{name}"
