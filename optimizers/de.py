"""DE: scipy's ``differential_evolution`` under the shared budget (optimizers.md §3b).

A reference beyond the paper. scipy runs ``best1bin`` with ``vectorized=True`` and
``updating="deferred"``, so every call of the objective is one batch of the whole population (100
rows). The initial population is an explicit Latin-hypercube array (row 0 = ``x0`` when given).
``tol = atol = 0`` and a large ``maxiter`` leave the budget as the only intended stop; when the budget
is spent, the wrapper raises a private exception that stops scipy, and the result is read from the
shared tracker. If scipy stops anyway (its population's costs all equal), a fresh Latin-hypercube
population restarts it until the budget is spent. scipy never sees ``inf`` or NaN (finite stand-in).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import Bounds, differential_evolution
from scipy.stats import qmc

from optimizers.base import (
    MESSAGE_INIT_EXHAUSTED,
    MESSAGE_MAX_EVALS,
    FloatArray,
    OptimizerBase,
    OptimizeResult,
    Problem,
    coerce_pair,
    is_real,
    require,
    require_integer,
)
from optimizers.registry import register_optimizer


class _BudgetSpent(Exception):
    """Raised inside scipy's call of the objective to stop it when the budget is spent."""


class _ObjectiveFailed(Exception):
    """Carries an error of the user's objective through scipy (which turns ValueError into RuntimeError)."""

    def __init__(self, error: Exception) -> None:
        super().__init__(str(error))
        self.error = error


def latin_hypercube(
    sampler: qmc.LatinHypercube, n: int, lo: FloatArray, hi: FloatArray, x0: FloatArray | None = None
) -> FloatArray:
    """An ``(n, d)`` Latin-hypercube population in the box, row 0 replaced by ``x0`` when given.

    Args:
        sampler: scipy's Latin-hypercube sampler of dimension d.
        n: Population size.
        lo: (d,) lower bounds.
        hi: (d,) upper bounds.
        x0: Optional warm start (already clipped).

    Returns:
        (n, d) initial population.
    """
    population = np.minimum(np.maximum(lo + sampler.random(n) * (hi - lo), lo), hi)
    if x0 is not None:
        population[0] = x0
    return population


@register_optimizer("de")
@dataclass(frozen=True)
class DE(OptimizerBase):
    """scipy's differential evolution, budgeted and restarted (optimizers.md §3b).

    Attributes:
        population_size: Rows of the Latin-hypercube initial population (= rows per batch).
        strategy: scipy's mutation strategy.
        mutation: scipy's differential weight (a dithering range).
        recombination: scipy's crossover probability.
    """

    population_size: int = 100  # budget fairness
    strategy: str = "best1bin"
    mutation: tuple[float, float] = (0.5, 1.0)  # scipy's default
    recombination: float = 0.7  # scipy's default

    def __post_init__(self) -> None:
        name = type(self).__name__
        require_integer(self, "population_size", 5, "scipy's minimum for an init array")
        require(isinstance(self.strategy, str), name, "strategy", self.strategy, "a scipy strategy name")
        mutation = coerce_pair(self, "mutation")
        require(all(is_real(m) and 0 <= m <= 2 for m in mutation), name, "mutation", mutation,
                "a pair (low, high) within [0, 2]")
        require(is_real(self.recombination) and 0 <= self.recombination <= 1, name, "recombination",
                self.recombination, "a number in [0, 1]")

    def solve(self, problem: Problem, rng: np.random.Generator) -> OptimizeResult:
        """Minimise ``fun`` (see :meth:`optimizers.base.OptimizerBase.minimize`); ``x0`` is row 0 of the first population.

        DECISION: scipy evaluates its population through an internal ``[0, 1]`` scaling that
        round-trips points only to within rounding. The wrapper therefore clips every row into the
        bounds (so ``fun`` sees exactly in-bounds rows, §1) and evaluates ``x0`` itself, exactly, as row 0
        of the first batch. Restarts draw a fresh Latin-hypercube population without ``x0``.
        """
        objective, lo, hi = problem.objective, problem.lo, problem.hi
        n, d = self.population_size, problem.dim
        sampler = qmc.LatinHypercube(d, rng=rng)
        batches = 0

        def batch_objective(xt: FloatArray) -> FloatArray:
            nonlocal batches
            if objective.remaining == 0:
                raise _BudgetSpent
            x = np.minimum(np.maximum(xt.T, lo), hi)
            if batches == 0 and problem.x0 is not None:
                x[0] = problem.x0
            try:
                costs = objective(x)
            except (ValueError, TypeError) as exc:
                raise _ObjectiveFailed(exc) from exc
            objective.record()
            batches += 1
            if objective.remaining == 0:
                raise _BudgetSpent
            return objective.finite_costs(costs)  # scipy never sees inf or NaN (§3b)

        while objective.remaining > 0:
            init = latin_hypercube(sampler, n, lo, hi, problem.x0 if batches == 0 else None)
            try:
                differential_evolution(
                    batch_objective,
                    Bounds(lo, hi),
                    strategy=self.strategy,
                    maxiter=objective.remaining // n + 2,  # the budget, not scipy, ends the run
                    tol=0.0,
                    atol=0.0,
                    mutation=self.mutation,
                    recombination=self.recombination,
                    rng=rng,
                    polish=False,
                    init=init,
                    updating="deferred",
                    vectorized=True,
                )
            except _BudgetSpent:
                break
            except _ObjectiveFailed as failure:
                raise failure.error from None
        message = MESSAGE_INIT_EXHAUSTED if objective.max_evals < n else MESSAGE_MAX_EVALS
        return objective.result(batches - 1, message)
