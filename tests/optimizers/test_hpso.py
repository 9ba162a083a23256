"""HPSO rules (optimizers.md §4, §11.3)."""

from __future__ import annotations

import numpy as np
import pytest

import optimizers.hpso as hpso_module
from optimizers import get_optimizer
from optimizers.hpso import (
    HPSO,
    holonic_attractors,
    holonic_velocity,
    level_weights,
    stage1_iterations,
)
from tests.optimizers.spies import record_calls


def sphere(x):
    return ((x - 1.5) ** 2).sum(axis=1)


BOUNDS = [(-5.0, 5.0)] * 10


def test_level_weights():
    assert level_weights(3) == pytest.approx([1.0, 2.0 / 3.0, 1.0 / 3.0])


def velocity_1d(sign: float) -> float:
    one = np.ones((1, 1))
    attractors = (np.array([[1.0]]), np.array([[2.0]]), np.array([3.0]))
    v = holonic_velocity(np.zeros((1, 1)), np.zeros((1, 1)), attractors, np.ones((3, 1, 1)), one,
                         acceleration=1.0, constriction=1.0, sign=sign)
    return float(v[0, 0])


def test_holonic_velocity_hand_values():
    assert velocity_1d(+1.0) == pytest.approx(1.0 + 4.0 / 3.0 + 1.0)  # stage 1 (eq. 22): 10/3
    assert velocity_1d(-1.0) == pytest.approx(1.0 - 4.0 / 3.0 - 1.0)  # eq. 23 as printed: -4/3
    assert velocity_1d(+1.0) == pytest.approx(10.0 / 3.0)  # D10: stage 2 with s = +1 equals stage 1


def test_holonic_velocity_constriction_and_inertia():
    attractors = (np.zeros((1, 1)), np.zeros((1, 1)), np.zeros(1))
    v = holonic_velocity(np.array([[2.0]]), np.zeros((1, 1)), attractors, np.ones((3, 1, 1)), np.array([[0.5]]),
                         acceleration=1.3667, constriction=0.7298)
    assert v[0, 0] == pytest.approx(0.7298 * 0.5 * 2.0)


def test_holonic_attractors_are_levels_of_personal_bests():
    pbest = np.arange(12.0).reshape(6, 2)
    f = np.array([5.0, 1.0, 3.0, 2.0, 9.0, 4.0])
    p1, p2, p3 = holonic_attractors(pbest, f, np.array([0, 0, 0, 1, 1, 1]))
    assert np.array_equal(p1, pbest)
    assert np.array_equal(p2, pbest[[1, 1, 1, 3, 3, 3]])
    assert np.array_equal(p3, pbest[1])


def test_stage_split():
    assert stage1_iterations(99, 0.8) == 79
    assert stage1_iterations(10, 0.8) == 8


def test_stage_split_in_a_run(monkeypatch):
    """Iterations 1..79 use eq. 22 (sign +1), iterations 80..99 eq. 23 (hpso-literal: sign -1)."""
    signs = record_calls(monkeypatch, hpso_module, "holonic_velocity", lambda *args, **kwargs: kwargs["sign"])
    res = get_optimizer("hpso-literal").minimize(sphere, BOUNDS, rng=0, max_evals=10_000)
    assert res.nit == 99
    assert signs == [1.0] * 79 + [-1.0] * 20


def test_random_regroupings_only_in_stage_1(monkeypatch):
    """With T_r = 10 the groups are redrawn before iterations 11, 21, ..., 71 only: 1 initial + 7."""
    calls = record_calls(monkeypatch, hpso_module, "random_equal_groups", lambda n, g, rng: (n, g))
    HPSO().minimize(sphere, BOUNDS, rng=0, max_evals=10_000)
    assert calls == [(100, 5)] * 8


def test_groups_used_by_the_velocity_follow_the_regroupings(monkeypatch):
    """The group attractor is the group-best pbest of the current partition (frozen in stage 2)."""
    seen = record_calls(monkeypatch, hpso_module, "holonic_attractors", lambda pbest, f_pbest, labels: np.array(labels))
    HPSO().minimize(sphere, BOUNDS, rng=0, max_evals=10_000)
    changes = [t + 1 for t in range(1, len(seen)) if not np.array_equal(seen[t], seen[t - 1])]
    assert changes == [11, 21, 31, 41, 51, 61, 71]


def test_hpso_converges_far_better_than_literal():
    good = HPSO().minimize(sphere, BOUNDS, rng=0, max_evals=10_000)
    literal = get_optimizer("hpso-literal").minimize(sphere, BOUNDS, rng=0, max_evals=10_000)
    assert good.fun < 1e-8  # §12: about 5e-13
    assert literal.fun > 1e3 * good.fun


@pytest.mark.parametrize(
    ("field", "value"),
    [("swarm_size", 1), ("n_groups", 0), ("n_groups", 101), ("inertia_range", (1.0, 0.5)),
     ("acceleration", -1.0), ("constriction", 0.0), ("stage1_fraction", 1.5), ("regroup_period", 0),
     ("stage2_sign", 0), ("inertia_range", 0.9)],
)
def test_invalid_hyper_parameters(field, value):
    with pytest.raises(ValueError, match=rf"HPSO\.{field}: got .*expected"):
        HPSO(**{field: value})
