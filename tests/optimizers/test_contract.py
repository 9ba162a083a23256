"""The contract every registered optimiser keeps (optimizers.md §11.1, C1-C9)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.optimize import Bounds

from optimizers import available_optimizers, get_optimizer, register_optimizer
from optimizers.pso import PSO

NAMES = available_optimizers()
REFERENCES = {"cem", "de", "cmaes", "cmaes-default"}  # §3b: batches, not swarm iterations
C5_EXEMPT = {"ihpso-literal", "hpso-literal"}  # D9/D10: the printed equations do not converge
MAX_ROWS = 100  # every default population is 100 (budget fairness)

D10_LO, D10_HI = -5.0 * np.ones(10), 5.0 * np.ones(10)


def shifted_sphere(x: np.ndarray) -> np.ndarray:
    """The C5 sphere: sum (x - 1.5)^2."""
    return ((x - 1.5) ** 2).sum(axis=1)


def rastrigin(x: np.ndarray) -> np.ndarray:
    z = x - 1.5
    return 10.0 * x.shape[1] + (z * z - 10.0 * np.cos(2.0 * np.pi * z)).sum(axis=1)


def adaptive(optimizer: object) -> bool:
    """Whether the optimiser may stop before the budget (IHPSO with adaptive termination)."""
    return bool(getattr(optimizer, "terminate", False))


class Recorder:
    """A batch objective that records every call and checks the rows it receives."""

    def __init__(self, fun, lo, hi):
        self.fun, self.lo, self.hi = fun, lo, hi
        self.calls: list[np.ndarray] = []
        self.violations: list[str] = []

    def __call__(self, x: np.ndarray) -> np.ndarray:
        if x.dtype != np.float64:
            self.violations.append(f"dtype {x.dtype}")
        if x.ndim != 2 or x.shape[1] != self.lo.shape[0]:
            self.violations.append(f"shape {x.shape}")
        if not 1 <= x.shape[0] <= MAX_ROWS:
            self.violations.append(f"{x.shape[0]} rows")
        if not (np.all(x >= self.lo) and np.all(x <= self.hi)):
            self.violations.append("row outside the bounds")
        self.calls.append(x.copy())
        x[:] = np.nan  # the objective owns its copy: mutating it must not affect the optimiser
        return self.fun(self.calls[-1])

    @property
    def rows(self) -> int:
        return sum(len(c) for c in self.calls)


@pytest.mark.parametrize("name", NAMES)
def test_c1_in_bounds(name):
    d = 15
    lo = -np.arange(1.0, d + 1)
    hi = np.resize([3.0, 1.0], d)
    rec = Recorder(lambda x: ((x - 0.7) ** 2).sum(axis=1), lo, hi)
    res = get_optimizer(name).minimize(rec, (lo, hi), rng=0, max_evals=1_500)
    assert rec.violations == []
    assert res.x.shape == (d,)
    assert np.all(res.x >= lo) and np.all(res.x <= hi)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("max_evals", [7, 1_000, 1_050])
def test_c2_budget(name, max_evals):
    opt = get_optimizer(name)
    rec = Recorder(shifted_sphere, D10_LO, D10_HI)
    res = opt.minimize(rec, (D10_LO, D10_HI), rng=1, max_evals=max_evals)
    assert res.nfev == rec.rows <= max_evals
    assert res.history_nfev[-1] == res.nfev
    if adaptive(opt) and "adaptive termination" in res.message:
        assert res.nfev < max_evals
    else:
        assert res.nfev == max_evals
        assert "max_evals reached" in res.message or "during initialisation" in res.message
    if max_evals == 7:
        assert res.nit == 0
        assert res.message.startswith("budget exhausted during initialisation")
    elif name in REFERENCES:
        assert res.nit == len(rec.calls) - 1  # every batch after the first is an iteration
    elif max_evals == 1_050 and not (adaptive(opt) and res.nfev < max_evals):
        assert res.nit == 10  # 9 full iterations and 1 truncated


@pytest.mark.parametrize("name", NAMES)
def test_c3_result_consistency(name):
    lo, hi = -5.12 * np.ones(6), 5.12 * np.ones(6)
    res = get_optimizer(name).minimize(rastrigin, (lo, hi), rng=3, max_evals=1_200)
    assert res.history.shape == res.history_nfev.shape == (res.nit + 1,)
    assert np.all(np.diff(res.history) <= 0)
    assert np.all(np.diff(res.history_nfev) >= 0)
    assert res.history[-1] == res.fun
    assert res.fun == rastrigin(res.x[None])[0]
    assert isinstance(res.fun, float) and isinstance(res.nfev, int) and isinstance(res.nit, int)


@pytest.mark.parametrize("name", NAMES)
def test_c4_determinism(name):
    opt = get_optimizer(name)
    bounds = (D10_LO, D10_HI)
    runs = [
        opt.minimize(shifted_sphere, bounds, rng=0, max_evals=1_000),
        opt.minimize(shifted_sphere, bounds, rng=0, max_evals=1_000),
        opt.minimize(shifted_sphere, bounds, rng=np.random.default_rng(0), max_evals=1_000),
    ]
    for other in runs[1:]:
        assert np.array_equal(other.x, runs[0].x)
        assert other.fun == runs[0].fun
        assert (other.nfev, other.nit) == (runs[0].nfev, runs[0].nit)
        assert np.array_equal(other.history, runs[0].history)
        assert np.array_equal(other.history_nfev, runs[0].history_nfev)
    seed1 = opt.minimize(shifted_sphere, bounds, rng=1, max_evals=1_000)
    assert not np.array_equal(seed1.x, runs[0].x)


@pytest.mark.parametrize("name", [n for n in NAMES if n not in C5_EXEMPT])
def test_c5_convergence(name):
    opt = get_optimizer(name)
    for seed in (0, 1, 2):
        res = opt.minimize(shifted_sphere, (D10_LO, D10_HI), rng=seed, max_evals=20_000)
        assert res.fun <= 0.1, (seed, res.fun)


def test_c5_exemptions_are_registered():
    assert C5_EXEMPT <= set(NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_c6_nan_handling(name):
    opt = get_optimizer(name)

    def half_nan(x):
        f = shifted_sphere(x)
        f[x[:, 0] > 0] = np.nan
        return f

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = opt.minimize(half_nan, (D10_LO, D10_HI), rng=0, max_evals=1_500)
        assert np.isfinite(res.fun)
        assert res.x[0] <= 0
        assert np.all(np.isfinite(res.history[-1:]))

        rec = Recorder(lambda x: np.full(len(x), np.nan), D10_LO, D10_HI)
        res = opt.minimize(rec, (D10_LO, D10_HI), rng=0, max_evals=1_000)
    assert res.fun == np.inf
    assert "no finite cost" in res.message
    assert np.all(res.x >= D10_LO) and np.all(res.x <= D10_HI)
    assert np.array_equal(res.x, rec.calls[0][0])  # the first evaluated row
    if adaptive(opt):
        assert res.nfev <= 1_000
    else:
        assert res.nfev == 1_000
    assert np.all(res.history == np.inf)


@pytest.mark.parametrize("name", NAMES)
def test_c7_warm_start(name):
    opt = get_optimizer(name)
    lo, hi = D10_LO, D10_HI
    x0 = np.linspace(-7.0, 7.0, 10)  # partly outside the bounds
    x0_before = x0.copy()
    clipped = np.clip(x0, lo, hi)
    rec = Recorder(shifted_sphere, lo, hi)
    res = opt.minimize(rec, (lo, hi), rng=0, max_evals=500, x0=x0)
    assert np.array_equal(rec.calls[0][0], clipped)
    assert res.fun <= shifted_sphere(clipped[None])[0]
    assert np.array_equal(x0, x0_before)  # inputs are never mutated

    # A good warm start is never lost: the result is at least as good.
    near = np.full(10, 1.5001)
    res = opt.minimize(shifted_sphere, (lo, hi), rng=0, max_evals=300, x0=near)
    assert res.fun <= shifted_sphere(near[None])[0]

    with pytest.raises(ValueError, match="x0"):
        opt.minimize(shifted_sphere, (lo, hi), rng=0, max_evals=300, x0=np.zeros(9))
    with pytest.raises(ValueError, match="x0"):
        opt.minimize(shifted_sphere, (lo, hi), rng=0, max_evals=300, x0=np.full(10, np.nan))


@pytest.mark.parametrize("name", NAMES)
def test_c8_bad_input(name):
    opt = get_optimizer(name)
    bounds = (D10_LO, D10_HI)
    first_batch = []

    def wrong_2d(x):
        first_batch.append(len(x))
        return np.zeros((len(x), 2))

    with pytest.raises(ValueError, match=r"objective returned shape \(\d+, 2\), expected \(\d+,\)") as err:
        opt.minimize(wrong_2d, bounds, rng=0, max_evals=500)
    assert f"expected ({first_batch[0]},)" in str(err.value)
    with pytest.raises(ValueError, match=r"expected \(\d+,\)"):
        opt.minimize(lambda x: np.zeros(len(x) + 1), bounds, rng=0, max_evals=500)
    bad_lo = D10_LO.copy()
    bad_lo[3] = 5.0
    with pytest.raises(ValueError, match=r"bounds\[3\]"):
        opt.minimize(shifted_sphere, (bad_lo, D10_HI), rng=0, max_evals=500)

    def minus_inf(x):
        f = shifted_sphere(x)
        f[-1] = -np.inf
        return f

    with pytest.raises(ValueError, match="-inf"):
        opt.minimize(minus_inf, bounds, rng=0, max_evals=500)
    with pytest.raises(ValueError, match="max_evals"):
        opt.minimize(shifted_sphere, bounds, rng=0, max_evals=0)


def test_c8_registry_errors():
    with pytest.raises(KeyError, match="'ihpso'"):
        get_optimizer("ihspo")
    with pytest.raises(ValueError, match="already registered"):
        register_optimizer("pso")(PSO)


@pytest.mark.parametrize("name", NAMES)
def test_c9_bounds_forms(name):
    opt = get_optimizer(name)
    lo = np.array([-5.0, -4.0, -3.0, 0.0, -1.0])
    hi = np.array([5.0, 1.0, 3.0, 2.0, 4.0])
    forms = [list(zip(lo, hi, strict=True)), np.column_stack([lo, hi]), (lo, hi), [lo, hi], Bounds(lo, hi)]
    results = [opt.minimize(rastrigin, form, rng=5, max_evals=600) for form in forms]
    for res in results[1:]:
        assert np.array_equal(res.x, results[0].x)
        assert np.array_equal(res.history, results[0].history)
