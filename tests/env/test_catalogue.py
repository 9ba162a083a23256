"""Scenario generators (model.md §7c procedural scenarios, §7d the DEM scenario) and the DEM loader."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage
from scipy.interpolate import RegularGridInterpolator

from uav_penetration_env.build import build_scenario, grid_for, natural_terrain, terrain_heights
from uav_penetration_env.catalogue import (
    HELD_OUT_SEEDS,
    dem_scenario,
    generate_dem_scenario,
    random_scenario,
    straight_climb_feasible,
)
from uav_penetration_env.dem import dem_heights, window_extent_km
from uav_penetration_env.scenario import DEMTerrain, Scenario, ScenarioError, paper_scenario
from uav_penetration_env.terrain import GridSpec, bilinear


def _distance_to_segment_km(point, a, b) -> float:
    p, a, b = (np.asarray(v, dtype=float) for v in (point, a, b))
    t = min(max(float(np.dot(p - a, b - a) / np.dot(b - a, b - a)), 0.0), 1.0)
    return float(np.linalg.norm(p - (a + t * (b - a))))


def _composed(scenario: Scenario) -> tuple[np.ndarray, GridSpec]:
    """h = max(h_nat, max_i H_i exp(-λ r²)) computed here, without the disk cache."""
    grid = grid_for(scenario)
    gx, gy = grid.mesh()
    heights = natural_terrain(scenario.terrain, grid)
    for m in scenario.terrain.mountains:
        r2 = (gx / 1e3 - m.x_km) ** 2 + (gy / 1e3 - m.y_km) ** 2
        heights = np.maximum(heights, m.height_m * np.exp(-scenario.terrain.mountain_decay_per_km2 * r2))
    return heights, grid


# --- procedural scenarios (§7c) -------------------------------------------------------------------


def test_same_generator_state_gives_the_same_scenario():
    a = random_scenario(np.random.default_rng(5), 0.5)
    b = random_scenario(np.random.default_rng(5), 0.5)
    assert a == b and a.hash == b.hash
    assert random_scenario(np.random.default_rng(6), 0.5) != a
    # The generator state, not the seed alone: a generator that has drawn before gives another scenario.
    used = np.random.default_rng(5)
    used.random()
    assert random_scenario(used, 0.5) != a


def test_random_scenario_draws_only_from_the_generator():
    rng = np.random.default_rng(21)
    first = random_scenario(rng, 0.3)
    second = random_scenario(rng, 0.3)  # the generator advanced: a new scenario
    assert first != second
    replay = np.random.default_rng(21)
    assert random_scenario(replay, 0.3) == first and random_scenario(replay, 0.3) == second


CASES = [(d, seed) for d in (0.0, 0.5, 1.0) for seed in (0, 1, 2)]


@pytest.mark.parametrize(("difficulty", "seed"), CASES)
def test_random_scenario_follows_the_rules(difficulty, seed):
    s = random_scenario(np.random.default_rng(seed), difficulty)
    n_mountains = 2 + round(4 * difficulty)
    n_radars = 2 + round(6 * difficulty)
    assert (len(s.terrain.mountains), len(s.radars)) == (n_mountains, n_radars)
    assert {0.0: (2, 2), 0.5: (4, 5), 1.0: (6, 8)}[difficulty] == (n_mountains, n_radars)

    start, goal = (s.start.x_km, s.start.y_km), (s.goal.x_km, s.goal.y_km)
    assert {start, goal} in ({(0.0, 0.0), (100.0, 100.0)}, {(0.0, 100.0), (100.0, 0.0)})
    assert s.map == paper_scenario().map

    assert all(300.0 <= m.height_m <= 900.0 for m in s.terrain.mountains)
    assert min(_distance_to_segment_km((m.x_km, m.y_km), start, goal) for m in s.terrain.mountains) <= 10.0

    near = sum(_distance_to_segment_km((r.x_km, r.y_km), start, goal) <= 30.0 for r in s.radars)
    assert near >= len(s.radars) / 2
    for r in s.radars:
        assert r.z_m is None and 10.0 <= r.mast_m <= 30.0
        assert r.ref_range_km == pytest.approx(60.0 + 80.0 * difficulty)
        assert r.ref_rcs_m2 == 0.1
        assert 0.0 <= r.x_km <= 100.0 and 0.0 <= r.y_km <= 100.0
    assert len({r.name for r in s.radars}) == len(s.radars)

    assert s.cost.weights == (0.3, 0.4, 0.3)
    assert s.profile == "benchmark"
    heights, grid = _composed(s)
    assert straight_climb_feasible(s, heights, grid)
    # It validates: a round trip through plain data re-runs every check.
    assert Scenario.from_dict(s.to_dict()) == s


def test_radars_stand_on_high_ground():
    # Each radar is the highest of 8 candidate sites: on average well above the typical terrain.
    s = random_scenario(np.random.default_rng(3), 1.0)
    heights, grid = _composed(s)
    ground = [
        float(bilinear(heights, *grid.fractional_index(np.array(r.x_km * 1e3), np.array(r.y_km * 1e3))))
        for r in s.radars
    ]
    inside = heights[50:251, 50:251]  # the [0, 100] km square
    assert np.mean(ground) > np.median(inside)


@pytest.mark.parametrize("difficulty", [-0.1, 1.01, float("nan"), float("inf")])
def test_difficulty_outside_0_1_raises(difficulty):
    with pytest.raises(ScenarioError) as info:
        random_scenario(np.random.default_rng(0), difficulty)
    assert info.value.field == "difficulty"


def test_held_out_seeds():
    assert list(HELD_OUT_SEEDS) == list(range(10_000, 10_050))


def test_a_random_scenario_builds():
    s = random_scenario(np.random.default_rng(4), 0.0)
    built = build_scenario(s)
    assert built.floors.shape == (2, 301, 301)
    for radar, xyz in zip(s.radars, built.radar_xyz, strict=True):
        ground = float(built.height(np.array(xyz[0]), np.array(xyz[1])))
        assert xyz[2] == pytest.approx(ground + radar.mast_m)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [10_000, 10_001, 10_002])
def test_held_out_scenarios_build_at_full_difficulty(seed):
    s = random_scenario(np.random.default_rng(seed), 1.0)
    built = build_scenario(s)
    assert built.floors.shape == (8, 301, 301)
    assert np.all(built.floors >= built.terrain)


# --- straight_climb_feasible on hand-made terrain -------------------------------------------------------


def _flat_scenario(**changes) -> Scenario:
    base = {
        "map": {"x_km": [-25, 50], "y_km": [-25, 50], "grid_m": 1000},
        "goal": {"x_km": 25, "y_km": 25},
        "terrain": {"natural": {"method": "flat"}, "mountains": []},
        "radars": [],
    }
    return Scenario.from_dict(base).updated(changes)


def test_straight_climb_on_flat_ground_is_feasible():
    s = _flat_scenario()
    heights, grid = _composed(s)
    assert straight_climb_feasible(s, heights, grid)


@pytest.mark.parametrize(
    ("peak_km", "height_m", "decay_per_km2", "feasible"),
    [
        # A 2000 m needle on the route 2.83 km from the start: from 100 m AGL a 15° climb reaches
        # 100 + 2828 tan(15°) = 858 m there, far below the crest.
        ((2, 2), 2000, 1.0, False),
        # 10 km down the route the same climb reaches 2780 m and clears it.
        ((7, 7), 2000, 1.0, True),
        # The same peak, far from the route, does not block it.
        ((40, -20), 2000, 1.0, True),
        # A broad 2990 m hill that a 15° climb can clear in time but which leaves less than the 30 m
        # clearance under the 3000 m ceiling; 90 m lower it leaves enough.
        ((20, 20), 2990, 0.001, False),
        ((20, 20), 2900, 0.001, True),
    ],
    ids=["needle-on-route", "needle-down-route", "needle-aside", "under-ceiling", "below-ceiling"],
)
def test_straight_climb_blocked_by_a_peak_or_the_ceiling(peak_km, height_m, decay_per_km2, feasible):
    s = _flat_scenario(
        terrain={
            "mountains": [{"x_km": peak_km[0], "y_km": peak_km[1], "height_m": height_m}],
            "mountain_decay_per_km2": decay_per_km2,
        }
    )
    assert bool(straight_climb_feasible(s, *_composed(s))) is feasible


# --- the DEM scenario (§7d) ------------------------------------------------------------------------------


def test_shipped_dem_yaml_is_the_rule_output():
    assert generate_dem_scenario() == dem_scenario()


def test_shipped_dem_yaml_matches_the_rule_except_normalisation():
    generated, shipped = generate_dem_scenario().to_dict(), dem_scenario().to_dict()
    generated.pop("normalisation")
    shipped.pop("normalisation")
    assert generated == shipped


def test_dem_scenario_layout():
    s = dem_scenario()
    assert isinstance(s.terrain.natural, DEMTerrain)
    assert s.terrain.natural == DEMTerrain(
        file="topobathy.npz", array="topo", lat_deg=(49.10, 49.98), lon_deg=(-123.38, -122.02)
    )
    assert (s.start.x_km, s.start.y_km) == (25.0, 25.0)
    assert (s.goal.x_km, s.goal.y_km) == (73.0, 73.0)
    # Map = the window projected equirectangularly about its centre, cut to whole 0.5 km cells.
    lat_c = math.radians((49.10 + 49.98) / 2)
    width = 6371.0 * math.cos(lat_c) * math.radians(-122.02 + 123.38)
    height = 6371.0 * math.radians(49.98 - 49.10)
    assert window_extent_km(s.terrain.natural) == pytest.approx((width, height), rel=1e-12)
    assert s.map.x_km == (0.0, math.floor(width / 0.5) * 0.5) == (0.0, 98.0)
    assert s.map.y_km == (0.0, math.floor(height / 0.5) * 0.5) == (0.0, 97.5)
    # Everything else as the paper scenario.
    paper = paper_scenario()
    for field in ("uav", "time", "radar_model", "cost", "profile"):
        assert getattr(s, field) == getattr(paper, field), field
    # Goal at least two turn radii inside every edge.
    edge = min(73.0, 98.0 - 73.0, 73.0, 97.5 - 73.0)
    assert edge >= paper.goal_edge_margin_km


def test_dem_mountains_are_the_highest_separated_local_maxima():
    s = dem_scenario()
    grid = grid_for(s)
    heights = dem_heights(s.terrain.natural, grid)
    mountains = s.terrain.mountains
    assert len(mountains) == 3
    for a in range(3):
        for b in range(a + 1, 3):
            assert (
                math.hypot(mountains[a].x_km - mountains[b].x_km, mountains[a].y_km - mountains[b].y_km)
                >= 15.0
            )
    is_peak = (heights == ndimage.maximum_filter(heights, size=3, mode="nearest")) & (heights > 0.0)
    chosen = set()
    for m in mountains:
        i, j = round(m.x_km / 0.5), round(m.y_km / 0.5)
        assert is_peak[i, j]
        assert m.height_m == pytest.approx(heights[i, j], abs=0.05)
        chosen.add((i, j))
    assert [m.height_m for m in mountains] == sorted((m.height_m for m in mountains), reverse=True)
    # Greedy rule: every higher local maximum that was not chosen lies within 15 km of a chosen one.
    lowest = min(m.height_m for m in mountains)
    for i, j in np.argwhere(is_peak):
        if (i, j) in chosen or heights[i, j] <= lowest:
            continue
        x, y = grid.x_nodes[i] / 1e3, grid.y_nodes[j] / 1e3
        assert any(
            math.hypot(x - m.x_km, y - m.y_km) < 15.0 for m in mountains if m.height_m >= heights[i, j] - 0.05
        )


def test_dem_radars_one_per_quadrant_on_its_highest_node():
    s = dem_scenario()
    grid = grid_for(s)
    heights = dem_heights(s.terrain.natural, grid)
    assert len(s.radars) == 4
    centre_x, centre_y = grid.x_nodes[grid.nx // 2] / 1e3, grid.y_nodes[grid.ny // 2] / 1e3
    gx, gy = (a / 1e3 for a in grid.mesh())
    quadrants = set()
    for r in s.radars:
        assert (r.mast_m, r.z_m, r.ref_range_km, r.ref_rcs_m2) == (20.0, None, 100.0, 0.1)
        east, north = r.x_km >= centre_x, r.y_km >= centre_y
        quadrants.add((east, north))
        in_quadrant = ((gx >= centre_x) == east) & ((gy >= centre_y) == north)
        i, j = round(r.x_km / 0.5), round(r.y_km / 0.5)
        assert heights[i, j] == heights[in_quadrant].max()
    assert len(quadrants) == 4


def test_dem_scenario_validates_builds_and_has_a_straight_climb():
    s = dem_scenario()
    assert Scenario.from_dict(s.to_dict()) == s
    built = build_scenario(s)
    assert built.terrain.shape == (197, 196)
    assert built.floors.shape == (4, 197, 196)
    assert np.all(built.floors >= built.terrain)
    for xyz in built.radar_xyz:
        assert xyz[2] == pytest.approx(float(built.height(np.array(xyz[0]), np.array(xyz[1]))) + 20.0)
    assert straight_climb_feasible(s, built.terrain, built.grid)
    # For real terrain the mountains only define the threat: the raster is not reshaped.
    np.testing.assert_array_equal(built.terrain, dem_heights(s.terrain.natural, built.grid))


# --- the DEM loader (§2.5) ---------------------------------------------------------------------------------


def _raw_topobathy():
    from matplotlib import cbook

    with np.load(cbook.get_sample_data("topobathy.npz", asfileobj=False)) as data:
        return (
            data["topo"].astype(float),
            data["latitude"].astype(float),
            data["longitude"].astype(float) - 360.0,
        )


def test_dem_heights_sample_the_raster_at_the_projected_nodes():
    # Independent oracle: RegularGridInterpolator over (lat, lon) at the equirectangular
    # coordinates of a few grid nodes (rows north->south and 0..360 longitudes handled).
    topo, lat, lon = _raw_topobathy()
    assert np.all(np.diff(lat) > 0) and np.all(np.diff(lon) > 0)
    oracle = RegularGridInterpolator((lat, lon), topo, method="linear")
    config = DEMTerrain()
    grid = GridSpec(0.0, 0.0, 500.0, 197, 196)
    heights = dem_heights(config, grid)
    lat_c = math.radians((49.10 + 49.98) / 2)
    for i, j in ((0, 0), (196, 195), (60, 140), (150, 20), (98, 98)):
        x, y = grid.x_nodes[i], grid.y_nodes[j]
        point_lat = 49.10 + math.degrees(y / 6_371_000.0)
        point_lon = -123.38 + math.degrees(x / (6_371_000.0 * math.cos(lat_c)))
        assert heights[i, j] == pytest.approx(max(float(oracle([[point_lat, point_lon]])[0]), 0.0), abs=1e-6)


def test_dem_heights_of_a_north_up_raster_with_a_scalar_extent():
    # jacksboro_fault_dem.npz stores rows north -> south (ymin = 36.733 > ymax = 36.446) and only a
    # scalar extent; the loader must flip it so that y grows northward (model.md §2.1).
    from matplotlib import cbook

    with np.load(cbook.get_sample_data("jacksboro_fault_dem.npz", asfileobj=False)) as data:
        elevation = data["elevation"].astype(float)
        lat = np.linspace(float(data["ymin"]), float(data["ymax"]), elevation.shape[0])
        lon = np.linspace(float(data["xmin"]), float(data["xmax"]), elevation.shape[1])
    assert lat[0] > lat[-1]
    oracle = RegularGridInterpolator((lat[::-1], lon), elevation[::-1], method="linear")
    config = DEMTerrain(
        file="jacksboro_fault_dem.npz", array="elevation", lat_deg=(36.5, 36.7), lon_deg=(-84.35, -84.1)
    )
    grid = GridSpec(0.0, 0.0, 500.0, 45, 45)
    heights = dem_heights(config, grid)
    lat_c = math.radians(36.6)
    for i, j in ((0, 0), (44, 0), (0, 44), (44, 44), (10, 31)):
        point_lat = 36.5 + math.degrees(grid.y_nodes[j] / 6_371_000.0)
        point_lon = -84.35 + math.degrees(grid.x_nodes[i] / (6_371_000.0 * math.cos(lat_c)))
        assert heights[i, j] == pytest.approx(float(oracle([[point_lat, point_lon]])[0]), abs=1e-6)


def test_dem_heights_are_at_or_above_the_sea_floor():
    grid = GridSpec(0.0, 0.0, 500.0, 197, 196)
    heights = dem_heights(DEMTerrain(), grid)
    assert heights.min() == 0.0  # the window has some sea, raised to 0 m
    assert 2000.0 < heights.max() <= 2205.0
    raw = dem_heights(DEMTerrain(sea_floor_m=-5000.0), grid)
    assert raw.min() < 0.0
    np.testing.assert_array_equal(heights, np.maximum(raw, 0.0))
    raised = dem_heights(DEMTerrain(sea_floor_m=50.0), grid)
    assert raised.min() == 50.0


def test_dem_window_outside_the_raster_raises():
    # topobathy.npz covers lat 48.02..49.98: a window reaching 50.5° N is outside.
    config = DEMTerrain(lat_deg=(49.5, 50.5))
    lat_c = math.radians(50.0)
    width = 6_371_000.0 * math.cos(lat_c) * math.radians(1.36)
    grid = GridSpec(0.0, 0.0, 500.0, int(width // 500), int(6_371_000.0 * math.radians(1.0) // 500))
    with pytest.raises(ScenarioError) as info:
        dem_heights(config, grid)
    assert info.value.field == "map"
    # A map larger than the window also reaches outside the raster, caught when the scenario builds.
    bigger = dem_scenario().updated({"map": {"x_km": [0, 400]}})
    with pytest.raises(ScenarioError) as info:
        terrain_heights(bigger)
    assert info.value.field == "map"


def test_dem_missing_file_or_array_raises():
    grid = GridSpec(0.0, 0.0, 500.0, 10, 10)
    with pytest.raises(ScenarioError) as info:
        dem_heights(DEMTerrain(file="no-such-dem.npz"), grid)
    assert info.value.field == "terrain.natural.file"
    with pytest.raises(ScenarioError) as info:
        dem_heights(DEMTerrain(array="elevation"), grid)
    assert info.value.field == "terrain.natural.array"
    assert "topo" in str(info.value)


def test_flat_terrain_is_shared_across_seeds():
    # Deterministic surfaces do not depend on the terrain seed: one cache entry serves every seed.
    a = terrain_heights(_flat_scenario(terrain={"seed": 1, "natural": {"method": "flat", "height_m": 5.0}}))
    b = terrain_heights(_flat_scenario(terrain={"seed": 2, "natural": {"method": "flat", "height_m": 5.0}}))
    assert b is a
    np.testing.assert_array_equal(a, np.full((76, 76), 5.0))
