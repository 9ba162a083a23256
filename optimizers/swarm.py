"""The particle swarms' shared machinery: options, state, loop and pure operators (optimizers.md §2, §2.10).

Two layers:

* **Pure operators** (the functions below the loop): random coefficient arrays arrive as arguments (so
  tests can pass ones or zeros), and only the running swarm draws from the Generator. The one exception
  is :func:`random_equal_groups`, which takes the Generator because its draw *is* the operation (a
  random partition), as in HPSO's Step 0 (§4).
* **The shared loop**: :class:`SwarmOptimizer` is the base of every swarm optimiser. It holds the
  options every swarm shares (boundary rule, initialisation region, velocity cap; docs/swarm.md) and
  the one loop (:meth:`SwarmOptimizer.solve`): initialise a :class:`Swarm` (positions, zero velocities,
  first evaluation, personal bests, first history entry), then run the algorithm's own iteration rule,
  recording the history after every iteration and stopping when the budget is spent or the rule asks to.
  An algorithm file only writes :meth:`SwarmOptimizer.iterate`: its velocity update, grouping, schedule
  and switching, calling :meth:`Swarm.fly` (or :meth:`Swarm.move` and :meth:`Swarm.evaluate`).

Shapes: ``N`` particles, ``d`` dimensions.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from optimizers.base import (
    MESSAGE_INIT_EXHAUSTED,
    MESSAGE_MAX_EVALS,
    FloatArray,
    IntArray,
    OptimizerBase,
    OptimizeResult,
    Problem,
    coerce_pair,
    is_int,
    is_real,
    normalize_bounds,
    require,
)

VELOCITY_FRACTION = 0.2
"""Default ``vmax_d = 0.2 (hi_d - lo_d)`` for every swarm (§2.4, D4); see ``velocity_fraction``."""

BOUNDARY_RULES = ("absorb", "reflect", "damp", "random")
"""What happens to a coordinate that would leave the bounds (docs/swarm.md §3)."""


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


def reflect_into_bounds(moved: ArrayLike, lo: ArrayLike, hi: ArrayLike) -> tuple[FloatArray, np.ndarray]:
    """Mirror every coordinate back into ``[lo, hi]`` by its overshoot, as often as it takes.

    A coordinate that ends at ``hi + e`` lands at ``hi - e``; one at ``lo - e`` lands at ``lo + e``. An
    overshoot larger than the range bounces off both walls in turn (the position folds with period
    ``2 (hi - lo)``), so every result lies inside the bounds. Coordinates already inside are unchanged.

    Args:
        moved: (..., d) positions after the move, possibly outside.
        lo: (d,) lower bounds.
        hi: (d,) upper bounds.

    Returns:
        ``(x, flipped)``: (..., d) positions inside ``[lo, hi]``, and the (..., d) mask of coordinates
        that bounced an odd number of times (their direction of travel is reversed).
    """
    moved = np.asarray(moved, dtype=np.float64)
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    span = hi - lo
    offset = moved - lo
    period = 2.0 * span
    folded = offset - np.floor(offset / period) * period  # in [0, 2 span), up to rounding
    folded = np.where(folded > span, period - folded, folded)
    inside = (moved >= lo) & (moved <= hi)
    x = np.where(inside, moved, np.minimum(np.maximum(lo + folded, lo), hi))  # the clip only guards rounding
    flipped = ~inside & (np.floor(offset / span) % 2 == 1)
    return x, flipped


def confine(
    x: ArrayLike,
    v: ArrayLike,
    lo: FloatArray,
    hi: FloatArray,
    rule: str = "absorb",
    rng: np.random.Generator | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Move ``x <- x + v`` and apply a boundary rule to the coordinates that leave ``[lo, hi]``.

    Rules (docs/swarm.md §3):

    * ``"absorb"``: clip to the wall, velocity 0 (§2.5, D5; the default, :func:`move_within_bounds`).
    * ``"reflect"``: mirror by the overshoot (:func:`reflect_into_bounds`); the velocity component is
      reversed when the coordinate bounced an odd number of times.
    * ``"damp"``: clip to the wall, velocity reversed and halved, ``v <- -0.5 v`` (SPSO 2011).
    * ``"random"``: the offending coordinate is re-drawn uniformly in ``[lo_j, hi_j]``, velocity 0.

    DECISION: ``reflect`` reverses the velocity of a coordinate that bounced an odd number of times, so
    the particle keeps travelling along the mirrored path (the rule of a ball between two walls);
    ``random`` sets the re-drawn coordinate's velocity to 0, as a freshly initialised particle has
    (§2.2), so that it is not thrown straight back out. Both are docs/swarm.md §3.

    Args:
        x: (..., d) positions.
        v: (..., d) new velocities (already clamped).
        lo: (d,) lower bounds.
        hi: (d,) upper bounds.
        rule: One of :data:`BOUNDARY_RULES`.
        rng: The run's Generator; used by ``"random"`` only, one draw per offending coordinate in
            row-major order.

    Returns:
        ``(x_new, v_new)``, new arrays, every ``x_new`` inside ``[lo, hi]``.

    Raises:
        ValueError: If ``rule`` is unknown, or ``"random"`` gets no Generator.
    """
    if rule == "absorb":
        return move_within_bounds(x, v, lo, hi)
    v = np.asarray(v, dtype=np.float64)
    moved = np.asarray(x, dtype=np.float64) + v
    if rule == "reflect":
        x_new, flipped = reflect_into_bounds(moved, lo, hi)
        return x_new, np.where(flipped, -v, v)
    out = (moved < lo) | (moved > hi)
    if rule == "damp":
        return np.minimum(np.maximum(moved, lo), hi), np.where(out, -0.5 * v, v)
    if rule == "random":
        if rng is None:
            raise ValueError("rng: got None, expected a Generator for the 'random' boundary rule")
        x_new, v_new = moved.copy(), v.copy()
        rows = np.nonzero(out)
        column = rows[-1]
        redrawn = lo[column] + rng.random(column.shape[0]) * (hi[column] - lo[column])
        x_new[rows] = np.minimum(np.maximum(redrawn, lo[column]), hi[column])
        v_new[rows] = 0.0
        return x_new, v_new
    raise ValueError(f"boundary: got {rule!r}, expected one of {BOUNDARY_RULES}")


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
    r: Sequence[FloatArray] | FloatArray,
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
        r: L arrays of (N, d) draws from ``U[0, 1)``, one per attractor (or one (L, N, d) array).
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


def pso_velocity(
    v: FloatArray,
    x: FloatArray,
    pbest: FloatArray,
    gbest: FloatArray,
    r1: FloatArray,
    r2: FloatArray,
    *,
    inertia: float,
    cognitive: float,
    social: float,
    constriction: float,
) -> FloatArray:
    """PSO velocity ``chi [w v + c1 r1 (p - x) + c2 r2 (g - x)]`` (§3 step 2; also LPSO §6, MCPSO §8).

    The constriction variant uses ``w = 1``; the inertia-weight variants ``chi = 1``.

    Args:
        v: (N, d) velocities.
        x: (N, d) positions.
        pbest: (N, d) personal bests.
        gbest: (d,) or (N, d) social attractor (global, neighbourhood or sub-swarm best).
        r1: (N, d) draws from ``U[0, 1)``.
        r2: (N, d) draws from ``U[0, 1)``.
        inertia: ``w``.
        cognitive: ``c1``.
        social: ``c2``.
        constriction: ``chi``.

    Returns:
        (N, d) velocities before the clamp.
    """
    return attractor_velocity(v, x, (pbest, gbest), (cognitive, social), (r1, r2), inertia, constriction)


# ----------------------------------------------------------------------------------------------
# Holonic levels, shared by HPSO (§4) and IHPSO (§5)
# ----------------------------------------------------------------------------------------------

N_LEVELS = 3  # the three levels of the holon hierarchy: particle, group, swarm (optimizers.md D8)


def level_weights(n_levels: int = N_LEVELS) -> FloatArray:
    """Holonic level weights ``lambda_l = (L - l + 1) / L``, l = 1..L (D8): ``(1, 2/3, 1/3)`` for L = 3."""
    levels = np.arange(1, n_levels + 1)
    return (n_levels - levels + 1) / n_levels


_HOLONIC_LEVEL_WEIGHTS = level_weights(N_LEVELS)  # computed once: eqs. 22-23 read it every iteration
_HOLONIC_LEVEL_WEIGHTS.flags.writeable = False


def holonic_attractors(
    pbest: FloatArray, f_pbest: FloatArray, labels: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``pBest_1..3`` for every particle: own pbest, group-best pbest, global-best pbest (D8, §2.9).

    Args:
        pbest: (N, d) personal-best positions.
        f_pbest: (N,) personal-best costs.
        labels: (N,) group labels.

    Returns:
        ``(p1, p2, p3)`` with shapes (N, d), (N, d) and (d,).
    """
    return pbest, pbest[group_best_index(f_pbest, labels)], pbest[int(np.argmin(f_pbest))]


def holonic_velocity(
    v: FloatArray,
    x: FloatArray,
    attractors: tuple[FloatArray, FloatArray, FloatArray],
    r: FloatArray,
    inertia: FloatArray | float,
    *,
    acceleration: float,
    constriction: float,
    sign: float = 1.0,
) -> FloatArray:
    """Eqs. 22-23 with constriction (D9): ``chi [w v + c l1 r1 (p1 - x) + s sum_{l>=2} c l_l r_l (p_l - x)]``.

    Eq. 22 (stage 1, broad search) is ``sign = +1``; eq. 23 (stage 2) uses ``sign = stage2_sign``.

    Args:
        v: (N, d) velocities.
        x: (N, d) positions.
        attractors: ``(pBest_1, pBest_2, pBest_3)`` as from :func:`holonic_attractors`.
        r: (3, N, d) draws from ``U[0, 1)``, one per level.
        inertia: (N, 1) per-particle inertia (or a scalar).
        acceleration: ``c`` (all levels).
        constriction: ``chi`` (1 = the printed form).
        sign: ``s`` applied to levels 2..3.

    Returns:
        (N, d) velocities before the clamp.
    """
    weights = _HOLONIC_LEVEL_WEIGHTS
    coefficients = (acceleration * weights[0], sign * acceleration * weights[1],
                    sign * acceleration * weights[2])
    return attractor_velocity(v, x, attractors, coefficients, r, inertia, constriction)


def validate_holonic(obj: object) -> None:
    """Validate the hyper-parameters HPSO and IHPSO share (§4 table).

    Raises:
        ValueError: Naming the field, the value and the rule.
    """
    name = type(obj).__name__
    n, g = obj.swarm_size, obj.n_groups  # type: ignore[attr-defined]
    require(is_int(n) and n >= 2, name, "swarm_size", n, "an integer >= 2")
    require(is_int(g) and 1 <= g <= n, name, "n_groups", g,
            f"an integer with 1 <= n_groups <= swarm_size={n}")
    w = coerce_pair(obj, "inertia_range")
    require(all(is_real(b) for b in w) and w[0] <= w[1], name, "inertia_range", w,
            "a pair (low, high) of finite numbers with low <= high")
    c = obj.acceleration  # type: ignore[attr-defined]
    require(is_real(c) and c >= 0, name, "acceleration", c, "a finite number >= 0")
    chi = obj.constriction  # type: ignore[attr-defined]
    require(is_real(chi) and chi > 0, name, "constriction", chi, "a finite number > 0")
    s = obj.stage2_sign  # type: ignore[attr-defined]
    require(s in (1, -1) and not isinstance(s, bool), name, "stage2_sign", s, "+1 or -1")
    tr = obj.regroup_period  # type: ignore[attr-defined]
    require(is_int(tr) and tr >= 1, name, "regroup_period", tr, "an integer >= 1")


def validate_schedule(obj: object, field: str) -> None:
    """Validate a ``(start, end)`` pair of finite numbers (an inertia schedule, §2.8).

    Raises:
        ValueError: Naming the field, the value and the rule.
    """
    pair = coerce_pair(obj, field)
    require(all(is_real(w) for w in pair), type(obj).__name__, field, pair,
            "a pair (w_start, w_end) of finite numbers")


# ----------------------------------------------------------------------------------------------
# The shared loop: options, swarm state, iteration
# ----------------------------------------------------------------------------------------------


class Swarm:
    """The state of one swarm run: positions, velocities, personal bests, budget and trace.

    Built by :meth:`SwarmOptimizer.solve`: positions uniform in the initialisation region with
    particle 0 at the warm start (§2.2, D1), zero velocities, one evaluation of the whole swarm as the
    first personal bests, and the first history entry (§2.6). Algorithms read the arrays and move the
    swarm with :meth:`fly`; they never call the objective themselves.

    Attributes:
        objective: The budgeted objective (the only caller of the user's function).
        lo: (d,) lower bounds.
        hi: (d,) upper bounds.
        n: Number of particles N.
        d: Number of dimensions.
        vmax: (d,) speed limit, ``velocity_fraction (hi - lo)`` (§2.4).
        boundary: The boundary rule (one of :data:`BOUNDARY_RULES`).
        x: (N, d) positions.
        v: (N, d) velocities.
        f: (N,) costs of the last evaluation of each particle.
        pbest: (N, d) personal-best positions.
        f_pbest: (N,) personal-best costs.
        trace: What the algorithm reports about its state machine (becomes ``OptimizeResult.trace``).
    """

    def __init__(
        self,
        problem: Problem,
        n: int,
        rng: np.random.Generator,
        *,
        boundary: str = "absorb",
        init_region: tuple[FloatArray, FloatArray] | None = None,
        velocity_fraction: float = VELOCITY_FRACTION,
    ) -> None:
        self.objective = problem.objective
        self.lo, self.hi = problem.lo, problem.hi
        self.n, self.d = int(n), problem.dim
        self.rng = rng
        self.boundary = boundary
        self.vmax = velocity_limit(self.lo, self.hi, velocity_fraction)
        init_lo, init_hi = (self.lo, self.hi) if init_region is None else init_region
        self.x = init_positions(rng.random((self.n, self.d)), init_lo, init_hi, problem.x0)
        self.v = np.zeros_like(self.x)
        self.f = self.objective(self.x)
        self.pbest, self.f_pbest = self.x.copy(), self.f.copy()
        self.trace: dict[str, Any] = {}
        self.objective.record()

    @property
    def planned(self) -> int:
        """The planned iteration count ``T`` of §2.7 for this budget and population."""
        return planned_iterations(self.objective.max_evals, self.n)

    def normalised(self) -> FloatArray:
        """(N, d) current positions in normalised coordinates (§2.1)."""
        return normalise(self.x, self.lo, self.hi)

    def move(self, v: ArrayLike, rows: slice = slice(None)) -> None:
        """Clamp the new velocities (§2.4) and move the particles ``rows`` under the boundary rule (§2.5).

        Args:
            v: (n_rows, d) new velocities before the clamp.
            rows: The particles that move (all by default; a sub-swarm for MCPSO).
        """
        x, v = confine(self.x[rows], clamp_velocity(v, self.vmax), self.lo, self.hi, self.boundary, self.rng)
        self.x[rows], self.v[rows] = x, v

    def evaluate(self, rows: slice = slice(None)) -> np.ndarray:
        """Evaluate the particles ``rows`` (one batch) and update their personal bests (§2.6 g).

        Returns:
            (n_rows,) boolean mask of the particles whose personal best improved.
        """
        f = self.objective(self.x[rows])
        pbest, f_pbest, improved = update_personal_best(self.x[rows], f, self.pbest[rows], self.f_pbest[rows])
        self.f[rows], self.pbest[rows], self.f_pbest[rows] = f, pbest, f_pbest
        return improved

    def fly(self, v: ArrayLike, rows: slice = slice(None)) -> np.ndarray:
        """:meth:`move` then :meth:`evaluate`: one swarm step of §2.6 for the particles ``rows``.

        Returns:
            (n_rows,) boolean mask of the particles whose personal best improved.
        """
        self.move(v, rows)
        return self.evaluate(rows)

    def run(self, steps: Iterator[str | None]) -> OptimizeResult:
        """The shared loop: one step of ``steps`` per iteration while budget remains (§2.6, §2.7).

        After each step the history is recorded. A step yields ``None`` to go on, or a message to stop
        (IHPSO's adaptive termination); otherwise the run ends when the budget is spent.

        Args:
            steps: The algorithm's iterator (:meth:`SwarmOptimizer.iterate`); each ``next`` runs one
                iteration.

        Returns:
            The result, ``nit`` the number of iterations run.
        """
        t = 0
        message = MESSAGE_MAX_EVALS
        while self.objective.remaining > 0:
            t += 1
            stop = next(steps)
            self.objective.record()
            if stop is not None:
                message = stop
                break
        return self.result(t, message)

    def result(self, nit: int, message: str) -> OptimizeResult:
        """The run's :class:`OptimizeResult`, with :attr:`trace` frozen (lists become tuples)."""
        trace = {key: tuple(value) if isinstance(value, list) else value for key, value in self.trace.items()}
        return self.objective.result(nit, message, trace=trace)


@dataclass(frozen=True, kw_only=True)
class SwarmOptimizer(OptimizerBase):
    """Base of every particle swarm: the shared options and the one loop (docs/swarm.md).

    A subclass is a frozen dataclass with a ``swarm_size`` (field or property) and an :meth:`iterate`
    generator; its own ``__post_init__`` calls ``super().__post_init__()``. The options are keyword-only
    fields of every swarm's configuration, so ``get_optimizer("pso", boundary="reflect")`` works.

    Attributes:
        boundary: What happens at the walls: ``"absorb"`` (default, §2.5 D5), ``"reflect"``, ``"damp"``
            or ``"random"`` (:func:`confine`).
        init_bounds: Initialisation region as ``(lower, upper)`` pairs, one per dimension, inside the
            bounds; ``None`` (default) initialises in the bounds. Any form of
            :func:`optimizers.base.normalize_bounds` is accepted and stored as a tuple of pairs.
        velocity_fraction: Speed limit as a share of each dimension's range (default 0.2, §2.4 D4).

    DECISION: a warm start ``x0`` seeds particle 0 even when it lies outside ``init_bounds`` (it is the
    caller's explicit choice); the region only places the other particles (docs/swarm.md
    §4). The defaults are the rules every swarm used before the options existed.
    """

    boundary: str = "absorb"
    init_bounds: tuple[tuple[float, float], ...] | None = None
    velocity_fraction: float = VELOCITY_FRACTION

    def __post_init__(self) -> None:
        name = type(self).__name__
        require(self.boundary in BOUNDARY_RULES, name, "boundary", self.boundary, f"one of {BOUNDARY_RULES}")
        require(is_real(self.velocity_fraction) and self.velocity_fraction > 0, name, "velocity_fraction",
                self.velocity_fraction, "a finite number > 0")
        if self.init_bounds is not None:
            try:
                lo, hi = normalize_bounds(self.init_bounds)
            except ValueError as exc:
                raise ValueError(f"{name}.init_bounds: {exc}") from None
            object.__setattr__(self, "init_bounds", tuple(zip(lo.tolist(), hi.tolist(), strict=True)))

    @property
    def swarm_size(self) -> int:
        """Number of particles; every subclass defines it (a field or a property)."""
        raise NotImplementedError

    def init_region(self, lo: FloatArray, hi: FloatArray) -> tuple[FloatArray, FloatArray] | None:
        """The initialisation region for these bounds, checked to lie inside them.

        Args:
            lo: (d,) lower bounds of the problem.
            hi: (d,) upper bounds of the problem.

        Returns:
            ``None`` (initialise in the bounds) or ``(init_lo, init_hi)``, (d,) arrays.

        Raises:
            ValueError: If the region has another dimension or leaves the bounds.
        """
        if self.init_bounds is None:
            return None
        name = type(self).__name__
        pairs = np.array(self.init_bounds, dtype=np.float64)
        if pairs.shape[0] != lo.shape[0]:
            raise ValueError(f"{name}.init_bounds: got {pairs.shape[0]} (lower, upper) pairs, expected "
                             f"{lo.shape[0]} (one per dimension of the bounds)")
        init_lo, init_hi = pairs[:, 0], pairs[:, 1]
        outside = (init_lo < lo) | (init_hi > hi)
        if outside.any():
            i = int(np.flatnonzero(outside)[0])
            raise ValueError(f"{name}.init_bounds[{i}]: got ({float(init_lo[i])!r}, {float(init_hi[i])!r}), "
                             f"expected an interval inside the bounds [{float(lo[i])!r}, {float(hi[i])!r}]")
        return init_lo, init_hi

    def solve(self, problem: Problem, rng: np.random.Generator) -> OptimizeResult:
        """Initialise the swarm, then run :meth:`iterate` in the shared loop (:meth:`Swarm.run`).

        ``x0`` (already in ``problem``) seeds particle 0.

        Raises:
            ValueError: If ``init_bounds`` has another dimension than the bounds or leaves them.
        """
        swarm = Swarm(problem, self.swarm_size, rng, boundary=self.boundary,
                      init_region=self.init_region(problem.lo, problem.hi),
                      velocity_fraction=self.velocity_fraction)
        if problem.objective.max_evals < swarm.n:
            return swarm.result(0, MESSAGE_INIT_EXHAUSTED)
        return swarm.run(self.iterate(swarm, rng))

    def iterate(self, swarm: Swarm, rng: np.random.Generator) -> Iterator[str | None]:
        """The algorithm's own rules: a generator that runs one iteration per ``next``.

        Code before the first iteration is the algorithm's set-up (groups, counters); each iteration
        computes the velocities, calls ``swarm.fly`` and yields ``None``, or a message to stop early.
        The shared loop (:meth:`Swarm.run`) records the history and watches the budget.

        Args:
            swarm: The initialised swarm.
            rng: The run's Generator (draws in the algorithm's order).

        Yields:
            ``None`` to continue, or the stop message.
        """
        raise NotImplementedError
