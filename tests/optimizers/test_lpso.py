"""LPSO rules (optimizers.md §6, §11.4)."""

from __future__ import annotations

import numpy as np
import pytest

import optimizers.lpso as lpso_module
from optimizers.lpso import LPSO, neighbourhood_fraction, spatial_neighbourhood_best
from tests.optimizers.spies import record_calls


def sphere(x):
    return ((x - 1.5) ** 2).sum(axis=1)


def test_neighbourhood_fraction():
    assert neighbourhood_fraction(0, 100) == pytest.approx(0.6)
    assert neighbourhood_fraction(9, 100) == pytest.approx(0.87)  # still spatial
    assert neighbourhood_fraction(11, 100) == pytest.approx(0.93)  # global best


def test_spatial_neighbourhood_best_hand_case():
    U = np.array([[0.0], [0.1], [0.5], [1.0]])
    # Neighbourhoods {0, 1, 2}, {0, 1, 2}, {2}, {2, 3}.
    assert spatial_neighbourhood_best(U, [4.0, 3.0, 2.0, 1.0], 0.6).tolist() == [2, 2, 2, 3]


def test_spatial_neighbourhood_best_degenerate_swarm_is_global():
    U = np.zeros((4, 3))  # dmax = 0: the neighbourhood is the whole swarm
    assert spatial_neighbourhood_best(U, [3.0, 1.0, 1.0, 2.0], 0.6).tolist() == [1, 1, 1, 1]


def test_spatial_neighbourhood_best_ties_and_infinite_costs():
    U = np.array([[0.0], [0.1], [0.5], [1.0]])
    assert spatial_neighbourhood_best(U, [np.inf] * 4, 0.6).tolist() == [0, 0, 2, 2]
    assert spatial_neighbourhood_best(U, [2.0, 2.0, 2.0, 2.0], 0.6).tolist() == [0, 0, 2, 2]


def test_spatial_neighbourhood_best_matches_a_loop():
    rng = np.random.default_rng(3)
    U = rng.random((30, 4))
    f = rng.integers(0, 5, 30).astype(float)
    frac = 0.7
    expected = []
    for i in range(30):
        d = np.linalg.norm(U - U[i], axis=1)
        members = [j for j in range(30) if j == i or d[j] < frac * d.max()]
        expected.append(min(members, key=lambda j: (f[j], j)))
    assert spatial_neighbourhood_best(U, f, frac).tolist() == expected


def test_spatial_neighbourhoods_only_in_the_first_tenth(monkeypatch):
    """frac(l) <= 0.9 only for l <= 9 when T = 99: ten spatial iterations, then global best."""
    calls = record_calls(monkeypatch, lpso_module, "spatial_neighbourhood_best", lambda U, f_pbest, frac: frac)
    res = LPSO().minimize(sphere, [(-5.0, 5.0)] * 10, rng=0, max_evals=10_000)
    assert res.nit == 99
    assert len(calls) == 10
    assert calls[0] == pytest.approx(0.6) and calls[-1] <= 0.9


def test_invalid_hyper_parameters():
    with pytest.raises(ValueError, match=r"LPSO\.gbest_threshold: got -1"):
        LPSO(gbest_threshold=-1.0)
    with pytest.raises(ValueError, match=r"LPSO\.inertia"):
        LPSO(inertia=(0.9,))
