"""Real terrain from an elevation raster and the DEM scenario (model.md §2.5, §7d).

The default raster is matplotlib's bundled ``topobathy.npz`` (Vancouver Island / Coast Mountains;
no download). A geographic window is projected to local metres by an equirectangular projection
about its centre (error negligible over 100 km), with the map origin at the window's south-west
corner, and resampled bilinearly to the scenario grid.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy import ndimage

from uav_penetration_env.scenario import DEMTerrain, ScenarioError
from uav_penetration_env.terrain import GridSpec
from uav_penetration_env.types import FloatArray

EARTH_RADIUS_M = 6_371_000.0  # mean earth radius for the local projection [m]


def _resolve(file: str) -> Path:
    path = Path(file).expanduser()
    if path.exists():
        return path
    from matplotlib import cbook

    try:
        return Path(cbook.get_sample_data(file, asfileobj=False))
    except (OSError, ValueError) as error:
        raise ScenarioError(
            "terrain.natural.file", file, f"an existing .npz path or a matplotlib sample file ({error})"
        ) from None


def load_raster(config: DEMTerrain) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Read heights [m] and their latitude/longitude vectors [deg] from the configured file.

    Two layouts are read: ``latitude``/``longitude`` coordinate vectors (``topobathy.npz``), or the
    scalar extent ``xmin, xmax, ymin, ymax`` in degrees (``jacksboro_fault_dem.npz``, whose rows
    run north to south when ``ymin > ymax``). Longitudes in [0, 360) are mapped to [-180, 180).

    Returns:
        heights (n_lat, n_lon) with latitude ascending along axis 0, latitude (n_lat,), longitude (n_lon,).
    """
    path = _resolve(config.file)
    try:
        with np.load(path, allow_pickle=False) as data:
            if config.array not in data.files:
                raise ScenarioError(
                    "terrain.natural.array",
                    config.array,
                    f"one of the arrays in {path.name}: {', '.join(data.files)}",
                )
            heights = np.asarray(data[config.array], dtype=np.float64)
            if "latitude" in data.files and "longitude" in data.files:
                latitude = np.asarray(data["latitude"], dtype=np.float64)
                longitude = np.asarray(data["longitude"], dtype=np.float64)
            elif {"xmin", "xmax", "ymin", "ymax"} <= set(data.files):
                longitude = np.linspace(float(data["xmin"]), float(data["xmax"]), heights.shape[1])
                latitude = np.linspace(float(data["ymin"]), float(data["ymax"]), heights.shape[0])
            else:
                raise ScenarioError(
                    "terrain.natural.file",
                    str(path),
                    "an .npz with latitude/longitude vectors or xmin/xmax/ymin/ymax",
                )
    except (OSError, ValueError) as error:
        if isinstance(error, ScenarioError):
            raise
        raise ScenarioError("terrain.natural.file", str(path), f"a readable .npz raster ({error})") from None
    if heights.ndim != 2 or heights.shape != (latitude.size, longitude.size):
        raise ScenarioError(
            "terrain.natural.array",
            config.array,
            f"a 2-D raster matching its coordinate vectors, got {heights.shape}",
        )
    longitude = np.mod(longitude + 180.0, 360.0) - 180.0
    if latitude[0] > latitude[-1]:
        latitude, heights = latitude[::-1], heights[::-1]
    if longitude[0] > longitude[-1]:
        longitude, heights = longitude[::-1], heights[:, ::-1]
    return heights, latitude, longitude


def window_extent_km(config: DEMTerrain) -> tuple[float, float]:
    """Width (east) and height (north) [km] of the projected window."""
    lat_c = math.radians(0.5 * (config.lat_deg[0] + config.lat_deg[1]))
    width = EARTH_RADIUS_M * math.cos(lat_c) * math.radians(config.lon_deg[1] - config.lon_deg[0])
    height = EARTH_RADIUS_M * math.radians(config.lat_deg[1] - config.lat_deg[0])
    return width / 1000.0, height / 1000.0


def dem_heights(config: DEMTerrain, grid: GridSpec) -> FloatArray:
    """Resample the raster window onto ``grid`` (origin at the window's south-west corner) [m].

    Heights below ``sea_floor_m`` (the sea) are raised to it: the UAV flies over the surface.

    Raises:
        ScenarioError: the grid reaches outside the raster or onto missing data.
    """
    heights, latitude, longitude = load_raster(config)
    lat_c = math.radians(0.5 * (config.lat_deg[0] + config.lat_deg[1]))
    gx, gy = grid.mesh()
    lon = config.lon_deg[0] + np.degrees(gx / (EARTH_RADIUS_M * math.cos(lat_c)))
    lat = config.lat_deg[0] + np.degrees(gy / EARTH_RADIUS_M)
    tolerance = 1e-9
    if (
        lon.min() < longitude[0] - tolerance
        or lon.max() > longitude[-1] + tolerance
        or lat.min() < latitude[0] - tolerance
        or lat.max() > latitude[-1] + tolerance
    ):
        raise ScenarioError(
            "map",
            f"lon {lon.min():.3f}..{lon.max():.3f}, lat {lat.min():.3f}..{lat.max():.3f}",
            f"a map inside the raster (lon {longitude[0]:.3f}..{longitude[-1]:.3f}, lat {latitude[0]:.3f}..{latitude[-1]:.3f})",
        )
    row = np.interp(lat, latitude, np.arange(latitude.size))
    col = np.interp(lon, longitude, np.arange(longitude.size))
    resampled = ndimage.map_coordinates(heights, [row, col], order=1, mode="nearest")
    if not np.all(np.isfinite(resampled)):
        raise ScenarioError("terrain.natural.file", config.file, "no missing data (NaN) inside the map")
    return np.maximum(resampled, config.sea_floor_m)
