"""Uniform random search: the smallest complete optimiser of the interface (docs/plugins.md §3).

Plug it into the harness with ``uav-bench run --import examples.random_search --policies
random-search greedy`` from the repository root; importing this module registers the name.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optimizers import BoundsLike, BudgetedObjective, OptimizeResult, normalize_bounds, register_optimizer


@register_optimizer("random-search")
@dataclass(frozen=True)
class RandomSearch:
    """Draw ``batch`` uniform points inside the bounds per iteration until the budget is spent.

    Attributes:
        batch: Points per call of the batch objective.
    """

    batch: int = 64

    def __post_init__(self) -> None:
        if not isinstance(self.batch, int) or self.batch < 1:
            raise ValueError(f"RandomSearch.batch: got {self.batch!r}, expected an integer >= 1")

    def minimize(
        self,
        fun,
        bounds: BoundsLike,
        *,
        rng: np.random.Generator | int | None = None,
        max_evals: int = 10_000,
        x0=None,
    ) -> OptimizeResult:
        """Minimise the batch objective ``fun`` inside ``bounds`` with at most ``max_evals`` rows.

        Args:
            fun: Batch objective, ``(n, d)`` points to ``(n,)`` costs.
            bounds: Any form :func:`optimizers.normalize_bounds` accepts; the MPC planner passes
                ``scipy.optimize.Bounds``.
            rng: Seed or Generator, the only source of randomness.
            max_evals: The budget of objective rows; never exceeded.
            x0: Optional ``(d,)`` warm start, evaluated first (the planner's shifted previous plan).

        Returns:
            The best point evaluated, with its cost and the best-so-far history.
        """
        lo, hi = normalize_bounds(bounds)
        rng = np.random.default_rng(rng)
        # The package's budgeted objective is the only caller of `fun`: it never evaluates more than
        # max_evals rows, checks the returned shape, reads NaN as +inf and keeps the best point.
        objective = BudgetedObjective(fun, lo.size, max_evals)
        iterations = 0
        while objective.remaining > 0:
            points = rng.uniform(lo, hi, size=(min(self.batch, objective.remaining), lo.size))
            if x0 is not None and objective.nfev == 0:
                points[0] = np.clip(x0, lo, hi)
            objective(points)
            objective.record()  # best-so-far cost and evaluations after this iteration
            iterations += 1
        return objective.result(nit=iterations - 1, message="max_evals reached")
