"""Scenario files: frozen dataclasses, YAML load/save and validation (model.md §7b).

A scenario is data. The dataclasses mirror the YAML schema field by field and keep the paper's
units (x, y in km, z in m, angles in degrees), so ``load_scenario(s.to_yaml(path)) == s`` holds
exactly. Every invalid value raises :class:`ScenarioError` naming the field path
(``radars[2].x_km``), the value received and what was expected; an unknown key suggests the
closest valid ones.

One idea per module, imported in this order (each only from those above it):

* ``errors``: :class:`ScenarioError`;
* ``rules``: checked fields (``height_m: float = non_negative(200.0)``) and their one check loop;
* ``convert``: plain data <-> dataclasses from the type hints, unknown keys with did-you-mean;
* ``files``: reading and writing YAML files;
* ``schema``: the dataclasses, :class:`Scenario` with its profile resolution and hash;
* ``load``: :func:`load_scenario`, :func:`paper_scenario` and the bundled ``scenarios/*.yaml``.
"""

from __future__ import annotations

from uav_penetration_env.scenario.errors import ScenarioError
from uav_penetration_env.scenario.load import PAPER_WEIGHTS, load_bundled, load_scenario, paper_scenario
from uav_penetration_env.scenario.schema import (
    BENCHMARK,
    PAPER,
    PAPER_MOUNTAINS,
    PAPER_RADARS,
    PROFILES,
    ConstantRCS,
    CostConfig,
    DEMTerrain,
    DiamondSquare,
    FlatTerrain,
    FuelConfig,
    GaussianField,
    GaussianHill,
    GoalConfig,
    Jitter,
    MapConfig,
    Mountain,
    NaturalTerrain,
    NormalisationConfig,
    PayoffConstants,
    PayoffNormalisation,
    PrimitivesRCS,
    Radar,
    RadarModelConfig,
    RandomWalk,
    RCSConfig,
    Scenario,
    SensingConfig,
    StartConfig,
    TableRCS,
    TerrainConfig,
    TimeConfig,
    UAVConfig,
)

# The name catalogue.py imports the bundled-file loader by (kept so no other module changes).
_load_bundled = load_bundled

__all__ = [
    "BENCHMARK",
    "PAPER",
    "PAPER_MOUNTAINS",
    "PAPER_RADARS",
    "PAPER_WEIGHTS",
    "PROFILES",
    "ConstantRCS",
    "CostConfig",
    "DEMTerrain",
    "DiamondSquare",
    "FlatTerrain",
    "FuelConfig",
    "GaussianField",
    "GaussianHill",
    "GoalConfig",
    "Jitter",
    "MapConfig",
    "Mountain",
    "NaturalTerrain",
    "NormalisationConfig",
    "PayoffConstants",
    "PayoffNormalisation",
    "PrimitivesRCS",
    "RCSConfig",
    "Radar",
    "RadarModelConfig",
    "RandomWalk",
    "Scenario",
    "ScenarioError",
    "SensingConfig",
    "StartConfig",
    "TableRCS",
    "TerrainConfig",
    "TimeConfig",
    "UAVConfig",
    "load_bundled",
    "load_scenario",
    "paper_scenario",
]
