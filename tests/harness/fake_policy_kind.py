"""A plug-in policy kind for the harness tests: ``fake[path=PATH]``, published ``fake:PATH``, labelled ``fake:STEM``."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from uav_penetration_env.benchmark.plugins import Needs, PolicyKind, argument_as
from uav_penetration_env.benchmark.policies import GreedyPolicy


@dataclass(frozen=True)
class FakeParams:
    """The fake kind's one parameter, a path (any text)."""

    path: str = field(metadata={"expected": "a path"})


def fake_kind(
    loaded: list[str] | None = None,
    needs: Needs | None = None,
    hybrid: Callable[[Any, Any], Any] | None = None,
) -> PolicyKind:
    """The ``fake`` kind: a greedy floor that records the paths it was loaded from in ``loaded``."""

    def load(params: FakeParams) -> GreedyPolicy:
        if loaded is not None:
            loaded.append(params.path)
        return GreedyPolicy()

    return PolicyKind(
        name="fake",
        params=FakeParams,
        load=load,
        usage="fake[path=PATH]",
        label=lambda params: f"fake:{Path(params.path).stem}",
        needs=needs or Needs(),
        hybrid=hybrid,
        prefixes={"fake": argument_as("path")},
    )
