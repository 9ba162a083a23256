"""Real terrain from an elevation raster and the DEM scenario (model.md §2.5, §7d).

Rasters come as ``.npz`` (the default is matplotlib's bundled ``topobathy.npz``: Vancouver Island /
Coast Mountains, no download) or GeoTIFF (``.tif``/``.tiff``, the format public DEMs are
distributed in; read with ``rasterio``, extra ``geo``). A geographic window is projected to local
metres by an equirectangular projection about its centre (error negligible over 100 km), with the
map origin at the window's south-west corner, and resampled bilinearly to the scenario grid.

Longitudes (model.md §2.5, "longitude convention"): inside the project a raster's longitudes are
one strictly increasing axis that starts in [-180, 180) and may run past 180 (a raster that crosses
the antimeridian, stored either as 179..181 or as 179..180, -180..-179, becomes 179..181). The
window ``lon_deg`` is shifted by a whole number of turns (360 deg) into that frame, so a window
written in [-180, 180) or in [0, 360) selects the same terrain. Columns stored east to west are
flipped (across the antimeridian too), and a raster that goes all the way round serves a window
across its own first and last column (:func:`_wrapped`).

Missing data (model.md §2.5, "missing data"): a cell is missing when it is NaN or infinite, equals
the file's declared nodata value or the scenario's ``nodata``, is masked by a GeoTIFF's mask band
(an internal per-dataset mask or an alpha band), lies outside the heights any terrain can have
(below the deepest ocean trench or above the highest summit: ``[-11 000, 9 000] m``; this catches
sentinels such as -32768 or -3.4e38 that a file does not declare), or is an undeclared void: a
patch of one value deeper than -500 m that sits more than 1 000 m below every valid cell around
it, such as a -9999 void among land heights (:func:`undeclared_voids`). Holes of at most
``fill_max_cells`` raster cells that the map touches are filled with the nearest valid cell's
height; any other missing cell the map touches is refused with a ``ScenarioError`` naming the
cells.

Identity (model.md §2.5, "identity by content"): the file is read once into memory, and the
terrain is parsed from those very bytes; given the digest the scenario's hash was taken from, a
file whose bytes no longer match it is refused instead of built under the old identity.
"""

from __future__ import annotations

import hashlib
import io
import math
import os
import stat
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from uav_penetration_env.files import resolve_data_file, sample_data_missing
from uav_penetration_env.scenario import DEMTerrain, ScenarioError
from uav_penetration_env.terrain import GridSpec
from uav_penetration_env.types import FloatArray

EARTH_RADIUS_M = 6_371_000.0  # mean earth radius for the local projection [m]
# DECISION (model.md §2.5): the heights any terrain on Earth can have [m]: the Challenger Deep is about -10 935 m
# and Everest 8 849 m. Values outside are missing-data sentinels (-9999, -32768, 32767, ...).
VALID_HEIGHT_RANGE_M = (-11_000.0, 9_000.0)
# DECISION (model.md §2.5): an undeclared void is a patch of one value below VOID_BELOW_M that lies more than
# VOID_STEP_M below every valid cell around it. No land is below -430 m (the Dead Sea shore), and no
# real sea floor is a flat-bottomed pit with kilometre-high walls one cell wide: real depths, the
# trenches included, change smoothly from cell to cell, so the rule cannot take them for voids.
VOID_BELOW_M = -500.0
VOID_STEP_M = 1_000.0
GEOTIFF_SUFFIXES = (".tif", ".tiff")
# DECISION (model.md §2.5): a raster file is read whole into memory, so it must be a regular file of at
# most 2 GiB. A device (/dev/zero), a FIFO or a socket is refused before it is opened for reading;
# 2 GiB holds a 1 arc-second raster of 30 000 x 30 000 int16 cells, far beyond any map's window.
MAX_RASTER_BYTES = 2 * 2**30
_MAX_LISTED_CELLS = 5


@dataclass(frozen=True)
class Raster:
    """An elevation raster in the project's conventions.

    Attributes:
        heights: (n_lat, n_lon) heights [m], latitude ascending along axis 0, NaN where missing.
        latitude: (n_lat,) strictly increasing cell-centre latitudes [deg].
        longitude: (n_lon,) strictly increasing cell-centre longitudes [deg]; the first in
            [-180, 180), later ones may exceed 180 (antimeridian crossing).
        path: the file read.
    """

    heights: FloatArray
    latitude: FloatArray
    longitude: FloatArray
    path: Path

    def extent(self) -> str:
        """The raster's coverage, for error messages."""
        return (
            f"lon {self.longitude[0]:.4f}..{self.longitude[-1]:.4f}, "
            f"lat {self.latitude[0]:.4f}..{self.latitude[-1]:.4f}"
        )


def resolve_raster_path(file: str) -> Path:
    """The raster's path: a file on disk, else a matplotlib sample file of that name.

    Raises:
        ScenarioError: ``terrain.natural.file`` names neither.
    """
    path = resolve_data_file(file)
    if path is None:
        raise ScenarioError(
            "terrain.natural.file",
            file,
            f"an existing .npz or GeoTIFF path or a matplotlib sample file{sample_data_missing()}",
        )
    return path


def _read_npz(path: Path, content: bytes, config: DEMTerrain) -> tuple[FloatArray, FloatArray, FloatArray]:
    with np.load(io.BytesIO(content), allow_pickle=False) as data:
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
            longitude = np.linspace(float(data["xmin"]), float(data["xmax"]), heights.shape[-1])
            latitude = np.linspace(float(data["ymin"]), float(data["ymax"]), heights.shape[0])
        else:
            raise ScenarioError(
                "terrain.natural.file",
                str(path),
                "an .npz with latitude/longitude vectors or xmin/xmax/ymin/ymax",
            )
    return heights, latitude, longitude


def _geographic_crs_problem(crs: object) -> str | None:
    """Why a GeoTIFF's CRS cannot be read as longitude/latitude degrees east of Greenwich, or None.

    DECISION (model.md §2.5): a geographic CRS is accepted on any datum (their offsets from WGS84, at most a few
    hundred metres, are below what the scenario grid resolves) but only in degrees on the Greenwich
    meridian; grads or a Paris meridian would put the map at the wrong place, so they are refused.
    """
    if crs is None or not crs.is_geographic:
        return "a raster in geographic coordinates (degrees, e.g. EPSG:4326)"
    unit, _ = crs.units_factor
    meridian = str(crs.to_dict().get("pm", "greenwich")).lower()
    if unit not in ("degree", "degrees") or meridian not in ("greenwich", "0"):
        return f"geographic coordinates in degrees on the Greenwich meridian (this CRS is in {unit}s, meridian {meridian})"
    return None


# What a GDAL sidecar may hold that changes heights (statistics and histograms do not).
_HEIGHT_CHANGING_PAM = (b"NoDataValue", b"<Offset>", b"<Scale>", b"<MaskBand>")


def _refuse_sidecars(path: Path) -> None:
    """Refuse a GeoTIFF whose heights a sidecar file would change: the hash covers the .tif alone.

    DECISION (model.md §2.5): the raster is read from the hashed bytes of the .tif, so a ``.msk`` mask or an
    ``.aux.xml`` that declares nodata, a scale, an offset or a mask is refused instead of ignored;
    an ``.aux.xml`` of statistics alone (GIS tools write them) is no part of the terrain.
    """
    mask = path.with_name(path.name + ".msk")
    aux = path.with_name(path.name + ".aux.xml")
    try:
        aux_changes = aux.is_file() and any(key in aux.read_bytes() for key in _HEIGHT_CHANGING_PAM)
    except OSError:
        aux_changes = True
    for sidecar, found in ((mask, mask.exists()), (aux, aux_changes)):
        if found:
            raise ScenarioError(
                "terrain.natural.file",
                path.name,
                f"a GeoTIFF without a {sidecar.name[len(path.name) :]} sidecar that changes its heights (the "
                "scenario hash covers the .tif alone): fold it in, e.g. gdal_translate -co "
                "GDAL_TIFF_INTERNAL_MASK=YES, or remove it",
            )


def _read_geotiff(
    path: Path, content: bytes, config: DEMTerrain
) -> tuple[FloatArray, FloatArray, FloatArray]:
    try:
        from rasterio.enums import MaskFlags
        from rasterio.io import MemoryFile
    except ImportError:  # pragma: no cover - depends on the installed extras
        raise ScenarioError(
            "terrain.natural.file", str(path), "rasterio to read GeoTIFF: pip install -e '.[geo]'"
        ) from None
    _refuse_sidecars(path)
    with MemoryFile(content) as memory, memory.open() as source:
        problem = _geographic_crs_problem(source.crs)
        if problem is not None:
            raise ScenarioError(
                "terrain.natural.file",
                f"{path.name} (CRS {source.crs})",
                f"{problem}; reproject it first, e.g. gdalwarp -t_srs EPSG:4326",
            )
        if not 1 <= config.band <= source.count:
            raise ScenarioError(
                "terrain.natural.band", config.band, f"a band of {path.name}: 1..{source.count}"
            )
        transform = source.transform
        if transform.b != 0 or transform.d != 0:
            raise ScenarioError("terrain.natural.file", path.name, "a north-up raster (no rotation or shear)")
        heights = source.read(config.band).astype(np.float64)
        scale, offset = source.scales[config.band - 1], source.offsets[config.band - 1]
        nodata = source.nodatavals[config.band - 1]
        flags = source.mask_flag_enums[config.band - 1]
        # GDAL's mask (0 = no data) covers a per-dataset mask band and an alpha band as well as nodata.
        masked = None if MaskFlags.all_valid in flags else source.read_masks(config.band) == 0
    rows, cols = heights.shape
    longitude = transform.c + (np.arange(cols) + 0.5) * transform.a  # cell centres
    latitude = transform.f + (np.arange(rows) + 0.5) * transform.e
    if nodata is not None:
        heights[heights == nodata] = np.nan  # before scaling: the sentinel is a stored value
    if masked is not None:
        heights[masked] = np.nan
    return heights * scale + offset, latitude, longitude


def _unwrap_longitudes(longitude: FloatArray, path: Path) -> FloatArray:
    """One strictly increasing longitude axis starting in [-180, 180) (the project's convention)."""
    longitude = np.mod(longitude + 180.0, 360.0) - 180.0
    longitude = np.unwrap(longitude, period=360.0)
    longitude = longitude - 360.0 * math.floor((longitude[0] + 180.0) / 360.0)
    if longitude.size > 1 and not (np.all(np.diff(longitude) > 0) and longitude[-1] - longitude[0] < 360.0):
        raise ScenarioError(
            "terrain.natural.file",
            str(path),
            "a raster whose longitudes are evenly ordered and span less than 360 deg",
        )
    return longitude


def undeclared_voids(heights: FloatArray) -> np.ndarray:
    """Cells of undeclared voids (model.md §2.5, "missing data"), such as -9999 among land heights.

    A void is a patch of one value below ``VOID_BELOW_M`` lying more than ``VOID_STEP_M`` below
    every valid cell around it. A patch is an 8-connected set of equal cells; a cell belongs to one when each of its 8
    neighbours is equal, missing (NaN) or more than ``VOID_STEP_M`` higher. A patch that shares its
    value with a neighbour outside it (a flat sea floor stored in whole metres) is real terrain, and
    so is one with no valid cell around it to compare with.

    Args:
        heights: (n_lat, n_lon) heights [m], NaN where already missing.

    Returns:
        (n_lat, n_lon) booleans, True on void cells.
    """
    voids = np.zeros(heights.shape, dtype=bool)
    with np.errstate(invalid="ignore"):
        deep = heights < VOID_BELOW_M
    if not deep.any():
        return voids
    rows, cols = np.nonzero(deep)
    r0, r1 = max(rows.min() - 1, 0), min(rows.max() + 2, heights.shape[0])
    c0, c1 = max(cols.min() - 1, 0), min(cols.max() + 2, heights.shape[1])
    block = heights[r0:r1, c0:c1]
    padded = np.pad(block, 1, constant_values=np.nan)
    offsets = [(di, dj) for di in (-1, 0, 1) for dj in (-1, 0, 1) if (di, dj) != (0, 0)]

    def neighbour(array: np.ndarray, di: int, dj: int) -> np.ndarray:
        return array[1 + di : 1 + di + block.shape[0], 1 + dj : 1 + dj + block.shape[1]]

    member = deep[r0:r1, c0:c1].copy()
    walled = np.zeros(block.shape, dtype=bool)  # a valid neighbour far above
    with np.errstate(invalid="ignore"):
        for di, dj in offsets:
            other = neighbour(padded, di, dj)
            far_above = other > block + VOID_STEP_M
            member &= (other == block) | np.isnan(other) | far_above
            walled |= far_above
        padded_member = np.pad(member, 1, constant_values=False)
        leaks = np.zeros(block.shape, dtype=bool)  # an equal neighbour outside the patch
        for di, dj in offsets:
            leaks |= member & (neighbour(padded, di, dj) == block) & ~neighbour(padded_member, di, dj)
    labels, _ = ndimage.label(member, structure=np.ones((3, 3), dtype=bool))
    void_labels = np.setdiff1d(np.unique(labels[member & walled]), np.unique(labels[leaks]))
    voids[r0:r1, c0:c1] = np.isin(labels, void_labels[void_labels > 0])
    return voids


def _read_bytes(path: Path, digest: str | None) -> bytes:
    """The file's bytes, checked against ``digest`` (SHA-256 hex) when given.

    Only a regular file of at most :data:`MAX_RASTER_BYTES` is read: a device would be read until
    memory runs out, and a FIFO would block. The file is opened without blocking and checked
    again on the open descriptor, so a path swapped after the first check is refused too.
    """
    field, expected = "terrain.natural.file", f"a regular file of at most {MAX_RASTER_BYTES} bytes"
    try:
        if not stat.S_ISREG(path.stat().st_mode):
            raise ScenarioError(field, str(path), f"{expected} (not a device, FIFO or folder)")
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(descriptor, "rb") as stream:
            status = os.fstat(stream.fileno())
            if not stat.S_ISREG(status.st_mode):
                raise ScenarioError(field, str(path), f"{expected} (not a device, FIFO or folder)")
            if status.st_size > MAX_RASTER_BYTES:
                raise ScenarioError(field, str(path), f"{expected}, got {status.st_size} bytes")
            content = stream.read(MAX_RASTER_BYTES + 1)
    except OSError as error:
        raise ScenarioError(field, str(path), f"a readable raster file ({error.strerror})") from None
    if len(content) > MAX_RASTER_BYTES:  # grew while it was read
        raise ScenarioError(field, str(path), f"{expected}, got more")
    if digest is not None and hashlib.sha256(content).hexdigest() != digest:
        raise ScenarioError(
            "terrain.natural.file",
            str(path),
            "the file as it was when the scenario was hashed (it changed since; load the scenario again)",
        )
    return content


def load_raster(config: DEMTerrain, digest: str | None = None) -> Raster:
    """Read the configured raster into the project's conventions (see the module docstring).

    Args:
        config: the raster and its window.
        digest: the SHA-256 (hex) the file's bytes must have (the one the scenario's hash was
            taken from); ``None`` reads the file as it is.

    Returns:
        The raster, latitude ascending, longitudes unwrapped, missing cells NaN.

    Raises:
        ScenarioError: an unreadable or malformed file, a missing array or band, a CRS that is
            not degrees on Greenwich, or bytes that do not match ``digest``.
    """
    path = resolve_raster_path(config.file)
    content = _read_bytes(path, digest)
    reader = _read_geotiff if path.suffix.lower() in GEOTIFF_SUFFIXES else _read_npz
    try:
        heights, latitude, longitude = reader(path, content, config)
    except ScenarioError:
        raise
    except Exception as error:  # any reader failure on a damaged or foreign file
        raise ScenarioError(
            "terrain.natural.file",
            str(path),
            f"a readable .npz or GeoTIFF raster ({type(error).__name__}: {error})",
        ) from None
    if heights.ndim != 2 or heights.shape != (latitude.size, longitude.size) or min(heights.shape) < 2:
        raise ScenarioError(
            "terrain.natural.array",
            config.array,
            f"a 2-D raster of at least 2 x 2 cells matching its coordinate vectors, got {heights.shape}",
        )
    if not (np.all(np.isfinite(latitude)) and np.all(np.isfinite(longitude))):
        raise ScenarioError("terrain.natural.file", str(path), "finite latitude and longitude coordinates")
    if latitude[0] > latitude[-1]:
        latitude, heights = latitude[::-1], heights[::-1]
    # East to west, possibly across the antimeridian (-178 .. -180, 179.95 .. 178): judged unwrapped.
    stored = np.unwrap(np.mod(longitude + 180.0, 360.0) - 180.0, period=360.0)
    if stored[0] > stored[-1] and np.all(np.diff(stored) < 0):
        longitude, heights = longitude[::-1], heights[:, ::-1]
    if not np.all(np.diff(latitude) > 0):
        raise ScenarioError("terrain.natural.file", str(path), "strictly ordered latitudes")
    longitude = _unwrap_longitudes(longitude, path)
    missing = ~np.isfinite(heights)
    missing |= (heights < VALID_HEIGHT_RANGE_M[0]) | (heights > VALID_HEIGHT_RANGE_M[1])
    if config.nodata is not None:
        missing |= heights == config.nodata
    heights = np.where(missing, np.nan, heights)
    heights[undeclared_voids(heights)] = np.nan
    return Raster(np.ascontiguousarray(heights), latitude, longitude, path)


def _is_global(longitude: FloatArray) -> tuple[bool, float]:
    """Whether evenly spaced cell centres go all the way round (n cells x step = 360 deg), and the step."""
    step = (longitude[-1] - longitude[0]) / (longitude.size - 1)
    even = np.allclose(np.diff(longitude), step, rtol=1e-6, atol=1e-9)
    return bool(even and abs(longitude.size * step - 360.0) <= 1e-6 * 360.0), float(step)


def _wrapped(raster: Raster, west: float, east: float) -> Raster:
    """The columns of a global raster that cover longitudes ``west..east``, taken round the globe.

    A raster that goes all the way round serves any window, across its own first and last column
    too (0..360 across the prime meridian, -180..180 across the antimeridian): the columns are
    taken modulo the raster's width, shifted by whole turns.
    """
    global_, step = _is_global(raster.longitude)
    if not global_ or (west >= raster.longitude[0] and east <= raster.longitude[-1]):
        return raster
    n = raster.longitude.size
    index = np.arange(
        math.floor((west - raster.longitude[0]) / step) - 1,
        math.ceil((east - raster.longitude[0]) / step) + 2,
    )
    columns, turns = np.mod(index, n), np.floor_divide(index, n)
    longitude = raster.longitude[columns] + 360.0 * turns
    heights = np.ascontiguousarray(raster.heights[:, columns])
    return Raster(heights, raster.latitude, longitude, raster.path)


def window_longitudes(config: DEMTerrain, raster: Raster) -> tuple[float, float]:
    """The window's longitudes shifted by whole turns into the raster's frame (nearest its centre)."""
    west, east = config.lon_deg
    offset = 0.5 * (raster.longitude[0] + raster.longitude[-1]) - 0.5 * (west + east)
    turns = round(offset / 360.0)
    return west + 360.0 * turns, east + 360.0 * turns


def window_extent_km(config: DEMTerrain) -> tuple[float, float]:
    """Width (east) and height (north) [km] of the projected window."""
    lat_c = math.radians(0.5 * (config.lat_deg[0] + config.lat_deg[1]))
    width = EARTH_RADIUS_M * math.cos(lat_c) * math.radians(config.lon_deg[1] - config.lon_deg[0])
    height = EARTH_RADIUS_M * math.radians(config.lat_deg[1] - config.lat_deg[0])
    return width / 1000.0, height / 1000.0


def local_to_lonlat(config: DEMTerrain, x_m: FloatArray, y_m: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Map coordinates [m] back to longitude and latitude [deg]: the inverse of the window's projection.

    The map origin is the window's south-west corner and the projection equirectangular about the
    window's centre latitude (model.md §2.5), as in :func:`dem_heights`.

    Args:
        config: the DEM window.
        x_m: (...) metres east of the origin.
        y_m: (...) metres north of the origin.

    Returns:
        Longitudes in [-180, 180) and latitudes [deg], each shaped like ``x_m``.
    """
    lat_c = math.radians(0.5 * (config.lat_deg[0] + config.lat_deg[1]))
    lon = config.lon_deg[0] + np.degrees(
        np.asarray(x_m, dtype=np.float64) / (EARTH_RADIUS_M * math.cos(lat_c))
    )
    lat = config.lat_deg[0] + np.degrees(np.asarray(y_m, dtype=np.float64) / EARTH_RADIUS_M)
    return (lon + 180.0) % 360.0 - 180.0, lat


def _fill_holes(
    heights: FloatArray, rows: slice, cols: slice, config: DEMTerrain, raster: Raster
) -> FloatArray:
    """Fill the missing cells the map touches (``rows`` x ``cols``) or refuse them.

    DECISION (model.md §2.5): a hole (8-connected missing cells) of at most ``fill_max_cells`` cells is filled with
    the height of the nearest valid cell: it invents no relief a hole did not hide. Holes are sized
    on a crop of the raster extended by ``fill_max_cells`` cells around the used block, so a hole
    that reaches the crop's edge is larger than the limit and is refused, as it should be.
    """
    block = heights[rows, cols]
    if not np.isnan(block).any():
        return heights
    limit = config.fill_max_cells
    margin = limit + 1
    r0, r1 = max(rows.start - margin, 0), min(rows.stop + margin, heights.shape[0])
    c0, c1 = max(cols.start - margin, 0), min(cols.stop + margin, heights.shape[1])
    crop = heights[r0:r1, c0:c1]
    missing = np.isnan(crop)
    labels, _ = ndimage.label(missing, structure=np.ones((3, 3), dtype=bool))
    sizes = np.bincount(labels.ravel())
    used = labels[rows.start - r0 : rows.stop - r0, cols.start - c0 : cols.stop - c0]
    touched = np.unique(used[used > 0])
    too_big = touched[sizes[touched] > limit]
    if too_big.size or not np.any(~missing):
        cells = np.argwhere(np.isin(labels, too_big) if too_big.size else missing)
        listed = "; ".join(
            f"lat {raster.latitude[r0 + i]:.4f} lon {raster.longitude[c0 + j]:.4f}"
            for i, j in cells[:_MAX_LISTED_CELLS]
        )
        largest = int(sizes[too_big].max()) if too_big.size else int(missing.sum())
        raise ScenarioError(
            "terrain.natural.file",
            raster.path.name,
            f"no missing data (NaN, nodata, masked, out-of-range heights or voids) under the map: {len(cells)} missing cells "
            f"({listed}{'; ...' if len(cells) > _MAX_LISTED_CELLS else ''}), largest hole {largest} cells; "
            f"set terrain.natural.fill_max_cells >= {largest} to fill holes that size, or move the window",
        )
    _, (near_i, near_j) = ndimage.distance_transform_edt(missing, return_indices=True)
    fillable = np.isin(labels, touched)
    filled = heights.copy()
    filled[r0:r1, c0:c1][fillable] = crop[near_i[fillable], near_j[fillable]]
    return filled


def dem_heights(config: DEMTerrain, grid: GridSpec, digest: str | None = None) -> FloatArray:
    """Resample the raster window onto ``grid`` (origin at the window's south-west corner) [m].

    Heights below ``sea_floor_m`` (the sea) are raised to it: the UAV flies over the surface.

    Args:
        config: the raster and its window (model.md §2.5).
        grid: the scenario grid; node (i, j) is at (x0 + i dx, y0 + j dx) metres east/north.
        digest: the SHA-256 the raster's bytes must have (see :func:`load_raster`).

    Returns:
        (nx, ny) heights [m].

    Raises:
        ScenarioError: the grid reaches outside the raster (the message gives the raster's true
            extent in the project's longitude convention), onto missing data that is not filled,
            or the file no longer matches ``digest``.
    """
    raster = load_raster(config, digest)
    latitude, longitude = raster.latitude, raster.longitude
    west, _ = window_longitudes(config, raster)
    lat_c = math.radians(0.5 * (config.lat_deg[0] + config.lat_deg[1]))
    gx, gy = grid.mesh()
    lon = west + np.degrees(gx / (EARTH_RADIUS_M * math.cos(lat_c)))
    lat = config.lat_deg[0] + np.degrees(gy / EARTH_RADIUS_M)
    raster = _wrapped(raster, float(lon.min()), float(lon.max()))
    latitude, longitude = raster.latitude, raster.longitude
    tolerance = 1e-9
    if (
        lon.min() < longitude[0] - tolerance
        or lon.max() > longitude[-1] + tolerance
        or lat.min() < latitude[0] - tolerance
        or lat.max() > latitude[-1] + tolerance
    ):
        raise ScenarioError(
            "map",
            f"lon {lon.min():.4f}..{lon.max():.4f}, lat {lat.min():.4f}..{lat.max():.4f}",
            f"a map inside the raster {raster.path.name} ({raster.extent()})",
        )
    row = np.interp(lat, latitude, np.arange(latitude.size))
    col = np.interp(lon, longitude, np.arange(longitude.size))
    rows = slice(int(np.floor(row.min())), min(int(np.floor(row.max())) + 2, latitude.size))
    cols = slice(int(np.floor(col.min())), min(int(np.floor(col.max())) + 2, longitude.size))
    heights = _fill_holes(raster.heights, rows, cols, config, raster)
    resampled = ndimage.map_coordinates(heights, [row, col], order=1, mode="nearest")
    return np.maximum(resampled, config.sea_floor_m)
