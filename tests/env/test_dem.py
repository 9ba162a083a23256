"""DEM rasters as real products deliver them: GeoTIFF, longitude conventions incl. the
antimeridian, missing data in every form, and identities keyed by the file's content.

Synthetic rasters are planes, h = a * lon + b * lat + c (lon unwrapped across the antimeridian), so
bilinear resampling reproduces them exactly and every expected height is computed by hand.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from uav_penetration_env import cache
from uav_penetration_env.build import terrain_heights
from uav_penetration_env.catalogue import dem_scenario
from uav_penetration_env.dem import EARTH_RADIUS_M, _fill_holes, dem_heights, load_raster
from uav_penetration_env.scenario import DEMTerrain, ScenarioError
from uav_penetration_env.terrain import GridSpec

A_PER_DEG_LON, B_PER_DEG_LAT, C_M = 100.0, 50.0, 300.0


def plane(lon_unwrapped, lat):
    return A_PER_DEG_LON * lon_unwrapped + B_PER_DEG_LAT * lat + C_M


def write_npz(path, lon_stored, lat, heights=None):
    lon_unwrapped = np.unwrap(np.asarray(lon_stored, dtype=float), period=360.0)
    if heights is None:
        heights = plane(lon_unwrapped[None, :] - lon_unwrapped[0], np.asarray(lat)[:, None])
    np.savez(
        path, topo=heights, latitude=np.asarray(lat, dtype=float), longitude=np.asarray(lon_stored, float)
    )
    return str(path)


def expected_heights(config: DEMTerrain, grid: GridSpec, lon_origin_unwrapped: float) -> np.ndarray:
    """The plane at the grid nodes' projected coordinates (the oracle)."""
    lat_c = math.radians(0.5 * sum(config.lat_deg))
    gx, gy = grid.mesh()
    lon = config.lon_deg[0] + np.degrees(gx / (EARTH_RADIUS_M * math.cos(lat_c)))
    lat = config.lat_deg[0] + np.degrees(gy / EARTH_RADIUS_M)
    return plane(lon - lon_origin_unwrapped, lat)


GRID = GridSpec(0.0, 0.0, 2000.0, 20, 20)  # 38 km x 38 km: about 0.53 deg of longitude at 50 N
LAT = np.arange(49.0, 51.0001, 0.05)


# --- longitudes --------------------------------------------------------------------------------------


def test_a_raster_stored_past_180_is_read_across_the_antimeridian(tmp_path):
    file = write_npz(tmp_path / "am.npz", np.arange(179.0, 181.0001, 0.05), LAT)
    config = DEMTerrain(file=file, lat_deg=(49.5, 50.0), lon_deg=(179.5, 180.3))
    np.testing.assert_allclose(dem_heights(config, GRID), expected_heights(config, GRID, 179.0), atol=1e-9)
    # A window east of the antimeridian selects the same terrain written in [-180, 180) or past 180.
    signed = DEMTerrain(file=file, lat_deg=(49.5, 50.0), lon_deg=(-179.9, -179.1))
    unwrapped = DEMTerrain(file=file, lat_deg=(49.5, 50.0), lon_deg=(180.1, 180.9))
    np.testing.assert_allclose(dem_heights(signed, GRID), dem_heights(unwrapped, GRID), atol=1e-9)
    np.testing.assert_allclose(
        dem_heights(unwrapped, GRID), expected_heights(unwrapped, GRID, 179.0), atol=1e-9
    )


def test_a_raster_stored_in_signed_longitudes_across_the_antimeridian(tmp_path):
    stored = np.arange(179.0, 181.0001, 0.05)
    stored = np.where(stored >= 180.0, stored - 360.0, stored)  # 179 .. 179.95, -180 .. -179
    file = write_npz(tmp_path / "signed.npz", stored, LAT)
    raster = load_raster(DEMTerrain(file=file))
    assert np.all(np.diff(raster.longitude) > 0)
    assert raster.longitude[0] == pytest.approx(179.0) and raster.longitude[-1] == pytest.approx(181.0)
    config = DEMTerrain(file=file, lat_deg=(49.5, 50.0), lon_deg=(179.6, 180.4))
    np.testing.assert_allclose(dem_heights(config, GRID), expected_heights(config, GRID, 179.0), atol=1e-9)


def test_a_window_outside_the_raster_is_refused_with_the_true_extent(tmp_path):
    file = write_npz(tmp_path / "am.npz", np.arange(179.0, 181.0001, 0.05), LAT)
    with pytest.raises(ScenarioError) as info:
        dem_heights(DEMTerrain(file=file, lat_deg=(49.5, 50.0), lon_deg=(10.0, 11.0)), GRID)
    assert info.value.field == "map"
    assert "lon 179.0000..181.0000" in str(info.value)
    assert "lat 49.0000..51.0000" in str(info.value)


def test_a_0_to_360_raster_takes_windows_in_either_convention(tmp_path):
    file = write_npz(tmp_path / "east.npz", np.arange(200.0, 202.0001, 0.05), LAT)
    config = DEMTerrain(file=file, lat_deg=(49.5, 50.0), lon_deg=(200.1, 201.1))
    heights = dem_heights(config, GRID)
    np.testing.assert_allclose(heights, expected_heights(config, GRID, 200.0), atol=1e-9)
    signed = DEMTerrain(file=file, lat_deg=(49.5, 50.0), lon_deg=(-159.9, -158.9))
    np.testing.assert_allclose(dem_heights(signed, GRID), heights, atol=1e-9)


def test_unordered_longitudes_are_refused(tmp_path):
    stored = np.arange(10.0, 12.0001, 0.05)
    stored[[3, 4]] = stored[[4, 3]]
    file = write_npz(tmp_path / "bad.npz", stored, LAT)
    with pytest.raises(ScenarioError, match="longitudes"):
        load_raster(DEMTerrain(file=file))


# --- missing data ------------------------------------------------------------------------------------


def _raster_with_hole(tmp_path, value, cells=((14, 16),)):
    lon = np.arange(10.0, 12.0001, 0.05)
    heights = plane(lon[None, :] - 10.0, LAT[:, None])
    for i, j in cells:
        heights[i, j] = value
    return write_npz(tmp_path / "hole.npz", lon, LAT, heights), heights


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf, -32768.0, -99999.0, 32767.0])
def test_missing_data_under_the_map_is_refused_naming_the_cells(tmp_path, value):
    file, _ = _raster_with_hole(tmp_path, value)
    config = DEMTerrain(file=file, lat_deg=(49.5, 50.5), lon_deg=(10.5, 11.5))
    with pytest.raises(ScenarioError) as info:
        dem_heights(config, GRID)
    message = str(info.value)
    assert info.value.field == "terrain.natural.file"
    assert "1 missing cells" in message and "lat 49.7000 lon 10.8000" in message
    assert "fill_max_cells >= 1" in message


def test_a_declared_nodata_value_counts_as_missing(tmp_path):
    # -9999 is a possible ocean depth (the deepest trench is about -10 935 m): missing only when declared.
    file, _ = _raster_with_hole(tmp_path, -9999.0)
    config = DEMTerrain(file=file, lat_deg=(49.5, 50.5), lon_deg=(10.5, 11.5), sea_floor_m=-20_000.0)
    assert dem_heights(config, GRID).min() < -5000.0
    with pytest.raises(ScenarioError, match="1 missing cells"):
        dem_heights(DEMTerrain(file=file, lat_deg=(49.5, 50.5), lon_deg=(10.5, 11.5), nodata=-9999.0), GRID)


def test_small_holes_are_filled_with_the_nearest_valid_height(tmp_path):
    file, heights = _raster_with_hole(tmp_path, np.nan, cells=((14, 16), (14, 17)))
    config = DEMTerrain(file=file, lat_deg=(49.5, 50.5), lon_deg=(10.5, 11.5), fill_max_cells=2)
    raster = load_raster(config)
    whole = slice(0, heights.shape[0]), slice(0, heights.shape[1])
    filled = _fill_holes(raster.heights, *whole, config, raster)
    # Brute-force oracle: each hole cell takes the height of one of its nearest valid cells.
    valid = np.argwhere(np.isfinite(raster.heights))
    for cell in ((14, 16), (14, 17)):
        distance = np.hypot(*(valid - cell).T)
        nearest = valid[distance == distance.min()]
        assert filled[cell] in {raster.heights[tuple(n)] for n in nearest}
    untouched = np.isfinite(raster.heights)
    np.testing.assert_array_equal(filled[untouched], raster.heights[untouched])
    assert np.isfinite(dem_heights(config, GRID)).all()
    with pytest.raises(ScenarioError, match="largest hole 2 cells"):
        dem_heights(DEMTerrain(file=file, lat_deg=(49.5, 50.5), lon_deg=(10.5, 11.5), fill_max_cells=1), GRID)


def test_missing_data_outside_the_map_is_ignored(tmp_path):
    file, _ = _raster_with_hole(tmp_path, np.nan, cells=((1, 1),))  # far south-west of the window
    config = DEMTerrain(file=file, lat_deg=(49.5, 50.5), lon_deg=(10.5, 11.5))
    np.testing.assert_allclose(dem_heights(config, GRID), expected_heights(config, GRID, 10.0), atol=1e-9)


@pytest.mark.parametrize(
    ("changes", "field"),
    [({"band": 0}, "band"), ({"fill_max_cells": -1}, "fill_max_cells"), ({"nodata": float("nan")}, "nodata")],
)
def test_bad_missing_data_settings_are_refused(changes, field):
    with pytest.raises(ScenarioError) as info:
        DEMTerrain(**changes)
    assert info.value.field == field


# --- GeoTIFF -----------------------------------------------------------------------------------------

rasterio = pytest.importorskip("rasterio", reason="GeoTIFF needs the geo extra (rasterio)")


def write_geotiff(path, heights_north_up, west, north, step, nodata=None, crs="EPSG:4326"):
    from affine import Affine

    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        height=heights_north_up.shape[0],
        width=heights_north_up.shape[1],
        count=1,
        dtype="float32",
        crs=crs,
        transform=Affine(step, 0.0, west, 0.0, -step, north),
        nodata=nodata,
    ) as target:
        target.write(heights_north_up.astype(np.float32), 1)
    return str(path)


def _geotiff_plane(tmp_path, nodata=None, hole=None):
    step = 0.05
    lon = 10.0 + (np.arange(41) + 0.5) * step  # cell centres
    lat = 51.0 - (np.arange(41) + 0.5) * step  # north-up rows
    heights = plane(lon[None, :] - 10.0, lat[:, None])
    if hole is not None:
        heights[hole] = nodata
    return write_geotiff(tmp_path / "dem.tif", heights, 10.0, 51.0, step, nodata=nodata), heights


def test_a_geotiff_is_read_at_its_cell_centres(tmp_path):
    file, _ = _geotiff_plane(tmp_path)
    config = DEMTerrain(file=file, lat_deg=(49.5, 50.5), lon_deg=(10.5, 11.5))
    # float32 storage: the plane's heights (< 1000 m) are exact to about 1e-4 m.
    np.testing.assert_allclose(dem_heights(config, GRID), expected_heights(config, GRID, 10.0), atol=1e-3)


def test_a_geotiff_nodata_value_is_missing_data(tmp_path):
    file, _ = _geotiff_plane(tmp_path, nodata=-9999.0, hole=(26, 16))
    config = DEMTerrain(file=file, lat_deg=(49.5, 50.5), lon_deg=(10.5, 11.5))
    with pytest.raises(ScenarioError, match="1 missing cells"):
        dem_heights(config, GRID)
    filled = dem_heights(
        DEMTerrain(file=file, lat_deg=(49.5, 50.5), lon_deg=(10.5, 11.5), fill_max_cells=1), GRID
    )
    assert np.isfinite(filled).all() and filled.min() > 0


def test_a_projected_geotiff_is_refused(tmp_path):
    heights = np.full((10, 10), 100.0)
    file = write_geotiff(tmp_path / "utm.tif", heights, 500_000.0, 5_500_000.0, 30.0, crs="EPSG:32610")
    with pytest.raises(ScenarioError, match="geographic coordinates"):
        load_raster(DEMTerrain(file=file))


def test_a_damaged_geotiff_is_refused(tmp_path):
    file, _ = _geotiff_plane(tmp_path)
    data = open(file, "rb").read()
    with open(file, "wb") as stream:
        stream.write(data[: len(data) // 3])
    with pytest.raises(ScenarioError) as info:
        load_raster(DEMTerrain(file=file))
    assert info.value.field == "terrain.natural.file"


# --- identities keyed by content ---------------------------------------------------------------------


def test_rewriting_a_raster_in_place_changes_the_hash_and_rebuilds_the_terrain(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENV_VAR, str(tmp_path / "cache"))
    cache.clear_memory()
    lon = np.arange(-123.6, -121.8, 0.02)
    lat = np.arange(48.9, 50.2, 0.02)
    path = tmp_path / "terrain.npz"
    write_npz(path, lon, lat, np.full((lat.size, lon.size), 200.0))
    scenario = dem_scenario().updated({"terrain": {"natural": {"file": str(path)}}})
    first_hash = scenario.hash
    before = terrain_heights(scenario)
    np.testing.assert_allclose(before, 200.0, rtol=1e-12)
    write_npz(path, lon, lat, np.full((lat.size, lon.size), 1000.0))  # same name, 800 m higher
    stat = os.stat(path)
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000_000))
    cache.clear_memory()
    rebuilt = dem_scenario().updated({"terrain": {"natural": {"file": str(path)}}})
    assert rebuilt.hash != first_hash
    np.testing.assert_allclose(terrain_heights(rebuilt), 1000.0, rtol=1e-12)


def test_scenarios_that_read_no_file_keep_their_field_hash():
    from uav_penetration_env import paper_scenario

    assert paper_scenario().input_files() == {}
    assert dem_scenario().input_files() == {"terrain.natural.file": "topobathy.npz"}
