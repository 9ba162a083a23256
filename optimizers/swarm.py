"""Shared pure operators of the particle swarms (optimizers.md §2, §2.10).

Every function here is pure: random coefficient arrays arrive as arguments (so tests can pass ones
or zeros), and only an optimiser's ``minimize`` draws from the Generator. The one exception is
:func:`random_equal_groups`, which takes the Generator because its draw *is* the operation (a random
partition), as in HPSO's Step 0 (§4). Shapes: ``N`` particles, ``d`` dimensions.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from optimizers.base import FloatArray, IntArray

VELOCITY_FRACTION = 0.2
"""``vmax_d = 0.2 (hi_d - lo_d)`` for every swarm (§2.4, D4)."""


def planned_iterations(max_evals: int, population: int) -> int:
    """Planned iteration count ``T = max(1, floor((max_evals - N) / N))`` (§2.7).

    Args:
        max_evals: The evaluation budget.
        population: Total population ``N`` (evaluations per iteration).

    Returns:
        ``T``; 99 for the defaults (10,000 evaluations, 100 particles).
    """
    return max(1, (int(max_evals) - int(population)) // int(population))


def time_fraction(t: int, planned: int) -> float:
    """Schedule position ``tau_t = min(1, (t - 1) / max(T - 1, 1))`` for iteration ``t >= 1`` (§2.8)."""
    return min(1.0, (t - 1) / max(planned - 1, 1))


def linear_schedule(start: float, end: float, t: int, planned: int) -> float:
    """Linear schedule from ``start`` (iteration 1) to ``end`` (iteration ``T`` and after) (§2.8)."""
    return start + (end - start) * time_fraction(t, planned)


def constriction_factor(phi: float) -> float:
    """Clerc–Kennedy constriction ``chi = 2 / |2 - phi - sqrt(phi^2 - 4 phi)|``.

    Args:
        phi: Sum of the acceleration coefficients; must exceed 4.

    Returns:
        ``chi``; about 0.72984 for ``phi = 4.1``.

    Raises:
        ValueError: If ``phi <= 4``.
    """
    if not phi > 4.0:
        raise ValueError(f"phi: got {phi!r}, expected a value > 4 (Clerc-Kennedy constriction)")
    return 2.0 / abs(2.0 - phi - math.sqrt(phi * phi - 4.0 * phi))


def init_positions(
    unit: FloatArray, lo: FloatArray, hi: FloatArray, x0: FloatArray | None = None
) -> FloatArray:
    """Initial positions: uniform in the box, particle 0 at the warm start (§2.2, D1).

    Args:
        unit: (N, d) draws from ``U[0, 1)``.
        lo: (d,) lower bounds.
        hi: (d,) upper bounds.
        x0: Optional (d,) warm start, already clipped into the bounds.

    Returns:
        (N, d) positions inside ``[lo, hi]``.
    """
    x = np.minimum(np.maximum(lo + unit * (hi - lo), lo), hi)  # the clip only guards against rounding
    if x0 is not None:
        x[0] = x0
    return x


def velocity_limit(lo: FloatArray, hi: FloatArray, fraction: float = VELOCITY_FRACTION) -> FloatArray:
    """Per-dimension speed limit ``vmax = fraction (hi - lo)`` (§2.4)."""
    return fraction * (hi - lo)


def clamp_velocity(v: ArrayLike, vmax: ArrayLike) -> FloatArray:
    """Clamp every velocity component to ``[-vmax_d, vmax_d]`` (§2.4).

    Args:
        v: (..., d) velocities.
        vmax: (d,) non-negative limits.

    Returns:
        The clamped velocities (a new array).
    """
    vmax = np.asarray(vmax, dtype=np.float64)
    return np.minimum(np.maximum(np.asarray(v, dtype=np.float64), -vmax), vmax)


def move_within_bounds(
    x: ArrayLike, v: ArrayLike, lo: ArrayLike, hi: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Move ``x <- x + v`` and stop at the walls (§2.5, D5).

    A component that leaves ``[lo, hi]`` is clipped to the bound and its velocity set to 0 (an absorbing
    wall).

    Args:
        x: (..., d) positions.
        v: (..., d) new velocities.
        lo: (d,) lower bounds.
        hi: (d,) upper bounds.

    Returns:
        ``(x_new, v_new)``, new arrays.
    """
    v = np.asarray(v, dtype=np.float64)
    moved = np.asarray(x, dtype=np.float64) + v
    x_new = np.minimum(np.maximum(moved, lo), hi)
    v_new = np.where(x_new != moved, 0.0, v)
    return x_new, v_new


def update_personal_best(
    x: FloatArray, f: FloatArray, pbest: FloatArray, f_pbest: FloatArray
) -> tuple[FloatArray, FloatArray, np.ndarray]:
    """Replace personal bests on strict improvement ``f < f_pbest`` (§2.6 g).

    Args:
        x: (N, d) evaluated positions.
        f: (N,) their costs.
        pbest: (N, d) personal-best positions.
        f_pbest: (N,) personal-best costs.

    Returns:
        ``(pbest, f_pbest, improved)``: new arrays, and the (N,) boolean mask of improved particles.
    """
    improved = f < f_pbest
    return np.where(improved[:, None], x, pbest), np.where(improved, f, f_pbest), improved


def normalise(x: ArrayLike, lo: FloatArray, hi: FloatArray) -> FloatArray:
    """Normalised coordinates ``u = (x - lo) / (hi - lo)`` in ``[0, 1]^d`` (§2.1, D2)."""
    return (np.asarray(x, dtype=np.float64) - lo) / (hi - lo)


def group_sizes(n: int, n_groups: int) -> tuple[int, ...]:
    """Sizes of an equal partition: ``floor(n / G) + [g < n mod G]`` for ``g = 0..G-1`` (§2.12, D14).

    Args:
        n: Number of particles.
        n_groups: Number of groups ``G`` (``1 <= G <= n``).

    Returns:
        The ``G`` sizes, largest first.

    Raises:
        ValueError: If ``G`` is not between 1 and ``n``.
    """
    if not 1 <= n_groups <= n:
        raise ValueError(f"n_groups: got {n_groups!r}, expected 1 <= n_groups <= n = {n}")
    base, extra = divmod(int(n), int(n_groups))
    return tuple(base + (g < extra) for g in range(n_groups))


def labels_from_order(order: ArrayLike, sizes: Sequence[int]) -> IntArray:
    """Cut an ordering of the particles into consecutive blocks of the given sizes.

    Args:
        order: (N,) a permutation of ``0..N-1``.
        sizes: Group sizes summing to ``N``.

    Returns:
        (N,) group labels: the first ``sizes[0]`` particles of ``order`` get label 0, and so on.
    """
    order = np.asarray(order)
    labels = np.empty(order.shape[0], dtype=np.int64)
    labels[order] = np.repeat(np.arange(len(sizes), dtype=np.int64), sizes)
    return labels


def random_equal_groups(n: int, n_groups: int, rng: np.random.Generator) -> IntArray:
    """A uniformly random partition with the sizes of §2.12 (HPSO's random grouping, §4 Step 0).

    Args:
        n: Number of particles.
        n_groups: Number of groups.
        rng: The run's Generator (one permutation is drawn).

    Returns:
        (n,) group labels.
    """
    return labels_from_order(rng.permutation(n), group_sizes(n, n_groups))


def cost_rank(f: ArrayLike) -> IntArray:
    """Rank of each cost, ties broken by the lower index (rank 0 = best; §2.9).

    Args:
        f: (N,) costs (``+inf`` allowed, no NaN).

    Returns:
        (N,) ranks, a permutation of ``0..N-1``.
    """
    order = np.argsort(np.asarray(f), kind="stable")
    rank = np.empty(order.shape[0], dtype=np.int64)
    rank[order] = np.arange(order.shape[0])
    return rank


def group_best_index(f_pbest: ArrayLike, labels: ArrayLike) -> IntArray:
    """For every particle, the index of the best personal best in its group (§2.9).

    Args:
        f_pbest: (N,) personal-best costs.
        labels: (N,) non-negative integer group labels.

    Returns:
        (N,) indices; the lowest cost in the group, ties to the lowest index.
    """
    f_pbest = np.asarray(f_pbest, dtype=np.float64)
    labels = np.asarray(labels)
    order = np.lexsort((f_pbest, labels))  # by label, then cost; stable, so ties keep the lower index
    sorted_labels = labels[order]
    first = np.ones(order.shape[0], dtype=bool)
    first[1:] = sorted_labels[1:] != sorted_labels[:-1]
    best_of_label = np.zeros(int(sorted_labels[-1]) + 1, dtype=np.int64)
    best_of_label[sorted_labels[first]] = order[first]
    return best_of_label[labels]


def attractor_velocity(
    v: FloatArray,
    x: FloatArray,
    attractors: Sequence[FloatArray],
    coefficients: Sequence[float],
    r: Sequence[FloatArray],
    inertia: float | FloatArray = 1.0,
    constriction: float = 1.0,
) -> FloatArray:
    """The common velocity rule ``chi [w v + sum_l c_l r_l * (A_l - x)]`` (before the clamp).

    PSO, HPSO/IHPSO (eqs. 22-23), LPSO, PS2O, MCPSO and CCPSO-ISM are all this rule with their own
    attractors and coefficients.

    Args:
        v: (N, d) current velocities.
        x: (N, d) current positions.
        attractors: L arrays broadcastable to (N, d) (personal, group, global bests, ...).
        coefficients: L acceleration coefficients (signs and level weights included).
        r: L arrays of (N, d) draws from ``U[0, 1)``, one per attractor.
        inertia: Scalar or (N, 1) inertia ``w``.
        constriction: Constriction factor ``chi`` (1 for the inertia-weight form).

    Returns:
        (N, d) new velocities.
    """
    acc = inertia * v
    for attractor, coefficient, draws in zip(attractors, coefficients, r, strict=True):
        acc += (coefficient * draws) * (attractor - x)
    if constriction != 1.0:
        acc *= constriction
    return acc
