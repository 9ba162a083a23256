"""LPSO: PSO with a spatial neighbourhood operator (Suganthan 1999).

optimizers.md §6 ([R]: the usual restatement of the CEC 1999 paper). Each particle's social attractor
is the best personal best among the particles within ``frac · dmax_i`` of it (in normalised
coordinates), where ``frac`` grows linearly with time; once ``frac`` exceeds 0.9 the global best is used.
Because ``d_ij / dmax_i <= 1``, the neighbourhood is spatial only during the first ~10 % of the planned
iterations; afterwards LPSO is a global-best PSO with these coefficients. That is the rule, not a bug.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from itertools import count

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.distance import pdist, squareform

from optimizers.base import FloatArray, IntArray, is_real, require, require_integer
from optimizers.registry import register_optimizer
from optimizers.swarm import (
    Swarm,
    SwarmOptimizer,
    cost_rank,
    linear_schedule,
    pso_velocity,
    validate_schedule,
)


def neighbourhood_fraction(step: int, planned: int, intercept: float = 0.6, slope: float = 3.0) -> float:
    """``frac(l) = (slope · l + intercept · T) / T`` with ``l = t - 1`` (§6 step 1).

    Args:
        step: ``l = t - 1``.
        planned: ``T``, the planned iterations.
        intercept: Fraction at ``l = 0``.
        slope: Growth per iteration, in units of ``1 / T``.

    Returns:
        The neighbourhood fraction; 0.6 at ``l = 0``, 0.87 at ``l = 9`` and 0.93 at ``l = 11`` for T = 100.
    """
    return (slope * step + intercept * planned) / planned


def spatial_neighbourhood_best(U: ArrayLike, f_pbest: ArrayLike, frac: float) -> IntArray:
    """Each particle's neighbourhood best (§6 step 2), fully vectorised.

    ``N_i = {i} ∪ {j : d_ij < frac · dmax_i}`` with ``d`` the distances between current positions and
    ``dmax_i = max_j d_ij``; if ``dmax_i = 0`` the neighbourhood is the whole swarm. The best is the
    lowest pbest cost in ``N_i``, ties to the lowest index (§2.9).

    Args:
        U: (N, d) current positions in normalised coordinates.
        f_pbest: (N,) personal-best costs.
        frac: Neighbourhood fraction.

    Returns:
        (N,) index of each particle's neighbourhood best.
    """
    U = np.asarray(U, dtype=np.float64)
    n = U.shape[0]
    dist = squareform(pdist(U))
    dmax = dist.max(axis=1)
    member = dist < (frac * dmax)[:, None]
    member[np.arange(n), np.arange(n)] = True
    member[dmax == 0.0] = True
    rank = cost_rank(f_pbest)
    best_rank = np.where(member, rank[None, :], n).min(axis=1)
    order = np.empty(n, dtype=np.int64)
    order[rank] = np.arange(n)
    return order[best_rank]


@register_optimizer("lpso")
@dataclass(frozen=True)
class LPSO(SwarmOptimizer):
    """PSO with a growing spatial neighbourhood (Suganthan 1999; optimizers.md §6).

    Attributes:
        swarm_size: N.
        inertia: ``(w_start, w_end)`` of the linear schedule (D21).
        cognitive: c1.
        social: c2.
        frac_intercept: neighbourhood fraction at the first iteration.
        frac_slope: its growth, ``frac(l) = (slope · l + intercept · T) / T``.
        gbest_threshold: use the global best once ``frac`` exceeds this.

    The shared swarm options are those of :class:`optimizers.swarm.SwarmOptimizer`.
    """

    swarm_size: int = 100  # N (budget fairness)
    inertia: tuple[float, float] = (0.9, 0.4)  # w, DECISION: optimizers.md D21
    cognitive: float = 2.0  # c1, [R]
    social: float = 2.0  # c2, [R]
    frac_intercept: float = 0.6  # [R]
    frac_slope: float = 3.0  # [R]
    gbest_threshold: float = 0.9  # [R]

    def __post_init__(self) -> None:
        super().__post_init__()
        name = type(self).__name__
        require_integer(self, "swarm_size", 1)
        validate_schedule(self, "inertia")
        for field in ("cognitive", "social", "frac_intercept", "frac_slope", "gbest_threshold"):
            value = getattr(self, field)
            require(is_real(value) and value >= 0, name, field, value, "a finite number >= 0")

    def iterate(self, swarm: Swarm, rng: np.random.Generator) -> Iterator[None]:
        """One iteration per ``next``: neighbourhood bests, velocity, move (§6 steps 1-3).

        Trace: ``global_best_from``, the first iteration that used the global best (``None`` while
        every iteration so far used spatial neighbourhoods).
        """
        swarm.trace["global_best_from"] = None
        for t in count(1):
            frac = neighbourhood_fraction(t - 1, swarm.planned, self.frac_intercept, self.frac_slope)
            if frac > self.gbest_threshold:
                local_best: FloatArray = swarm.pbest[np.argmin(swarm.f_pbest)]
                if swarm.trace["global_best_from"] is None:
                    swarm.trace["global_best_from"] = t
            else:
                local_best = swarm.pbest[spatial_neighbourhood_best(swarm.normalised(), swarm.f_pbest, frac)]
            w = linear_schedule(self.inertia[0], self.inertia[1], t, swarm.planned)
            r1, r2 = rng.random((2, swarm.n, swarm.d))
            swarm.fly(pso_velocity(swarm.v, swarm.x, swarm.pbest, local_best, r1, r2, inertia=w,
                                   cognitive=self.cognitive, social=self.social, constriction=1.0))
            yield None
