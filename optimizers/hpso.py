"""HPSO: holonic PSO (Roshanzamir, Balafar & Razavi 2017, as restated by the seed paper §3.1).

optimizers.md §4. Three holonic levels (D8): the particle, its group (G = 5 random equal groups,
regrouped every ``T_r`` iterations in stage 1) and the whole swarm. Stage 1 (the first 80 % of the
planned iterations) uses eq. 22, stage 2 eq. 23 with frozen groups. Both carry the Clerc–Kennedy
constriction (D9) and stage 2's sign is ``+1`` (D10); the printed forms are the ``hpso-literal``
configuration. IHPSO (``ihpso.py``) reuses the level weights, the attractors and the velocity rule.
"""

from __future__ import annotations

import math
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
    group_best_index,
    init_positions,
    move_within_bounds,
    planned_iterations,
    random_equal_groups,
    update_personal_best,
    velocity_limit,
)

N_LEVELS = 3  # particle, group, swarm (D8)


def level_weights(n_levels: int = N_LEVELS) -> FloatArray:
    """Holonic level weights ``lambda_l = (L - l + 1) / L``, l = 1..L (D8): ``(1, 2/3, 1/3)`` for L = 3."""
    levels = np.arange(1, n_levels + 1)
    return (n_levels - levels + 1) / n_levels


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
    weights = level_weights(N_LEVELS)
    coefficients = (acceleration * weights[0], sign * acceleration * weights[1],
                    sign * acceleration * weights[2])
    return attractor_velocity(v, x, attractors, coefficients, r, inertia, constriction)


def stage1_iterations(planned: int, fraction: float) -> int:
    """Length of HPSO's stage 1, ``n1 = floor(fraction T + 0.5)`` (§4 Step 0): 79 for T = 99, 8 for T = 10."""
    return math.floor(fraction * planned + 0.5)


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


@register_optimizer("hpso")
@dataclass(frozen=True)
class HPSO:
    """Holonic PSO with random groups and a fixed 0.8 stage split (optimizers.md §4).

    Attributes:
        swarm_size: N.
        n_groups: G, the level-2 holons.
        inertia_range: ``w ~ U[a, b]`` drawn per particle per iteration (D28).
        acceleration: c, all levels.
        constriction: chi (D9); 1.0 is the printed eq. 22.
        stage1_fraction: share of the planned iterations in stage 1.
        regroup_period: T_r, iterations between random regroupings in stage 1 (D11).
        stage2_sign: s in eq. 23 (D10); -1 is the printed eq. 23.
    """

    swarm_size: int = 100  # N, seed §5
    n_groups: int = 5  # G, seed §5
    inertia_range: tuple[float, float] = (0.95, 1.0)  # w ~ U[0.95, 1], seed §5
    acceleration: float = 1.3667  # c, seed §5
    constriction: float = 0.7298  # chi, DECISION: optimizers.md D9
    stage1_fraction: float = 0.8  # seed §3.1 Step 3
    regroup_period: int = 10  # T_r, DECISION: optimizers.md D11
    stage2_sign: int = 1  # s, DECISION: optimizers.md D10

    def __post_init__(self) -> None:
        validate_holonic(self)
        require(is_real(self.stage1_fraction) and 0 <= self.stage1_fraction <= 1, type(self).__name__,
                "stage1_fraction", self.stage1_fraction, "a number in [0, 1]")

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
        n, d = self.swarm_size, problem.dim
        vmax = velocity_limit(lo, hi)
        w_low, w_high = self.inertia_range
        n1 = stage1_iterations(planned_iterations(objective.max_evals, n), self.stage1_fraction)

        x = init_positions(rng.random((n, d)), lo, hi, problem.x0)
        v = np.zeros_like(x)
        f = objective(x)
        pbest, f_pbest = x.copy(), f.copy()
        objective.record()
        if objective.max_evals < n:
            return objective.result(0, MESSAGE_INIT_EXHAUSTED)
        labels = random_equal_groups(n, self.n_groups, rng)
        since_grouping = 0

        t = 0
        while objective.remaining > 0:
            t += 1
            stage1 = t <= n1
            if stage1 and since_grouping == self.regroup_period:
                labels = random_equal_groups(n, self.n_groups, rng)  # DECISION: optimizers.md D11
                since_grouping = 0
            attractors = holonic_attractors(pbest, f_pbest, labels)
            w = rng.uniform(w_low, w_high, size=(n, 1))  # DECISION: optimizers.md D28
            r = rng.random((3, n, d))
            sign = 1.0 if stage1 else float(self.stage2_sign)  # stage 2 keeps its groups frozen
            v = holonic_velocity(v, x, attractors, r, w, acceleration=self.acceleration,
                                 constriction=self.constriction, sign=sign)
            x, v = move_within_bounds(x, clamp_velocity(v, vmax), lo, hi)
            f = objective(x)
            pbest, f_pbest, _ = update_personal_best(x, f, pbest, f_pbest)
            objective.record()
            since_grouping += 1
        return objective.result(t, MESSAGE_MAX_EVALS)


register_optimizer("hpso-literal")(partial(HPSO, constriction=1.0, stage2_sign=-1))
