"""CMA-ES through the ``cmaes`` package, with IPOP restarts (optimizers.md §3b).

A reference beyond the paper. The package's bounded ``CMA`` class works in normalised coordinates
(§2.1, the box ``[0, 1]^d``) with its own ``RandomState(seed)``, seeded from the run's Generator.
Defaults: mean at ``x0`` (normalised) or the centre, ``sigma = 0.3``, population 100 (budget fairness;
``cmaes-default`` uses the package's ``4 + floor(3 ln d)``). One generation is evaluated in batches of
at most 100 rows. When the package's ``should_stop()`` fires and budget remains, CMA-ES restarts with
twice the population (IPOP). The package never sees ``inf`` or NaN (finite stand-in).

DECISION (optimizers.md §3b, bounded resampling): ``ask()`` draws a candidate again while it lies
outside the box, at most :data:`MAX_RESAMPLING` times (the package's default is 100), then clips
the last draw to the box. Each draw multiplies a d x d matrix; in 100 dimensions almost every draw
leaves the box, so the default spent 101 matrix products per candidate (seconds per generation
idle, minutes on a busy machine) for a candidate that is clipped in the end anyway. In a few
dimensions a candidate rarely needs more than a handful of draws, so the bound leaves those runs
as they were.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np
from cmaes import CMA

from optimizers.base import (
    MESSAGE_INIT_EXHAUSTED,
    MESSAGE_MAX_EVALS,
    OptimizerBase,
    OptimizeResult,
    Problem,
    is_int,
    is_real,
    require,
    require_integer,
)
from optimizers.registry import register_optimizer
from optimizers.swarm import normalise

MAX_RESAMPLING = 10  # draws of one candidate outside the box before it is clipped (the package's default: 100)


@register_optimizer("cmaes")
@dataclass(frozen=True)
class CMAES(OptimizerBase):
    """CMA-ES (``cmaes.CMA``) in normalised coordinates with IPOP restarts (optimizers.md §3b).

    Attributes:
        population_size: λ of the first run; ``None`` = the package default ``4 + floor(3 ln d)``.
        sigma: Initial step size in normalised coordinates.
        max_batch: Largest batch passed to the objective.
        restart: Restart with a doubled population when ``should_stop()`` fires (IPOP).
    """

    population_size: int | None = 100  # budget fairness; None in cmaes-default
    sigma: float = 0.3  # in normalised coordinates
    max_batch: int = 100  # rows per objective call (§1: n <= swarm size)
    restart: bool = True  # IPOP

    def __post_init__(self) -> None:
        name = type(self).__name__
        p = self.population_size
        require(p is None or (is_int(p) and p >= 2), name, "population_size", p, "None or an integer >= 2")
        require(is_real(self.sigma) and self.sigma > 0, name, "sigma", self.sigma, "a finite number > 0")
        require_integer(self, "max_batch", 1)
        require(isinstance(self.restart, bool), name, "restart", self.restart, "True or False")

    def solve(self, problem: Problem, rng: np.random.Generator) -> OptimizeResult:
        """Minimise ``fun`` (see :meth:`optimizers.base.OptimizerBase.minimize`); ``x0`` is the first mean and solution.

        DECISION: an IPOP restart starts from a mean drawn uniformly in the box (the usual IPOP
        practice; the spec names only the doubled population), with ``sigma`` as at the start and a
        fresh package seed. A generation whose evaluation the budget cuts short is not told to CMA-ES.
        Without ``restart`` the run still spends the whole budget: the stopped state keeps sampling.
        """
        objective, lo, hi = problem.objective, problem.lo, problem.hi
        d = problem.dim
        unit_box = np.tile([0.0, 1.0], (d, 1))
        start = None if problem.x0 is None else np.clip(normalise(problem.x0, lo, hi), 0.0, 1.0)
        mean = np.full(d, 0.5) if start is None else start
        population = self.population_size
        batches = 0
        first_batch = 0

        while objective.remaining > 0:
            strategy = CMA(mean=mean, sigma=self.sigma, bounds=unit_box, seed=int(rng.integers(2**31)),
                           population_size=population, n_max_resampling=MAX_RESAMPLING)
            lam = strategy.population_size
            while objective.remaining > 0:
                u = np.array([strategy.ask() for _ in range(lam)])
                x = np.minimum(np.maximum(lo + u * (hi - lo), lo), hi)
                if batches == 0 and start is not None:
                    u[0], x[0] = start, problem.x0  # the warm start replaces the first solution
                costs = np.full(lam, np.inf)
                evaluated = 0
                for begin in range(0, lam, self.max_batch):
                    if objective.remaining == 0:
                        break
                    stop = min(begin + self.max_batch, lam)
                    before = objective.nfev
                    costs[begin:stop] = objective(x[begin:stop])
                    evaluated += objective.nfev - before
                    objective.record()
                    if batches == 0:
                        first_batch = stop - begin
                    batches += 1
                if evaluated < lam:  # the budget cut this generation short: nothing to tell
                    break
                strategy.tell(list(zip(u, objective.finite_costs(costs).tolist(), strict=True)))
                if self.restart and strategy.should_stop():
                    break
            population = 2 * lam
            mean = rng.random(d)
        message = MESSAGE_INIT_EXHAUSTED if objective.max_evals < first_batch else MESSAGE_MAX_EVALS
        return objective.result(batches - 1, message)


register_optimizer("cmaes-default")(partial(CMAES, population_size=None))
