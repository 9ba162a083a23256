"""Building the 1° RCS table offline: the airframe averaged over each cell, or one constant (model.md §5.2, §5.3).

The build runs once per airframe (``build.py`` caches its result on disk); the model only reads
the finished table through `uav_penetration_env.rcs.lookup`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import TypeVar

import numpy as np

from uav_penetration_env.rcs.airframe import (
    AirframeRCS,
    Cap,
    Cylinder,
    Plate,
    Vector3,
    airframe_lines,
    airframe_rcs_from_dots,
)
from uav_penetration_env.rcs.grid import TABLE_AZ_DEG, TABLE_EL_DEG, TABLE_SHAPE
from uav_penetration_env.types import FloatArray, IntArray

__all__ = ["build_rcs_table", "constant_rcs_table"]

_MIRROR_TOL = 1e-12  # two primitives are mirror images if their numbers agree this closely
# Directions evaluated per chunk of the table build: 256 kB per temporary array, so the dozen
# temporaries of one chunk stay in cache; measured fastest among 2^14…2^20 (2^17 is ~1.5× slower).
_CHUNK_POINTS = 1 << 15

_P = TypeVar("_P")


def _close(x: float, y: float) -> bool:
    return abs(x - y) <= _MIRROR_TOL


def _same_line(v: Vector3, w: Vector3) -> bool:
    return all(_close(a, b) for a, b in zip(v, w, strict=True)) or all(
        _close(a, -b) for a, b in zip(v, w, strict=True)
    )


def _same_vector(v: Vector3, w: Vector3) -> bool:
    return all(_close(a, b) for a, b in zip(v, w, strict=True))


def _mirror(vector: Vector3, axis: int) -> Vector3:
    return tuple(-c if i == axis else c for i, c in enumerate(vector))  # type: ignore[return-value]


def _plates_match(p: Plate, q: Plate) -> bool:
    # A plate's σ is even in n, a1 and a2 and symmetric in swapping its two sides.
    def sides_match(l1: float, a1: Vector3, l2: float, a2: Vector3) -> bool:
        return (
            _close(p.side1_m, l1)
            and _same_line(p.axis1, a1)
            and _close(p.side2_m, l2)
            and _same_line(p.axis2, a2)
        )

    return _same_line(p.normal, q.normal) and (
        sides_match(q.side1_m, q.axis1, q.side2_m, q.axis2)
        or sides_match(q.side2_m, q.axis2, q.side1_m, q.axis1)
    )


def _cylinders_match(c: Cylinder, d: Cylinder) -> bool:
    # A cylinder's σ is even in its axis.
    return _close(c.radius_m, d.radius_m) and _close(c.length_m, d.length_m) and _same_line(c.axis, d.axis)


def _caps_match(c: Cap, d: Cap) -> bool:
    return _close(c.radius_m, d.radius_m) and _same_vector(c.facing, d.facing)


def _each_has_partner(originals: tuple[_P, ...], mirrored: list[_P], match: Callable[[_P, _P], bool]) -> bool:
    unused = list(originals)
    for image in mirrored:
        for i, original in enumerate(unused):
            if match(image, original):
                del unused[i]
                break
        else:
            return False
    return True


def _is_mirror_symmetric(airframe: AirframeRCS, axis: int) -> bool:
    """Whether σ(u) = σ(u with component ``axis`` negated) for every u, from the geometry alone.

    True when the mirror image of every primitive is a primitive of the airframe (a primitive may be
    its own image): plates and cylinders up to the sign of their vectors, caps with their facing.
    """
    plates = [
        replace(p, axis1=_mirror(p.axis1, axis), axis2=_mirror(p.axis2, axis), normal=_mirror(p.normal, axis))
        for p in airframe.plates
    ]
    cylinders = [replace(c, axis=_mirror(c.axis, axis)) for c in airframe.cylinders]
    caps = [replace(c, facing=_mirror(c.facing, axis)) for c in airframe.caps]
    return (
        _each_has_partner(airframe.plates, plates, _plates_match)
        and _each_has_partner(airframe.cylinders, cylinders, _cylinders_match)
        and _each_has_partner(airframe.caps, caps, _caps_match)
    )


def _canonical_azimuths(az_deg: IntArray, mirror_x: bool, mirror_y: bool) -> IntArray:
    """Map integer azimuths [deg] onto the computed range; both ±180° always map to one column."""
    az = np.asarray(az_deg)
    if mirror_y:  # (a, b, c) -> (a, −b, c): az -> −az
        az = np.abs(az)
    if mirror_x:  # (a, b, c) -> (−a, b, c): az -> 180° − az
        az = np.where(az > 90, 180 - az, np.where(az < -90, -180 - az, az))
    if not (mirror_x or mirror_y):
        az = np.where(az == 180, -180, az)
    return az


def build_rcs_table(airframe: AirframeRCS, subsamples: int = 10, floor_dbsm: float = -60.0) -> FloatArray:
    """Tabulate the airframe's RCS on the 1° (el, az) grid in dBsm (model.md §5.2–5.3).

    Each node is the power mean (m²) over ``subsamples`` × ``subsamples`` directions at the centres
    of a regular split of its ±0.5° × ±0.5° (el, az) cell (removes the sub-degree PO lobes; the
    fuselage broadside lobe is 1.9° wide at 3 GHz), then 10 log10, floored at ``floor_dbsm``.

    Mirror symmetries of the geometry (left-right always for the default airframe; also fore-aft and
    up-down for its axis-aligned primitives and equal caps) are detected from the primitives, and
    only the fundamental part of the grid is evaluated; the rest is copied, so the table is exactly
    symmetric, e.g. table[:, az] == table[:, −az] for a left-right symmetric airframe. Measured on
    one core at ``subsamples=10``: 0.05 s for the default airframe (three mirror planes), 0.2 s with
    left-right symmetry only, 0.45 s with none (6.5 M directions).

    DECISION: the cells of the el = ±90° rows are sampled like any other, so their sub-samples cross
    the pole along the node's meridian (`direction_from_aspect` is continuous there) rather than
    being clipped to half a cell.

    Args:
        airframe: The primitive model.
        subsamples: Sub-samples per axis and cell, >= 1 (1 evaluates the nodes themselves).
        floor_dbsm: Lower bound of the table [dBsm]; keeps −inf out where σ = 0.

    Returns:
        (181, 361) RCS [dBsm]; rows el = −90…90°, columns az = −180…180° (last column == first).

    Raises:
        ValueError: If ``subsamples`` < 1 or ``floor_dbsm`` is not finite.
    """
    if int(subsamples) != subsamples or subsamples < 1:
        raise ValueError(f"subsamples: got {subsamples!r}, expected an integer >= 1")
    if not math.isfinite(floor_dbsm):
        raise ValueError(f"floor_dbsm: got {floor_dbsm!r}, expected a finite number [dBsm]")
    n_sub = int(subsamples)
    mirror_x, mirror_y, mirror_z = (_is_mirror_symmetric(airframe, axis) for axis in range(3))

    # Fundamental domain of the node grid [deg].
    if mirror_x and mirror_y:
        az_nodes = np.arange(0, 91)
    elif mirror_y:
        az_nodes = np.arange(0, 181)
    elif mirror_x:
        az_nodes = np.arange(-90, 91)
    else:
        az_nodes = np.arange(-180, 180)
    el_nodes = np.arange(0, 91) if mirror_z else np.arange(-90, 91)

    offsets_deg = (np.arange(n_sub) + 0.5) / n_sub - 0.5  # cell-centred sub-sample offsets [deg]
    az_fine = np.radians((az_nodes[:, None] + offsets_deg).ravel())  # node-major, (n_az * n_sub,)
    cos_az, sin_az = np.cos(az_fine), np.sin(az_fine)
    vectors = airframe_lines(airframe)
    # u·v = cos el (v_x cos az + v_y sin az) + v_z sin el: the azimuth part is computed once.
    horizontal = {v: v[0] * cos_az + v[1] * sin_az for v in vectors if v[0] != 0.0 or v[1] != 0.0}

    n_az_fine = az_fine.size
    rows_per_chunk = max(1, _CHUNK_POINTS // (n_sub * n_az_fine))
    power = np.empty((el_nodes.size, az_nodes.size))  # [m²] cell means
    for start in range(0, el_nodes.size, rows_per_chunk):
        nodes = el_nodes[start : start + rows_per_chunk]
        el_fine = np.radians((nodes[:, None] + offsets_deg).ravel())[:, None]
        cos_el, sin_el = np.cos(el_fine), np.sin(el_fine)
        dots: dict[Vector3, FloatArray] = {}
        for v in vectors:
            # Vectors along z_b give a (rows, 1) column that broadcasts: no work per azimuth.
            dot = cos_el * horizontal[v] if v in horizontal else np.zeros_like(cos_el)
            if v[2] != 0.0:
                dot = dot + v[2] * sin_el
            dots[v] = dot
        sigma = airframe_rcs_from_dots(dots, airframe, (el_fine.size, n_az_fine))
        cells = sigma.reshape(nodes.size, n_sub, az_nodes.size, n_sub).sum(axis=3).sum(axis=1)
        power[start : start + nodes.size] = cells / (n_sub * n_sub)

    floor_m2 = 10.0 ** (floor_dbsm / 10.0)
    fundamental_dbsm = 10.0 * np.log10(np.maximum(power, floor_m2))

    el_all = TABLE_EL_DEG.astype(np.int64)
    az_all = TABLE_AZ_DEG.astype(np.int64)
    rows = (np.abs(el_all) if mirror_z else el_all) - el_nodes[0]
    cols = _canonical_azimuths(az_all, mirror_x, mirror_y) - az_nodes[0]
    return fundamental_dbsm[np.ix_(rows, cols)]


def constant_rcs_table(rcs_m2: float) -> FloatArray:
    """Table of one RCS value for every aspect (UAV model ``constant``, model.md §5.3).

    Args:
        rcs_m2: The RCS [m²], > 0.

    Returns:
        (181, 361) table [dBsm], all equal to 10 log10(rcs_m2).

    Raises:
        ValueError: If ``rcs_m2`` is not a finite positive number.
    """
    rcs_m2 = float(rcs_m2)
    if not (math.isfinite(rcs_m2) and rcs_m2 > 0.0):
        raise ValueError(f"rcs_m2: got {rcs_m2}, expected a finite RCS > 0 [m²]")
    return np.full(TABLE_SHAPE, 10.0 * math.log10(rcs_m2))
