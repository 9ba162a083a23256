"""An optimiser that takes a fixed wall time per planning step: a run of it lasts long enough to be interrupted."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from optimizers import OptimizeResult, register_optimizer

SECONDS_PER_STEP = 0.2


@register_optimizer("test-slow")
@dataclass(frozen=True)
class SlowHold:
    """Sleeps :data:`SECONDS_PER_STEP`, then returns the box's centre after one evaluation."""

    def minimize(self, fun, bounds, *, rng=None, max_evals=10_000):
        time.sleep(SECONDS_PER_STEP)
        x = (np.asarray(bounds.lb, float) + np.asarray(bounds.ub, float)) / 2.0
        f = float(np.asarray(fun(x[None]), float)[0])
        return OptimizeResult(x=x, fun=f, nfev=1, nit=0, history=np.array([f]), history_nfev=np.array([1]),
                              message="one evaluation")  # fmt: skip
