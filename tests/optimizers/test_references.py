"""References beyond the paper: CEM, DE, CMA-ES (optimizers.md §3b)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import optimizers.cem as cem_module
import optimizers.cma_es as cma_module
import optimizers.de as de_module
from optimizers import get_optimizer
from optimizers.cem import CEM, cem_samples, cem_update
from optimizers.cma_es import CMAES
from optimizers.de import DE
from tests.optimizers.spies import record_calls

LO, HI = np.array([-5.0, 0.0, 10.0]), np.array([5.0, 1.0, 30.0])


def sphere(x):
    return ((x - 1.5) ** 2).sum(axis=1)


def plateau(x):
    return np.ones(len(x))


class Batches:
    def __init__(self, fun):
        self.fun, self.calls = fun, []

    def __call__(self, x):
        self.calls.append(x.copy())
        return self.fun(x)

    @property
    def sizes(self):
        return [len(c) for c in self.calls]


# ---------------------------------------------------------------- CEM


def test_cem_samples_are_clipped_to_the_unit_box():
    z = np.array([[-10.0, 0.0], [10.0, 1.0]])
    out = cem_samples(np.array([0.5, 0.5]), np.array([0.25, 0.25]), z)
    assert out.tolist() == [[0.0, 0.5], [1.0, 0.75]]


def test_cem_update_hand_case():
    samples = np.array([[0.0], [1.0], [0.2], [0.4]])
    costs = np.array([3.0, np.inf, 1.0, 2.0])
    mean, std = cem_update(samples, costs, np.array([0.5]), np.array([0.25]), n_elite=2, smoothing=0.9,
                           min_std=1e-6)
    assert mean[0] == pytest.approx(0.9 * 0.3 + 0.1 * 0.5)  # elites 0.2 and 0.4
    assert std[0] == pytest.approx(0.9 * 0.1 + 0.1 * 0.25)
    _, std = cem_update(np.full((4, 1), 0.3), costs, np.array([0.5]), np.array([0.0]), n_elite=2,
                        smoothing=1.0, min_std=1e-6)
    assert std[0] == 1e-6  # the floor


def test_cem_batches_and_warm_start_mean(monkeypatch):
    means = record_calls(monkeypatch, cem_module, "cem_samples", lambda mean, std, z: (mean.copy(), std.copy()))
    rec = Batches(sphere)
    x0 = np.array([0.0, 0.25, 25.0])
    res = CEM().minimize(rec, (LO, HI), rng=0, max_evals=1_000, x0=x0)
    assert rec.sizes == [100] * 10 and res.nit == 9
    assert means[0][0] == pytest.approx([0.5, 0.25, 0.75])
    assert means[0][1].tolist() == [0.25] * 3
    assert CEM().n_elite == 10


# ---------------------------------------------------------------- DE


def test_de_batches_are_whole_populations():
    rec = Batches(sphere)
    res = DE().minimize(rec, (LO, HI), rng=0, max_evals=1_050)
    assert rec.sizes == [100] * 10 + [50]
    assert res.nit == 10 and res.nfev == 1_050


def test_de_initial_population_is_a_latin_hypercube_with_x0_first():
    rec = Batches(sphere)
    x0 = np.array([1.0, 0.5, 12.0])
    DE().minimize(rec, (LO, HI), rng=0, max_evals=300, x0=x0)
    first = rec.calls[0]
    assert first[0].tolist() == x0.tolist()
    u = (first[1:] - LO) / (HI - LO)
    strata = np.floor(u * 100).astype(int)
    for j in range(3):
        assert len(set(strata[:, j].tolist())) == 99  # one point per stratum (row 0 replaced by x0)


def test_de_restarts_when_scipy_stops_and_never_sees_infinities(monkeypatch):
    runs, seen = [], []
    real = de_module.differential_evolution

    def spy(func, bounds, **kwargs):
        runs.append(kwargs["init"].copy())

        def checked(x):
            out = func(x)
            seen.append(out.copy())
            return out

        return real(checked, bounds, **kwargs)

    monkeypatch.setattr(de_module, "differential_evolution", spy)
    res = DE().minimize(lambda x: np.full(len(x), np.nan), (LO, HI), rng=0, max_evals=1_000)
    assert res.nfev == 1_000 and res.fun == math.inf
    assert len(runs) > 1  # all costs equal: scipy converges at once and is restarted
    assert all(np.isfinite(s).all() for s in seen)
    assert not np.array_equal(runs[0], runs[1])  # a fresh Latin hypercube


def test_de_passes_objective_errors_through():
    with pytest.raises(ValueError, match="-inf"):
        DE().minimize(lambda x: np.full(len(x), -np.inf), (LO, HI), rng=0, max_evals=300)


# ---------------------------------------------------------------- CMA-ES


def spy_on_cma(monkeypatch):
    created, told = [], []
    real = cma_module.CMA

    class SpyCMA(real):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            created.append((kwargs["mean"].copy(), self.population_size))

        def tell(self, solutions):
            told.append([value for _, value in solutions])
            super().tell(solutions)

    monkeypatch.setattr(cma_module, "CMA", SpyCMA)
    return created, told


def test_cmaes_population_and_warm_start(monkeypatch):
    created, told = spy_on_cma(monkeypatch)
    rec = Batches(sphere)
    x0 = np.array([0.0, 1.0, 20.0])
    res = CMAES().minimize(rec, (LO, HI), rng=0, max_evals=1_000, x0=x0)
    assert rec.sizes == [100] * 10 and res.nit == 9
    assert created[0][0].tolist() == [0.5, 1.0, 0.5] and created[0][1] == 100
    assert rec.calls[0][0].tolist() == x0.tolist()
    assert len(told) == 10


def test_cmaes_default_uses_the_package_population():
    rec = Batches(sphere)
    get_optimizer("cmaes-default").minimize(rec, (LO, HI), rng=0, max_evals=70)
    assert rec.sizes == [4 + math.floor(3 * math.log(3))] * 10


def test_cmaes_in_100_dimensions_spends_its_budget_without_endless_bound_resampling(monkeypatch):
    """cmaes' ask() resamples out-of-box candidates: in 100-D almost every one leaves the box, and the
    package's default of 100 draws per candidate (a d x d product each) sat in ask() for seconds idle
    and minutes on a busy machine (repro_17). The draws per candidate are bounded (counted, not timed)."""
    draws = []
    real = cma_module.CMA._sample_solution

    def counted(self):
        draws.append(1)
        return real(self)

    monkeypatch.setattr(cma_module.CMA, "_sample_solution", counted)
    res = get_optimizer("cmaes").minimize(lambda x: x.sum(axis=1), [(-5.0, 0.5)] * 100, rng=2, max_evals=17)
    assert res.nfev == 17 and np.all((res.x >= -5.0) & (res.x <= 0.5))
    candidates = 100  # one generation of the default population
    assert candidates < len(draws) <= candidates * (cma_module.MAX_RESAMPLING + 1)
    assert cma_module.MAX_RESAMPLING <= 10


def test_ipop_doubles_the_population_in_batches_of_at_most_100(monkeypatch):
    created, told = spy_on_cma(monkeypatch)
    rec = Batches(lambda x: ((x - 0.3) ** 2).sum(axis=1))
    get_optimizer("cmaes-default").minimize(rec, [(-1.0, 1.0)] * 2, rng=0, max_evals=6_000)
    sizes = [p for _, p in created]
    assert len(sizes) >= 5
    assert sizes == [6 * 2**k for k in range(len(sizes))]
    assert max(rec.sizes) == 100 and sum(rec.sizes) == 6_000
    assert all(np.isfinite(values).all() for values in told)


def test_cmaes_never_tells_infinities(monkeypatch):
    _, told = spy_on_cma(monkeypatch)

    def half_nan(x):
        f = sphere(x)
        f[x[:, 0] > 0] = np.nan
        return f

    res = CMAES().minimize(half_nan, (LO, HI), rng=0, max_evals=2_000)
    assert told and all(np.isfinite(values).all() for values in told)
    assert np.isfinite(res.fun) and res.x[0] <= 0


@pytest.mark.parametrize(
    ("cls", "field", "value"),
    [(CEM, "elite_fraction", 0.0), (CEM, "smoothing", 1.5), (DE, "population_size", 4), (DE, "mutation", (0.5, 3)),
     (CMAES, "population_size", 1), (CMAES, "sigma", 0.0)],
)
def test_invalid_hyper_parameters(cls, field, value):
    with pytest.raises(ValueError, match=rf"{cls.__name__}\.{field}: got"):
        cls(**{field: value})
