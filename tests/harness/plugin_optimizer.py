"""A third-party optimiser living outside the packages: registered only when this module is imported."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optimizers import OptimizeResult, register_optimizer


@register_optimizer("test-random-search")
@dataclass(frozen=True)
class RandomSearch:
    """Uniform random search in batches of 50 (no warm start)."""

    batch: int = 50

    def minimize(self, fun, bounds, *, rng=None, max_evals=10_000):
        rng = np.random.default_rng(rng)
        lo, hi = np.asarray(bounds.lb, float), np.asarray(bounds.ub, float)
        best_x, best_f, used, history, history_nfev = lo.copy(), np.inf, 0, [], []
        while used < max_evals:
            n = min(self.batch, max_evals - used)
            xs = rng.uniform(lo, hi, size=(n, lo.size))
            fs = np.asarray(fun(xs), float)
            used += n
            i = int(np.argmin(fs))
            if fs[i] < best_f:
                best_x, best_f = xs[i], float(fs[i])
            history.append(best_f)
            history_nfev.append(used)
        return OptimizeResult(
            x=best_x, fun=best_f, nfev=used, nit=len(history) - 1, history=np.array(history),
            history_nfev=np.array(history_nfev), message="max_evals reached",
        )  # fmt: skip
