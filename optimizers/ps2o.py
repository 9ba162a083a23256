"""PS2O: symbiotic multi-species PSO (Chen & Zhu 2008; Chen, Zhu, Hu & He 2010).

optimizers.md §7. ``M`` species of ``n`` particles. A particle follows its own pbest, its species'
best and the best of its species' symbiotic partners (a random symmetric graph redrawn every
iteration, D22), all under the Clerc–Kennedy constriction (three attractors, φ = 4.1). A species that
has not improved for ``extinction_patience`` iterations, unless it holds the global best, dies out
and is re-seeded at random (D23). Flat order: species ``k`` holds particles ``k·n … k·n + n − 1``.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import partial
from itertools import count

import numpy as np
from numpy.typing import ArrayLike

from optimizers.base import FloatArray, IntArray, is_int, is_real, require, require_integer
from optimizers.registry import register_optimizer
from optimizers.swarm import Swarm, SwarmOptimizer, attractor_velocity, cost_rank, init_positions


def species_best(f_pbest: FloatArray, n_species: int) -> tuple[IntArray, FloatArray]:
    """Best personal best of every species (§7 step 1).

    Args:
        f_pbest: (M·n,) personal-best costs in flat species order.
        n_species: M.

    Returns:
        ``(index, cost)``: (M,) flat index of each species' best pbest (ties to the lowest index) and
        its cost.
    """
    per_species = f_pbest.reshape(n_species, -1)
    local = np.argmin(per_species, axis=1)
    size = per_species.shape[1]
    return np.arange(n_species) * size + local, per_species[np.arange(n_species), local]


def partner_graph(link_draws: FloatArray, lonely_draws: FloatArray, link_probability: float) -> np.ndarray:
    """This iteration's symbiotic partners (D22).

    Each unordered pair of species is linked when its draw (upper triangle of ``link_draws``) is below
    ``link_probability``; the graph is symmetric with an empty diagonal. A species left without a
    partner gets one, uniformly among the others (``lonely_draws[k]`` picks it), as a one-way link.

    Args:
        link_draws: (M, M) draws from ``U[0, 1)``; only the strict upper triangle is used.
        lonely_draws: (M,) draws from ``U[0, 1)``.
        link_probability: p_link.

    Returns:
        (M, M) boolean adjacency; row k lists the partners of species k.
    """
    m = link_draws.shape[0]
    upper = np.triu(link_draws < link_probability, k=1)
    adjacency = upper | upper.T
    lonely = ~adjacency.any(axis=1)
    if m > 1 and lonely.any():
        k = np.flatnonzero(lonely)
        pick = np.minimum((lonely_draws[k] * (m - 1)).astype(np.int64), m - 2)  # index among the others
        partner = pick + (pick >= k)  # skip the species itself
        adjacency[k, partner] = True
    return adjacency


def partner_best_index(adjacency: ArrayLike, f_species: ArrayLike) -> IntArray:
    """For every species, its partner species with the lowest best cost (ties to the lowest index).

    Args:
        adjacency: (M, M) boolean; row k lists the partners of species k (at least one per row).
        f_species: (M,) species-best costs.

    Returns:
        (M,) partner species indices.

    Raises:
        ValueError: If a species has no partner.
    """
    adjacency = np.asarray(adjacency, dtype=bool)
    m = adjacency.shape[0]
    if not adjacency.any(axis=1).all():
        raise ValueError(f"species {np.flatnonzero(~adjacency.any(axis=1)).tolist()} have no partner")
    rank = cost_rank(f_species)
    best_rank = np.where(adjacency, rank[None, :], m).min(axis=1)
    order = np.empty(m, dtype=np.int64)
    order[rank] = np.arange(m)
    return order[best_rank]


def species_to_reseed(counters: ArrayLike, patience: int | None, global_best_species: int) -> np.ndarray:
    """Species that die out this iteration (D23): stagnant for ``patience`` iterations, not the global best.

    Args:
        counters: (M,) iterations since each species last improved.
        patience: Extinction patience, or ``None`` (extinction off).
        global_best_species: The species holding the global best (never re-seeded).

    Returns:
        (M,) boolean mask.
    """
    counters = np.asarray(counters)
    if patience is None:
        return np.zeros(counters.shape[0], dtype=bool)
    mask = counters >= patience
    mask[global_best_species] = False
    return mask


def reseed(
    x: FloatArray,
    v: FloatArray,
    pbest: FloatArray,
    f_pbest: FloatArray,
    reborn: np.ndarray,
    positions: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Re-seed the particles of extinct species (D23): new positions, zero velocity, no personal best yet.

    Args:
        x: (N, d) positions.
        v: (N, d) velocities.
        pbest: (N, d) personal-best positions.
        f_pbest: (N,) personal-best costs.
        reborn: (N,) particles to re-seed.
        positions: (reborn.sum(), d) their new positions (uniform in the box).

    Returns:
        New ``(x, v, pbest, f_pbest)``: re-seeded rows at ``positions`` with ``v = 0`` and pbest cost
        ``+inf`` (so their first evaluation becomes their pbest), other rows unchanged.
    """
    x, v, pbest, f_pbest = x.copy(), v.copy(), pbest.copy(), f_pbest.copy()
    x[reborn] = positions
    v[reborn] = 0.0
    pbest[reborn] = positions
    f_pbest[reborn] = np.inf
    return x, v, pbest, f_pbest


@register_optimizer("ps2o")
@dataclass(frozen=True)
class PS2O(SwarmOptimizer):
    """Symbiotic multi-species PSO (optimizers.md §7).

    Attributes:
        n_species: M.
        species_size: n (particles per species); the population is ``M · n``.
        constriction: chi.
        acceleration: c1 = c2 = c3.
        link_probability: p_link of the random symbiosis graph (D22).
        extinction_patience: iterations without species improvement before re-seeding; ``None`` = off (D23).

    The shared swarm options are those of :class:`optimizers.swarm.SwarmOptimizer`.
    """

    n_species: int = 5  # M, DECISION: optimizers.md D24
    species_size: int = 20  # n, DECISION: optimizers.md D24
    constriction: float = 0.7298  # chi, [R]
    acceleration: float = 1.3667  # c1 = c2 = c3, [R]
    link_probability: float = 0.5  # DECISION: optimizers.md D22
    extinction_patience: int | None = 30  # DECISION: optimizers.md D23

    def __post_init__(self) -> None:
        super().__post_init__()
        name = type(self).__name__
        require_integer(self, "n_species", 2, "a species needs a symbiotic partner")
        require_integer(self, "species_size", 1)
        require(is_real(self.constriction) and self.constriction > 0, name, "constriction", self.constriction,
                "a finite number > 0")
        require(is_real(self.acceleration) and self.acceleration >= 0, name, "acceleration",
                self.acceleration, "a finite number >= 0")
        require(is_real(self.link_probability) and 0 <= self.link_probability <= 1, name,
                "link_probability", self.link_probability, "a number in [0, 1]")
        p = self.extinction_patience
        require(p is None or (is_int(p) and p >= 1), name, "extinction_patience", p,
                "None or an integer >= 1")

    @property
    def swarm_size(self) -> int:
        """Total population ``M · n``."""
        return self.n_species * self.species_size

    def iterate(self, swarm: Swarm, rng: np.random.Generator) -> Iterator[None]:
        """One iteration per ``next`` (§7 steps 1-4); ``x0`` seeds species 0 particle 0.

        Trace: ``extinctions``, one ``(t, species)`` pair per iteration in which species died out
        (``species`` a tuple of species indices, re-seeded in the bounds at iteration ``t``).
        """
        m, size = self.n_species, self.species_size
        n, d = swarm.n, swarm.d
        species_of = np.repeat(np.arange(m), size)
        c = self.acceleration
        remembered = species_best(swarm.f_pbest, m)[1]  # each species' best cost so far
        counters = np.zeros(m, dtype=np.int64)
        extinctions: list[tuple[int, tuple[int, ...]]] = []
        swarm.trace["extinctions"] = extinctions
        for t in count(1):
            # Steps 1-2: species bests and this iteration's symbiotic partners.
            best_index, f_species = species_best(swarm.f_pbest, m)
            adjacency = partner_graph(rng.random((m, m)), rng.random(m), self.link_probability)
            partner = partner_best_index(adjacency, f_species)
            s_k = swarm.pbest[best_index][species_of]
            q_k = swarm.pbest[best_index[partner]][species_of]
            # Step 3: extinction (D23), decided before the velocity update. The attractors above were
            # computed first (the spec's step order), so a species that dies this iteration may still
            # be some survivor's partner best for this one move: its best is an evaluated point.
            dead = species_to_reseed(counters, self.extinction_patience, int(np.argmin(swarm.f_pbest)) // size)
            # Step 4: velocity, clamp and move (re-seeded particles' moves are replaced below).
            r = rng.random((3, n, d))
            swarm.move(attractor_velocity(swarm.v, swarm.x, (swarm.pbest, s_k, q_k), (c, c, c), r, 1.0,
                                          self.constriction))
            if dead.any():  # re-seeded particles skip step 4 and are evaluated in the same batch
                reborn = dead[species_of]
                # DECISION: re-seeded in the bounds, not in init_bounds (docs/swarm.md §4): the region
                # only sets where the run starts.
                positions = init_positions(rng.random((int(reborn.sum()), d)), swarm.lo, swarm.hi)
                swarm.x, swarm.v, swarm.pbest, swarm.f_pbest = reseed(swarm.x, swarm.v, swarm.pbest,
                                                                      swarm.f_pbest, reborn, positions)
                counters[dead] = 0
                remembered[dead] = np.inf
                extinctions.append((t, tuple(np.flatnonzero(dead).tolist())))
            swarm.evaluate()
            # Species stagnation counters.
            now = species_best(swarm.f_pbest, m)[1]
            improved = now < remembered
            counters = np.where(improved, 0, counters + 1)
            remembered = np.minimum(now, remembered)
            yield None


register_optimizer("ps2o-noext")(partial(PS2O, extinction_patience=None))
