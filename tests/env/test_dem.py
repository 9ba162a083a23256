"""DEM rasters as real products deliver them: GeoTIFF, longitude conventions incl. the
antimeridian, missing data in every form, and identities keyed by the file's content.

Synthetic rasters are planes, h = a * lon + b * lat + c (lon unwrapped across the antimeridian), so
bilinear resampling reproduces them exactly and every expected height is computed by hand.
"""

from __future__ import annotations

import hashlib
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


def test_a_descending_raster_across_the_antimeridian_is_flipped(tmp_path):
    stored = np.arange(179.0, 181.0001, 0.05)[::-1]  # east to west: -179 .. -180, 179.95 .. 179
    stored = np.where(stored >= 180.0, stored - 360.0, stored)
    heights = plane(np.where(stored < 0.0, stored + 360.0, stored)[None, :] - 179.0, LAT[:, None])
    file = write_npz(tmp_path / "desc.npz", stored, LAT, heights)
    raster = load_raster(DEMTerrain(file=file))
    assert raster.longitude[0] == pytest.approx(179.0) and raster.longitude[-1] == pytest.approx(181.0)
    config = DEMTerrain(file=file, lat_deg=(49.5, 50.0), lon_deg=(179.5, 180.3))
    np.testing.assert_allclose(dem_heights(config, GRID), expected_heights(config, GRID, 179.0), atol=1e-9)


@pytest.mark.parametrize(
    ("start", "window"), [(0.0, (-0.8, 0.8)), (-180.0, (179.2, 180.8))], ids=["0-360", "signed"]
)
def test_a_global_raster_serves_a_window_across_its_seam(tmp_path, start, window):
    # The same periodic surface stored from `start` (the window crosses its first/last column) and
    # from a longitude that puts the window inside: the same cells, so the same terrain.
    def surface(lon):
        return 1000.0 + 500.0 * np.cos(np.radians(lon))[None, :] + 10.0 * LAT[:, None]

    seam = np.arange(3600) * 0.1 + start
    inside = np.arange(3600) * 0.1 + start + 90.0
    config = {"lat_deg": (49.5, 50.0), "lon_deg": window}
    across = dem_heights(
        DEMTerrain(file=write_npz(tmp_path / "seam.npz", seam, LAT, surface(seam)), **config), GRID
    )
    within = dem_heights(
        DEMTerrain(file=write_npz(tmp_path / "inside.npz", inside, LAT, surface(inside)), **config), GRID
    )
    np.testing.assert_allclose(across, within, atol=1e-9)
    # A raster that is not global still refuses a window beyond its edge.
    part = seam[:3000]
    with pytest.raises(ScenarioError, match="a map inside the raster"):
        dem_heights(
            DEMTerrain(file=write_npz(tmp_path / "part.npz", part, LAT, surface(part)), **config), GRID
        )


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
    # -400 m is a possible height (the Dead Sea shore is at -430 m), above any void: missing only when declared.
    file, _ = _raster_with_hole(tmp_path, -400.0, cells=((14, 16),))
    window = {"lat_deg": (49.5, 50.5), "lon_deg": (10.5, 11.5), "sea_floor_m": -20_000.0}
    assert dem_heights(DEMTerrain(file=file, **window), GRID).min() < 1000.0  # the pit, read as a height
    with pytest.raises(ScenarioError, match="1 missing cells"):
        dem_heights(DEMTerrain(file=file, nodata=-400.0, **window), GRID)


@pytest.mark.parametrize("cells", [((14, 16),), tuple((i, j) for i in (13, 14, 15) for j in (15, 16, 17))])
def test_an_undeclared_void_among_land_is_missing(tmp_path, cells):
    # SRTM-style -9999 voids (one cell, or a 3 x 3 patch) on a plateau at about 2 800 m, not declared.
    file, _ = _raster_with_hole(tmp_path, -9999.0, cells=cells)
    config = DEMTerrain(file=file, lat_deg=(49.5, 50.5), lon_deg=(10.5, 11.5), sea_floor_m=-20_000.0)
    with pytest.raises(ScenarioError, match=f"{len(cells)} missing cells"):
        dem_heights(config, GRID)
    filled = dem_heights(DEMTerrain(**{**config.__dict__, "fill_max_cells": len(cells)}), GRID)
    np.testing.assert_allclose(filled, expected_heights(config, GRID, 10.0), atol=200.0)


def test_the_void_rule_keeps_real_ocean_depths():
    from uav_penetration_env.dem import VOID_STEP_M, undeclared_voids

    land = np.full((7, 7), 200.0)
    # A -9999 cell in a smooth trench floor, a flat floor stored in whole metres, a cell just
    # VOID_STEP_M below its neighbours, a pit above -500 m: all real terrain.
    trench = -10_000.0 + np.add.outer(np.arange(7.0), np.arange(7.0))
    trench[3, 3] = -9999.0
    flat = np.full((7, 7), -5000.0)
    step = np.full((7, 7), -1000.0)
    step[3, 3] = -1000.0 - VOID_STEP_M
    shallow = land.copy()
    shallow[3, 3] = -499.0
    for heights in (trench, flat, step, shallow):
        assert not undeclared_voids(heights).any()
    step[3, 3] -= 1.0  # now more than VOID_STEP_M below every neighbour
    assert undeclared_voids(step).sum() == 1
    # A void patch beside missing cells (NaN) and the raster's edge is still a void.
    land[0:2, 0:2] = -9999.0
    land[0, 2] = np.nan
    np.testing.assert_array_equal(np.argwhere(undeclared_voids(land)), [[0, 0], [0, 1], [1, 0], [1, 1]])


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


def write_geotiff(path, heights_north_up, west, north, step, nodata=None, crs="EPSG:4326", mask=None):
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
        if mask is not None:
            target.write_mask(mask)
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


def test_a_geotiff_mask_band_marks_missing_data(tmp_path):
    # No nodata value: the void is marked only by the per-dataset mask (0 = no data); its stored 0 is no height.
    heights = np.full((41, 41), 2000.0)
    heights[26, 16] = 0.0  # under the map
    mask = np.full(heights.shape, 255, np.uint8)
    mask[26, 16] = 0
    file = write_geotiff(tmp_path / "masked.tif", heights, 10.0, 51.0, 0.05, mask=mask)
    window = {"file": file, "lat_deg": (49.5, 50.5), "lon_deg": (10.5, 11.5)}
    with pytest.raises(ScenarioError, match="1 missing cells"):
        dem_heights(DEMTerrain(**window), GRID)
    np.testing.assert_allclose(dem_heights(DEMTerrain(**window, fill_max_cells=1), GRID), 2000.0)


@pytest.mark.parametrize(
    ("crs", "unit"),
    [
        ("EPSG:4807", "grads, meridian paris"),
        ("+proj=longlat +ellps=WGS84 +pm=paris +no_defs", "degrees, meridian paris"),
    ],
)
def test_a_geographic_crs_not_in_greenwich_degrees_is_refused(tmp_path, crs, unit):
    heights = np.full((41, 41), 100.0)
    file = write_geotiff(tmp_path / "ntf.tif", heights, 0.0, 51.0, 0.05, crs=crs)
    with pytest.raises(ScenarioError, match="degrees on the Greenwich meridian") as info:
        load_raster(DEMTerrain(file=file))
    assert unit in str(info.value) and "ntf.tif" in str(info.value)


def test_a_geographic_crs_on_another_datum_in_degrees_is_read(tmp_path):
    heights = np.full((41, 41), 100.0)
    file = write_geotiff(tmp_path / "nad83.tif", heights, 10.0, 51.0, 0.05, crs="EPSG:4269")
    np.testing.assert_allclose(load_raster(DEMTerrain(file=file)).heights, 100.0)


def test_a_geotiff_with_a_sidecar_the_hash_misses_is_refused(tmp_path):
    file, _ = _geotiff_plane(tmp_path)
    statistics = b"<PAMDataset><PAMRasterBand band='1'><Metadata><MDI key='STATISTICS_MEAN'>5</MDI>"
    (tmp_path / "dem.tif.aux.xml").write_bytes(statistics + b"</Metadata></PAMRasterBand></PAMDataset>")
    load_raster(DEMTerrain(file=file))  # statistics change no height
    (tmp_path / "dem.tif.aux.xml").write_bytes(
        statistics.replace(b"<Metadata>", b"<NoDataValue>0</NoDataValue>")
    )
    with pytest.raises(ScenarioError, match=r"\.aux\.xml sidecar"):
        load_raster(DEMTerrain(file=file))
    (tmp_path / "dem.tif.aux.xml").unlink()
    (tmp_path / "dem.tif.msk").write_bytes(b"")
    with pytest.raises(ScenarioError, match=r"\.msk sidecar"):
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


FLAT_LON = np.arange(-123.6, -121.8, 0.02)  # covers the catalogue's DEM scenario window
FLAT_LAT = np.arange(48.9, 50.2, 0.02)


@pytest.fixture
def flat_raster(tmp_path, monkeypatch):
    """Write a flat raster of the given height to one path (a fresh cache), and read the DEM scenario."""
    monkeypatch.setenv(cache.ENV_VAR, str(tmp_path / "cache"))
    cache.clear_memory()
    path = tmp_path / "terrain.npz"

    def write(height_m: float):
        write_npz(path, FLAT_LON, FLAT_LAT, np.full((FLAT_LAT.size, FLAT_LON.size), height_m))
        return path

    def scenario():
        return dem_scenario().updated({"terrain": {"natural": {"file": str(path)}}})

    return write, scenario


def test_rewriting_a_raster_in_place_changes_the_hash_and_rebuilds_the_terrain(flat_raster):
    write, scenario_of_file = flat_raster
    path = write(200.0)
    scenario = scenario_of_file()
    first_hash = scenario.hash
    before = terrain_heights(scenario)
    np.testing.assert_allclose(before, 200.0, rtol=1e-12)
    write(1000.0)  # same name, 800 m higher
    stat = os.stat(path)
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000_000))
    cache.clear_memory()
    rebuilt = scenario_of_file()
    assert rebuilt.hash != first_hash
    np.testing.assert_allclose(terrain_heights(rebuilt), 1000.0, rtol=1e-12)


def test_scenarios_that_read_no_file_keep_their_field_hash():
    from uav_penetration_env import paper_scenario

    assert paper_scenario().input_files() == {}
    assert dem_scenario().input_files() == {"terrain.natural.file": "topobathy.npz"}


def test_a_raster_rewritten_after_the_hash_is_refused_not_built_under_the_old_hash(flat_raster):
    write, scenario_of_file = flat_raster
    path = write(200.0)
    scenario = scenario_of_file()
    old_hash = scenario.hash
    write(900.0)  # rewritten before the build
    with pytest.raises(ScenarioError, match="changed since") as info:
        terrain_heights(scenario)
    assert info.value.field == "terrain.natural.file"
    reloaded = scenario_of_file()
    assert reloaded.hash != old_hash
    np.testing.assert_allclose(terrain_heights(reloaded), 900.0, rtol=1e-12)
    # The hash is made of the digests the build checks against.
    assert reloaded.input_digests["terrain.natural.file"] == hashlib.sha256(path.read_bytes()).hexdigest()
