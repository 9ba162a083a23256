"""CCPSO-ISM: competitive and cooperative PSO with information sharing (Li, Zhan, Lin, Zhang & Luo 2015).

optimizers.md §9, following the public Java class ``CCPSO_ISM``. The information sharing mechanism
is a blackboard of all personal bests. Each particle follows one exemplar ``E_i``. While it keeps
improving, the exemplar is left alone; once it has stalled for ``G_r`` iterations, every dimension of
the exemplar is refreshed each iteration (until the particle improves): with probability ``p_l``
from the winner of a competition among ``K_t`` random particles (the lowest pbest cost wins, D27),
otherwise from the particle's own pbest. ``K_t`` grows from about 1 to N over the planned iterations.
Slow convergence at 10^4 evaluations is the design, not a bug (§9).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from itertools import count

import numpy as np
from numpy.typing import ArrayLike

from optimizers.base import FloatArray, IntArray, is_real, require, require_integer
from optimizers.registry import register_optimizer
from optimizers.swarm import Swarm, SwarmOptimizer, attractor_velocity, cost_rank


def competition_size(t: int, planned: int, n: int) -> int:
    """``K_t = clip(ceil(t N / T), 1, N)`` (§9): 2, 51, 100 for t = 1, 50, 99 with T = 99, N = 100."""
    return int(min(max(math.ceil(t * n / planned), 1), n))


def learning_slots(refresh: ArrayLike, learn_draws: ArrayLike, learning_probability: float) -> np.ndarray:
    """The exemplar coordinates that are learnt from a competition winner this iteration.

    Args:
        refresh: (N,) particles whose exemplar is refreshed (stalled for ``G_r`` iterations or more).
        learn_draws: (N, d) draws from ``U[0, 1)``.
        learning_probability: p_l (per dimension).

    Returns:
        (N, d) boolean mask: ``refresh[i] and learn_draws[i, d] < p_l``.
    """
    return np.asarray(refresh, dtype=bool)[:, None] & (np.asarray(learn_draws) < learning_probability)


def random_candidates(keys: FloatArray, k: int) -> IntArray:
    """``K`` distinct candidates per row: the positions of the ``K`` smallest random keys.

    Args:
        keys: (m, N) draws from ``U[0, 1)``, one row per learning slot.
        k: Competition size ``K`` (``1 <= K <= N``).

    Returns:
        (m, K) candidate particle indices, distinct within each row, uniformly random ``K``-subsets.
    """
    n = keys.shape[1]
    if k >= n:
        return np.broadcast_to(np.arange(n), keys.shape).copy()
    return np.argpartition(keys, k - 1, axis=1)[:, :k]


def refresh_exemplar(
    exemplar: FloatArray,
    pbest: FloatArray,
    f_pbest: FloatArray,
    refresh: ArrayLike,
    learn: ArrayLike,
    candidates: IntArray,
) -> FloatArray:
    """The CC operator (§9 step 1.2): refresh the exemplars of stalled particles dimension by dimension.

    For a refreshed particle i, coordinate d is copied from the pbest of the competition winner (the
    candidate with the lowest pbest cost, ties to the lowest index, D27) where ``learn[i, d]``, and from
    i's own pbest elsewhere. Exemplars of other particles are unchanged.

    Args:
        exemplar: (N, d) current exemplars.
        pbest: (N, d) personal bests (the blackboard).
        f_pbest: (N,) personal-best costs.
        refresh: (N,) particles to refresh.
        learn: (N, d) learning slots (only inside refreshed rows; see :func:`learning_slots`).
        candidates: (m, K) candidate indices, one row per True entry of ``learn`` in row-major order.

    Returns:
        (N, d) new exemplars.
    """
    refresh = np.asarray(refresh, dtype=bool)
    learn = np.asarray(np.asarray(learn, dtype=bool) & refresh[:, None])
    out = exemplar.copy()
    out[refresh] = pbest[refresh]
    rows, cols = np.nonzero(learn)
    if rows.size:
        rank = cost_rank(f_pbest)
        winner = np.take_along_axis(candidates, np.argmin(rank[candidates], axis=1)[:, None], axis=1)[:, 0]
        out[rows, cols] = pbest[winner, cols]
    return out


@register_optimizer("ccpso-ism")
@dataclass(frozen=True)
class CCPSOISM(SwarmOptimizer):
    """Competitive and cooperative PSO with information sharing (optimizers.md §9).

    Attributes:
        swarm_size: N.
        inertia: w (constant).
        acceleration: c.
        refreshing_gap: G_r, stalled iterations before the exemplar is refreshed.
        learning_probability: p_l, per dimension.

    The shared swarm options are those of :class:`optimizers.swarm.SwarmOptimizer`.
    """

    swarm_size: int = 100  # N (budget fairness)
    inertia: float = 0.6  # w, [S] implementation
    acceleration: float = 2.0  # c, [S] implementation
    refreshing_gap: int = 5  # G_r, [S] implementation
    learning_probability: float = 0.05  # p_l, [S] implementation

    def __post_init__(self) -> None:
        super().__post_init__()
        name = type(self).__name__
        require_integer(self, "swarm_size", 1)
        require(is_real(self.inertia), name, "inertia", self.inertia, "a finite number")
        require(is_real(self.acceleration) and self.acceleration >= 0, name, "acceleration",
                self.acceleration, "a finite number >= 0")
        require_integer(self, "refreshing_gap", 0)
        require(is_real(self.learning_probability) and 0 <= self.learning_probability <= 1, name,
                "learning_probability", self.learning_probability, "a number in [0, 1]")

    def iterate(self, swarm: Swarm, rng: np.random.Generator) -> Iterator[None]:
        """One iteration per ``next``: the CC operator on stalled particles, velocity, move (§9 step 1)."""
        n, d = swarm.n, swarm.d
        exemplar = swarm.x.copy()  # E_i = the initial pbest
        stall = np.zeros(n, dtype=np.int64)  # s_i
        for t in count(1):
            k = competition_size(t, swarm.planned, n)
            refresh = stall >= self.refreshing_gap
            if refresh.any():  # the CC operator; s_i is not reset by a refresh
                learn = learning_slots(refresh, rng.random((n, d)), self.learning_probability)
                candidates = random_candidates(rng.random((int(learn.sum()), n)), k)
                exemplar = refresh_exemplar(exemplar, swarm.pbest, swarm.f_pbest, refresh, learn, candidates)
            r = rng.random((1, n, d))
            improved = swarm.fly(attractor_velocity(swarm.v, swarm.x, (exemplar,), (self.acceleration,), r,
                                                    self.inertia))
            stall = np.where(improved, 0, stall + 1)
            yield None
