"""Reference global-best PSO: constriction (``pso``) and linearly decreasing inertia (``pso-ldw``).

optimizers.md §3. Constriction form from Clerc & Kennedy (2002) with ``phi = 4.1``; the inertia-weight
form from Shi & Eberhart (1998), ``w`` falling linearly from 0.9 to 0.4 over the planned iterations.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import partial
from itertools import count

import numpy as np

from optimizers.base import is_real, require, require_integer
from optimizers.registry import register_optimizer
from optimizers.swarm import Swarm, SwarmOptimizer, linear_schedule, pso_velocity, validate_schedule

VARIANTS = ("constriction", "ldw")


@register_optimizer("pso")
@dataclass(frozen=True)
class PSO(SwarmOptimizer):
    """Global-best PSO, the reference row of the leaderboards (optimizers.md §3).

    Attributes:
        swarm_size: N.
        variant: ``"constriction"`` (``chi [v + ...]``) or ``"ldw"`` (``w_t v + ...``).
        constriction: chi, used by the constriction variant.
        cognitive: c1.
        social: c2.
        inertia: ``(w_start, w_end)`` of the ldw variant's linear schedule (§2.8).

    The shared swarm options (``boundary``, ``init_bounds``, ``velocity_fraction``) are those of
    :class:`optimizers.swarm.SwarmOptimizer`.
    """

    swarm_size: int = 100  # N (budget fairness)
    variant: str = "constriction"
    constriction: float = 0.72984  # chi, from phi = 4.1
    cognitive: float = 2.05  # c1
    social: float = 2.05  # c2
    inertia: tuple[float, float] = (0.9, 0.4)  # w, ldw only

    def __post_init__(self) -> None:
        super().__post_init__()
        name = type(self).__name__
        require_integer(self, "swarm_size", 1)
        require(self.variant in VARIANTS, name, "variant", self.variant, f"one of {VARIANTS}")
        require(is_real(self.constriction) and self.constriction > 0, name, "constriction", self.constriction,
                "a finite number > 0")
        for field in ("cognitive", "social"):
            value = getattr(self, field)
            require(is_real(value) and value >= 0, name, field, value, "a finite number >= 0")
        validate_schedule(self, "inertia")

    def iterate(self, swarm: Swarm, rng: np.random.Generator) -> Iterator[None]:
        """One iteration per ``next``: global best, velocity, move (§3 steps 1-3)."""
        ldw = self.variant == "ldw"
        for t in count(1):
            gbest = swarm.pbest[np.argmin(swarm.f_pbest)]
            r1, r2 = rng.random((2, swarm.n, swarm.d))
            if ldw:
                w = linear_schedule(self.inertia[0], self.inertia[1], t, swarm.planned)
                v = pso_velocity(swarm.v, swarm.x, swarm.pbest, gbest, r1, r2, inertia=w,
                                 cognitive=self.cognitive, social=self.social, constriction=1.0)
            else:
                v = pso_velocity(swarm.v, swarm.x, swarm.pbest, gbest, r1, r2, inertia=1.0,
                                 cognitive=self.cognitive, social=self.social, constriction=self.constriction)
            swarm.fly(v)
            yield None


register_optimizer("pso-ldw")(partial(PSO, variant="ldw", cognitive=2.0, social=2.0))
