"""Swarm and reference optimisers behind one small interface (knows nothing about UAVs).

``get_optimizer(name, **params)`` builds a registered optimiser; every optimiser has
``minimize(fun, bounds, *, rng=None, max_evals=10_000, x0=None) -> OptimizeResult`` for a batch
objective ``fun: (n, d) -> (n,)`` (optimizers.md §1). Registered names (§10): the seed paper's IHPSO
and its comparison set (HPSO, LPSO, PS2O, MCPSO, CCPSO-ISM), the reference PSOs, CEM, DE, CMA-ES,
and the ablation configurations. ``normalize_bounds(bounds)`` converts any bounds form the
interface accepts (the MPC planner passes ``scipy.optimize.Bounds``) into ``(lower, upper)`` arrays,
for optimisers of your own (docs/plugins.md §2).
"""

from __future__ import annotations

from optimizers import ccpso_ism, cem, cma_es, de, hpso, ihpso, lpso, mcpso, ps2o, pso  # noqa: F401  (registration)
from optimizers.base import BoundsLike, BudgetedObjective, Optimizer, OptimizeResult, normalize_bounds
from optimizers.registry import available_optimizers, get_optimizer, register_optimizer

__all__ = [
    "BoundsLike",
    "BudgetedObjective",
    "OptimizeResult",
    "Optimizer",
    "available_optimizers",
    "get_optimizer",
    "normalize_bounds",
    "register_optimizer",
]
