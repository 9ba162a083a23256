"""IHPSO's mechanisms on realistic swarms, and the 2022v0 configuration (optimizers.md §5).

The termination test (eq. 33, D19) must fail on a swarm split into separated clumps and pass on a single
cloud; the grouping (D13, D14) must keep clumps whole; the fitness level (D16) must follow the leading
particles, not crash escapes; the switch (eqs. 27-28) fires at any local peak of the slope. The 1 000-draw
versions of the swarm tests are marked slow; the default run uses 200 draws with the same thresholds.
"""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.distance import pdist

import optimizers.ihpso as ihpso_module
from optimizers import get_optimizer
from optimizers.ihpso import IHPSO, fitness_level, front_size, switch_condition, switch_due
from optimizers.ihpso_2022v0 import IHPSO_2022V0
from optimizers.ihpso_grouping import (
    dendrogram_groups,
    group_rms_distances,
    spread_threshold,
    termination_spreads,
    termination_test,
)
from tests.golden import golden_cases
from tests.optimizers import swarms as study  # the swarm generators the retired study script's table used

clump_centres, clumps, cloud = study.clump_centres, study.clumps, study.cloud
N, G = study.SWARM_SIZE, study.N_GROUPS
BOUNDS = [(-5.0, 5.0)] * 10


def sphere(x):
    return ((x - 1.5) ** 2).sum(axis=1)


# ----------------------------------------------------------------------------------------------
# Realistic swarms: 100 particles, 3-D and 15-D
# ----------------------------------------------------------------------------------------------


CLUMP_SIZES = [(50, 50), (70, 30), (34, 33, 33), (50, 30, 20), (60, 30, 10)]


def pass_rate(make, draws: int, seed: int) -> float:
    return study.termination_pass_rate(make, draws, seed)


def check_clumps_fail(sizes, dim, draws):
    rate = pass_rate(lambda rng: clumps(sizes, dim, rng), draws, seed=1000 + dim)
    assert 1.0 - rate >= 0.9, f"{sizes} in {dim}-D: the test failed in only {1 - rate:.1%} of {draws} draws"


def check_cloud_passes(kind, dim, draws):
    rate = pass_rate(lambda rng: cloud(kind, dim, rng), draws, seed=2000 + dim)
    assert rate >= 0.5, f"{kind} cloud in {dim}-D: the test passed in only {rate:.1%} of {draws} draws"


@pytest.mark.parametrize("dim", [3, 15])
@pytest.mark.parametrize("sizes", CLUMP_SIZES, ids=["-".join(map(str, s)) for s in CLUMP_SIZES])
def test_termination_fails_on_separated_clumps(sizes, dim):
    check_clumps_fail(sizes, dim, draws=200)


@pytest.mark.parametrize("dim", [3, 15])
@pytest.mark.parametrize("kind", ["uniform", "gaussian"])
def test_termination_passes_on_a_single_cloud(kind, dim):
    check_cloud_passes(kind, dim, draws=200)


@pytest.mark.slow
@pytest.mark.parametrize("dim", [3, 15])
@pytest.mark.parametrize("sizes", CLUMP_SIZES, ids=["-".join(map(str, s)) for s in CLUMP_SIZES])
def test_termination_fails_on_separated_clumps_1000_draws(sizes, dim):
    check_clumps_fail(sizes, dim, draws=1000)


@pytest.mark.slow
@pytest.mark.parametrize("dim", [3, 15])
@pytest.mark.parametrize("kind", ["uniform", "gaussian"])
def test_termination_passes_on_a_single_cloud_1000_draws(kind, dim):
    check_cloud_passes(kind, dim, draws=1000)


@pytest.mark.parametrize("dim", [3, 15])
def test_2022v0_termination_passes_on_two_clumps(dim):
    """The reading measured on MPC windows (optimizers.md §5.6): equal-size blocks and sums pass on two separated clumps of 50."""
    rng = np.random.default_rng(3)
    old = [
        termination_test(clumps((50, 50), dim, rng), G, method="average", cut="equal", spread="sum")
        for _ in range(100)
    ]
    assert np.mean(old) >= 0.5


@pytest.mark.parametrize("dim", [3, 15])
@pytest.mark.parametrize("sizes", [(70, 30), (50, 30, 20), (60, 30, 10)])
def test_cluster_grouping_keeps_clumps_whole(sizes, dim):
    """G = number of clumps: the clusters are the clumps, whatever their sizes; G = 5: no group straddles.

    At 10 standard deviations a 15-D clump's diameter can exceed the closest cross-clump distance, so
    complete linkage may, rarely, cut along the geometry (0.5 % of draws in a 200-draw check); the equal
    cut of 2022v0 splits every unequal clump by construction.
    """
    rng = np.random.default_rng(4)
    exact, whole, draws = 0, 0, 100
    for _ in range(draws):
        clump_of = np.repeat(np.arange(len(sizes)), sizes)
        points = clump_centres(len(sizes), dim, rng)[clump_of] + rng.normal(size=(N, dim))
        labels = dendrogram_groups(points, len(sizes), inverse=False)
        exact += {frozenset(np.flatnonzero(labels == g)) for g in range(len(sizes))} == {
            frozenset(np.flatnonzero(clump_of == c)) for c in range(len(sizes))
        }
        labels = dendrogram_groups(points, G, inverse=False)
        whole += all(np.unique(clump_of[labels == g]).size == 1 for g in np.unique(labels))
        equal = dendrogram_groups(points, len(sizes), inverse=False, cut="equal", method="average")
        assert sorted(np.bincount(equal).tolist()) != sorted(sizes)  # 2022v0: sizes forced equal
    assert exact / draws >= 0.97 and whole / draws >= 0.97


def test_cluster_grouping_recovers_strictly_separated_clumps_exactly():
    """When every within-clump distance is below every cross-clump one, complete linkage must find the clumps."""
    rng = np.random.default_rng(8)
    sizes = (60, 30, 10)
    clump_of = np.repeat(np.arange(3), sizes)
    for dim in (3, 15):
        points = 4.0 * clump_centres(3, dim, rng)[clump_of] + rng.normal(size=(N, dim))  # 40 sd apart
        labels = dendrogram_groups(points, 3, inverse=False)
        assert {frozenset(np.flatnonzero(labels == g)) for g in range(3)} == {
            frozenset(np.flatnonzero(clump_of == c)) for c in range(3)
        }


@pytest.mark.parametrize("dim", [3, 15])
def test_entropy_grouping_spans_clumps(dim):
    """Far particles together: the entropy groups with a pair mostly hold members of both clumps."""
    rng = np.random.default_rng(5)
    mixed, total = 0, 0
    for _ in range(20):
        centres = clump_centres(2, dim, rng)
        clump_of = np.repeat([0, 1], 50)
        points = centres[clump_of] + rng.normal(size=(N, dim))
        labels = dendrogram_groups(points, G, inverse=True)
        for g in np.unique(labels):
            members = clump_of[labels == g]
            if members.size >= 2:
                total += 1
                mixed += np.unique(members).size == 2
    assert mixed / total >= 0.9


def within_group_rms_distances(U, labels):
    """Oracle: eq. 30 as read in D19, the root-mean-square distance over each group's pairs, one pair at a time."""
    U, labels = np.asarray(U, dtype=float), np.asarray(labels)
    squares, pairs = np.zeros(labels.max() + 1), np.zeros(labels.max() + 1)
    for i, j in itertools.combinations(range(len(U)), 2):
        if labels[i] == labels[j]:
            squares[labels[i]] += math.dist(U[i], U[j]) ** 2
            pairs[labels[i]] += 1
    return np.array([math.sqrt(s / p) if p else math.nan for s, p in zip(squares, pairs, strict=True)])


def test_group_rms_distances_and_groups_of_one():
    points, labels = [(0, 0), (3, 0), (0, 4), (9, 9)], np.array([0, 0, 0, 1])
    rms = within_group_rms_distances(points, labels)
    assert rms[0] == pytest.approx(math.sqrt((9 + 16 + 25) / 3)) and math.isnan(rms[1])
    assert group_rms_distances(pdist(points), labels) == pytest.approx(rms, nan_ok=True)
    U = np.random.default_rng(9).random((40, 6))
    labels = np.random.default_rng(10).integers(0, 5, size=40)
    assert group_rms_distances(pdist(U), labels) == pytest.approx(within_group_rms_distances(U, labels))
    # A group of one is left out of eqs. 31-32; with N == G no group has a pair and the test fails.
    assert all(math.isnan(v) for v in termination_spreads(np.eye(3), 3))
    assert termination_test(np.eye(3), 3) is False


def test_spread_threshold_is_the_linear_size_of_one_group_in_volume():
    assert spread_threshold(5, 3) == pytest.approx(5 ** (1 / 3))
    assert spread_threshold(5, 15) == pytest.approx(1.1133, abs=1e-4)
    assert spread_threshold(1, 15) == 1.0


# ----------------------------------------------------------------------------------------------
# Eq. 29's fitness level on mixed penalty and finite costs (D16)
# ----------------------------------------------------------------------------------------------


def test_front_level_ignores_crash_escapes_and_follows_the_leaders():
    rng = np.random.default_rng(6)
    costs = np.full(N, 150.0)  # 70 particles still crash (penalty cost)
    costs[:30] = 4.0 + rng.random(30)
    front = front_size(N, G)
    assert front == 20
    level = fitness_level(costs, front)
    assert level == pytest.approx(np.sort(costs)[:20].mean())
    assert np.median(costs) == 150.0  # a median is the penalty while more than half crash
    escaped = costs.copy()
    escaped[50] = 10.0  # one particle leaves the crash region, still worse than every leader
    assert fitness_level(escaped, front) == level
    assert fitness_level(escaped) == pytest.approx(fitness_level(costs) - 140.0 / N)  # 2022v0 moves by 1.4
    improved = costs.copy()
    improved[int(np.argmin(costs))] -= 1.0  # a leader improves
    assert fitness_level(improved, front) == pytest.approx(level - 1.0 / 20)
    # Fewer finite costs than the front: the mean of the finite ones; none: undefined.
    few = np.full(N, math.inf)
    few[:3] = [1.0, 2.0, 6.0]
    assert fitness_level(few, front) == 3.0
    assert fitness_level(np.full(N, math.inf), front) is None


def test_configuration_level_reading():
    costs = np.concatenate([np.arange(1.0, 21.0), np.full(80, 150.0)])
    assert IHPSO().fitness_level(costs) == pytest.approx(10.5)
    assert get_optimizer("ihpso-2022v0").fitness_level(costs) == pytest.approx(costs.mean())


# ----------------------------------------------------------------------------------------------
# Eqs. 27-28: switch timing
# ----------------------------------------------------------------------------------------------


def test_geometric_slope_decay_never_switches():
    """k_t = k_0 q^t: the relative decrease is constant, so eq. 27 needs ω > 1; with ω = 0.8 it never holds."""
    for q in (0.5, 0.9, 0.99):
        slopes = [math.inf, *(q**t for t in range(1, 60))]
        assert not any(switch_due(slopes, t, 0, 1, 0.8, 3.0) for t in range(3, 60))


def test_a_noisy_slope_switches_at_its_first_local_peak():
    """With j = 1 every local peak k_{t-1} > k_{t-2}, k_t < k_{t-1} satisfies eq. 27 (and 28' for α >= 1).

    So a noisy level switches at the first peak at the latest: at t = 3 whenever k_2 > k_1 and k_3 < k_2.
    """
    rng = np.random.default_rng(7)
    at_three = 0
    for _ in range(500):
        t_all = np.arange(1, 40)
        slopes = [math.inf, *(0.95**t_all * np.exp(0.5 * rng.normal(size=t_all.size)))]
        first_switch = next((t for t in range(3, 40) if switch_due(slopes, t, 0, 1, 0.8, 3.0)), None)
        first_peak = next(t for t in range(3, 40) if slopes[t - 2] < slopes[t - 1] > slopes[t])
        assert first_switch is not None and first_switch <= first_peak
        at_three += first_switch == 3
    assert at_three / 500 > 0.3  # the earliest allowed iteration is common under noise
    assert switch_condition(0.0, 1.0, 0.5, 0.8, 3.0)  # a zero slope before a peak also switches


def test_first_switch_is_never_before_2j_plus_1():
    for lag in (1, 2):
        res = IHPSO(switch_lag=lag).minimize(sphere, BOUNDS, rng=0, max_evals=5_000)
        assert not res.trace["switch_iterations"] or res.trace["switch_iterations"][0] >= 2 * lag + 1


# ----------------------------------------------------------------------------------------------
# Ablations and trace
# ----------------------------------------------------------------------------------------------


def test_noswitch_stays_in_broad_search():
    res = get_optimizer("ihpso-noswitch").minimize(sphere, BOUNDS, rng=0, max_evals=3_000)
    assert set(res.trace["mode"]) == {"broad"} and res.trace["switch_iterations"] == ()
    assert res.trace["termination_tests"] == () and res.nfev == 3_000


def test_noreverse_stays_in_accurate_search(monkeypatch):
    """Scripted: switch after 3, zero slopes from 5 on, eq. 33 false twice then true."""
    zero = iter([False] + [True] * 100)
    converged = iter([False, False, True])
    monkeypatch.setattr(ihpso_module, "switch_due", lambda slopes, t, *args: t == 3)
    monkeypatch.setattr(ihpso_module, "slope_is_zero", lambda *args: next(zero))
    monkeypatch.setattr(ihpso_module, "spreads_converge", lambda *args: next(converged))
    res = get_optimizer("ihpso-noreverse").minimize(sphere, BOUNDS, rng=0, max_evals=5_000)
    assert res.trace["mode"] == ("broad",) * 3 + ("accurate",) * 4
    assert res.trace["reverse_switch_iterations"] == ()
    assert res.trace["termination_tests"] == ((5, False), (6, False), (7, True))
    assert res.trace["stopped_by"] == "termination" and res.nit == 7


@pytest.mark.parametrize("name", ["ihpso", "ihpso-2022v0"])
def test_trace_spreads_agree_with_the_tests(name):
    res = get_optimizer(name).minimize(sphere, BOUNDS, rng=1, max_evals=30_000)
    tests, spreads = res.trace["termination_tests"], res.trace["termination_spreads"]
    assert len(tests) == len(spreads) >= 1
    for (t, passed), (t_spread, entropy_min, cluster_max) in zip(tests, spreads, strict=True):
        assert t == t_spread and passed == (entropy_min <= cluster_max)
    assert len(res.trace["levels"]) == res.nit + 1
    levels = [v for v in res.trace["levels"] if v is not None]
    assert all(b <= a for a, b in itertools.pairwise(levels))  # pbests never worsen, so neither does J


def test_ablations_are_registered_with_their_overrides():
    assert get_optimizer("ihpso-noswitch") == IHPSO(switch=False)
    assert get_optimizer("ihpso-noreverse") == IHPSO(reverse_switch=False)
    assert get_optimizer("ihpso-2022v0") == IHPSO(**IHPSO_2022V0)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("grouping_cut", "blocks"),
        ("spread", "mean"),
        ("level", "median"),
        ("switch", 1),
        ("reverse_switch", None),
    ],
)
def test_invalid_new_hyper_parameters(field, value):
    with pytest.raises(ValueError, match=rf"IHPSO\.{field}: got .*expected"):
        IHPSO(**{field: value})


# ----------------------------------------------------------------------------------------------
# ihpso-2022v0 is the pre-issue-11 ihpso, bit for bit
# ----------------------------------------------------------------------------------------------

# A snapshot of the ihpso keys of tests/golden/*.json as they were before IHPSO's mechanisms were re-read (copied, not edited):
# the golden files themselves will be regenerated for the new ihpso, and this test must keep the old one.
SNAPSHOT = json.loads((Path(__file__).parent / "data" / "ihpso_2022v0_golden.json").read_text())


def test_the_snapshot_holds_the_ihpso_cases():
    assert len(SNAPSHOT["optimizers"]) == 6 and len(SNAPSHOT["planners"]) == 4


@pytest.mark.parametrize("key", sorted(SNAPSHOT["optimizers"]))
def test_ihpso_2022v0_reproduces_the_golden_ihpso(key):
    _, function, seed = key.split("/")
    assert golden_cases.optimizer_case("ihpso-2022v0", function, int(seed)) == SNAPSHOT["optimizers"][key]


@pytest.mark.parametrize(
    ("name", "key"),
    [
        ("ihpso-2022v0", "ihpso/0"),
        pytest.param("ihpso-2022v0", "ihpso/1", marks=pytest.mark.slow),
        pytest.param("ihpso-2022v0-eq37", "ihpso-eq37/0", marks=pytest.mark.slow),
        pytest.param("ihpso-2022v0-eq37", "ihpso-eq37/1", marks=pytest.mark.slow),
    ],
)
def test_ihpso_2022v0_reproduces_the_golden_ihpso_planner(name, key):
    """The paper-scenario MPC episodes of the old ``ihpso`` planner.

    The snapshot was taken with the numpy model; the compiled model reproduces it
    exactly apart from the last bits of the cost sums (numpy's SIMD transcendental functions and
    the C maths library differ in the last digit), so the totals are compared to 1e-15 relative
    and everything else (outcome, steps, evaluations, final position) exactly.
    """
    case = golden_cases.planner_case(name, int(key.split("/")[1]))
    expected = SNAPSHOT["planners"][key]
    totals = ("total_J", "total_cost")
    assert {k: v for k, v in case.items() if k not in totals} == {
        k: v for k, v in expected.items() if k not in totals
    }
    for total in totals:
        assert float.fromhex(case[total]) == pytest.approx(float.fromhex(expected[total]), rel=1e-15, abs=0)
