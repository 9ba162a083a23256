"""CEM: the cross-entropy method, the standard optimiser of sampling-based MPC (optimizers.md §3b, D31).

A reference beyond the paper. In normalised coordinates (§2.1) it keeps a diagonal Gaussian
``N(mu, sigma^2)``: each iteration samples 100 points, clips them to the box, evaluates them as one
batch, and moves ``mu`` and ``sigma`` toward the mean and standard deviation of the 10 best with
smoothing 0.9. It follows §1 (interface, budget, NaN, ``x0``, rng) but not the swarm conventions of §2:
the first batch is the initialisation and every later batch is one iteration.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optimizers.base import (
    MESSAGE_INIT_EXHAUSTED,
    MESSAGE_MAX_EVALS,
    FloatArray,
    OptimizerBase,
    OptimizeResult,
    Problem,
    is_real,
    require,
    require_integer,
)
from optimizers.registry import register_optimizer
from optimizers.swarm import normalise


def cem_samples(mean: FloatArray, std: FloatArray, z: FloatArray) -> FloatArray:
    """Samples ``clip(mu + sigma z, 0, 1)`` in normalised coordinates.

    Args:
        mean: (d,) mean ``mu``.
        std: (d,) standard deviation ``sigma``.
        z: (n, d) standard normal draws.

    Returns:
        (n, d) samples in ``[0, 1]^d``.
    """
    return np.minimum(np.maximum(mean + std * z, 0.0), 1.0)


def cem_update(
    samples: FloatArray,
    costs: FloatArray,
    mean: FloatArray,
    std: FloatArray,
    *,
    n_elite: int,
    smoothing: float,
    min_std: float,
) -> tuple[FloatArray, FloatArray]:
    """Refit the sampling distribution to the elite samples, with smoothing (D31).

    Args:
        samples: (n, d) normalised samples of this batch.
        costs: (n,) their costs (``+inf`` allowed).
        mean: (d,) old mean.
        std: (d,) old standard deviation.
        n_elite: Number of elite samples (lowest costs, ties to the lower index).
        smoothing: α; the new value is ``α · elite + (1 − α) · old``.
        min_std: Floor on every component of the new standard deviation.

    Returns:
        ``(mean, std)`` of the next iteration.
    """
    elite = samples[np.argsort(costs, kind="stable")[:n_elite]]
    new_mean = smoothing * elite.mean(axis=0) + (1.0 - smoothing) * mean
    new_std = smoothing * elite.std(axis=0) + (1.0 - smoothing) * std
    return new_mean, np.maximum(new_std, min_std)


@register_optimizer("cem")
@dataclass(frozen=True)
class CEM(OptimizerBase):
    """Cross-entropy method in normalised coordinates (optimizers.md §3b, D31).

    Attributes:
        population_size: Samples per iteration.
        elite_fraction: Share of the samples that refit the distribution.
        smoothing: α.
        initial_std: σ at the start, per dimension, in normalised coordinates.
        min_std: Floor on σ.
    """

    population_size: int = 100  # budget fairness
    elite_fraction: float = 0.1  # DECISION: optimizers.md D31
    smoothing: float = 0.9  # α, DECISION: optimizers.md D31
    initial_std: float = 0.25  # σ0 in normalised coordinates, DECISION: optimizers.md D31
    min_std: float = 1e-6

    def __post_init__(self) -> None:
        name = type(self).__name__
        require_integer(self, "population_size", 1)
        require(is_real(self.elite_fraction) and 0 < self.elite_fraction <= 1, name, "elite_fraction",
                self.elite_fraction, "a number in (0, 1]")
        require(is_real(self.smoothing) and 0 < self.smoothing <= 1, name, "smoothing", self.smoothing,
                "a number in (0, 1]")
        require(is_real(self.initial_std) and self.initial_std > 0, name, "initial_std", self.initial_std,
                "a finite number > 0")
        require(is_real(self.min_std) and self.min_std >= 0, name, "min_std", self.min_std,
                "a finite number >= 0")

    @property
    def n_elite(self) -> int:
        """Number of elite samples, ``max(1, round(elite_fraction · population_size))`` (10 by default)."""
        return max(1, round(self.elite_fraction * self.population_size))

    def solve(self, problem: Problem, rng: np.random.Generator) -> OptimizeResult:
        """Minimise ``fun`` (see :meth:`optimizers.base.OptimizerBase.minimize`); ``x0`` is the first mean and sample."""
        objective, lo, hi = problem.objective, problem.lo, problem.hi
        n, d = self.population_size, problem.dim
        start = None if problem.x0 is None else np.clip(normalise(problem.x0, lo, hi), 0.0, 1.0)
        mean = np.full(d, 0.5) if start is None else start.copy()
        std = np.full(d, self.initial_std)

        batches = 0
        while objective.remaining > 0:
            u = cem_samples(mean, std, rng.standard_normal((n, d)))
            x = np.minimum(np.maximum(lo + u * (hi - lo), lo), hi)
            if batches == 0 and problem.x0 is not None:
                u[0], x[0] = start, problem.x0  # the warm start is sample 0 of the first batch
            costs = objective(x)
            objective.record()
            batches += 1
            mean, std = cem_update(u, costs, mean, std, n_elite=self.n_elite, smoothing=self.smoothing,
                                   min_std=self.min_std)
        message = MESSAGE_INIT_EXHAUSTED if objective.max_evals < n else MESSAGE_MAX_EVALS
        return objective.result(batches - 1, message)
