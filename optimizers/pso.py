"""Reference global-best PSO: constriction (``pso``) and linearly decreasing inertia (``pso-ldw``).

optimizers.md §3. Constriction form from Clerc & Kennedy (2002) with ``phi = 4.1``; the inertia-weight
form from Shi & Eberhart (1998), ``w`` falling linearly from 0.9 to 0.4 over the planned iterations.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np
from numpy.typing import ArrayLike

from optimizers.base import (
    MESSAGE_INIT_EXHAUSTED,
    MESSAGE_MAX_EVALS,
    BatchObjective,
    BoundsLike,
    FloatArray,
    OptimizeResult,
    RNGLike,
    coerce_pair,
    is_int,
    is_real,
    prepare,
    require,
)
from optimizers.registry import register_optimizer
from optimizers.swarm import (
    attractor_velocity,
    clamp_velocity,
    init_positions,
    linear_schedule,
    move_within_bounds,
    planned_iterations,
    update_personal_best,
    velocity_limit,
)

VARIANTS = ("constriction", "ldw")


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
    """PSO velocity ``chi [w v + c1 r1 (p - x) + c2 r2 (g - x)]`` (§3 step 2).

    The constriction variant uses ``w = 1``; the ldw variant ``chi = 1``.

    Args:
        v: (N, d) velocities.
        x: (N, d) positions.
        pbest: (N, d) personal bests.
        gbest: (d,) or (N, d) social attractor (global or neighbourhood best).
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


@register_optimizer("pso")
@dataclass(frozen=True)
class PSO:
    """Global-best PSO, the reference row of the leaderboards (optimizers.md §3).

    Attributes:
        swarm_size: N.
        variant: ``"constriction"`` (``chi [v + ...]``) or ``"ldw"`` (``w_t v + ...``).
        constriction: chi, used by the constriction variant.
        cognitive: c1.
        social: c2.
        inertia: ``(w_start, w_end)`` of the ldw variant's linear schedule (§2.8).
    """

    swarm_size: int = 100  # N (budget fairness)
    variant: str = "constriction"
    constriction: float = 0.72984  # chi, from phi = 4.1
    cognitive: float = 2.05  # c1
    social: float = 2.05  # c2
    inertia: tuple[float, float] = (0.9, 0.4)  # w, ldw only

    def __post_init__(self) -> None:
        name = type(self).__name__
        require(is_int(self.swarm_size) and self.swarm_size >= 1, name, "swarm_size", self.swarm_size,
                "an integer >= 1")
        require(self.variant in VARIANTS, name, "variant", self.variant, f"one of {VARIANTS}")
        require(is_real(self.constriction) and self.constriction > 0, name, "constriction", self.constriction,
                "a finite number > 0")
        for field in ("cognitive", "social"):
            value = getattr(self, field)
            require(is_real(value) and value >= 0, name, field, value, "a finite number >= 0")
        inertia = coerce_pair(self, "inertia")
        require(all(is_real(w) for w in inertia), name, "inertia", inertia,
                "a pair (w_start, w_end) of finite numbers")

    def minimize(
        self,
        fun: BatchObjective,
        bounds: BoundsLike,
        *,
        rng: RNGLike | None = None,
        max_evals: int = 10_000,
        x0: ArrayLike | None = None,
    ) -> OptimizeResult:
        """Minimise ``fun`` (see :class:`optimizers.base.Optimizer`)."""
        rng = np.random.default_rng(rng)
        problem = prepare(fun, bounds, max_evals, x0)
        objective, lo, hi = problem.objective, problem.lo, problem.hi
        n = self.swarm_size
        vmax = velocity_limit(lo, hi)
        planned = planned_iterations(objective.max_evals, n)
        ldw = self.variant == "ldw"

        x = init_positions(rng.random((n, problem.dim)), lo, hi, problem.x0)
        v = np.zeros_like(x)
        f = objective(x)
        pbest, f_pbest = x.copy(), f.copy()
        objective.record()
        if objective.max_evals < n:
            return objective.result(0, MESSAGE_INIT_EXHAUSTED)

        t = 0
        while objective.remaining > 0:
            t += 1
            gbest = pbest[np.argmin(f_pbest)]
            r1, r2 = rng.random((2, n, problem.dim))
            if ldw:
                w = linear_schedule(self.inertia[0], self.inertia[1], t, planned)
                v = pso_velocity(v, x, pbest, gbest, r1, r2, inertia=w, cognitive=self.cognitive,
                                 social=self.social, constriction=1.0)
            else:
                v = pso_velocity(v, x, pbest, gbest, r1, r2, inertia=1.0, cognitive=self.cognitive,
                                 social=self.social, constriction=self.constriction)
            x, v = move_within_bounds(x, clamp_velocity(v, vmax), lo, hi)
            f = objective(x)
            pbest, f_pbest, _ = update_personal_best(x, f, pbest, f_pbest)
            objective.record()
        return objective.result(t, MESSAGE_MAX_EVALS)


register_optimizer("pso-ldw")(partial(PSO, variant="ldw", cognitive=2.0, social=2.0))
