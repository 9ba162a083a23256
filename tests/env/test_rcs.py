"""RCS model (model.md §5): PO primitives, the 1° dBsm table, aspect angles, lookup and loaders."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.interpolate import RegularGridInterpolator

from uav_penetration_env.rcs import (
    TABLE_AZ_DEG,
    TABLE_EL_DEG,
    AirframeRCS,
    Cap,
    Cylinder,
    Plate,
    airframe_rcs,
    aspect_angles,
    build_rcs_table,
    cap_rcs,
    constant_rcs_table,
    cylinder_rcs,
    direction_from_aspect,
    load_rcs_table,
    plate_rcs,
    rcs_lookup,
)

# A round wavelength for hand numbers: k = 2π/λ = 20π rad/m.
WAVELENGTH_M = 0.1
X_B, Y_B, Z_B = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


unit_vectors = (
    st.tuples(*[st.floats(-1.0, 1.0, allow_nan=False)] * 3)
    .filter(lambda v: np.linalg.norm(v) > 0.1)
    .map(_unit)
)


def _body_axes(heading: float, pitch: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x_b, y_b, z_b of model.md §0, written out independently of the module."""
    cp, sp, ct, st_ = math.cos(heading), math.sin(heading), math.cos(pitch), math.sin(pitch)
    return (
        np.array([cp * ct, sp * ct, st_]),
        np.array([-sp, cp, 0.0]),
        np.array([-cp * st_, -sp * st_, ct]),
    )


def _dbsm(sigma_m2, floor_dbsm: float = -60.0) -> np.ndarray:
    return 10.0 * np.log10(np.maximum(sigma_m2, 10.0 ** (floor_dbsm / 10.0)))


@pytest.fixture(scope="module")
def default_table() -> np.ndarray:
    return build_rcs_table(AirframeRCS(), subsamples=10)


@pytest.fixture(scope="module")
def random_table() -> np.ndarray:
    table = np.random.default_rng(20220132).uniform(-30.0, 20.0, (181, 361))
    table[:, -1] = table[:, 0]  # az = +180° is az = −180°
    return table


# ------------------------------------------------------------------------------------------- plate


def test_plate_peak_at_normal_incidence_is_4pi_area_squared_over_lambda_squared():
    plate = Plate(side1_m=0.3, side2_m=0.5, axis1=X_B, axis2=Y_B, normal=Z_B)
    # 4π (0.3 · 0.5)² / 0.1² = 4π · 0.0225 / 0.01 = 9π m²
    peak = 4.0 * math.pi * (0.3 * 0.5) ** 2 / WAVELENGTH_M**2
    assert peak == pytest.approx(9.0 * math.pi)
    sigma = plate_rcs(np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]), plate, WAVELENGTH_M)
    np.testing.assert_allclose(sigma, [peak, peak], rtol=1e-12)


def test_plate_off_normal_matches_the_sinc_formula():
    # Plate 0.25 m (x_b) × 0.4 m (y_b): A = 0.1 m², peak 4π A²/λ² = 4π m².
    plate = Plate(side1_m=0.25, side2_m=0.4, axis1=X_B, axis2=Y_B, normal=Z_B)
    # Tilted in the x-z plane with u·x_b = 0.1: k L1 u·a1 = 20π · 0.25 · 0.1 = π/2, so
    # sinc² = (sin(π/2) / (π/2))² = 4/π²; (u·n)² = 1 − 0.1² = 0.99; u·a2 = 0.
    u = np.array([0.1, 0.0, math.sqrt(0.99)])
    expected = 4.0 * math.pi * 0.99 * 4.0 / math.pi**2  # = 15.84/π ≈ 5.042 m²
    assert plate_rcs(u, plate, WAVELENGTH_M) == pytest.approx(expected, rel=1e-12)
    # u·x_b = 0.2: k L1 u·a1 = π, the first null of the sinc.
    u_null = np.array([0.2, 0.0, math.sqrt(0.96)])
    assert plate_rcs(u_null, plate, WAVELENGTH_M) == pytest.approx(0.0, abs=1e-12 * 4.0 * math.pi)
    # Edge-on (u in the plate's plane): (u·n)² = 0.
    assert plate_rcs(np.array([0.6, 0.8, 0.0]), plate, WAVELENGTH_M) == 0.0


@given(u=unit_vectors, flips=st.tuples(*[st.sampled_from([-1.0, 1.0])] * 3))
def test_plate_is_even_in_each_component_of_u(u, flips):
    # Every factor is a square of a dot product (or sinc², which is even), so an axis-aligned
    # plate cannot tell the sign of any component of u.
    plate = Plate(side1_m=0.25, side2_m=2.5, axis1=X_B, axis2=Y_B, normal=Z_B)
    np.testing.assert_allclose(
        plate_rcs(u * np.array(flips), plate, WAVELENGTH_M), plate_rcs(u, plate, WAVELENGTH_M), rtol=1e-12
    )
    tilted = Plate(
        side1_m=0.3, side2_m=0.7, axis1=(0.6, 0.8, 0.0), axis2=(0.0, 0.0, 1.0), normal=(0.8, -0.6, 0.0)
    )
    np.testing.assert_allclose(
        plate_rcs(-u, tilted, WAVELENGTH_M), plate_rcs(u, tilted, WAVELENGTH_M), rtol=1e-12
    )


@pytest.mark.parametrize(
    ("kwargs", "problem"),
    [
        ({"side1_m": 0.0}, "side1_m"),
        ({"axis1": (1.0, 1.0, 0.0)}, "unit vector"),
        ({"normal": (1.0, 0.0, 0.0)}, "orthogonal"),
    ],
)
def test_plate_rejects_bad_geometry(kwargs, problem):
    base = {"side1_m": 1.0, "side2_m": 1.0, "axis1": X_B, "axis2": Y_B, "normal": Z_B}
    with pytest.raises(ValueError, match=problem):
        Plate(**(base | kwargs))


def test_primitive_vectors_are_stored_as_float_tuples():
    plate = Plate(1, 2, [1, 0, 0], [0, 1, 0], [0, 0, 1])
    assert plate.axis1 == (1.0, 0.0, 0.0)
    assert hash(AirframeRCS(plates=(plate,))) is not None  # a cache key


# ---------------------------------------------------------------------------------------- cylinder

FUSELAGE = Cylinder(radius_m=0.1, length_m=1.5, axis=X_B)
# 2π r L² / λ = 2π · 0.1 · 1.5² / 0.1 = 4.5π ≈ 14.14 m²
CYLINDER_PEAK_M2 = 2.0 * math.pi * 0.1 * 1.5**2 / WAVELENGTH_M


def test_cylinder_broadside_peak_is_2pi_r_length_squared_over_lambda():
    assert CYLINDER_PEAK_M2 == pytest.approx(4.5 * math.pi)
    broadside = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.6, 0.8]])  # all ⟂ the axis
    np.testing.assert_allclose(cylinder_rcs(broadside, FUSELAGE, WAVELENGTH_M), CYLINDER_PEAK_M2, rtol=1e-12)


def test_cylinder_off_broadside_matches_the_formula():
    # sin ψ = 1/60: k L sin ψ = 20π · 1.5 / 60 = π/2, sinc² = 4/π², cos ψ = sqrt(1 − 1/3600).
    sin_psi = 1.0 / 60.0
    u = np.array([sin_psi, math.sqrt(1.0 - sin_psi**2), 0.0])
    expected = CYLINDER_PEAK_M2 * math.sqrt(1.0 - sin_psi**2) * 4.0 / math.pi**2
    assert cylinder_rcs(u, FUSELAGE, WAVELENGTH_M) == pytest.approx(expected, rel=1e-12)
    # sin ψ = 1/30: k L sin ψ = π, the first null; end-on: cos ψ = 0.
    u_null = np.array([1.0 / 30.0, math.sqrt(1.0 - 1.0 / 900.0), 0.0])
    assert cylinder_rcs(u_null, FUSELAGE, WAVELENGTH_M) == pytest.approx(0.0, abs=1e-12 * CYLINDER_PEAK_M2)
    assert cylinder_rcs(np.array([-1.0, 0.0, 0.0]), FUSELAGE, WAVELENGTH_M) == 0.0


# --------------------------------------------------------------------------------------------- cap


def test_cap_is_pi_r_squared_from_its_own_hemisphere_and_zero_from_the_other():
    cap = Cap(radius_m=0.1, facing=X_B)
    u = _unit([[1.0, 0.0, 0.0], [0.2, -0.9, 0.3], [-1.0, 0.0, 0.0], [-0.1, 0.9, 0.1]])
    np.testing.assert_allclose(cap_rcs(u, cap), [math.pi * 0.01, math.pi * 0.01, 0.0, 0.0], rtol=1e-15)


@given(u=unit_vectors)
def test_two_opposite_caps_make_a_sphere(u):
    front, back = Cap(radius_m=0.1, facing=Y_B), Cap(radius_m=0.1, facing=(0.0, -1.0, 0.0))
    if u[1] != 0.0:  # on the equator neither hemisphere claims u
        assert cap_rcs(u, front) + cap_rcs(u, back) == pytest.approx(math.pi * 0.1**2, rel=1e-15)


# ---------------------------------------------------------------------------------------- airframe


def test_airframe_broadside_is_reflectivity_times_fuselage_plus_fin_plus_diffuse():
    airframe = AirframeRCS()
    wavelength = 299_792_458.0 / 3e9  # [m] at 3 GHz
    assert airframe.wavelength_m == pytest.approx(wavelength, rel=1e-15)
    # From +y_b only the fuselage (broadside) and the fin (normal incidence) return energy: the
    # wing and tail are edge-on and neither cap faces ±y_b.
    fuselage = 2.0 * math.pi * 0.10 * 1.5**2 / wavelength
    fin = 4.0 * math.pi * (0.20 * 0.30) ** 2 / wavelength**2
    expected = 0.1 * (fuselage + fin) + 0.005
    assert airframe_rcs(np.array(Y_B), airframe) == pytest.approx(expected, rel=1e-12)
    assert airframe_rcs(np.array([0.0, -1.0, 0.0]), airframe) == pytest.approx(expected, rel=1e-12)


def test_airframe_nose_on_sees_only_the_nose_cap_and_the_diffuse_term():
    lossless = AirframeRCS(reflectivity=1.0, diffuse_m2=0.0)
    assert airframe_rcs(np.array(X_B), lossless) == pytest.approx(math.pi * 0.1**2, rel=1e-12)
    assert airframe_rcs(np.array(X_B), AirframeRCS()) == pytest.approx(0.1 * math.pi * 0.01 + 0.005)


def test_airframe_rcs_is_batched():
    u = _unit(np.random.default_rng(0).normal(size=(4, 5, 3)))
    batched = airframe_rcs(u, AirframeRCS())
    assert batched.shape == (4, 5)
    loop = [[airframe_rcs(u[i, j], AirframeRCS()) for j in range(5)] for i in range(4)]
    np.testing.assert_allclose(batched, loop, rtol=1e-14)


# ------------------------------------------------------------------------------------------- table


def test_default_table_shape_and_range(default_table):
    assert default_table.shape == (181, 361)
    assert np.all(np.isfinite(default_table))
    assert default_table.min() >= -60.0


def test_default_table_is_left_right_symmetric_and_wraps(default_table):
    # Column j is az = j − 180°, so az -> −az reverses the columns.
    np.testing.assert_array_equal(default_table, default_table[:, ::-1])
    np.testing.assert_array_equal(default_table[:, -1], default_table[:, 0])


def test_nose_on_is_far_below_broadside_and_the_wing_dominates_from_below(default_table):
    level = default_table[90]  # el = 0
    nose_on, left, right = level[180], level[270], level[90]
    assert nose_on <= left - 15.0
    assert nose_on <= right - 15.0
    # From straight above/below the wing plate faces the radar: ρ 4πA²/λ² = 0.1 · 4π · 0.625² /
    # 0.0999² ≈ 49 m² = +16.9 dBsm; the cell average over ±0.5° keeps it above +10 dBsm.
    assert default_table[0].min() >= 10.0
    assert default_table[180].min() >= 10.0
    assert default_table[[0, 180]].min() > level.max()


def test_table_with_one_subsample_is_airframe_rcs_at_the_nodes():
    airframe = AirframeRCS()
    table = build_rcs_table(airframe, subsamples=1)
    u = direction_from_aspect(np.radians(TABLE_AZ_DEG)[None, :], np.radians(TABLE_EL_DEG)[:, None])
    np.testing.assert_allclose(table, _dbsm(airframe_rcs(u, airframe)), rtol=0, atol=1e-9)


def _brute_force_table(airframe: AirframeRCS, subsamples: int) -> np.ndarray:
    """Every direction of every cell evaluated, no symmetry used."""
    offsets = (np.arange(subsamples) + 0.5) / subsamples - 0.5  # [deg] cell-centred
    el = np.radians(TABLE_EL_DEG[:, None] + offsets)[:, :, None, None]
    az = np.radians(TABLE_AZ_DEG[:, None] + offsets)[None, None, :, :]
    sigma = airframe_rcs(direction_from_aspect(az, el), airframe)
    return _dbsm(sigma.mean(axis=(1, 3)))


V_TAIL = (
    Plate(0.2, 0.4, X_B, (0.0, 0.8, 0.6), (0.0, -0.6, 0.8)),
    Plate(0.2, 0.4, X_B, (0.0, -0.8, 0.6), (0.0, 0.6, 0.8)),
)
LOPSIDED = AirframeRCS(
    plates=(Plate(0.5, 0.3, _unit([1.0, 0.0, 1.0]), Y_B, _unit([-1.0, 0.0, 1.0])),),
    cylinders=(Cylinder(0.05, 0.8, _unit([1.0, 2.0, 0.5])),),
    caps=(Cap(0.1, Y_B),),
)


@pytest.mark.parametrize(
    "airframe",
    [
        AirframeRCS(),  # mirror-symmetric fore-aft, left-right and up-down: a quarter of az, half of el
        AirframeRCS(plates=(AirframeRCS().plates[0], *V_TAIL)),  # the tail planes are each other's images
        AirframeRCS(caps=(Cap(0.1, X_B),)),  # no tail cap: left-right and up-down only
        AirframeRCS(caps=(Cap(0.1, Y_B),)),  # one side cap: fore-aft and up-down only
        LOPSIDED,  # no symmetry: every node evaluated
    ],
    ids=["default", "v-tail", "nose-cap-only", "side-cap", "lopsided"],
)
def test_table_cells_are_power_means_over_the_subsamples(airframe):
    # The build evaluates only the part of the grid its symmetries leave; a brute-force mean over
    # 2 × 2 sub-samples of every cell must agree, symmetric or not.
    np.testing.assert_allclose(
        build_rcs_table(airframe, subsamples=2), _brute_force_table(airframe, 2), rtol=0, atol=1e-9
    )


def test_asymmetric_airframe_gives_an_asymmetric_table():
    table = build_rcs_table(LOPSIDED, subsamples=1)
    # The cap faces +y_b (az = +90°): seen from the left, hidden from the right. The plate is
    # edge-on from ±y_b and the cylinder sees (u·a)² alike, so the sides differ by ρ π r² exactly.
    left, right = 10.0 ** (table[90, 270] / 10.0), 10.0 ** (table[90, 90] / 10.0)
    assert left - right == pytest.approx(0.1 * math.pi * 0.1**2, rel=1e-9)
    np.testing.assert_array_equal(table[:, -1], table[:, 0])


def test_table_floor():
    bare = AirframeRCS(plates=(), cylinders=(), caps=(), diffuse_m2=0.0)
    np.testing.assert_array_equal(build_rcs_table(bare, subsamples=2), -60.0)
    np.testing.assert_array_equal(build_rcs_table(bare, subsamples=1, floor_dbsm=-80.0), -80.0)


@pytest.mark.parametrize("subsamples", [0, 2.5, -1])
def test_table_rejects_bad_subsamples(subsamples):
    with pytest.raises(ValueError, match="subsamples"):
        build_rcs_table(AirframeRCS(), subsamples=subsamples)


# ------------------------------------------------------------------------------------------ aspect

HEADING = 0.7  # [rad], an arbitrary heading


def _world(body_vectors: np.ndarray, heading: float, pitch: float) -> np.ndarray:
    x_b, y_b, z_b = _body_axes(heading, pitch)
    d = np.asarray(body_vectors, dtype=float)
    return d[..., :1] * x_b + d[..., 1:2] * y_b + d[..., 2:] * z_b


def test_radar_dead_ahead_at_the_same_altitude_is_az_0_el_0():
    u = np.array([[math.cos(HEADING), math.sin(HEADING), 0.0]])
    az, el = aspect_angles(u, np.float64(HEADING), np.float64(0.0))
    np.testing.assert_allclose([az[0], el[0]], [0.0, 0.0], atol=1e-15)


def test_radar_on_the_left_wing_side_is_az_plus_90():
    u = np.array([[-math.sin(HEADING), math.cos(HEADING), 0.0]])  # +y_b
    az, el = aspect_angles(u, np.float64(HEADING), np.float64(0.0))
    np.testing.assert_allclose([az[0], el[0]], [math.pi / 2, 0.0], atol=1e-15)


def test_nose_up_pitch_puts_a_radar_ahead_below_the_wing_plane():
    pitch = math.radians(10.0)
    u = np.array([[math.cos(HEADING), math.sin(HEADING), 0.0]])
    az, el = aspect_angles(u, np.float64(HEADING), np.float64(pitch))
    np.testing.assert_allclose([az[0], el[0]], [0.0, -pitch], atol=1e-15)


def test_radar_directly_above_is_el_plus_90():
    _, el = aspect_angles(np.array([[0.0, 0.0, 1.0]]), np.float64(HEADING), np.float64(0.0))
    assert el[0] == pytest.approx(math.pi / 2, abs=1e-15)


def test_radar_dead_astern_is_az_plus_pi_even_with_signed_zeros():
    # heading −0.0 and u_y = −0.0 give b = −0.0, for which atan2 returns −π.
    az, _ = aspect_angles(np.array([[-1.0, -0.0, 0.0]]), np.float64(-0.0), np.float64(0.0))
    assert az[0] == math.pi


@given(
    body=unit_vectors,
    heading=st.floats(-math.pi, math.pi),
    pitch=st.floats(-1.4, 1.4),
)
def test_aspect_angles_invert_direction_from_aspect(body, heading, pitch):
    az, el = aspect_angles(_world(body[None, :], heading, pitch), np.float64(heading), np.float64(pitch))
    assert -math.pi < az[0] <= math.pi
    assert -math.pi / 2 <= el[0] <= math.pi / 2
    np.testing.assert_allclose(direction_from_aspect(az, el)[0], body, atol=1e-12)


def test_aspect_angles_broadcast_over_leading_axes_and_radars():
    rng = np.random.default_rng(1)
    heading = rng.uniform(-math.pi, math.pi, (3, 5))
    pitch = rng.uniform(-0.3, 0.3, (3, 5))
    u = _unit(rng.normal(size=(3, 5, 4, 3)))
    az, el = aspect_angles(u, heading, pitch)
    assert az.shape == el.shape == (3, 5, 4)
    for i, j in np.ndindex(3, 5):
        az_ij, el_ij = aspect_angles(u[i, j], heading[i, j], pitch[i, j])
        np.testing.assert_allclose(az[i, j], az_ij, rtol=1e-15)
        np.testing.assert_allclose(el[i, j], el_ij, rtol=1e-15)


# ------------------------------------------------------------------------------------------ lookup


def test_lookup_at_the_nodes_returns_the_node_values(random_table):
    az_deg, el_deg = np.meshgrid(TABLE_AZ_DEG, TABLE_EL_DEG)
    az, el = np.radians(az_deg), np.radians(el_deg)
    sigma = rcs_lookup(random_table, az, el)
    expected = 10.0 ** (random_table / 10.0)
    # Bit-exact wherever degrees -> radians -> degrees round-trips exactly; elsewhere the interpolation
    # weight is one rounding error (~1e-14) instead of 0.
    exact = (np.degrees(az) == az_deg) & (np.degrees(el) == el_deg)
    assert exact.mean() > 0.5
    np.testing.assert_array_equal(sigma[exact], expected[exact])
    np.testing.assert_allclose(sigma, expected, rtol=1e-12)


@pytest.mark.parametrize("which", ["random", "default"])
def test_lookup_between_nodes_matches_regular_grid_interpolator(which, random_table, default_table):
    table = random_table if which == "random" else default_table
    rng = np.random.default_rng(7)
    el_deg = rng.uniform(-90.0, 90.0, 2000)
    az_deg = rng.uniform(-180.0, 180.0, 2000)
    oracle = RegularGridInterpolator((TABLE_EL_DEG, TABLE_AZ_DEG), table, method="linear")
    expected = 10.0 ** (oracle(np.column_stack([el_deg, az_deg])) / 10.0)
    np.testing.assert_allclose(rcs_lookup(table, np.radians(az_deg), np.radians(el_deg)), expected, rtol=1e-9)


def test_lookup_wraps_azimuth_across_180(random_table):
    el = np.radians(TABLE_EL_DEG)
    # az = +179.5° lies between the columns 179° and 180°; −179.5° between −180° and −179°; since
    # column +180° is column −180°, both mix that column with a neighbour half and half.
    plus = rcs_lookup(random_table, np.radians(179.5), el)
    minus = rcs_lookup(random_table, np.radians(-179.5), el)
    np.testing.assert_allclose(
        plus, 10.0 ** ((random_table[:, 359] + random_table[:, 360]) / 20.0), rtol=1e-12
    )
    np.testing.assert_allclose(minus, 10.0 ** ((random_table[:, 0] + random_table[:, 1]) / 20.0), rtol=1e-12)
    az = np.radians(np.linspace(-180.0, 180.0, 97))
    np.testing.assert_allclose(
        rcs_lookup(random_table, az + 2 * math.pi, el[:, None]),
        rcs_lookup(random_table, az, el[:, None]),
        rtol=1e-10,
    )
    np.testing.assert_allclose(
        rcs_lookup(random_table, az - 4 * math.pi, el[:, None]),
        rcs_lookup(random_table, az, el[:, None]),
        rtol=1e-10,
    )
    np.testing.assert_allclose(
        rcs_lookup(random_table, math.pi, el), rcs_lookup(random_table, -math.pi, el), rtol=1e-12
    )


def test_lookup_clamps_elevation(random_table):
    az = np.radians(np.linspace(-180.0, 180.0, 37))
    np.testing.assert_array_equal(
        rcs_lookup(random_table, az, np.radians(100.0)), rcs_lookup(random_table, az, np.radians(90.0))
    )
    np.testing.assert_array_equal(
        rcs_lookup(random_table, az, np.radians(-120.0)), rcs_lookup(random_table, az, np.radians(-90.0))
    )


def test_lookup_keeps_leading_shapes(random_table):
    rng = np.random.default_rng(3)
    az = rng.uniform(-math.pi, math.pi, (2, 3, 4))
    el = rng.uniform(-math.pi / 2, math.pi / 2, (2, 3, 4))
    sigma = rcs_lookup(random_table, az, el)
    assert sigma.shape == (2, 3, 4)
    np.testing.assert_allclose(sigma.ravel(), rcs_lookup(random_table, az.ravel(), el.ravel()), rtol=1e-15)
    assert rcs_lookup(random_table, az, 0.0).shape == (2, 3, 4)
    assert np.shape(rcs_lookup(random_table, 0.3, -0.2)) == ()


def test_lookup_rejects_a_table_of_the_wrong_shape():
    with pytest.raises(ValueError, match=r"\(181, 361\)"):
        rcs_lookup(np.zeros((181, 360)), np.zeros(3), np.zeros(3))


def test_lookup_of_the_default_table_at_the_nodes_is_the_table(default_table):
    # Nose-on, broadside: the lookup returns the tabulated power.
    assert rcs_lookup(default_table, 0.0, 0.0) == pytest.approx(10.0 ** (default_table[90, 180] / 10.0))
    assert rcs_lookup(default_table, math.pi / 2, 0.0) == pytest.approx(
        10.0 ** (default_table[90, 270] / 10.0)
    )


# ----------------------------------------------------------------------------------------- loaders


def test_constant_table_gives_the_constant_everywhere():
    table = constant_rcs_table(0.1)
    assert table.shape == (181, 361)
    np.testing.assert_allclose(table, -10.0, rtol=1e-15)
    rng = np.random.default_rng(5)
    sigma = rcs_lookup(table, rng.uniform(-10.0, 10.0, 500), rng.uniform(-2.0, 2.0, 500))
    np.testing.assert_allclose(sigma, 0.1, rtol=1e-14)


@pytest.mark.parametrize("value", [0.0, -1.0, math.nan, math.inf])
def test_constant_table_rejects_non_positive_values(value):
    with pytest.raises(ValueError, match="rcs_m2"):
        constant_rcs_table(value)


def _write_csv(path, rows: np.ndarray, header: str = "el_deg,az_deg,rcs_dbsm") -> None:
    np.savetxt(path, rows, delimiter=",", header=header, comments="", fmt="%.17g")


def _grid_rows(table: np.ndarray) -> np.ndarray:
    az, el = np.meshgrid(TABLE_AZ_DEG, TABLE_EL_DEG)
    return np.column_stack([el.ravel(), az.ravel(), table.ravel()])


def test_load_csv_round_trip_in_any_row_and_column_order(tmp_path, random_table):
    rows = _grid_rows(random_table)
    rows = rows[np.random.default_rng(2).permutation(len(rows))]
    path = tmp_path / "uav.csv"
    _write_csv(path, rows[:, [2, 0, 1]], header="rcs_dbsm, el_deg, az_deg")
    np.testing.assert_array_equal(load_rcs_table(path), random_table)
    # az = +180° may be left out: it is az = −180°.
    _write_csv(path, rows[rows[:, 1] != 180.0])
    np.testing.assert_array_equal(load_rcs_table(path), random_table)


def test_load_npy_round_trip(tmp_path, random_table):
    path = tmp_path / "uav.npy"
    np.save(path, random_table)
    np.testing.assert_array_equal(load_rcs_table(str(path)), random_table)


def _broken_csv_rows(random_table: np.ndarray, problem: str) -> tuple[np.ndarray, str]:
    rows = _grid_rows(random_table)
    if problem == "missing":
        return np.delete(rows, 1234, axis=0), r"grid node\(s\) missing"
    if problem == "duplicated":
        return np.vstack([rows, rows[:1]]), "duplicated"
    if problem == "off-grid":
        rows[10, 0] = 0.5
        return rows, "off the table grid"
    if problem == "non-finite":
        rows[10, 2] = np.nan
        return rows, "non-finite"
    if problem == "seam":
        rows[rows[:, 1] == 180.0, 2] += 1.0
        return rows, "az=-180 and az=\\+180 deg differ"
    raise AssertionError(problem)


@pytest.mark.parametrize("problem", ["missing", "duplicated", "off-grid", "non-finite", "seam"])
def test_load_csv_errors_name_the_file_and_the_problem(tmp_path, random_table, problem):
    rows, message = _broken_csv_rows(random_table, problem)
    path = tmp_path / f"broken-{problem}.csv"
    _write_csv(path, rows)
    with pytest.raises(ValueError, match=message) as error:
        load_rcs_table(path)
    assert path.name in str(error.value)
    assert "expected" in str(error.value)


def test_load_csv_rejects_missing_columns_and_text(tmp_path, random_table):
    path = tmp_path / "columns.csv"
    _write_csv(path, _grid_rows(random_table), header="el_deg,azimuth,rcs_dbsm")
    with pytest.raises(ValueError, match=r"missing column.*az_deg") as error:
        load_rcs_table(path)
    assert path.name in str(error.value)
    path.write_text("el_deg,az_deg,rcs_dbsm\n0,0,loud\n")
    with pytest.raises(ValueError, match="unreadable"):
        load_rcs_table(path)


def test_load_npy_and_suffix_errors(tmp_path):
    path = tmp_path / "short.npy"
    np.save(path, np.zeros((181, 360)))
    with pytest.raises(ValueError, match=r"shape \(181, 360\), expected \(181, 361\)") as error:
        load_rcs_table(path)
    assert path.name in str(error.value)
    other = tmp_path / "table.txt"
    other.write_text("1 2 3")
    with pytest.raises(ValueError, match=r"unsupported file type '\.txt'"):
        load_rcs_table(other)
    with pytest.raises(FileNotFoundError, match=r"absent\.csv"):
        load_rcs_table(tmp_path / "absent.csv")


# ---------------------------------------------------------------------------------------- modules


def test_runtime_lookup_imports_nothing_of_the_table_build():
    """The model's per-step path (aspect angles, lookup) reads the grid only, never the build code."""
    import ast
    import inspect

    from uav_penetration_env.rcs import lookup

    tree = ast.parse(inspect.getsource(lookup))
    imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    imported |= {
        alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names
    }
    assert imported == {"__future__", "numpy", "uav_penetration_env.rcs.grid", "uav_penetration_env.types"}
