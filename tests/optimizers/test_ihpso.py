"""IHPSO rules: grouping, switching, adaptive termination (optimizers.md §5, §11.3)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.spatial.distance import pdist

import optimizers.ihpso as ihpso_module
from optimizers import get_optimizer
from optimizers.ihpso import (
    IHPSO,
    dendrogram_groups,
    fitness_level,
    fitness_slope,
    slope_is_zero,
    switch_condition,
    switch_due,
    switch_window_open,
    termination_test,
)
from optimizers.ihpso_2022v0 import group_distance_sums
from optimizers.ihpso_grouping import cluster_both_ways

TWO_CLUMPS = np.array([(0, 0), (0.01, 0), (0, 0.02), (1, 1), (1.01, 1), (1, 1.02)], dtype=float)
THREE_CLUMPS = np.array([(0, 0), (0, 0.01), (1, 0), (1, 0.01), (0, 1), (0.01, 1)], dtype=float)
CLUMP_OF = np.array([0, 0, 1, 1, 2, 2])


def partition(labels):
    labels = np.asarray(labels)
    return {frozenset(np.flatnonzero(labels == g).tolist()) for g in np.unique(labels)}


def sphere(x):
    return ((x - 1.5) ** 2).sum(axis=1)


BOUNDS = [(-5.0, 5.0)] * 10
V0 = {"method": "average", "cut": "equal"}  # the 2022v0 grouping


def test_cluster_grouping_finds_two_clumps():
    labels = dendrogram_groups(TWO_CLUMPS, 2, inverse=False)
    assert partition(labels) == {frozenset({0, 1, 2}), frozenset({3, 4, 5})}


def test_entropy_grouping_mixes_two_clumps():
    for cut in ("maxclust", "equal"):
        groups = partition(dendrogram_groups(TWO_CLUMPS, 2, inverse=True, cut=cut))
        assert len(groups) == 2
        for group in groups:
            assert group & {0, 1, 2} and group & {3, 4, 5}
    equal = partition(dendrogram_groups(TWO_CLUMPS, 2, inverse=True, cut="equal", method="average"))
    assert all(len(g) == 3 for g in equal)  # the 2022v0 equal-size cut


def test_three_clumps():
    assert partition(dendrogram_groups(THREE_CLUMPS, 3, inverse=False)) == {
        frozenset({0, 1}), frozenset({2, 3}), frozenset({4, 5})
    }
    entropy = dendrogram_groups(THREE_CLUMPS, 3, inverse=True)
    for group in partition(entropy):
        clumps = CLUMP_OF[list(group)]
        assert len(set(clumps.tolist())) == len(clumps)  # no two members of the same clump


@pytest.mark.parametrize("inverse", [False, True])
def test_group_sizes_of_seven_under_the_equal_cut(inverse):
    U = np.random.default_rng(0).random((7, 3))
    labels = dendrogram_groups(U, 3, inverse=inverse, cut="equal", method="average")
    assert sorted(np.bincount(labels).tolist(), reverse=True) == [3, 2, 2]


def test_coincident_particles_stay_finite():
    labels = dendrogram_groups(np.zeros((6, 2)), 3, inverse=True, cut="equal", method="average")
    assert sorted(np.bincount(labels).tolist()) == [2, 2, 2]
    labels = dendrogram_groups(np.zeros((6, 2)), 3, inverse=True)  # every merge height ties
    assert labels.min() == 0 and labels.max() <= 2 and np.array_equal(np.unique(labels), np.arange(labels.max() + 1))


def within_group_distance_sums(U, labels):
    """Oracle: eq. 30's sums (the 2022v0 statistic), one unordered pair at a time."""
    U, labels = np.asarray(U, dtype=float), np.asarray(labels)
    sums = np.zeros(labels.max() + 1)
    for i, j in itertools.combinations(range(len(U)), 2):
        if labels[i] == labels[j]:
            sums[labels[i]] += math.dist(U[i], U[j])
    return sums


def test_within_group_distance_sums():
    assert within_group_distance_sums([(0, 0), (3, 0), (0, 4)], [0, 0, 0]).tolist() == [12.0]
    sums = within_group_distance_sums([(0, 0), (3, 0), (0, 4), (0, 5)], [0, 1, 0, 1])
    assert sums == pytest.approx([4.0, math.hypot(3, 5)])
    U = np.random.default_rng(1).random((30, 4))
    labels = np.random.default_rng(2).integers(0, 4, size=30)
    assert group_distance_sums(pdist(U), labels, 4) == pytest.approx(within_group_distance_sums(U, labels))
    assert group_distance_sums(pdist(U[:3]), np.zeros(3, dtype=np.int64), 2).tolist()[1] == 0.0  # empty group


def test_both_groupings_are_the_dendrogram_groupings():
    """One distance computation gives exactly the groupings each method gives alone, under either cut."""
    U = np.random.default_rng(3).random((40, 5))
    for kwargs in ({}, V0):
        clustering = cluster_both_ways(U, 5, **kwargs)
        assert np.array_equal(clustering.entropy, dendrogram_groups(U, 5, inverse=True, **kwargs))
        assert np.array_equal(clustering.cluster, dendrogram_groups(U, 5, inverse=False, **kwargs))
        assert np.array_equal(clustering.distances, pdist(U))


def test_termination_test_2022v0():
    assert termination_test(TWO_CLUMPS, 2, spread="sum", **V0) is False
    labels_e = dendrogram_groups(TWO_CLUMPS, 2, inverse=True, **V0)
    labels_c = dendrogram_groups(TWO_CLUMPS, 2, inverse=False, **V0)
    assert group_distance_sums(pdist(TWO_CLUMPS), labels_e, 2).min() == pytest.approx(2.83, abs=0.01)
    assert group_distance_sums(pdist(TWO_CLUMPS), labels_c, 2).max() == pytest.approx(0.052, abs=0.001)
    assert termination_test(np.full((6, 2), 0.3), 3, spread="sum", **V0) is True


def test_termination_test():
    assert termination_test(TWO_CLUMPS, 2) is False
    assert termination_test(THREE_CLUMPS, 3) is False
    assert termination_test(np.full((6, 2), 0.3), 3) is True  # coincident: every spread is 0


@pytest.mark.parametrize(
    ("ks", "expected"),
    [
        ((8, 4, 1), True),  # 16 < 19.2 and 1 < 12
        ((8, 4, 3), False),  # (27) fails: 16 < 6.4 is false
        ((1, 4, 12), False),  # (28') fails: 12 < 12 is false
        ((1, 4, 11), True),  # -12 < -5.6 and 11 < 12
        ((8, 4, 20), False),  # (28') fails
        ((0, 0, 0), False),  # zero previous slope
        ((5, 0, 0), False),
        ((math.inf, 4, 1), False),  # undefined slopes never switch
        ((8, math.inf, 1), False),
    ],
)
def test_switch_condition(ks, expected):
    assert switch_condition(*ks, omega=0.8, alpha=3.0) is expected


def test_switch_due_with_lag_two():
    slopes = [math.inf, 8, 100, 4, 100, 1]  # slopes[t] = k_t
    assert switch_due(slopes, 5, 0, 2, 0.8, 3.0) is True  # judges k_1, k_3, k_5
    assert switch_due([math.inf, 8, 100, 4, 100, 3], 5, 0, 2, 0.8, 3.0) is False
    assert switch_due(slopes, 4, 0, 2, 0.8, 3.0) is False  # window closed


def test_switch_window_after_a_return_to_broad_mode():
    j, t0 = 1, 17
    assert not switch_window_open(t0 + 2 * j, t0, j)
    assert switch_window_open(t0 + 2 * j + 1, t0, j)
    assert switch_window_open(3, 0, 1) and not switch_window_open(2, 0, 1)
    # Stale slopes from before t0 that would switch are never judged.
    slopes = [math.inf, 8, 4, 1, 0, 0]
    assert switch_condition(slopes[1], slopes[2], slopes[3], 0.8, 3.0)
    assert not switch_due(slopes, 3, 2, 1, 0.8, 3.0)


def test_slope_is_zero():
    assert slope_is_zero(1e-10, 100, rtol=1e-9) is True  # 2022v0: k <= 1e-12 + 1e-7
    assert slope_is_zero(1e-6, 100, rtol=1e-9) is False
    assert slope_is_zero(1e-2, 100) is True  # default rtol 1e-4 (D15): k <= 1e-12 + 1e-2
    assert slope_is_zero(1.1e-2, 100) is False
    assert slope_is_zero(0.0, 0.0) is True  # the absolute floor: a level of 0 that stopped moving
    assert slope_is_zero(0.0, None) is False
    assert slope_is_zero(math.inf, 1.0) is False


def test_fitness_level_and_slope():
    assert fitness_level([1.0, 3.0, math.inf]) == 2.0
    assert fitness_level([math.inf, math.inf]) is None
    assert fitness_slope(fitness_level([math.inf, math.inf]), fitness_level([1.0, 2.0])) == math.inf
    assert fitness_slope(2.0, 3.5) == 1.5


def test_adaptive_termination_end_to_end():
    """C5 sphere, 30,000 evaluations: ihpso stops early (a prototype stopped after ~10,300-11,000)."""
    res = get_optimizer("ihpso").minimize(sphere, BOUNDS, rng=0, max_evals=30_000)
    assert "adaptive termination" in res.message
    assert res.nfev < 30_000
    assert res.fun < 1e-8
    locked = get_optimizer("ihpso-noterm").minimize(sphere, BOUNDS, rng=0, max_evals=30_000)
    assert locked.nfev == 30_000
    assert locked.message == "max_evals reached"
    # Both runs are identical up to the termination point.
    assert np.array_equal(locked.history[: res.nit + 1], res.history)


def spy_on_grouping(monkeypatch):
    calls = []
    real = ihpso_module.dendrogram_groups

    def spy(U, n_groups, *, inverse, **kwargs):
        calls.append("entropy" if inverse else "cluster")
        return real(U, n_groups, inverse=inverse, **kwargs)

    monkeypatch.setattr(ihpso_module, "dendrogram_groups", spy)
    return calls


def test_scheme_4_groups_by_entropy_in_broad_and_cluster_in_accurate_mode(monkeypatch):
    calls = spy_on_grouping(monkeypatch)
    res = get_optimizer("ihpso").minimize(sphere, BOUNDS, rng=0, max_evals=30_000)
    assert "adaptive termination" in res.message
    assert calls[0] == "entropy"  # initial grouping, broad mode
    assert "cluster" in calls  # the switch to accurate search happened
    assert calls.index("cluster") >= 1
    # Broad phases regroup every 10 iterations, so there are at most nit / 10 + switches groupings.
    assert len(calls) <= res.nit


@pytest.mark.parametrize(
    ("name", "methods"),
    [("ihpso-scheme1", {"cluster"}), ("ihpso-scheme2", {"entropy"}), ("ihpso-random", set())],
)
def test_ablation_schemes_use_their_grouping(monkeypatch, name, methods):
    calls = spy_on_grouping(monkeypatch)
    get_optimizer(name).minimize(sphere, BOUNDS, rng=0, max_evals=3_000)
    assert set(calls) == methods


def floor_sum(x):
    """A staircase: the swarm's fitness level stops moving after a few iterations."""
    return np.floor(x).sum(axis=1)


def test_mode_state_machine(monkeypatch):
    """Broad -> accurate (switch), accurate -> broad (zero slope, test fails), then termination.

    ``stage2_sign=-1`` makes the mode visible in the velocity rule's sign (+1 broad, -1 accurate).
    The first termination test is forced to fail, so the run must go back to broad search with a fresh
    broad grouping and no switch test inside the D18 window.
    """
    signs, labels, tests = [], [], []
    real_velocity, real_attractors = ihpso_module.holonic_velocity, ihpso_module.holonic_attractors

    def velocity(*args, **kwargs):
        signs.append(kwargs["sign"])
        return real_velocity(*args, **kwargs)

    def attractors(pbest, f_pbest, group_labels):
        labels.append(np.array(group_labels))
        return real_attractors(pbest, f_pbest, group_labels)

    def termination(spreads):
        tests.append(len(signs))  # the iteration t at which the test is made
        return len(tests) > 1

    tested_positions = []
    real_clustering = ihpso_module.cluster_both_ways

    def clustering(U, n_groups, **kwargs):
        tested_positions.append(np.array(U))
        return real_clustering(U, n_groups, **kwargs)

    monkeypatch.setattr(ihpso_module, "holonic_velocity", velocity)
    monkeypatch.setattr(ihpso_module, "holonic_attractors", attractors)
    monkeypatch.setattr(ihpso_module, "spreads_converge", termination)
    monkeypatch.setattr(ihpso_module, "cluster_both_ways", clustering)
    groupings = spy_on_grouping(monkeypatch)
    res = IHPSO(stage2_sign=-1).minimize(floor_sum, BOUNDS, rng=0, max_evals=30_000)

    assert res.message.startswith("adaptive termination") and len(tests) == 2 and res.nit == tests[1]
    assert signs[:3] == [1.0, 1.0, 1.0]  # the first switch test is at t = 2j + 1 = 3
    t1 = tests[0]
    assert signs[t1 - 1] == -1.0  # the failed test was made in accurate mode ...
    assert signs[t1 : t1 + 3] == [1.0, 1.0, 1.0]  # ... then broad, with no switch before t1 + 2j + 1
    # The broad groups after the failed test are the entropy grouping of the tested positions.
    assert len(tested_positions) == 2
    assert np.array_equal(labels[t1], dendrogram_groups(tested_positions[0], 5, inverse=True))  # not the spy
    assert -1.0 in signs[t1:]  # and a second switch to accurate search
    assert groupings.count("cluster") == 2 and groupings[-1] == "cluster"
    for t in range(1, len(signs)):
        if signs[t] == signs[t - 1] == -1.0:
            assert np.array_equal(labels[t], labels[t - 1])  # no regrouping in accurate mode
    broad_label_changes = [t + 1 for t in range(1, t1) if signs[t] == 1.0 and signs[t - 1] == 1.0
                           and not np.array_equal(labels[t], labels[t - 1])]
    assert all(t % 10 == 1 for t in broad_label_changes)  # T_r = 10 in the first broad phase


def test_literal_configuration_is_the_printed_equations():
    literal = get_optimizer("ihpso-literal")
    assert (literal.constriction, literal.stage2_sign) == (1.0, -1)
    assert get_optimizer("ihpso-noterm").terminate is False


@pytest.mark.parametrize(
    ("field", "value"),
    [("scheme", ("entropy", "kmeans")), ("scheme", "entropy"), ("switch_lag", 0), ("switch_weight", 0.0),
     ("jump_factor", -1.0), ("slope_atol", -1e-3), ("terminate", 1), ("linkage", "ward"), ("entropy_eps", 0.0),
     ("n_groups", 200)],
)
def test_invalid_hyper_parameters(field, value):
    with pytest.raises(ValueError, match=rf"IHPSO\.{field}: got .*expected"):
        IHPSO(**{field: value})
