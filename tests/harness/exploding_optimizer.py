"""A registered optimiser that always raises: its episodes end as error rows (exit-status tests)."""

from __future__ import annotations

from dataclasses import dataclass

from optimizers import register_optimizer


@register_optimizer("test-exploding")
@dataclass(frozen=True)
class Exploding:
    """Raises on every call, as a planner with a bug would."""

    def minimize(self, fun, bounds, *, rng=None, max_evals=10_000):
        raise RuntimeError("exploding optimiser: planned failure")
