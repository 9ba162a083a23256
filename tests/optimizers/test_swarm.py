"""Shared swarm operators (optimizers.md §2, §11.2)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from optimizers import get_optimizer
from optimizers.swarm import (
    attractor_velocity,
    clamp_velocity,
    cost_rank,
    group_best_index,
    group_sizes,
    init_positions,
    labels_from_order,
    linear_schedule,
    move_within_bounds,
    normalise,
    planned_iterations,
    random_equal_groups,
    time_fraction,
    update_personal_best,
    velocity_limit,
)

finite = st.floats(-1e6, 1e6, allow_nan=False)


def partition(labels):
    """A labelling as a set of frozensets (partitions are never compared by label values)."""
    labels = np.asarray(labels)
    return {frozenset(np.flatnonzero(labels == g).tolist()) for g in np.unique(labels)}


def test_clamp_velocity():
    assert clamp_velocity([3.0, -3.0], vmax=[1.0, 1.0]).tolist() == [1.0, -1.0]
    assert clamp_velocity([[0.5, -0.2]], vmax=[1.0, 0.1]).tolist() == [[0.5, -0.1]]


def test_move_within_bounds_absorbs_at_the_wall():
    x, v = move_within_bounds(x=[0.9], v=[0.5], lo=[0.0], hi=[1.0])
    assert x.tolist() == [1.0] and v.tolist() == [0.0]
    x, v = move_within_bounds(x=[[0.5, 0.1]], v=[[0.2, -0.3]], lo=[0.0, 0.0], hi=[1.0, 1.0])
    assert x.tolist() == [[0.7, 0.0]] and v.tolist() == [[0.2, 0.0]]


@given(
    hnp.arrays(np.float64, (5, 3), elements=st.floats(0, 1)),
    hnp.arrays(np.float64, (5, 3), elements=st.floats(-3, 3)),
)
def test_move_within_bounds_stays_inside(unit, v):
    lo, hi = np.array([-1.0, 0.0, 2.0]), np.array([1.0, 0.5, 7.0])
    x = lo + unit * (hi - lo)
    x_new, v_new = move_within_bounds(x, v, lo, hi)
    assert np.all(x_new >= lo) and np.all(x_new <= hi)
    moved_freely = (x + v >= lo) & (x + v <= hi)
    assert np.array_equal(v_new[moved_freely], v[moved_freely])
    assert np.all(v_new[~moved_freely] == 0.0)


def test_velocity_limit_is_a_fifth_of_the_range():
    assert velocity_limit(np.array([-5.0, 0.0]), np.array([5.0, 1.0])).tolist() == [2.0, 0.2]


def test_planned_iterations_and_schedule():
    assert planned_iterations(10_000, 100) == 99
    assert planned_iterations(50, 100) == 1
    assert planned_iterations(10_100, 100) == 100
    assert time_fraction(1, 99) == 0
    assert time_fraction(99, 99) == 1
    assert time_fraction(1, 1) == 0
    assert time_fraction(100, 99) == 1  # a truncated extra iteration keeps the end value
    assert linear_schedule(0.9, 0.4, 1, 99) == 0.9
    assert linear_schedule(0.9, 0.4, 99, 99) == pytest.approx(0.4)
    assert linear_schedule(0.9, 0.4, 50, 99) == pytest.approx(0.65)


def constriction_factor(phi: float) -> float:
    """Oracle: the Clerc-Kennedy constriction ``chi = 2 / |2 - phi - sqrt(phi^2 - 4 phi)|``, for ``phi > 4``."""
    if not phi > 4.0:
        raise ValueError(f"phi: got {phi!r}, expected a value > 4 (Clerc-Kennedy constriction)")
    return 2.0 / abs(2.0 - phi - math.sqrt(phi * phi - 4.0 * phi))


def test_constriction_factor():
    assert constriction_factor(4.1) == pytest.approx(0.72984, abs=1e-5)
    with pytest.raises(ValueError, match="phi"):
        constriction_factor(4.0)


@pytest.mark.parametrize("name", ["pso", "hpso", "ihpso", "ps2o"])
def test_default_constrictions_are_clerc_kennedy_for_phi_4_1(name):
    """D9: the swarms' chi is the Clerc-Kennedy value of phi = 4.1 (to its printed digits)."""
    assert get_optimizer(name).constriction == pytest.approx(constriction_factor(4.1), abs=1e-4)


def test_init_positions_uniform_and_warm_start():
    lo, hi = np.array([-1.0, 10.0]), np.array([1.0, 20.0])
    unit = np.array([[0.0, 0.5], [0.25, 0.999], [0.5, 0.0]])
    x = init_positions(unit, lo, hi)
    assert np.allclose(x, [[-1.0, 15.0], [-0.5, 19.99], [0.0, 10.0]])
    x = init_positions(unit, lo, hi, x0=np.array([0.3, 11.0]))
    assert x[0].tolist() == [0.3, 11.0]
    assert np.allclose(x[1:], [[-0.5, 19.99], [0.0, 10.0]])


def test_update_personal_best_is_strict():
    x = np.array([[1.0], [2.0], [3.0]])
    pbest = np.array([[0.0], [0.0], [0.0]])
    p, fp, improved = update_personal_best(x, np.array([1.0, 2.0, np.inf]), pbest, np.array([2.0, 2.0, np.inf]))
    assert improved.tolist() == [True, False, False]
    assert p.ravel().tolist() == [1.0, 0.0, 0.0]
    assert fp.tolist() == [1.0, 2.0, np.inf]


def test_normalise():
    assert normalise([[0.0, 5.0]], np.array([-1.0, 5.0]), np.array([1.0, 15.0])).tolist() == [[0.5, 0.0]]


def test_group_sizes():
    assert group_sizes(100, 5) == (20,) * 5
    assert group_sizes(7, 3) == (3, 2, 2)
    assert group_sizes(4, 4) == (1, 1, 1, 1)
    with pytest.raises(ValueError, match="n_groups"):
        group_sizes(3, 4)


@given(st.integers(1, 60), st.integers(1, 60))
def test_group_sizes_partition_n(n, g):
    if g > n:
        return
    sizes = group_sizes(n, g)
    assert sum(sizes) == n and max(sizes) - min(sizes) <= 1 and list(sizes) == sorted(sizes, reverse=True)


def test_labels_from_order():
    labels = labels_from_order([4, 0, 2, 1, 3], (3, 2))
    assert partition(labels) == {frozenset({4, 0, 2}), frozenset({1, 3})}


def test_random_equal_groups_sizes_and_randomness():
    a = random_equal_groups(100, 5, np.random.default_rng(0))
    b = random_equal_groups(100, 5, np.random.default_rng(1))
    assert sorted(np.bincount(a).tolist()) == [20] * 5
    assert partition(a) != partition(b)
    c = random_equal_groups(7, 3, np.random.default_rng(0))
    assert sorted(np.bincount(c).tolist(), reverse=True) == [3, 2, 2]


def test_group_best_index():
    f_pbest = [5, 1, 3, 2, 9, 4]
    labels = [0, 0, 0, 1, 1, 1]
    assert group_best_index(f_pbest, labels).tolist() == [1, 1, 1, 3, 3, 3]
    assert int(np.argmin(f_pbest)) == 1


def test_group_best_index_ties_and_infinities():
    # Ties go to the lowest index; an all-inf group still points into itself.
    f = [np.inf, 2.0, np.inf, 2.0, np.inf, np.inf]
    labels = [1, 0, 0, 0, 1, 1]
    assert group_best_index(f, labels).tolist() == [0, 1, 1, 1, 0, 0]


@given(hnp.arrays(np.float64, 12, elements=st.sampled_from([0.0, 1.0, 2.0, np.inf])),
       hnp.arrays(np.int64, 12, elements=st.integers(0, 3)))
def test_group_best_index_matches_a_loop(f, labels):
    expected = []
    for i in range(12):
        members = [j for j in range(12) if labels[j] == labels[i]]
        expected.append(min(members, key=lambda j: (f[j], j)))
    assert group_best_index(f, labels).tolist() == expected


def test_cost_rank_ties_to_lower_index():
    assert cost_rank([3.0, 1.0, np.inf, 1.0]).tolist() == [2, 0, 3, 1]


def test_attractor_velocity():
    v = np.array([[1.0]])
    x = np.array([[0.0]])
    ones = np.ones((1, 1))
    out = attractor_velocity(v, x, (np.array([[1.0]]), np.array([2.0])), (2.0, 3.0), (ones, ones), 0.5, 0.1)
    assert out.tolist() == [[pytest.approx(0.1 * (0.5 + 2.0 + 6.0))]]
    zeros = np.zeros((1, 1))
    assert attractor_velocity(v, x, (np.array([[5.0]]),), (2.0,), (zeros,), 0.5).tolist() == [[0.5]]
