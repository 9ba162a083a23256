"""Terrain (model.md §2-3): bilinear queries, natural terrain generators, mountains, terrain threat.

The batched formulas tested here are the numpy oracle (tests/numpy_model.py); test_kernels.py checks
the compiled model against it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy_model import terrain_threat
from scipy import ndimage
from scipy.interpolate import RegularGridInterpolator

from uav_penetration_env.build import grid_for, natural_terrain, terrain_heights
from uav_penetration_env.scenario import (
    DiamondSquare,
    FlatTerrain,
    GaussianField,
    GaussianHill,
    RandomWalk,
    TerrainConfig,
    paper_scenario,
)
from uav_penetration_env.terrain import (
    GridSpec,
    bilinear,
    diamond_square_field,
    gaussian_field,
    gaussian_hill,
    mountain_heights,
    mountain_shape,
    random_walk_field,
    scale_to_height,
)

# A small non-square grid of arbitrary values (axis 0 = x, axis 1 = y).
NX, NY = 7, 9
VALUES = np.random.default_rng(0).normal(100.0, 50.0, size=(NX, NY))
LAYERS = np.random.default_rng(1).normal(0.0, 10.0, size=(4, NX, NY))


# --- bilinear interpolation ---------------------------------------------------------------------


@given(st.floats(0.0, NX - 1.0), st.floats(0.0, NY - 1.0))
def test_bilinear_equals_regular_grid_interpolator_inside(fi, fj):
    oracle = RegularGridInterpolator((np.arange(NX), np.arange(NY)), VALUES, method="linear")
    got = bilinear(VALUES, np.array(fi), np.array(fj))
    assert got == pytest.approx(oracle([[fi, fj]])[0], rel=1e-12, abs=1e-9)


@given(st.floats(-5.0, NX + 4.0), st.floats(-5.0, NY + 4.0))
def test_bilinear_holds_edge_values_outside(fi, fj):
    oracle = ndimage.map_coordinates(VALUES, [[fi], [fj]], order=1, mode="nearest")[0]
    got = bilinear(VALUES, np.array(fi), np.array(fj))
    assert got == pytest.approx(oracle, rel=1e-12, abs=1e-9)
    # Clamping: the value lies within the grid's range.
    assert VALUES.min() - 1e-9 <= got <= VALUES.max() + 1e-9


def test_bilinear_hits_nodes_and_the_last_row_exactly():
    ii, jj = np.meshgrid(np.arange(NX), np.arange(NY), indexing="ij")
    np.testing.assert_array_equal(bilinear(VALUES, ii.astype(float), jj.astype(float)), VALUES)
    # Corners far outside hold the corner values.
    assert bilinear(VALUES, np.array(-100.0), np.array(1e6)) == VALUES[0, -1]
    assert bilinear(VALUES, np.array(1e6), np.array(-100.0)) == VALUES[-1, 0]


def test_bilinear_is_exact_for_a_bilinear_function():
    # f = a + b i + c j + d i j is reproduced exactly by bilinear interpolation.
    ii, jj = np.meshgrid(np.arange(NX), np.arange(NY), indexing="ij")
    grid = 3.0 + 2.0 * ii - 0.5 * jj + 0.25 * ii * jj
    fi, fj = np.array([0.3, 2.75, 5.999]), np.array([7.5, 0.1, 4.0])
    np.testing.assert_allclose(bilinear(grid, fi, fj), 3.0 + 2.0 * fi - 0.5 * fj + 0.25 * fi * fj, rtol=1e-14)


def test_bilinear_keeps_the_query_shape():
    fi = np.full((2, 3, 5), 1.5)
    assert bilinear(VALUES, fi, fi).shape == (2, 3, 5)


def test_grid_spec_maps_metres_to_fractional_indices():
    grid = GridSpec(x0_m=-25_000.0, y0_m=-10_000.0, dx_m=500.0, nx=301, ny=201)
    fi, fj = grid.fractional_index(np.array([-25_000.0, 0.0, 250.0]), np.array([-10_000.0, 0.0, 125.0]))
    np.testing.assert_allclose(fi, [0.0, 50.0, 50.5])
    np.testing.assert_allclose(fj, [0.0, 20.0, 20.25])
    gx, gy = grid.mesh()
    assert gx.shape == (301, 201)
    assert gx[1, 0] - gx[0, 0] == 500.0 and gy[0, 1] - gy[0, 0] == 500.0
    assert grid.x_nodes[-1] == 125_000.0 and grid.y_nodes[-1] == 90_000.0


@given(
    st.lists(
        st.tuples(st.floats(-3.0, NX + 2.0), st.floats(-3.0, NY + 2.0), st.integers(0, 3)),
        min_size=1,
        max_size=20,
    )
)
def test_layered_lookup_equals_per_layer_lookups(points):
    fi = np.array([p[0] for p in points])
    fj = np.array([p[1] for p in points])
    layer = np.array([p[2] for p in points])
    got = bilinear(LAYERS, fi, fj, layer)
    expected = [float(bilinear(LAYERS[k], np.array(a), np.array(b))) for a, b, k in points]
    np.testing.assert_allclose(got, expected, rtol=1e-13, atol=1e-12)


def test_layered_lookup_flattens_leading_axes_and_broadcasts():
    stacked = LAYERS.reshape(2, 2, NX, NY)
    fi = np.array([[1.25], [4.5]])  # (2, 1)
    fj = np.array([[0.5, 8.0, 3.3]])  # (1, 3)
    layer = np.array([0, 3, 2])  # broadcast to (2, 3)
    fi_b, fj_b = np.broadcast_arrays(fi, fj)
    got = bilinear(stacked, fi_b, fj_b, layer)
    assert got.shape == (2, 3)
    for r in range(2):
        for c in range(3):
            assert got[r, c] == pytest.approx(
                float(bilinear(LAYERS[layer[c]], fi_b[r, c], fj_b[r, c])), rel=1e-13
            )


# --- natural terrain ----------------------------------------------------------------------------------

SMALL_GRID = GridSpec(0.0, 0.0, 500.0, 61, 41)


def test_gaussian_field_is_filtered_white_noise_scaled_to_0_200():
    # The spec's recipe (§2.3), written out: xi ~ N(0,1) from the seed, gaussian_filter(sigma = l/dx, reflect).
    config = TerrainConfig(seed=5, natural=GaussianField(height_m=200.0, correlation_km=5.0), mountains=())
    heights = natural_terrain(config, SMALL_GRID)
    noise = np.random.default_rng(5).standard_normal((61, 41))
    smooth = ndimage.gaussian_filter(noise, sigma=10.0, mode="reflect")
    expected = 200.0 * (smooth - smooth.min()) / (smooth.max() - smooth.min())
    np.testing.assert_allclose(heights, expected, rtol=0, atol=1e-9)
    assert heights.min() == 0.0 and heights.max() == 200.0
    assert np.all((heights >= 0.0) & (heights <= 200.0))


def test_gaussian_field_is_deterministic_per_seed():
    a = gaussian_field((40, 30), np.random.default_rng(9), 4.0)
    b = gaussian_field((40, 30), np.random.default_rng(9), 4.0)
    c = gaussian_field((40, 30), np.random.default_rng(10), 4.0)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)
    # A longer correlation length gives a smoother surface (smaller mean neighbour difference).
    rough = scale_to_height(gaussian_field((60, 60), np.random.default_rng(2), 1.0), 200.0)
    smooth = scale_to_height(gaussian_field((60, 60), np.random.default_rng(2), 6.0), 200.0)
    assert np.abs(np.diff(smooth, axis=0)).mean() < np.abs(np.diff(rough, axis=0)).mean()


def test_scale_to_height_maps_min_to_0_and_max_to_height():
    field = np.array([[-3.0, 1.0], [5.0, 0.0]])
    np.testing.assert_allclose(scale_to_height(field, 200.0), [[0.0, 100.0], [200.0, 75.0]])
    np.testing.assert_array_equal(scale_to_height(np.full((3, 3), 7.0), 200.0), np.zeros((3, 3)))


def _walk_oracle(xi: np.ndarray) -> np.ndarray:
    """Eq. 4 corrected (A8), one cell at a time."""
    n = xi.shape[0]
    h = np.zeros((n, n))
    h[0, 0] = xi[0, 0]
    for i in range(1, n):
        h[i, i] = h[i - 1, i - 1] + xi[i, i]
    for i in range(n):
        for j in range(i + 1, n):  # upper triangle along rows
            h[i, j] = h[i, j - 1] + xi[i, j]
    for j in range(n):
        for i in range(j + 1, n):  # lower triangle along columns
            h[i, j] = h[i - 1, j] + xi[i, j]
    return h


@pytest.mark.parametrize("n", [1, 2, 6, 17])
def test_random_walk_without_smoothing_satisfies_eq4(n):
    walk = random_walk_field((n, n), np.random.default_rng(42), passes=0)
    xi = np.random.default_rng(42).standard_normal((n, n))
    np.testing.assert_allclose(walk, _walk_oracle(xi), rtol=0, atol=1e-12)
    # The recurrences directly, as differences of the returned field.
    assert walk[0, 0] == pytest.approx(xi[0, 0])
    for i in range(n - 1):
        assert walk[i + 1, i + 1] - walk[i, i] == pytest.approx(xi[i + 1, i + 1], abs=1e-12)
    for i in range(n):
        for j in range(n):
            if j > i:
                assert walk[i, j] - walk[i, j - 1] == pytest.approx(xi[i, j], abs=1e-12)
            elif i > j:
                assert walk[i, j] - walk[i - 1, j] == pytest.approx(xi[i, j], abs=1e-12)


def test_random_walk_one_pass_is_the_2x2_box_mean():
    n = 12
    raw = random_walk_field((n + 1, n + 1), np.random.default_rng(3), passes=0)
    smoothed = random_walk_field((n, n), np.random.default_rng(3), passes=1)
    box = 0.25 * (raw[:-1, :-1] + raw[1:, :-1] + raw[:-1, 1:] + raw[1:, 1:])
    assert smoothed.shape == (n, n)
    np.testing.assert_allclose(smoothed, box, rtol=0, atol=1e-12)
    twice = random_walk_field((n - 1, n - 1), np.random.default_rng(3), passes=2)
    np.testing.assert_allclose(
        twice, 0.25 * (box[:-1, :-1] + box[1:, :-1] + box[:-1, 1:] + box[1:, 1:]), atol=1e-12
    )


def test_random_walk_terrain_is_scaled_and_deterministic():
    config = TerrainConfig(seed=8, natural=RandomWalk(height_m=200.0, passes=1), mountains=())
    a = natural_terrain(config, SMALL_GRID)
    assert a.shape == (61, 41)
    assert a.min() == 0.0 and a.max() == 200.0
    np.testing.assert_array_equal(a, natural_terrain(config, SMALL_GRID))
    other = natural_terrain(TerrainConfig(seed=9, natural=RandomWalk(), mountains=()), SMALL_GRID)
    assert not np.allclose(a, other)


def test_diamond_square_is_finite_deterministic_and_scaled():
    a = diamond_square_field((50, 33), np.random.default_rng(4), 0.5)
    b = diamond_square_field((50, 33), np.random.default_rng(4), 0.5)
    c = diamond_square_field((50, 33), np.random.default_rng(5), 0.5)
    assert a.shape == (50, 33)
    assert np.all(np.isfinite(a))
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)
    config = TerrainConfig(seed=4, natural=DiamondSquare(height_m=200.0), mountains=())
    heights = natural_terrain(config, SMALL_GRID)
    assert np.all(np.isfinite(heights)) and heights.min() == 0.0 and heights.max() == 200.0


def test_diamond_square_smaller_roughness_is_smoother():
    rough = scale_to_height(diamond_square_field((65, 65), np.random.default_rng(0), 0.9), 1.0)
    smooth = scale_to_height(diamond_square_field((65, 65), np.random.default_rng(0), 0.3), 1.0)
    assert np.abs(np.diff(smooth, axis=0)).mean() < np.abs(np.diff(rough, axis=0)).mean()


def test_gaussian_hill_and_flat_terrain():
    config = TerrainConfig(natural=GaussianHill(height_m=200.0, sigma_km=5.0), mountains=())
    heights = natural_terrain(config, SMALL_GRID)  # centre (15, 10) km = node (30, 20)
    assert heights[30, 20] == pytest.approx(200.0)
    assert heights.max() == pytest.approx(200.0)
    # One sigma (5 km = 10 nodes) east: 200 exp(-1/2).
    assert heights[40, 20] == pytest.approx(200.0 * math.exp(-0.5), rel=1e-12)
    assert gaussian_hill(np.array(3.0), np.array(4.0), (0.0, 0.0), 5.0) == pytest.approx(math.exp(-0.5))
    flat = natural_terrain(TerrainConfig(natural=FlatTerrain(height_m=12.5), mountains=()), SMALL_GRID)
    np.testing.assert_array_equal(flat, np.full((61, 41), 12.5))


# --- mountains and terrain threat (eqs. 2, 3, 6) --------------------------------------------------


def test_mountain_shape_is_exp_minus_lambda_r2_in_km():
    centres = np.array([[10.0, 10.0], [40.0, 25.0]])
    f = mountain_shape(np.array([10.0, 13.0, 40.0]), np.array([10.0, 14.0, 30.0]), centres, 0.04)
    assert f.shape == (3, 2)
    assert f[0, 0] == 1.0  # at the centre
    assert f[1, 0] == pytest.approx(math.exp(-1.0), rel=1e-14)  # r = 5 km: the e-folding radius at λ = 0.04
    assert f[2, 1] == pytest.approx(math.exp(-1.0), rel=1e-14)
    assert f[0, 1] == pytest.approx(math.exp(-0.04 * (30.0**2 + 15.0**2)), rel=1e-12)


def test_mountain_heights_is_the_max_of_scaled_peaks():
    centres = np.array([[0.0, 0.0], [6.0, 0.0]])
    heights = np.array([500.0, 300.0])
    x = np.array([0.0, 3.0, 6.0])
    got = mountain_heights(x, np.zeros(3), centres, heights, 0.04)
    expected = [max(500.0 * math.exp(-0.04 * xx**2), 300.0 * math.exp(-0.04 * (xx - 6.0) ** 2)) for xx in x]
    np.testing.assert_allclose(got, expected, rtol=1e-14)
    empty = mountain_heights(np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((0, 2)), np.zeros(0), 0.04)
    np.testing.assert_array_equal(empty, np.zeros((2, 3)))


PEAKS = np.array([[10.0, 10.0], [40.0, 25.0], [45.0, 50.0]])


@given(st.floats(-25.0, 125.0), st.floats(-25.0, 125.0), st.floats(0.001, 1.0))
def test_terrain_threat_is_the_max_over_peaks_in_0_1(x, y, decay):
    threat = float(terrain_threat(np.array(x), np.array(y), PEAKS, decay))
    expected = max(math.exp(-decay * ((x - px) ** 2 + (y - py) ** 2)) for px, py in PEAKS)
    assert 0.0 <= threat <= 1.0
    assert threat == pytest.approx(expected, rel=1e-12, abs=1e-300)


@given(st.floats(0.0, 60.0), st.floats(0.0, 60.0), st.lists(st.booleans(), min_size=3, max_size=3))
def test_masked_peaks_are_ignored(x, y, present):
    mask = np.array(present, dtype=float)
    threat = float(terrain_threat(np.array(x), np.array(y), PEAKS, 0.04, mask))
    kept = PEAKS[np.array(present)]
    expected = max((math.exp(-0.04 * ((x - px) ** 2 + (y - py) ** 2)) for px, py in kept), default=0.0)
    assert threat == pytest.approx(expected, rel=1e-12, abs=1e-300)


def test_terrain_threat_hand_values_and_batching():
    # At M1's centre the threat is 1; a masked M1 leaves M2/M3's contribution.
    assert terrain_threat(np.array(10.0), np.array(10.0), PEAKS, 0.04) == 1.0
    masked = terrain_threat(np.array(10.0), np.array(10.0), PEAKS, 0.04, np.array([0.0, 1.0, 1.0]))
    assert masked == pytest.approx(math.exp(-0.04 * (30.0**2 + 15.0**2)), rel=1e-12)
    xs = np.array([[10.0, 40.0], [45.0, 0.0]])
    out = terrain_threat(xs, np.array([[10.0, 25.0], [50.0, 0.0]]), PEAKS, 0.04)
    assert out.shape == (2, 2)
    np.testing.assert_allclose(out[0], [1.0, 1.0])
    assert out[1, 0] == 1.0
    assert out[1, 1] == pytest.approx(math.exp(-0.04 * 200.0), rel=1e-12)
    # Per-point peak lists (leading axes on the centres): a (2, 3, 2) centre array for 2 points.
    centres = np.stack([PEAKS, PEAKS + 1.0])
    per_point = terrain_threat(np.array([10.0, 11.0]), np.array([10.0, 11.0]), centres, 0.04)
    np.testing.assert_allclose(per_point, [1.0, 1.0])
    none = terrain_threat(np.array([1.0, 2.0]), np.array([1.0, 2.0]), np.zeros((0, 2)), 0.04)
    np.testing.assert_array_equal(none, [0.0, 0.0])


# --- composition h = max(h_nat, h_mtn) (model.md §2.4) -----------------------------------------------


def _composed_oracle(scenario) -> np.ndarray:
    grid = grid_for(scenario)
    gx, gy = grid.mesh()
    natural = natural_terrain(scenario.terrain, grid)
    peaks = [
        m.height_m
        * np.exp(
            -scenario.terrain.mountain_decay_per_km2 * ((gx / 1e3 - m.x_km) ** 2 + (gy / 1e3 - m.y_km) ** 2)
        )
        for m in scenario.terrain.mountains
    ]
    return np.maximum(natural, np.max(peaks, axis=0))


@pytest.mark.parametrize("which", ["tiny", "paper"])
def test_composed_terrain_is_max_of_natural_and_mountains(which, tiny):
    scenario = tiny if which == "tiny" else paper_scenario()
    heights = terrain_heights(scenario)
    grid = grid_for(scenario)
    assert heights.shape == (grid.nx, grid.ny)
    np.testing.assert_allclose(heights, _composed_oracle(scenario), rtol=0, atol=1e-9)
    natural = natural_terrain(scenario.terrain, grid)
    for m in scenario.terrain.mountains:
        i = round((m.x_km * 1e3 - grid.x0_m) / grid.dx_m)
        j = round((m.y_km * 1e3 - grid.y0_m) / grid.dx_m)
        assert heights[i, j] >= m.height_m
        assert heights[i, j] == max(natural[i, j], m.height_m)
    assert np.all(heights >= natural)


def test_paper_grid_is_301_squared_at_500_m():
    grid = grid_for(paper_scenario())
    assert (grid.nx, grid.ny, grid.dx_m, grid.x0_m, grid.y0_m) == (301, 301, 500.0, -25_000.0, -25_000.0)
