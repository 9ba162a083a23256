"""Terrain: grid geometry, bilinear queries, natural terrain, mountains (paper §2.2, eqs. 2-5).

Everything here is a pure function of its arguments. Heights live on a regular grid
``heights[ix, iy]`` (axis 0 = x/east, axis 1 = y/north, model.md §2.1); a query is bilinear
interpolation with edge values held outside the grid (``map_coordinates(order=1, mode='nearest')``
semantics, written with plain index arithmetic because it runs on the planners' hot path).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from uav_penetration_env.types import FloatArray


@dataclass(frozen=True)
class GridSpec:
    """A regular grid: node ``(i, j)`` sits at ``(x0 + i dx, y0 + j dx)`` metres."""

    x0_m: float
    y0_m: float
    dx_m: float
    nx: int
    ny: int

    @property
    def x_nodes(self) -> FloatArray:
        """Node x coordinates [m], shape (nx,)."""
        return self.x0_m + self.dx_m * np.arange(self.nx)

    @property
    def y_nodes(self) -> FloatArray:
        """Node y coordinates [m], shape (ny,)."""
        return self.y0_m + self.dx_m * np.arange(self.ny)

    def mesh(self) -> tuple[FloatArray, FloatArray]:
        """Node coordinates [m] as two (nx, ny) arrays (``indexing='ij'``)."""
        return np.meshgrid(self.x_nodes, self.y_nodes, indexing="ij")

    def fractional_index(self, x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Fractional grid indices of points given in metres."""
        return (np.asarray(x) - self.x0_m) / self.dx_m, (np.asarray(y) - self.y0_m) / self.dx_m


def bilinear(values: FloatArray, fi: FloatArray, fj: FloatArray, layer: FloatArray | int = 0) -> FloatArray:
    """Bilinear interpolation on one or several stacked grids, edge values held outside.

    Args:
        values: (..., nx, ny) grid values; leading axes are flattened into layers.
        fi: fractional x index (any shape).
        fj: fractional y index (same shape as ``fi``).
        layer: flat index of the layer to read for each point (broadcast with ``fi``); 0 for a
            single grid.

    Returns:
        Interpolated values with the shape of ``fi``.
    """
    nx, ny = values.shape[-2], values.shape[-1]
    flat = values.reshape(-1)
    fi = np.clip(fi, 0.0, nx - 1.0)
    fj = np.clip(fj, 0.0, ny - 1.0)
    i0 = np.minimum(fi.astype(np.intp), nx - 2)
    j0 = np.minimum(fj.astype(np.intp), ny - 2)
    ti = fi - i0
    tj = fj - j0
    base = i0 * ny + j0
    if not (isinstance(layer, int) and layer == 0):
        base = base + np.asarray(layer, dtype=np.intp) * (nx * ny)
    v00 = flat.take(base)
    v01 = flat.take(base + 1)
    v10 = flat.take(base + ny)
    v11 = flat.take(base + ny + 1)
    return (v00 + (v01 - v00) * tj) * (1.0 - ti) + (v10 + (v11 - v10) * tj) * ti


# --- natural terrain generators (unscaled fields; `scale_to_height` maps them to [0, H]) ---------


def gaussian_field(shape: tuple[int, int], rng: np.random.Generator, correlation_cells: float) -> FloatArray:
    """A smooth Gaussian random field: white noise filtered by a Gaussian kernel (model.md §2.3).

    DECISION (model.md §2.3, A10): the paper's "joint two-dimensional Gaussian distribution" is read
    as a Gaussian random field with correlation length ``correlation_cells`` grid cells.
    """
    noise = rng.standard_normal(shape)
    return ndimage.gaussian_filter(noise, sigma=correlation_cells, mode="reflect")


def random_walk_field(shape: tuple[int, int], rng: np.random.Generator, passes: int = 1) -> FloatArray:
    """The paper's random-walk terrain (eqs. 4-5, corrected as in model.md §2.3, A8/A9).

    The walk starts at (0, 0) with zero-mean N(0, 1) increments: the diagonal by ``cumsum``, the
    upper triangle (j > i) along rows from the diagonal, the lower triangle (i > j) along columns.
    Each smoothing pass is the 2 x 2 box mean of eq. 5, which shrinks the grid by one node per
    axis, so the walk is drawn ``passes`` nodes larger than ``shape``.
    """
    n = max(shape) + passes
    steps = rng.standard_normal((n, n))
    diagonal = np.cumsum(np.diag(steps))
    upper = np.cumsum(np.triu(steps, 1), axis=1)  # h(i, j) = h(i, j-1) + xi for j > i
    lower = np.cumsum(np.tril(steps, -1), axis=0)  # h(i, j) = h(i-1, j) + xi for i > j
    rows, cols = np.indices((n, n))
    walk = np.where(cols > rows, diagonal[:, None] + upper, 0.0)
    walk = np.where(rows > cols, diagonal[None, :] + lower, walk)
    walk = np.where(rows == cols, diagonal[rows], walk)
    for _ in range(passes):
        walk = 0.25 * (walk[:-1, :-1] + walk[1:, :-1] + walk[:-1, 1:] + walk[1:, 1:])
    return walk[: shape[0], : shape[1]]


def diamond_square_field(
    shape: tuple[int, int], rng: np.random.Generator, roughness: float = 0.5
) -> FloatArray:
    """Diamond-square fractal terrain on the smallest 2^n + 1 square covering ``shape``.

    ``roughness`` in (0, 1) is the factor by which the random displacement shrinks per level
    (0.5 gives the classic fractal dimension ~2.5 surface).
    """
    size = 1
    while size + 1 < max(shape):
        size *= 2
    n = size + 1
    field = np.zeros((n, n))
    field[::size, ::size] = rng.standard_normal((2, 2))
    step, scale = size, 1.0
    while step > 1:
        half = step // 2
        # Diamond step: centres of squares get the mean of their four corners plus noise.
        corners = field[0:-1:step, 0:-1:step] + field[step::step, 0:-1:step]
        corners = corners + field[0:-1:step, step::step] + field[step::step, step::step]
        centre_count = corners.shape
        field[half::step, half::step] = 0.25 * corners + scale * rng.standard_normal(centre_count)
        # Square step: edge midpoints get the mean of their (up to four) neighbours plus noise.
        padded = np.pad(field, half, mode="constant", constant_values=np.nan)
        for offset_i, offset_j in ((0, half), (half, 0)):
            ii, jj = np.meshgrid(np.arange(offset_i, n, step), np.arange(offset_j, n, step), indexing="ij")
            neighbours = np.stack(
                [
                    padded[ii, jj + half],
                    padded[ii + 2 * half, jj + half],
                    padded[ii + half, jj],
                    padded[ii + half, jj + 2 * half],
                ]
            )
            count = np.sum(~np.isnan(neighbours), axis=0)
            mean = np.nansum(neighbours, axis=0) / count
            field[ii, jj] = mean + scale * rng.standard_normal(ii.shape)
        step, scale = half, scale * roughness
    return field[: shape[0], : shape[1]]


def gaussian_hill(
    x_m: FloatArray, y_m: FloatArray, centre_m: tuple[float, float], sigma_m: float
) -> FloatArray:
    """One Gaussian bump exp(-|r - mu|^2 / (2 sigma^2)) in [0, 1] (model.md §2.3 option)."""
    r2 = (x_m - centre_m[0]) ** 2 + (y_m - centre_m[1]) ** 2
    return np.exp(-r2 / (2.0 * sigma_m**2))


def scale_to_height(field: FloatArray, height_m: float) -> FloatArray:
    """Min-max scale a field to [0, height_m]; a constant field maps to 0."""
    low, high = float(field.min()), float(field.max())
    if high - low <= 0.0:
        return np.zeros_like(field)
    return height_m * (field - low) / (high - low)


# --- mountains and terrain threat (eqs. 2, 3, 6) -------------------------------------------------


def mountain_shape(
    x_km: FloatArray, y_km: FloatArray, centres_km: FloatArray, decay_per_km2: float
) -> FloatArray:
    """f_i(x, y) = exp(-lambda [(x - x_i)^2 + (y - y_i)^2]) for every peak (eq. 2 with its squares).

    Args:
        x_km: (...) query x [km].
        y_km: (...) query y [km].
        centres_km: (..., I, 2) peak centres [km] (leading axes broadcast with the query).
        decay_per_km2: lambda [km^-2].

    Returns:
        (..., I) values in (0, 1].
    """
    dx = np.asarray(x_km)[..., None] - centres_km[..., 0]
    dy = np.asarray(y_km)[..., None] - centres_km[..., 1]
    return np.exp(-decay_per_km2 * (dx * dx + dy * dy))


def mountain_heights(
    x_km: FloatArray, y_km: FloatArray, centres_km: FloatArray, heights_m: FloatArray, decay_per_km2: float
) -> FloatArray:
    """h_mtn = max_i H_i f_i(x, y) [m] (eq. 3's max); 0 where there are no peaks."""
    if len(heights_m) == 0:
        return np.zeros(np.broadcast(np.asarray(x_km), np.asarray(y_km)).shape)
    return np.max(heights_m * mountain_shape(x_km, y_km, centres_km, decay_per_km2), axis=-1)
