"""Scenario precomputation: terrain grid, radar positions, visibility floors, RCS table.

Everything a scenario needs beyond its scalar constants is computed here once (and cached on
disk, see :mod:`uav_penetration_env.cache`): the composed terrain h = max(h_nat, h_mtn)
(model.md §2.4), each radar's visibility-floor map (§4.4) and the airframe's RCS table (§5).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from uav_penetration_env import dem, rcs
from uav_penetration_env.cache import cached_arrays
from uav_penetration_env.files import file_digest
from uav_penetration_env.radar import visibility_floor
from uav_penetration_env.scenario import (
    ConstantRCS,
    DEMTerrain,
    DiamondSquare,
    FlatTerrain,
    GaussianField,
    GaussianHill,
    PrimitivesRCS,
    RandomWalk,
    Scenario,
    ScenarioError,
    TableRCS,
    TerrainConfig,
)
from uav_penetration_env.terrain import (
    GridSpec,
    bilinear,
    diamond_square_field,
    gaussian_field,
    gaussian_hill,
    mountain_heights,
    random_walk_field,
    scale_to_height,
)
from uav_penetration_env.types import FloatArray

RCS_TABLE_SUBSAMPLES = 10  # model.md §5.3: each 1° cell is the power mean of 10 x 10 sub-samples


@dataclass(frozen=True, eq=False)
class BuiltScenario:
    """A scenario with its precomputed arrays (SI units)."""

    scenario: Scenario
    grid: GridSpec
    terrain: FloatArray  # (nx, ny) heights above datum [m]
    radar_xyz: FloatArray  # (M, 3) antenna positions [m]
    floors: FloatArray  # (M, nx, ny) visibility floors [m]; (0, nx, ny) when masking is off
    rcs_table: FloatArray  # (181, 361) dBsm on el x az
    mountains: FloatArray  # (I, 3) [x_km, y_km, height_m]

    def height(self, x_m: FloatArray, y_m: FloatArray) -> FloatArray:
        """Terrain height [m] at points given in metres (bilinear)."""
        fi, fj = self.grid.fractional_index(x_m, y_m)
        return bilinear(self.terrain, fi, fj)


def grid_for(scenario: Scenario) -> GridSpec:
    """The terrain grid covering the scenario's map."""
    m = scenario.map
    nx = round((m.x_km[1] - m.x_km[0]) * 1000.0 / m.grid_m) + 1
    ny = round((m.y_km[1] - m.y_km[0]) * 1000.0 / m.grid_m) + 1
    return GridSpec(m.x_km[0] * 1000.0, m.y_km[0] * 1000.0, float(m.grid_m), nx, ny)


def _terrain_inputs(scenario: Scenario) -> dict:
    terrain = dataclasses.asdict(scenario.terrain)
    terrain.pop("threat_altitude_scale_m")
    terrain.pop("randomize_terrain")
    if isinstance(scenario.terrain.natural, (FlatTerrain, GaussianHill, DEMTerrain)):
        terrain.pop("seed")  # deterministic surfaces: share one cache entry across seeds
    inputs = {"terrain": terrain, "map": dataclasses.asdict(scenario.map)}
    if isinstance(scenario.terrain.natural, DEMTerrain):
        # Keyed by the raster's content as the scenario's hash saw it, not by its name: a file
        # rewritten in place is a new key, and the build reads only bytes with this digest.
        inputs["raster_sha256"] = scenario.input_digests["terrain.natural.file"]
    return inputs


def natural_terrain(config: TerrainConfig, grid: GridSpec, raster_digest: str | None = None) -> FloatArray:
    """The natural terrain h_nat on the grid (model.md §2.3), drawn from ``config.seed``.

    ``raster_digest``: the SHA-256 a DEM raster's bytes must have (``None``: the file as it is).
    """
    natural = config.natural
    shape = (grid.nx, grid.ny)
    rng = np.random.default_rng(config.seed)
    if isinstance(natural, GaussianField):
        field = gaussian_field(shape, rng, natural.correlation_km * 1000.0 / grid.dx_m)
        return scale_to_height(field, natural.height_m)
    if isinstance(natural, RandomWalk):
        return scale_to_height(random_walk_field(shape, rng, natural.passes), natural.height_m)
    if isinstance(natural, DiamondSquare):
        return scale_to_height(diamond_square_field(shape, rng, natural.roughness), natural.height_m)
    if isinstance(natural, GaussianHill):
        gx, gy = grid.mesh()
        centre = (grid.x0_m + 0.5 * (grid.nx - 1) * grid.dx_m, grid.y0_m + 0.5 * (grid.ny - 1) * grid.dx_m)
        return natural.height_m * gaussian_hill(gx, gy, centre, natural.sigma_km * 1000.0)
    if isinstance(natural, FlatTerrain):
        return np.full(shape, natural.height_m)
    if isinstance(natural, DEMTerrain):
        return dem.dem_heights(natural, grid, raster_digest)
    raise TypeError(f"unknown natural terrain {natural!r}")  # the schema admits no other type


def compose_terrain(scenario: Scenario) -> FloatArray:
    """The composed terrain h = max(h_nat, h_mtn) on the scenario's grid [m] (model.md §2.4), uncached.

    DECISION: for real terrain (``method: dem``) the listed mountains only define the terrain
    threat (§3); the raster already contains them, so they do not reshape it.
    """
    grid = grid_for(scenario)
    digest = scenario.input_digests.get("terrain.natural.file")
    heights = natural_terrain(scenario.terrain, grid, digest)
    if not isinstance(scenario.terrain.natural, DEMTerrain) and scenario.terrain.mountains:
        gx, gy = grid.mesh()
        centres, peak_heights = _mountain_arrays(scenario)
        mountains = mountain_heights(
            gx / 1000.0, gy / 1000.0, centres, peak_heights, scenario.terrain.mountain_decay_per_km2
        )
        heights = np.maximum(heights, mountains)
    return heights


def terrain_heights(scenario: Scenario) -> FloatArray:
    """:func:`compose_terrain`, cached in memory and on disk."""
    return cached_arrays(
        "terrain", _terrain_inputs(scenario), lambda: {"heights": compose_terrain(scenario)}
    )["heights"]


def _mountain_arrays(scenario: Scenario) -> tuple[FloatArray, FloatArray]:
    mountains = scenario.terrain.mountains
    centres = np.array([[m.x_km, m.y_km] for m in mountains], dtype=np.float64).reshape(-1, 2)
    heights = np.array([m.height_m for m in mountains], dtype=np.float64)
    return centres, heights


def rcs_table(scenario: Scenario) -> FloatArray:
    """The airframe's (181, 361) dBsm table for the scenario's RCS model (model.md §5, cached)."""
    config = scenario.uav.rcs
    if isinstance(config, ConstantRCS):
        return rcs.constant_rcs_table(config.rcs_m2)
    if isinstance(config, TableRCS):
        try:
            table = rcs.load_rcs_table(config.path)
        except (OSError, ValueError) as error:
            raise ScenarioError("uav.rcs.path", config.path, f"a readable RCS table ({error})") from None
        # Digested after the read: a table rewritten since the scenario's hash is refused (model.md §2.5,
        # "identity by content"), never built under the old identity.
        if file_digest(config.path) != scenario.input_digests["uav.rcs.path"]:
            raise ScenarioError(
                "uav.rcs.path",
                config.path,
                "the file as it was when the scenario was hashed (it changed since; load the scenario again)",
            )
        return table
    if isinstance(config, PrimitivesRCS):
        airframe = rcs.AirframeRCS(frequency_ghz=config.frequency_ghz)
        inputs = {"airframe": repr(airframe), "subsamples": RCS_TABLE_SUBSAMPLES}
        return cached_arrays(
            "rcs", inputs, lambda: {"table": rcs.build_rcs_table(airframe, RCS_TABLE_SUBSAMPLES)}
        )["table"]
    raise TypeError(f"unknown RCS model {config!r}")


def check_reachable(scenario: Scenario, grid: GridSpec, heights: FloatArray) -> None:
    """Refuse a start or goal that the ceiling makes impossible (model.md §2.6).

    The start's altitude is the terrain under it plus ``start.z_agl_m``; at or above the ceiling,
    every episode would end out of the area at its first step. DECISION (model.md §2.6): the goal
    is refused when the terrain at the goal and at every grid node inside its disc lies above
    ``map.ceiling_m - uav.min_clearance_m``: no altitude there is both clear of the terrain and
    below the ceiling, so no planner can reach it. One low node inside the disc is enough to keep
    the goal, so a reachable goal is never refused on a peak at its edge.

    Raises:
        ScenarioError: naming ``start.z_agl_m`` or ``goal``.
    """
    ceiling = scenario.map.ceiling_m
    start, goal = scenario.start, scenario.goal
    ground = float(bilinear(heights, *grid.fractional_index(np.array(start.x_km * 1e3), np.array(start.y_km * 1e3))))
    if ground + start.z_agl_m >= ceiling:
        raise ScenarioError(
            "start.z_agl_m",
            start.z_agl_m,
            f"a start altitude below the ceiling {ceiling:g} m (the terrain under the start is {ground:.1f} m)",
        )
    gx, gy = grid.mesh()
    inside = np.hypot(gx - goal.x_km * 1e3, gy - goal.y_km * 1e3) <= goal.radius_km * 1e3
    centre = bilinear(heights, *grid.fractional_index(np.array(goal.x_km * 1e3), np.array(goal.y_km * 1e3)))
    lowest = float(min(np.min(heights[inside], initial=np.inf), centre))
    if lowest + scenario.uav.min_clearance_m > ceiling:
        raise ScenarioError(
            "goal",
            {"x_km": goal.x_km, "y_km": goal.y_km, "radius_km": goal.radius_km},
            f"a goal with ground that can be flown over below the ceiling {ceiling:g} m (the lowest terrain "
            f"within its radius is {lowest:.1f} m, plus uav.min_clearance_m = {scenario.uav.min_clearance_m:g} m)",
        )


def build_scenario(scenario: Scenario) -> BuiltScenario:
    """Precompute (or load from the cache) everything the physics model needs for ``scenario``.

    Raises:
        ScenarioError: a radar antenna lies below the terrain, the start or the goal lies above the
            ceiling (:func:`check_reachable`), or the DEM has no data in the map.
    """
    grid = grid_for(scenario)
    heights = terrain_heights(scenario)
    check_reachable(scenario, grid, heights)
    radar_xyz = np.zeros((len(scenario.radars), 3))
    for i, radar in enumerate(scenario.radars):
        x, y = radar.x_km * 1000.0, radar.y_km * 1000.0
        ground = float(bilinear(heights, *grid.fractional_index(np.array(x), np.array(y))))
        if radar.z_m is not None:
            if radar.z_m < ground:
                raise ScenarioError(
                    f"radars[{i}].z_m",
                    radar.z_m,
                    f"an antenna altitude at or above the terrain ({ground:.1f} m there)",
                )
            z = radar.z_m
        else:
            z = ground + radar.mast_m
        radar_xyz[i] = (x, y, z)
    earth_radius = scenario.radar_model.effective_earth_radius_km * 1000.0
    if scenario.masking == "off":
        floors = np.zeros((0, grid.nx, grid.ny))
    else:
        terrain_key = _terrain_inputs(scenario)
        floors = (
            np.stack(
                [
                    cached_arrays(
                        "floor",
                        {"terrain": terrain_key, "radar": xyz.tolist(), "earth_radius_m": earth_radius},
                        lambda xyz=xyz: {"floor": visibility_floor(heights, grid, tuple(xyz), earth_radius)},
                    )["floor"]
                    for xyz in radar_xyz
                ]
            )
            if len(radar_xyz)
            else np.zeros((0, grid.nx, grid.ny))
        )
    centres, peak_heights = _mountain_arrays(scenario)
    return BuiltScenario(
        scenario=scenario,
        grid=grid,
        terrain=heights,
        radar_xyz=radar_xyz,
        floors=floors,
        rcs_table=rcs_table(scenario),
        mountains=np.column_stack([centres, peak_heights]) if len(peak_heights) else np.zeros((0, 3)),
    )
