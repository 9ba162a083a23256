"""PS2O rules (optimizers.md §7, §11.4)."""

from __future__ import annotations

import numpy as np
import pytest

import optimizers.ps2o as ps2o_module
from optimizers import get_optimizer
from optimizers.ps2o import (
    PS2O,
    partner_best_index,
    partner_graph,
    reseed,
    species_best,
    species_to_reseed,
)


def test_partner_best_index_hand_case():
    adjacency = [[0, 0, 1], [0, 0, 1], [1, 1, 0]]
    assert partner_best_index(adjacency, [3.0, 1.0, 2.0]).tolist() == [2, 2, 1]


def test_partner_best_index_requires_a_partner():
    with pytest.raises(ValueError, match="no partner"):
        partner_best_index([[0, 1], [0, 0]], [1.0, 2.0])


def test_partner_graph_is_symmetric_with_empty_diagonal():
    rng = np.random.default_rng(0)
    for _ in range(20):
        draws = rng.random((5, 5))
        upper = np.triu(draws < 0.5, k=1)
        adjacency = partner_graph(draws, rng.random(5), 0.5)
        assert not adjacency.diagonal().any()
        assert adjacency.any(axis=1).all()
        linked = upper | upper.T
        assert np.array_equal(adjacency & linked, linked)  # every drawn link is kept both ways


def test_lonely_species_get_exactly_one_one_way_partner():
    m = 5
    no_links = np.ones((m, m))  # every draw >= p_link: nobody is linked
    for pick in (0.0, 0.3, 0.999):
        adjacency = partner_graph(no_links, np.full(m, pick), 0.5)
        assert adjacency.sum(axis=1).tolist() == [1] * m
        assert not adjacency.diagonal().any()
    # Species 0 and 1 are linked; species 2 is alone and gets one partner, which does not get it back.
    draws = np.ones((3, 3))
    draws[0, 1] = 0.0
    adjacency = partner_graph(draws, np.array([0.0, 0.0, 0.0]), 0.5)
    assert adjacency[2].sum() == 1 and adjacency[2, 0]
    assert adjacency[0].tolist() == [False, True, False]


def test_species_best():
    index, cost = species_best(np.array([3.0, 1.0, 5.0, 5.0, 2.0, 0.5]), 3)
    assert index.tolist() == [1, 2, 5] and cost.tolist() == [1.0, 5.0, 0.5]


def test_species_to_reseed():
    assert species_to_reseed([30, 31, 5], 30, 1).tolist() == [True, False, False]
    assert species_to_reseed([30, 31, 5], None, 1).tolist() == [False, False, False]
    assert species_to_reseed([40, 31, 5], 30, 0).tolist() == [False, True, False]


def test_reseed_clears_velocity_and_personal_best():
    x = np.arange(8.0).reshape(4, 2)
    v = np.ones((4, 2))
    pbest = x + 0.5
    f = np.array([1.0, 2.0, 3.0, 4.0])
    reborn = np.array([False, True, True, False])
    new = np.array([[9.0, 9.0], [8.0, 8.0]])
    x2, v2, p2, f2 = reseed(x, v, pbest, f, reborn, new)
    assert np.array_equal(x2[reborn], new) and np.all(v2[reborn] == 0.0)
    assert np.all(f2[reborn] == np.inf) and np.array_equal(p2[reborn], new)
    assert np.array_equal(x2[~reborn], x[~reborn]) and np.array_equal(v2[~reborn], v[~reborn])
    assert np.array_equal(f2[~reborn], f[~reborn]) and f.tolist() == [1.0, 2.0, 3.0, 4.0]


def spy_on_reseed(monkeypatch):
    calls = []
    real = ps2o_module.reseed

    def spy(x, v, pbest, f_pbest, reborn, positions):
        calls.append(np.flatnonzero(reborn) // 20)
        return real(x, v, pbest, f_pbest, reborn, positions)

    monkeypatch.setattr(ps2o_module, "reseed", spy)
    return calls


def plateau(x):
    """Constant cost: no species ever improves after initialisation."""
    return np.ones(len(x))


def test_extinction_on_a_plateau(monkeypatch):
    calls = spy_on_reseed(monkeypatch)
    res = PS2O().minimize(plateau, [(-1.0, 1.0)] * 3, rng=0, max_evals=3_600)
    assert res.nit == 35
    # Counters reach 30 after iteration 30; at iteration 31 every species but the global best's (0) dies.
    assert len(calls) == 1
    assert sorted(set(calls[0].tolist())) == [1, 2, 3, 4]


def test_noext_never_reseeds(monkeypatch):
    calls = spy_on_reseed(monkeypatch)
    get_optimizer("ps2o-noext").minimize(plateau, [(-1.0, 1.0)] * 3, rng=0, max_evals=5_000)
    assert calls == []


def test_species_layout_and_warm_start():
    opt = PS2O(n_species=3, species_size=4)
    assert opt.swarm_size == 12
    batches = []

    def fun(x):
        batches.append(x.copy())
        return (x**2).sum(axis=1)

    opt.minimize(fun, [(-1.0, 1.0)] * 2, rng=0, max_evals=48, x0=[0.25, -0.5])
    assert [len(b) for b in batches] == [12, 12, 12, 12]
    assert batches[0][0].tolist() == [0.25, -0.5]


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"n_species": 1}, r"PS2O\.n_species: got 1"),
        ({"extinction_patience": 0}, r"PS2O\.extinction_patience: got 0"),
        ({"link_probability": 1.5}, r"PS2O\.link_probability"),
    ],
)
def test_invalid_hyper_parameters(changes, message):
    with pytest.raises(ValueError, match=message):
        PS2O(**changes)
