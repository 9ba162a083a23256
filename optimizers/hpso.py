"""HPSO: holonic PSO (Roshanzamir, Balafar & Razavi 2017, as restated by the seed paper §3.1).

optimizers.md §4. Three holonic levels (D8): the particle, its group (G = 5 random equal groups,
regrouped every ``T_r`` iterations in stage 1) and the whole swarm. Stage 1 (the first 80 % of the
planned iterations) uses eq. 22, stage 2 eq. 23 with frozen groups. Both carry the Clerc–Kennedy
constriction (D9) and stage 2's sign is ``+1`` (D10); the printed forms are the ``hpso-literal``
configuration. The level weights, the attractors and the velocity rule live in ``swarm.py``, shared
with IHPSO.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from functools import partial
from itertools import count

import numpy as np

from optimizers.base import is_real, require
from optimizers.registry import register_optimizer
from optimizers.swarm import (
    Swarm,
    SwarmOptimizer,
    holonic_attractors,
    holonic_velocity,
    level_weights,
    random_equal_groups,
    validate_holonic,
)

__all__ = ["HPSO", "holonic_attractors", "holonic_velocity", "level_weights", "stage1_iterations"]


def stage1_iterations(planned: int, fraction: float) -> int:
    """Length of HPSO's stage 1, ``n1 = floor(fraction T + 0.5)`` (§4 Step 0): 79 for T = 99, 8 for T = 10."""
    return math.floor(fraction * planned + 0.5)


@register_optimizer("hpso")
@dataclass(frozen=True)
class HPSO(SwarmOptimizer):
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

    The shared swarm options are those of :class:`optimizers.swarm.SwarmOptimizer`.
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
        super().__post_init__()
        validate_holonic(self)
        require(is_real(self.stage1_fraction) and 0 <= self.stage1_fraction <= 1, type(self).__name__,
                "stage1_fraction", self.stage1_fraction, "a number in [0, 1]")

    def iterate(self, swarm: Swarm, rng: np.random.Generator) -> Iterator[None]:
        """One iteration per ``next``: regrouping in stage 1, attractors, velocity, move (§4 steps 1-4).

        Trace: ``stage1_iterations`` (n1, the planned stage-1 length), ``stage2_start`` (the first
        iteration of stage 2, ``None`` if the run ended in stage 1) and ``regroup_iterations`` (the
        iterations that began with a random regrouping; the initial grouping is not listed).
        """
        n, d = swarm.n, swarm.d
        w_low, w_high = self.inertia_range
        n1 = stage1_iterations(swarm.planned, self.stage1_fraction)
        labels = random_equal_groups(n, self.n_groups, rng)
        since_grouping = 0
        regroupings: list[int] = []
        swarm.trace.update(stage1_iterations=n1, stage2_start=None, regroup_iterations=regroupings)
        for t in count(1):
            stage1 = t <= n1
            if stage1 and since_grouping == self.regroup_period:
                labels = random_equal_groups(n, self.n_groups, rng)  # DECISION: optimizers.md D11
                since_grouping = 0
                regroupings.append(t)
            if t == n1 + 1:
                swarm.trace["stage2_start"] = t
            attractors = holonic_attractors(swarm.pbest, swarm.f_pbest, labels)
            w = rng.uniform(w_low, w_high, size=(n, 1))  # DECISION: optimizers.md D28
            r = rng.random((3, n, d))
            sign = 1.0 if stage1 else float(self.stage2_sign)  # stage 2 keeps its groups frozen
            swarm.fly(holonic_velocity(swarm.v, swarm.x, attractors, r, w, acceleration=self.acceleration,
                                       constriction=self.constriction, sign=sign))
            yield None
            since_grouping += 1


register_optimizer("hpso-literal")(partial(HPSO, constriction=1.0, stage2_sign=-1))
