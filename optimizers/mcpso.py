"""MCPSO: multi-swarm cooperative PSO (Niu, Zhu & He 2005; Niu, Zhu, He & Wu 2007).

optimizers.md §8, following the public implementation xiaokewan/MCPSO (``COL_MCPSO.m``,
``COM_MCPSO.m``): one master swarm and three slave swarms of 25 particles. The slaves run
inertia-weight PSO independently; the master also follows the best slave particle, either always
(collaborative, COL, the default) or in competition with its own best (COM). Each iteration evaluates
the slaves first, then the master, so the master sees the updated slave information: two batches
(75 + 25 rows) per iteration. Flat order: master = particles 0..24, slave k = the next 25 each.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import partial
from itertools import count

import numpy as np

from optimizers.base import FloatArray, is_int, is_real, require, require_integer
from optimizers.registry import register_optimizer
from optimizers.swarm import (
    Swarm,
    SwarmOptimizer,
    attractor_velocity,
    group_best_index,
    group_sizes,
    linear_schedule,
    pso_velocity,
    validate_schedule,
)

VERSIONS = ("col", "com")


def migration_factor(f_slaves: float, f_master: float) -> float:
    """COM's migration factor Φ: 0 if the slaves' best is better, 0.5 if equal, 1 if worse (D26).

    Args:
        f_slaves: Cost of the best slave pbest, ``f(g_S)``.
        f_master: Cost of the master's best pbest, ``f(g_M)``.

    Returns:
        Φ, the weight on the master's own best (``1 - Φ`` goes to the slaves' best).
    """
    if f_slaves < f_master:
        return 0.0
    if f_slaves == f_master:
        return 0.5
    return 1.0


def master_velocity(
    v: FloatArray,
    x: FloatArray,
    pbest: FloatArray,
    g_master: FloatArray,
    g_slaves: FloatArray,
    r: FloatArray,
    *,
    inertia: float,
    cognitive: float,
    social: float,
    migration: float,
    phi: float | None = None,
) -> FloatArray:
    """The master's velocity (§8 step 2), before the clamp.

    COL (``phi=None``): ``w v + c1 r1 (p - x) + c2 r2 (g_M - x) + c3 r3 (g_S - x)``.
    COM (``phi`` = Φ): ``w v + c1 r1 (p - x) + Φ c2 r2 (g_M - x) + (1 - Φ) c3 r3 (g_S - x)``.

    Args:
        v: (n, d) master velocities.
        x: (n, d) master positions.
        pbest: (n, d) master personal bests.
        g_master: (d,) the master's best pbest.
        g_slaves: (d,) the best pbest over all slave particles.
        r: (3, n, d) draws from ``U[0, 1)``.
        inertia: w.
        cognitive: c1.
        social: c2.
        migration: c3.
        phi: Migration factor for COM; ``None`` for COL.

    Returns:
        (n, d) velocities.
    """
    if phi is None:
        coefficients = (cognitive, social, migration)
    else:
        coefficients = (cognitive, phi * social, (1.0 - phi) * migration)
    return attractor_velocity(v, x, (pbest, g_master, g_slaves), coefficients, r, inertia)


@register_optimizer("mcpso")
@dataclass(frozen=True)
class MCPSO(SwarmOptimizer):
    """Master-slave multi-swarm cooperative PSO (optimizers.md §8).

    Attributes:
        swarm_size: Total population, split into ``n_slaves + 1`` sub-swarms by §2.12 (master first).
        n_slaves: S.
        version: ``"col"`` (collaborative) or ``"com"`` (competitive).
        inertia: ``(w_start, w_end)`` of the linear schedule (§2.8).
        cognitive: c1.
        social: c2.
        migration: c3.

    The shared swarm options are those of :class:`optimizers.swarm.SwarmOptimizer`; ``x0`` seeds master
    particle 0.
    """

    swarm_size: int = 100  # budget fairness
    n_slaves: int = 3  # S, [S] implementation
    version: str = "col"  # seed wording ("cooperative")
    inertia: tuple[float, float] = (0.9, 0.4)  # w, [S] implementation
    cognitive: float = 2.05  # c1, [S] implementation
    social: float = 2.05  # c2, [S] implementation
    migration: float = 2.0  # c3, [S] implementation

    def __post_init__(self) -> None:
        super().__post_init__()
        name = type(self).__name__
        require_integer(self, "n_slaves", 1)
        require(is_int(self.swarm_size) and self.swarm_size >= self.n_slaves + 1, name, "swarm_size",
                self.swarm_size, f"an integer >= n_slaves + 1 = {self.n_slaves + 1}")
        require(self.version in VERSIONS, name, "version", self.version, f"one of {VERSIONS}")
        validate_schedule(self, "inertia")
        for field in ("cognitive", "social", "migration"):
            value = getattr(self, field)
            require(is_real(value) and value >= 0, name, field, value, "a finite number >= 0")

    def iterate(self, swarm: Swarm, rng: np.random.Generator) -> Iterator[None]:
        """One iteration per ``next``: the slaves' batch, then the master's (§8 steps 1-2)."""
        n, d = swarm.n, swarm.d
        sizes = group_sizes(n, self.n_slaves + 1)  # DECISION: optimizers.md D25 (master gets any extra)
        n_master = sizes[0]
        master = slice(0, n_master)
        slaves = slice(n_master, n)
        slave_labels = np.repeat(np.arange(self.n_slaves), sizes[1:])
        for t in count(1):
            w = linear_schedule(self.inertia[0], self.inertia[1], t, swarm.planned)
            # Step 1: the slaves, one batch; each follows its own swarm's best.
            ps, fps = swarm.pbest[slaves], swarm.f_pbest[slaves]
            g_k = ps[group_best_index(fps, slave_labels)]
            r1, r2 = rng.random((2, n - n_master, d))
            swarm.fly(pso_velocity(swarm.v[slaves], swarm.x[slaves], ps, g_k, r1, r2, inertia=w,
                                   cognitive=self.cognitive, social=self.social, constriction=1.0), slaves)
            # Step 2: the master, a second batch that sees the updated slaves (skipped if no budget is left).
            if swarm.objective.remaining > 0:
                pm, fpm = swarm.pbest[master], swarm.f_pbest[master]
                i_master, i_slave = int(np.argmin(fpm)), int(np.argmin(fps))
                phi = None if self.version == "col" else migration_factor(fps[i_slave], fpm[i_master])
                r = rng.random((3, n_master, d))
                swarm.fly(master_velocity(swarm.v[master], swarm.x[master], pm, pm[i_master], ps[i_slave], r,
                                          inertia=w, cognitive=self.cognitive, social=self.social,
                                          migration=self.migration, phi=phi), master)
            yield None


register_optimizer("mcpso-com")(partial(MCPSO, version="com"))
