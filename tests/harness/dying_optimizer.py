"""A worker death on purpose: an optimiser that ends the process flying its episode.

``os._exit`` stands for what no planner can catch: a segfault in compiled code, the OOM killer.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from optimizers import register_optimizer


@register_optimizer("test-dying")
@dataclass(frozen=True)
class Dying:
    """Ends the worker process flying its episode with exit code 3."""

    def minimize(self, fun, bounds, *, rng=None, max_evals=10_000, x0=None):
        os._exit(3)
