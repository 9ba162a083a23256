"""Physical-optics RCS of a small fixed-wing UAV: primitives and their incoherent sum (model.md §5.3).

The paper (Luo, Liang & Li 2022) makes the radar threat depend on the UAV's aspect towards each
radar but publishes no RCS data (model.md §10, A21). This module supplies, as pure batched numpy,
the flat plate, finite cylinder and hemispherical cap and the default generic airframe built from
them. Angles are in radians; areas in m².
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from uav_penetration_env.types import FloatArray

__all__ = [
    "SPEED_OF_LIGHT_M_S",
    "AirframeRCS",
    "Cap",
    "Cylinder",
    "Plate",
    "Vector3",
    "airframe_lines",
    "airframe_rcs",
    "airframe_rcs_from_dots",
    "cap_rcs",
    "cylinder_rcs",
    "plate_rcs",
]

SPEED_OF_LIGHT_M_S = 299_792_458.0  # [m/s]

_VECTOR_TOL = 1e-9  # unit-norm and orthogonality tolerance for user-given primitive axes

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
# the `_from_dots` forms take the dot products, so the table build (table.py, through
# `airframe_rcs_from_dots`) can form them on its separable (el, az) grid without materialising u.


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


def airframe_lines(airframe: AirframeRCS) -> list[Vector3]:
    """Distinct lines (vectors up to sign) on which the airframe's primitives need u·v.

    Args:
        airframe: The primitive model.

    Returns:
        One representative per line, the first non-zero component positive: the keys
        `airframe_rcs_from_dots` reads.
    """
    vectors = [v for p in airframe.plates for v in (p.normal, p.axis1, p.axis2)]
    vectors += [c.axis for c in airframe.cylinders] + [c.facing for c in airframe.caps]
    return list(dict.fromkeys(_line_key(v)[0] for v in vectors))


def airframe_rcs_from_dots(
    dots: dict[Vector3, FloatArray], airframe: AirframeRCS, shape: tuple[int, ...]
) -> FloatArray:
    """Mean RCS of the airframe from the dot products u·v instead of u (model.md §5.3).

    Args:
        dots: u·v for each line v of `airframe_lines`, each broadcastable to ``shape``.
        airframe: The primitive model.
        shape: Shape of the result, the directions' batch shape.

    Returns:
        ``shape`` RCS [m²], ρ Σ σ_p + σ₀ as `airframe_rcs`.
    """

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
    dots = {v: u @ np.asarray(v) for v in airframe_lines(airframe)}
    return airframe_rcs_from_dots(dots, airframe, u.shape[:-1])
