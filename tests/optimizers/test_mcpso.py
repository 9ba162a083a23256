"""MCPSO rules (optimizers.md §8, §11.4)."""

from __future__ import annotations

import numpy as np
import pytest

import optimizers.mcpso as mcpso_module
from optimizers import get_optimizer
from optimizers.mcpso import MCPSO, master_velocity, migration_factor
from tests.optimizers.spies import record_calls


def sphere(x):
    return ((x - 1.5) ** 2).sum(axis=1)


def test_migration_factor():
    assert migration_factor(1, 2) == 0
    assert migration_factor(2, 2) == 0.5
    assert migration_factor(3, 2) == 1
    assert migration_factor(np.inf, np.inf) == 0.5


def master_1d(phi=None, v=0.0, inertia=0.0):
    one = np.ones((1, 1))
    out = master_velocity(np.array([[v]]), np.zeros((1, 1)), one, np.array([2.0]), np.array([3.0]),
                          np.ones((3, 1, 1)), inertia=inertia, cognitive=2.05, social=2.05, migration=2.0,
                          phi=phi)
    return float(out[0, 0])


def test_col_master_velocity():
    assert master_1d() == pytest.approx(2.05 + 4.1 + 6.0)  # 12.15 before the clamp
    assert master_1d(v=2.0, inertia=0.5) == pytest.approx(1.0 + 12.15)


def test_com_master_velocity():
    assert master_1d(phi=0.0) == pytest.approx(2.05 + 6.0)  # slaves better: follow them only
    assert master_1d(phi=1.0) == pytest.approx(2.05 + 4.1)  # master better: follow itself only
    assert master_1d(phi=0.5) == pytest.approx(2.05 + 2.05 + 3.0)


def batch_sizes(opt, max_evals, x0=None):
    sizes, first = [], []

    def fun(x):
        sizes.append(len(x))
        if not first:
            first.append(x[0].copy())
        return sphere(x)

    res = opt.minimize(fun, [(-5.0, 5.0)] * 4, rng=0, max_evals=max_evals, x0=x0)
    return res, sizes, first[0]


def test_two_batches_per_iteration():
    res, sizes, _ = batch_sizes(MCPSO(), 10_000)
    assert sizes == [100] + [75, 25] * 99
    assert res.nit == 99 and len(res.history) == 100


def test_truncated_last_iteration_skips_the_master():
    res, sizes, _ = batch_sizes(MCPSO(), 1_050)
    assert sizes == [100] + [75, 25] * 9 + [50]
    assert res.nit == 10 and res.nfev == 1_050
    res, sizes, _ = batch_sizes(MCPSO(), 1_080)
    assert sizes == [100] + [75, 25] * 9 + [75, 5]
    assert res.nit == 10


def test_warm_start_is_master_particle_0():
    _, _, first = batch_sizes(MCPSO(), 500, x0=[0.1, 0.2, 0.3, 0.4])
    assert first.tolist() == [0.1, 0.2, 0.3, 0.4]


def test_uneven_population_gives_the_extra_particle_to_the_master():
    _, sizes, _ = batch_sizes(MCPSO(swarm_size=10), 30)
    assert sizes == [10, 7, 3, 7, 3]


def test_com_uses_the_migration_factor(monkeypatch):
    phis = record_calls(monkeypatch, mcpso_module, "master_velocity", lambda *args, **kwargs: kwargs["phi"])
    get_optimizer("mcpso").minimize(sphere, [(-5.0, 5.0)] * 4, rng=0, max_evals=1_000)
    assert phis and all(p is None for p in phis)
    phis.clear()
    get_optimizer("mcpso-com").minimize(sphere, [(-5.0, 5.0)] * 4, rng=0, max_evals=1_000)
    assert len(phis) == 9 and set(phis) <= {0.0, 0.5, 1.0}


def test_invalid_hyper_parameters():
    with pytest.raises(ValueError, match=r"MCPSO\.version: got 'coop'"):
        MCPSO(version="coop")
    with pytest.raises(ValueError, match=r"MCPSO\.swarm_size: got 3"):
        MCPSO(swarm_size=3)
