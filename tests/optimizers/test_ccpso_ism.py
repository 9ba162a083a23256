"""CCPSO-ISM rules (optimizers.md §9, §11.4)."""

from __future__ import annotations

import numpy as np
import pytest

import optimizers.ccpso_ism as ccpso_module
from optimizers.ccpso_ism import (
    CCPSOISM,
    competition_size,
    learning_slots,
    random_candidates,
    refresh_exemplar,
)


def test_competition_size():
    assert [competition_size(t, 99, 100) for t in (1, 50, 99)] == [2, 51, 100]
    assert competition_size(100, 99, 100) == 100  # a truncated extra iteration stays at N
    assert competition_size(1, 1000, 10) == 1


def blackboard():
    rng = np.random.default_rng(0)
    pbest = rng.random((6, 3))
    f_pbest = np.array([4.0, 2.0, 9.0, 1.0, 1.0, 5.0])  # best: particle 3 (tie with 4 -> lower index)
    exemplar = rng.random((6, 3))
    return pbest, f_pbest, exemplar


def test_refresh_with_certain_learning_and_full_competition_copies_the_best():
    pbest, f_pbest, exemplar = blackboard()
    refresh = np.array([True, False, True, True, False, True])
    learn = learning_slots(refresh, np.zeros((6, 3)), 1.0)
    candidates = random_candidates(np.random.default_rng(1).random((int(learn.sum()), 6)), 6)
    out = refresh_exemplar(exemplar, pbest, f_pbest, refresh, learn, candidates)
    assert np.array_equal(out[refresh], np.tile(pbest[3], (4, 1)))
    assert np.array_equal(out[~refresh], exemplar[~refresh])


def test_refresh_without_learning_copies_the_own_pbest():
    pbest, f_pbest, exemplar = blackboard()
    refresh = np.array([True, True, False, False, False, True])
    learn = learning_slots(refresh, np.random.default_rng(2).random((6, 3)), 0.0)
    assert not learn.any()
    out = refresh_exemplar(exemplar, pbest, f_pbest, refresh, learn, np.zeros((0, 6), dtype=np.int64))
    assert np.array_equal(out[refresh], pbest[refresh])
    assert np.array_equal(out[~refresh], exemplar[~refresh])


def test_refresh_learns_dimension_by_dimension_from_the_competition_winner():
    pbest, f_pbest, exemplar = blackboard()
    refresh = np.array([True, False, False, False, False, False])
    learn = np.zeros((6, 3), dtype=bool)
    learn[0, 1] = True
    out = refresh_exemplar(exemplar, pbest, f_pbest, refresh, learn, np.array([[2, 5, 1]]))
    # Candidates 2, 5, 1 have costs 9, 5, 2: particle 1 wins dimension 1; the others are own pbest.
    assert out[0].tolist() == [pbest[0, 0], pbest[1, 1], pbest[0, 2]]


def test_random_candidates_are_distinct_uniform_subsets():
    keys = np.random.default_rng(0).random((2_000, 10))
    cands = random_candidates(keys, 3)
    assert cands.shape == (2_000, 3)
    assert all(len(set(row)) == 3 for row in cands.tolist())
    counts = np.bincount(cands.ravel(), minlength=10)
    assert counts.min() > 0.8 * 600 and counts.max() < 1.2 * 600


def spy_on_refresh(monkeypatch):
    calls = []
    real = ccpso_module.refresh_exemplar

    def spy(exemplar, pbest, f_pbest, refresh, learn, candidates):
        out = real(exemplar, pbest, f_pbest, refresh, learn, candidates)
        calls.append((np.array(refresh), np.array_equal(out[~refresh], exemplar[~refresh])))
        return out

    monkeypatch.setattr(ccpso_module, "refresh_exemplar", spy)
    return calls


def test_stall_counter_and_exemplar_lifecycle(monkeypatch):
    """Even particles improve at every call, odd ones never do.

    Odd particles stall; from iteration G_r + 1 = 6 their exemplars are refreshed at every iteration
    (a refresh does not reset the stall counter). Improving particles are never refreshed.
    """
    calls = spy_on_refresh(monkeypatch)
    counter = [0.0]
    n = 10

    def fun(x):
        counter[0] -= 1.0
        f = np.ones(len(x))
        f[::2] = counter[0]
        return f

    res = CCPSOISM(swarm_size=n).minimize(fun, [(-1.0, 1.0)] * 2, rng=0, max_evals=200)
    assert res.nit == 19
    assert len(calls) == 19 - 5
    odd = np.arange(n) % 2 == 1
    for refresh, others_unchanged in calls:
        assert np.array_equal(refresh, odd)
        assert others_unchanged


def test_improving_particles_keep_their_initial_exemplar(monkeypatch):
    calls = spy_on_refresh(monkeypatch)
    counter = [0.0]

    def always_better(x):
        counter[0] -= 1.0
        return np.full(len(x), counter[0])

    CCPSOISM(swarm_size=10).minimize(always_better, [(-1.0, 1.0)] * 2, rng=0, max_evals=300)
    assert calls == []


def test_invalid_hyper_parameters():
    with pytest.raises(ValueError, match=r"CCPSOISM\.learning_probability: got 2"):
        CCPSOISM(learning_probability=2)
    with pytest.raises(ValueError, match=r"CCPSOISM\.refreshing_gap"):
        CCPSOISM(refreshing_gap=-1)
