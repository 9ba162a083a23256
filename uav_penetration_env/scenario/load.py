"""Getting a scenario: from a YAML path, a mapping or a ready one, or a bundled file (model.md §7b)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

from uav_penetration_env.scenario.errors import ScenarioError
from uav_penetration_env.scenario.files import read_yaml
from uav_penetration_env.scenario.schema import Scenario

__all__ = ["PAPER_WEIGHTS", "load_bundled", "load_scenario", "paper_scenario"]

PAPER_WEIGHTS = {"w1": (0.3, 0.4, 0.3), "w2": (0.3, 0.5, 0.2)}


def load_scenario(source: str | Path | Mapping[str, Any] | Scenario) -> Scenario:
    """Load a scenario from a YAML path, a mapping or a :class:`Scenario` (returned as is).

    Raises:
        ScenarioError: the file is missing or unreadable, is not valid YAML, or a field is invalid
            (the message then ends with ``(in <path>)``).
    """
    if isinstance(source, Scenario):
        return source
    if isinstance(source, Mapping):
        return Scenario.from_dict(source)
    path = Path(source)
    data = read_yaml(path)
    try:
        return Scenario.from_dict(data if data is not None else {})
    except ScenarioError as error:
        raise ScenarioError(error.field, error.value, f"{error.expected} (in {path})") from None


@cache
def load_bundled(name: str) -> Scenario:
    """The scenario file ``name`` shipped in ``uav_penetration_env/scenarios/`` (loaded once)."""
    return load_scenario(Path(str(resources.files("uav_penetration_env") / "scenarios" / name)))


def paper_scenario(weights: str = "w1") -> Scenario:
    """The paper's §5 scenario (``scenarios/paper.yaml``); ``weights`` ``"w1"`` = 0.3/0.4/0.3, ``"w2"`` = 0.3/0.5/0.2.

    Raises:
        ScenarioError: ``weights`` is neither ``"w1"`` nor ``"w2"``.
    """
    if weights not in PAPER_WEIGHTS:
        raise ScenarioError("weights", weights, "'w1' (0.3/0.4/0.3) or 'w2' (0.3/0.5/0.2)")
    scenario = load_bundled("paper.yaml")
    if weights == "w2":
        scenario = replace(
            scenario, name=f"{scenario.name}-w2", cost=replace(scenario.cost, weights=PAPER_WEIGHTS["w2"])
        )
    return scenario
