"""nevergrad's TwoPointsDE behind the optimiser interface (docs/plugins.md §4; extra ``examples``).

Plug it into the harness with ``uav-bench run --import examples.nevergrad_de --policies
ng-twopointsde greedy`` from the repository root; importing this module registers the name.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

try:
    import nevergrad as ng
except ImportError as error:  # one line that says how to get it, for `uav-bench run --import`
    raise ImportError("examples.nevergrad_de needs nevergrad: pip install -e '.[examples]'") from error

from optimizers import BoundsLike, BudgetedObjective, OptimizeResult, normalize_bounds, register_optimizer


@register_optimizer("ng-twopointsde")
@dataclass(frozen=True)
class NevergradTwoPointsDE:
    """nevergrad's ``TwoPointsDE`` with ``workers`` candidates asked per batch-objective call.

    Attributes:
        workers: Candidates asked (and evaluated in one batch) before they are told back.
    """

    workers: int = 32

    def __post_init__(self) -> None:
        if not isinstance(self.workers, int) or self.workers < 1:
            raise ValueError(f"NevergradTwoPointsDE.workers: got {self.workers!r}, expected an integer >= 1")

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
            rng: Seed or Generator; nevergrad's own generator is seeded from it.
            max_evals: The budget of objective rows; never exceeded.
            x0: Optional ``(d,)`` warm start: the first candidate asked, and the centre of the
                initial population.

        Returns:
            The best point evaluated, with its cost and the best-so-far history.
        """
        lo, hi = normalize_bounds(bounds)
        rng = np.random.default_rng(rng)
        start = (lo + hi) / 2 if x0 is None else np.clip(np.asarray(x0, dtype=np.float64), lo, hi)
        parametrization = ng.p.Array(init=start, lower=lo, upper=hi)
        # nevergrad draws from a legacy RandomState: seeded from our Generator, so a seed replays a run.
        parametrization.random_state = np.random.RandomState(int(rng.integers(2**32)))
        optimizer = ng.optimizers.TwoPointsDE(
            parametrization=parametrization, budget=max_evals, num_workers=self.workers
        )
        if x0 is not None:
            optimizer.suggest(start)  # the next ask returns the warm start itself
        # The package's budgeted objective is the only caller of `fun`: it never evaluates more than
        # max_evals rows, checks the returned shape, reads NaN as +inf and keeps the best point.
        objective = BudgetedObjective(fun, lo.size, max_evals)
        iterations = 0
        while objective.remaining > 0:
            asked = [optimizer.ask() for _ in range(min(self.workers, objective.remaining))]
            costs = objective(np.array([candidate.value for candidate in asked], dtype=np.float64))
            # nevergrad wants finite losses: +inf becomes a cost worse than any finite one seen
            for candidate, cost in zip(asked, objective.finite_costs(costs), strict=True):
                optimizer.tell(candidate, float(cost))
            objective.record()  # best-so-far cost and evaluations after this iteration
            iterations += 1
        return objective.result(nit=iterations - 1, message="max_evals reached")
