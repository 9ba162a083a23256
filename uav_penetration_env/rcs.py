"""Radar cross section (RCS) of a small fixed-wing UAV as seen by each radar (model.md §5).

The paper (Luo, Liang & Li 2022) makes the radar threat depend on the UAV's aspect towards each radar
but publishes no RCS data (model.md §10, A21). This module supplies, as pure batched numpy:

* physical-optics primitives (flat plate, finite cylinder, hemispherical cap) and their incoherent
  sum for a generic small fixed-wing UAV (model.md §5.3);
* the 1° table ``σ_dBsm[el, az]`` the environment looks up (model.md §5.2), built by averaging power
  over each cell; a constant table (model ``constant``) and a loader for user tables (model
  ``table``, model.md §5.4);
* the body-frame aspect angles of the radars (model.md §5.1) and the bilinear-in-dB lookup that sits
  on the planner's hot path (model.md §8).

Angles are in radians unless a name ends in ``_deg``; areas in m²; tables in dBsm.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TypeVar

import numpy as np

from uav_penetration_env.types import FloatArray, IntArray

SPEED_OF_LIGHT_M_S = 299_792_458.0  # [m/s]

TABLE_EL_DEG = np.arange(-90.0, 91.0)  # [deg] table rows, el = −90…90 step 1°
TABLE_AZ_DEG = np.arange(-180.0, 181.0)  # [deg] table columns, az = −180…180 step 1° (last == first)
TABLE_EL_DEG.setflags(write=False)
TABLE_AZ_DEG.setflags(write=False)
TABLE_SHAPE = (TABLE_EL_DEG.size, TABLE_AZ_DEG.size)  # (181, 361)

_N_EL, _N_AZ = TABLE_SHAPE
_VECTOR_TOL = 1e-9  # unit-norm and orthogonality tolerance for user-given primitive axes
_MIRROR_TOL = 1e-12  # two primitives are mirror images if their numbers agree this closely
# Directions evaluated per chunk of the table build: 256 kB per temporary array, so the dozen
# temporaries of one chunk stay in cache; measured fastest among 2^14…2^20 (2^17 is ~1.5× slower).
_CHUNK_POINTS = 1 << 15

Vector3 = tuple[float, float, float]


def _unit_vector(name: str, value: Sequence[float]) -> Vector3:
    """Return ``value`` as a tuple of three floats after checking that it is a unit vector."""
    vector = tuple(float(c) for c in value)
    if len(vector) != 3 or not all(math.isfinite(c) for c in vector):
        raise ValueError(f"{name}: got {value!r}, expected three finite numbers (a body-frame vector)")
    norm = math.sqrt(sum(c * c for c in vector))
    if abs(norm - 1.0) > _VECTOR_TOL:
        raise ValueError(f"{name}: got {vector} with norm {norm:.6g}, expected a unit vector (norm 1)")
    return vector  # type: ignore[return-value]


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{name}: got {value}, expected a finite number > 0")
    return value


def _dot3(v: Vector3, w: Vector3) -> float:
    return v[0] * w[0] + v[1] * w[1] + v[2] * w[2]


@dataclass(frozen=True)
class Plate:
    """Flat rectangular plate in the body frame (model.md §5.3).

    Attributes:
        side1_m: Length L1 along ``axis1`` [m].
        side2_m: Length L2 along ``axis2`` [m].
        axis1: Unit vector of the first side (body FLU).
        axis2: Unit vector of the second side, orthogonal to ``axis1``.
        normal: Unit normal n, orthogonal to both sides (its sign does not matter).
    """

    side1_m: float
    side2_m: float
    axis1: Vector3
    axis2: Vector3
    normal: Vector3

    def __post_init__(self) -> None:
        object.__setattr__(self, "side1_m", _positive("Plate.side1_m", self.side1_m))
        object.__setattr__(self, "side2_m", _positive("Plate.side2_m", self.side2_m))
        for name in ("axis1", "axis2", "normal"):
            object.__setattr__(self, name, _unit_vector(f"Plate.{name}", getattr(self, name)))
        for first, second in (("axis1", "axis2"), ("axis1", "normal"), ("axis2", "normal")):
            dot = _dot3(getattr(self, first), getattr(self, second))
            if abs(dot) > _VECTOR_TOL:
                raise ValueError(
                    f"Plate.{first}·Plate.{second}: got {dot:.6g}, expected 0 (orthogonal unit vectors)"
                )


@dataclass(frozen=True)
class Cylinder:
    """Finite circular cylinder in the body frame (model.md §5.3).

    Attributes:
        radius_m: Radius r [m].
        length_m: Length L along ``axis`` [m].
        axis: Unit vector of the cylinder axis (its sign does not matter).
    """

    radius_m: float
    length_m: float
    axis: Vector3

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius_m", _positive("Cylinder.radius_m", self.radius_m))
        object.__setattr__(self, "length_m", _positive("Cylinder.length_m", self.length_m))
        object.__setattr__(self, "axis", _unit_vector("Cylinder.axis", self.axis))


@dataclass(frozen=True)
class Cap:
    """Hemispherical cap, seen only from its own hemisphere ``u·facing > 0`` (model.md §5.3).

    Attributes:
        radius_m: Radius r [m].
        facing: Unit vector from the sphere's centre to the cap's pole (body FLU).
    """

    radius_m: float
    facing: Vector3

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius_m", _positive("Cap.radius_m", self.radius_m))
        object.__setattr__(self, "facing", _unit_vector("Cap.facing", self.facing))


_X_B: Vector3 = (1.0, 0.0, 0.0)
_Y_B: Vector3 = (0.0, 1.0, 0.0)
_Z_B: Vector3 = (0.0, 0.0, 1.0)
_MINUS_X_B: Vector3 = (-1.0, 0.0, 0.0)

# Default geometry of model.md §5.3 (body FLU).
_WING = Plate(side1_m=0.25, side2_m=2.5, axis1=_X_B, axis2=_Y_B, normal=_Z_B)  # chord × span
_HORIZONTAL_TAIL = Plate(side1_m=0.15, side2_m=0.8, axis1=_X_B, axis2=_Y_B, normal=_Z_B)
_FIN = Plate(side1_m=0.20, side2_m=0.30, axis1=_X_B, axis2=_Z_B, normal=_Y_B)  # chord × height
_FUSELAGE = Cylinder(radius_m=0.10, length_m=1.5, axis=_X_B)
_NOSE_CAP = Cap(radius_m=0.10, facing=_X_B)
_TAIL_CAP = Cap(radius_m=0.10, facing=_MINUS_X_B)


@dataclass(frozen=True)
class AirframeRCS:
    """Physical-optics RCS model of the default generic small fixed-wing UAV (model.md §5.3).

    σ_total = ρ Σ_p σ_p + σ₀, an incoherent power sum: a mean-RCS pattern without scintillation.

    Attributes:
        frequency_ghz: Radar carrier frequency [GHz]; S band by default (DECISION, model.md §5.3).
        reflectivity: Power reflectivity ρ applied to every primitive (0.1 = −10 dB, composite airframe).
        diffuse_m2: Isotropic diffuse term σ₀ [m²].
        plates: Flat plates: wing, horizontal tail, fin.
        cylinders: Cylinders: fuselage.
        caps: Hemispherical caps: nose (+x_b) and tail (−x_b) ends of the fuselage.
    """

    frequency_ghz: float = 3.0  # [GHz]
    reflectivity: float = 0.1  # ρ [-]
    diffuse_m2: float = 0.005  # σ₀ [m²]
    plates: tuple[Plate, ...] = (_WING, _HORIZONTAL_TAIL, _FIN)
    cylinders: tuple[Cylinder, ...] = (_FUSELAGE,)
    caps: tuple[Cap, ...] = (_NOSE_CAP, _TAIL_CAP)

    def __post_init__(self) -> None:
        _positive("AirframeRCS.frequency_ghz", self.frequency_ghz)
        for name in ("reflectivity", "diffuse_m2"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"AirframeRCS.{name}: got {value}, expected a finite number >= 0")
        for name, kind in (("plates", Plate), ("cylinders", Cylinder), ("caps", Cap)):
            items = tuple(getattr(self, name))
            for i, item in enumerate(items):
                if not isinstance(item, kind):
                    raise ValueError(f"AirframeRCS.{name}[{i}]: got {item!r}, expected a {kind.__name__}")
            object.__setattr__(self, name, items)

    @property
    def wavelength_m(self) -> float:
        """Radar wavelength λ = c / f [m]."""
        return SPEED_OF_LIGHT_M_S / (self.frequency_ghz * 1e9)


# --------------------------------------------------------------------------------------------------
# Primitives. Each public function takes unit vectors u (..., 3) towards the radar in the body frame;
# the private `_from_dots` forms take the dot products, so the table build can form them on its
# separable (el, az) grid without materialising u.


def _sinc_squared(x: FloatArray) -> FloatArray:
    """(sin x / x)², equal to 1 at x = 0 (the unnormalised sinc of model.md §5.3)."""
    x = np.asarray(x, dtype=np.float64)
    out = np.sin(x, out=np.empty_like(x))
    nonzero = x != 0.0
    np.divide(out, x, out=out, where=nonzero)
    np.copyto(out, 1.0, where=~nonzero)
    out *= out
    return out


def _plate_from_dots(
    u_normal: FloatArray, u_axis1: FloatArray, u_axis2: FloatArray, plate: Plate, wavenumber: float
) -> FloatArray:
    # 4π (L1 L2)² / λ² written with k = 2π/λ: (k L1 L2)² / π.
    peak_m2 = (wavenumber * plate.side1_m * plate.side2_m) ** 2 / math.pi
    sigma = _sinc_squared(wavenumber * plate.side1_m * u_axis1)
    sigma *= _sinc_squared(wavenumber * plate.side2_m * u_axis2)
    sigma *= peak_m2 * np.square(u_normal)
    return sigma


def _cylinder_from_dots(u_axis: FloatArray, cylinder: Cylinder, wavenumber: float) -> FloatArray:
    # 2π r L² / λ written with k = 2π/λ: k r L².
    peak_m2 = wavenumber * cylinder.radius_m * cylinder.length_m**2
    # cos ψ = sqrt(1 − sin²ψ); the clip keeps rounding (|u·a| a hair above 1) out of the sqrt.
    cos_psi = np.sqrt(np.clip(1.0 - np.square(u_axis), 0.0, None))
    sigma = _sinc_squared(wavenumber * cylinder.length_m * u_axis)
    sigma *= peak_m2 * cos_psi
    return sigma


def _cap_from_dots(u_facing: FloatArray, cap: Cap) -> FloatArray:
    # Optical-region sphere π r², visible only from the cap's own hemisphere.
    return np.where(u_facing > 0.0, math.pi * cap.radius_m**2, 0.0)


def _body_dots(u: FloatArray, vector: Vector3) -> FloatArray:
    return np.asarray(u, dtype=np.float64) @ np.asarray(vector)


def plate_rcs(u: FloatArray, plate: Plate, wavelength_m: float) -> FloatArray:
    """Physical-optics RCS of a flat rectangular plate (model.md §5.3, Mahafza eq. 2.62 form).

    σ = (4π (L1 L2)² / λ²) (u·n)² sinc²(k L1 u·a1) sinc²(k L2 u·a2), with k = 2π/λ and
    sinc x = sin x / x; the peak 4πA²/λ² is at normal incidence.

    Args:
        u: (..., 3) unit vectors towards the radar, body frame.
        plate: The plate.
        wavelength_m: Radar wavelength λ [m].

    Returns:
        (...) RCS [m²].
    """
    wavenumber = 2.0 * math.pi / wavelength_m
    return _plate_from_dots(
        _body_dots(u, plate.normal), _body_dots(u, plate.axis1), _body_dots(u, plate.axis2), plate, wavenumber
    )


def cylinder_rcs(u: FloatArray, cylinder: Cylinder, wavelength_m: float) -> FloatArray:
    """Physical-optics RCS of a finite circular cylinder (model.md §5.3, stationary phase).

    σ = (2π r L² / λ) cos ψ sinc²(k L sin ψ) with sin ψ = u·a; 2π r L²/λ at broadside, 0 end-on.

    Args:
        u: (..., 3) unit vectors towards the radar, body frame.
        cylinder: The cylinder.
        wavelength_m: Radar wavelength λ [m].

    Returns:
        (...) RCS [m²].
    """
    wavenumber = 2.0 * math.pi / wavelength_m
    return _cylinder_from_dots(_body_dots(u, cylinder.axis), cylinder, wavenumber)


def cap_rcs(u: FloatArray, cap: Cap) -> FloatArray:
    """RCS of a hemispherical cap: π r² from its own hemisphere (u·facing > 0), 0 elsewhere.

    Args:
        u: (..., 3) unit vectors towards the radar, body frame.
        cap: The cap.

    Returns:
        (...) RCS [m²].
    """
    return _cap_from_dots(_body_dots(u, cap.facing), cap)


def _line_key(vector: Vector3) -> tuple[Vector3, float]:
    """Canonical representative of ±vector (first non-zero component positive) and the sign to it."""
    for component in vector:
        if component != 0.0:
            if component < 0.0:
                return (-vector[0], -vector[1], -vector[2]), -1.0
            break
    return vector, 1.0


def _airframe_vectors(airframe: AirframeRCS) -> list[Vector3]:
    """Distinct lines (vectors up to sign) on which the airframe's primitives need u·v."""
    vectors = [v for p in airframe.plates for v in (p.normal, p.axis1, p.axis2)]
    vectors += [c.axis for c in airframe.cylinders] + [c.facing for c in airframe.caps]
    return list(dict.fromkeys(_line_key(v)[0] for v in vectors))


def _airframe_from_dots(
    dots: dict[Vector3, FloatArray], airframe: AirframeRCS, shape: tuple[int, ...]
) -> FloatArray:
    """ρ Σ σ_p + σ₀ from u·v for every line v of `_airframe_vectors` (each broadcastable to shape)."""

    def dot(vector: Vector3) -> FloatArray:
        # Plates and cylinders are even in their vectors, so only caps need the sign.
        key, sign = _line_key(vector)
        return dots[key] if sign > 0 else -dots[key]

    wavenumber = 2.0 * math.pi / airframe.wavelength_m
    total = np.zeros(shape)
    for plate in airframe.plates:
        total += _plate_from_dots(dot(plate.normal), dot(plate.axis1), dot(plate.axis2), plate, wavenumber)
    for cylinder in airframe.cylinders:
        total += _cylinder_from_dots(dot(cylinder.axis), cylinder, wavenumber)
    for cap in airframe.caps:
        total += _cap_from_dots(dot(cap.facing), cap)
    total *= airframe.reflectivity
    total += airframe.diffuse_m2
    return total


def airframe_rcs(u: FloatArray, airframe: AirframeRCS) -> FloatArray:
    """Mean RCS of the airframe, σ = ρ Σ_p σ_p + σ₀ (incoherent sum, model.md §5.3).

    Args:
        u: (..., 3) unit vectors towards the radar, body frame.
        airframe: The primitive model.

    Returns:
        (...) RCS [m²].
    """
    u = np.asarray(u, dtype=np.float64)
    dots = {v: u @ np.asarray(v) for v in _airframe_vectors(airframe)}
    return _airframe_from_dots(dots, airframe, u.shape[:-1])


# --------------------------------------------------------------------------------------------------
# Aspect angles (model.md §5.1)


def direction_from_aspect(az: FloatArray, el: FloatArray) -> FloatArray:
    """Body-frame unit vector for an azimuth and elevation (inverse of `aspect_angles`).

    Args:
        az: (...) azimuth [rad], 0 = dead ahead (+x_b), +π/2 = left wing side (+y_b).
        el: (...) elevation [rad] above the wing plane; broadcasts with ``az``.

    Returns:
        (..., 3) unit vectors (cos el cos az, cos el sin az, sin el).
    """
    az = np.asarray(az, dtype=np.float64)
    el = np.asarray(el, dtype=np.float64)
    cos_el = np.cos(el)
    return np.stack(np.broadcast_arrays(cos_el * np.cos(az), cos_el * np.sin(az), np.sin(el)), axis=-1)


def aspect_angles(
    radar_dir_world: FloatArray, heading: FloatArray, pitch: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Azimuth and elevation of each radar in the UAV's body frame (model.md §5.1).

    With the FLU body axes x_b, y_b, z_b of heading φ and pitch θ (model.md §0) and
    a = u·x_b, b = u·y_b, c = u·z_b: az = atan2(b, a), el = atan2(c, hypot(a, b)).

    Args:
        radar_dir_world: (..., M, 3) unit vectors from the UAV to the radars, world ENU frame.
        heading: (...) heading φ [rad], counter-clockwise from +x (east).
        pitch: (...) flight-path angle θ [rad], positive nose-up.

    Returns:
        az: (..., M) azimuth [rad] in (−π, π]; 0 = radar dead ahead, +π/2 = on the left wing side.
        el: (..., M) elevation [rad] in [−π/2, π/2]; positive = radar above the wing plane.
    """
    u = np.asarray(radar_dir_world, dtype=np.float64)
    heading = np.asarray(heading, dtype=np.float64)[..., None]  # broadcast over the M radars
    pitch = np.asarray(pitch, dtype=np.float64)[..., None]
    cos_h, sin_h = np.cos(heading), np.sin(heading)
    cos_p, sin_p = np.cos(pitch), np.sin(pitch)
    ux, uy, uz = u[..., 0], u[..., 1], u[..., 2]
    horizontal = ux * cos_h + uy * sin_h  # u · (cos φ, sin φ, 0)
    a = horizontal * cos_p + uz * sin_p  # u·x_b
    b = uy * cos_h - ux * sin_h  # u·y_b
    c = uz * cos_p - horizontal * sin_p  # u·z_b
    az = np.arctan2(b, a)
    # atan2 returns −π for b = −0.0, a < 0; the convention is (−π, π].
    az = np.where(az == -np.pi, np.pi, az)
    el = np.arctan2(c, np.hypot(a, b))
    return az, el


# --------------------------------------------------------------------------------------------------
# Table build (model.md §5.2–5.3)

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
    vectors = _airframe_vectors(airframe)
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
        sigma = _airframe_from_dots(dots, airframe, (el_fine.size, n_az_fine))
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


# --------------------------------------------------------------------------------------------------
# User tables (model ``table``, model.md §5.4)

_CSV_COLUMNS = ("el_deg", "az_deg", "rcs_dbsm")
# DECISION: a user table may give az = −180° and +180° or only one of them (the other is the same
# direction and is copied); when both are given they must agree to this tolerance [dB].
_SEAM_TOL_DB = 1e-6


def _check_table(table: FloatArray, source: str) -> FloatArray:
    if table.shape != TABLE_SHAPE:
        raise ValueError(
            f"{source}: got a table of shape {table.shape}, expected {TABLE_SHAPE} "
            "(el = -90..90 deg in rows, az = -180..180 deg in columns, step 1 deg)"
        )
    bad = ~np.isfinite(table)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise ValueError(
            f"{source}: {int(bad.sum())} non-finite RCS values (first at el={TABLE_EL_DEG[i]:.0f} deg, "
            f"az={TABLE_AZ_DEG[j]:.0f} deg), expected finite dBsm values"
        )
    seam = np.abs(table[:, -1] - table[:, 0])
    if seam.max() > _SEAM_TOL_DB:
        i = int(np.argmax(seam))
        raise ValueError(
            f"{source}: az=-180 and az=+180 deg differ by {seam[i]:.6g} dB at el={TABLE_EL_DEG[i]:.0f} deg, "
            "expected equal values (the same direction)"
        )
    return table


def _load_csv_table(path: Path) -> FloatArray:
    source = str(path)
    with path.open(newline="") as handle:
        header = [name.strip() for name in handle.readline().split(",")]
    missing = [name for name in _CSV_COLUMNS if name not in header]
    if missing:
        raise ValueError(
            f"{source}: missing column(s) {', '.join(missing)} in header {header}, "
            f"expected columns {', '.join(_CSV_COLUMNS)}"
        )
    try:
        data = np.loadtxt(
            path, delimiter=",", skiprows=1, usecols=[header.index(n) for n in _CSV_COLUMNS], ndmin=2
        )
    except ValueError as error:
        raise ValueError(f"{source}: unreadable row ({error}), expected numbers in every column") from error
    el, az, rcs = data.T
    off_grid = ~((el == np.round(el)) & (az == np.round(az)) & (np.abs(el) <= 90) & (np.abs(az) <= 180))
    if off_grid.any():
        k = int(np.argmax(off_grid))
        raise ValueError(
            f"{source}: row {k + 2} has el={el[k]:g}, az={az[k]:g} deg off the table grid, expected "
            "integer degrees with -90 <= el <= 90 and -180 <= az <= 180"
        )
    if not np.isfinite(rcs).all():
        k = int(np.argmin(np.isfinite(rcs)))
        raise ValueError(
            f"{source}: row {k + 2} has a non-finite rcs_dbsm ({rcs[k]}), expected a finite dBsm value"
        )
    flat = (el.astype(np.int64) + 90) * _N_AZ + (az.astype(np.int64) + 180)
    counts = np.bincount(flat, minlength=_N_EL * _N_AZ).reshape(TABLE_SHAPE)
    if (counts > 1).any():
        i, j = np.argwhere(counts > 1)[0]
        raise ValueError(
            f"{source}: {int((counts > 1).sum())} duplicated grid node(s) (first el={TABLE_EL_DEG[i]:.0f}, "
            f"az={TABLE_AZ_DEG[j]:.0f} deg), expected each (el, az) once"
        )
    table = np.full(TABLE_SHAPE, np.nan)
    table.flat[flat] = rcs
    seam_missing = counts[:, 0] == 0
    table[seam_missing, 0] = table[seam_missing, -1]
    seam_missing = counts[:, -1] == 0
    table[seam_missing, -1] = table[seam_missing, 0]
    missing_nodes = np.isnan(table)
    if missing_nodes.any():
        i, j = np.argwhere(missing_nodes)[0]
        raise ValueError(
            f"{source}: {int(missing_nodes.sum())} grid node(s) missing (first el={TABLE_EL_DEG[i]:.0f}, "
            f"az={TABLE_AZ_DEG[j]:.0f} deg), expected every el = -90..90 and az = -180..180 deg "
            "in 1 deg steps (az=+180 may be omitted)"
        )
    return _check_table(table, source)


def load_rcs_table(path: str | os.PathLike[str]) -> FloatArray:
    """Load a user RCS table (UAV model ``table``, model.md §5.4).

    Accepted formats:

    * ``.csv`` with a header naming the columns ``el_deg``, ``az_deg`` and ``rcs_dbsm`` (any order,
      other columns ignored) and one row per node of the 1° grid, el = −90…90°, az = −180…180°
      (az = +180° or −180° may be omitted: it is the same direction as the other);
    * ``.npy`` holding a (181, 361) array in dBsm laid out like `build_rcs_table`.

    Angles are body-frame az/el as in `aspect_angles`; measured data in other conventions must be
    converted first.

    Args:
        path: The file.

    Returns:
        (181, 361) RCS table [dBsm].

    Raises:
        FileNotFoundError: If the file does not exist.
        ValueError: If the format, columns, grid coverage or values are wrong; the message names the
            file, the problem and what was expected.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such RCS table file")
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return _load_csv_table(path)
    if suffix == ".npy":
        try:
            table = np.load(path, allow_pickle=False)
        except ValueError as error:
            raise ValueError(f"{path}: not a plain numeric .npy array ({error})") from error
        if not np.issubdtype(table.dtype, np.number):
            raise ValueError(f"{path}: got an array of dtype {table.dtype}, expected numbers in dBsm")
        return _check_table(np.asarray(table, dtype=np.float64), str(path))
    raise ValueError(f"{path}: unsupported file type {path.suffix!r}, expected .csv or .npy")


# --------------------------------------------------------------------------------------------------
# Lookup (model.md §5.2, §8)


def rcs_lookup(table_dbsm: FloatArray, az: FloatArray, el: FloatArray) -> FloatArray:
    """RCS [m²] for body-frame aspects, bilinear in dBsm on a (181, 361) table (model.md §5.2).

    Azimuth wraps (any real value), elevation is clamped to [−90°, 90°]; the table's duplicated
    az = +180° column is the wrap-around padding. Interpolating in dB keeps relative accuracy across
    the table's 40 dB range. Plain index arithmetic on the flattened table: for the planner's
    ~2 000 points per call it is faster than `scipy.ndimage.map_coordinates(order=1)` (measured
    ~40 µs against ~65 µs on one core), which it equals to rounding.

    Args:
        table_dbsm: (181, 361) table [dBsm] as from `build_rcs_table`.
        az: (...) azimuth [rad], finite.
        el: (...) elevation [rad], finite; broadcasts with ``az``.

    Returns:
        (...) RCS [m²], 10^(dB/10).

    Raises:
        ValueError: If the table does not have shape (181, 361).
    """
    if table_dbsm.shape != TABLE_SHAPE:
        raise ValueError(f"table_dbsm: got shape {table_dbsm.shape}, expected {TABLE_SHAPE}")
    flat = np.ravel(table_dbsm)
    col = np.degrees(az) + 180.0  # [table columns]
    # Wrap into [0, 360) with floor, not np.mod: the same result for in-range angles (exact) at a
    # fraction of the cost. Rounding may leave col a hair below 0 (truncation then gives cell 0) or
    # near 360 (the minimum gives the last cell); the weight then extrapolates by ~1e-14, harmlessly.
    col -= 360.0 * np.floor(col / 360.0)
    row = np.clip(np.degrees(el) + 90.0, 0.0, 180.0)  # [table rows]; clamps el to ±90°
    col0 = np.minimum(col.astype(np.intp), _N_AZ - 2)
    row0 = np.minimum(row.astype(np.intp), _N_EL - 2)  # row >= 0: truncation is floor
    frac_col = col - col0
    frac_row = row - row0
    index = row0 * _N_AZ + col0
    v00 = flat.take(index)
    v01 = flat.take(index + 1)
    v10 = flat.take(index + _N_AZ)
    v11 = flat.take(index + (_N_AZ + 1))
    low = v00 + frac_col * (v01 - v00)
    high = v10 + frac_col * (v11 - v10)
    # Row weights in the two-sided form: exact at frac_row = 1 too, which is how el = +90° (the
    # last row, reached from the cell below) returns its node value unchanged.
    dbsm = low * (1.0 - frac_row) + high * frac_row
    return 10.0 ** (dbsm / 10.0)
