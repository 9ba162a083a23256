"""The RL statistics (Agarwal et al. 2021) against values computed by hand from rliable's definitions."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats as scipy_stats

from uav_penetration_env.benchmark import rl_stats
from uav_penetration_env.benchmark.rl_stats import (
    interval_estimate,
    iqm_score,
    performance_profile,
    probability_of_improvement,
    stratified_bootstrap,
    stratified_resamples,
)

# --- IQM ---------------------------------------------------------------------------------------------


def test_iqm_pools_runs_and_tasks_before_trimming():
    # 4 runs x 2 tasks = 8 scores 1..7 and 100: drop the two lowest and two highest, mean(3, 4, 5, 6).
    scores = [[1, 2], [3, 4], [5, 6], [7, 100]]
    assert iqm_score(scores) == pytest.approx(4.5)
    # rliable's aggregate_iqm is trim_mean over the flattened matrix.
    assert iqm_score(scores) == pytest.approx(scipy_stats.trim_mean(np.ravel(scores), 0.25))


def test_iqm_of_one_task_is_the_trimmed_mean_of_its_runs():
    assert iqm_score([10.0, 20.0, 30.0, 40.0]) == pytest.approx(25.0)  # middle two of four


# --- the stratified bootstrap ------------------------------------------------------------------------


def test_resamples_never_mix_tasks():
    scores = np.array([[0.0, 100.0], [1.0, 101.0], [2.0, 102.0]])
    stack = stratified_resamples(scores, np.random.default_rng(0), 500)
    assert stack.shape == (500, 3, 2)
    assert set(np.unique(stack[:, :, 0])) <= {0.0, 1.0, 2.0}
    assert set(np.unique(stack[:, :, 1])) <= {100.0, 101.0, 102.0}


def test_bootstrap_distribution_of_the_mean_takes_only_stratified_values():
    # Task 0 runs {0, 1}, task 1 runs {10, 10}: a resampled task-0 mean is 0, 0.5 or 1 (probabilities
    # 1/4, 1/2, 1/4), task 1 always 10, so the mean over tasks is 5, 5.25 or 5.5. A bootstrap that
    # drew runs across tasks would put a 10 into task 0 and give other values.
    scores = np.array([[0.0, 10.0], [1.0, 10.0]])
    draws = stratified_bootstrap(scores, "mean", seed=1, n_resamples=4000)
    values, counts = np.unique(draws, return_counts=True)
    assert values.tolist() == [5.0, 5.25, 5.5]
    assert counts / counts.sum() == pytest.approx([0.25, 0.5, 0.25], abs=0.03)


def test_percentile_interval_of_two_runs_by_hand():
    # One task, runs {0, 1}: the resampled mean is 0, 0.5, 1 with probabilities 1/4, 1/2, 1/4.
    # The 30th and 70th percentiles both fall on 0.5 (P(0) = 0.25 < 0.3, P(<= 0.5) = 0.75 > 0.7).
    estimate = interval_estimate([0.0, 1.0], "mean", seed=2, n_resamples=4000, confidence=0.4)
    assert (estimate.value, estimate.low, estimate.high) == (0.5, 0.5, 0.5)
    wide = interval_estimate([0.0, 1.0], "mean", seed=2, n_resamples=4000, confidence=0.95)
    assert (wide.low, wide.high) == (0.0, 1.0)


def test_one_run_per_task_gives_a_degenerate_interval():
    estimate = interval_estimate([[3.0, 5.0, 9.0]], "iqm", seed=0)
    assert estimate.low == estimate.value == estimate.high


def test_interval_is_reproducible_and_contains_the_point():
    scores = np.random.default_rng(5).normal(20.0, 3.0, size=(5, 4))
    first = interval_estimate(scores, "iqm", seed=7, n_resamples=500)
    again = interval_estimate(scores, "iqm", seed=7, n_resamples=500)
    assert first == again
    assert first.low <= first.value <= first.high


def test_bad_inputs_name_the_argument():
    with pytest.raises(ValueError, match="scores: got non-finite"):
        iqm_score([1.0, np.nan])
    with pytest.raises(ValueError, match=r"scores: got shape \(0,\)"):
        iqm_score([])
    with pytest.raises(ValueError, match="statistic: got 'median'"):
        interval_estimate([1.0, 2.0], "median", seed=0)
    with pytest.raises(ValueError, match=r"confidence: got 1\.5"):
        interval_estimate([1.0, 2.0], seed=0, confidence=1.5)
    with pytest.raises(ValueError, match="x, y: got 2 and 1 tasks"):
        probability_of_improvement([[1.0, 2.0]], [[1.0]])


# --- performance profiles ------------------------------------------------------------------------------


def test_profile_of_costs_is_the_fraction_below_tau():
    # Costs 1, 2, 3, 4 (2 runs x 2 tasks): below 0.5 none, below 2.5 half, below 2 only the 1
    # (strict), below 10 all.
    profile = performance_profile([[1.0, 2.0], [3.0, 4.0]], [0.5, 2.0, 2.5, 10.0], seed=0, n_resamples=200)
    assert profile.fraction.tolist() == [0.0, 0.25, 0.5, 1.0]
    assert np.all(profile.low <= profile.fraction) and np.all(profile.fraction <= profile.high)
    # Taus outside the scores' range have no spread at all.
    assert (profile.low[0], profile.high[0], profile.low[-1], profile.high[-1]) == (0.0, 0.0, 1.0, 1.0)


def test_profile_higher_is_better_is_rliables_fraction_above_tau():
    scores = [[1.0, 2.0], [3.0, 4.0]]
    returns = performance_profile(scores, [2.0], higher_is_better=True, seed=0, n_resamples=10)
    assert returns.fraction.tolist() == [0.5]  # 3 and 4 are above 2 (strictly)
    # The cost profile at tau is rliable's profile of the negated scores at -tau.
    costs = performance_profile(scores, [3.0], seed=0, n_resamples=10)
    negated = performance_profile(-np.array(scores), [-3.0], higher_is_better=True, seed=0, n_resamples=10)
    assert costs.fraction.tolist() == negated.fraction.tolist() == [0.5]


# --- probability of improvement --------------------------------------------------------------------------


def test_probability_of_improvement_by_hand():
    # Costs x = {1, 2}, y = {2, 3}: pairs (1,2) win, (1,3) win, (2,2) tie = 1/2, (2,3) win -> 3.5 / 4.
    assert probability_of_improvement([1.0, 2.0], [2.0, 3.0]).value == pytest.approx(0.875)
    # The reverse direction is the complement.
    assert probability_of_improvement([2.0, 3.0], [1.0, 2.0]).value == pytest.approx(0.125)


def test_probability_of_improvement_is_mann_whitney_over_nm_averaged_over_tasks():
    rng = np.random.default_rng(3)
    x, y = rng.integers(0, 6, size=(5, 3)).astype(float), rng.integers(0, 6, size=(4, 3)).astype(float)
    # rliable: per task U / (n m) with scipy's U of "x greater" on returns; here returns = -costs.
    expected = np.mean([scipy_stats.mannwhitneyu(-x[:, t], -y[:, t]).statistic / (5 * 4) for t in range(3)])
    assert probability_of_improvement(x, y).value == pytest.approx(expected)
    assert probability_of_improvement(-x, -y, higher_is_better=True).value == pytest.approx(expected)


def test_probability_of_improvement_interval():
    x, y = [10.0, 11.0, 12.0], [20.0, 21.0]
    certain = probability_of_improvement(x, y, seed=0, n_resamples=300)
    assert (certain.value, certain.low, certain.high) == (1.0, 1.0, 1.0)  # every pair: x cheaper
    mixed = probability_of_improvement([1.0, 3.0, 5.0], [2.0, 4.0], seed=0, n_resamples=500)
    assert mixed.value == pytest.approx(0.5)  # 3 wins of 6
    assert 0.0 <= mixed.low < 0.5 < mixed.high <= 1.0
    assert probability_of_improvement([1.0, 3.0, 5.0], [2.0, 4.0], seed=0, n_resamples=500) == mixed


# --- the paired difference -------------------------------------------------------------------------------


def _difference_by_loop(x, y, seed, n):
    """The two-stage bootstrap of mean_difference, written as loops over the same draws."""
    rng_tasks, rng_x, rng_y = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(3))
    (rx, tasks), ry = x.shape, y.shape[0]
    drawn = rng_tasks.integers(0, tasks, size=(n, 1, tasks))
    runs_x = rng_x.integers(0, rx, size=(n, rx, tasks))
    runs_y = rng_y.integers(0, ry, size=(n, ry, tasks))
    values = []
    for k in range(n):
        per_task = []
        for j in range(tasks):
            t = drawn[k, 0, j]
            per_task.append(np.mean([x[i, t] for i in runs_x[k, :, j]]) - np.mean([y[i, t] for i in runs_y[k, :, j]]))
        values.append(np.mean(per_task))
    return np.percentile(values, [2.5, 97.5])


def test_mean_difference_by_hand_and_against_a_loop_over_the_same_draws():
    x = np.array([[1.0, 2.0, 3.0], [2.0, 3.0, 4.0]])  # task means 1.5, 2.5, 3.5
    y = np.array([[2.0, 2.0, 5.0]])  # 2, 2, 5: differences -0.5, 0.5, -1.5
    estimate = rl_stats.mean_difference(x, y, seed=np.random.SeedSequence(7), n_resamples=300)
    assert estimate.value == pytest.approx(-0.5)
    low, high = _difference_by_loop(x, y, 7, 300)
    assert (estimate.low, estimate.high) == (pytest.approx(low), pytest.approx(high))
    assert estimate.low <= estimate.value <= estimate.high


def test_mean_difference_intervals_for_one_task_one_run_and_a_clear_winner():
    one = rl_stats.mean_difference([[3.0]], [[5.0]], seed=0)
    assert (one.value, one.low, one.high) == (-2.0, -2.0, -2.0)
    shifted = np.array([[1.0, 4.0, 2.0]]), np.array([[2.0, 5.0, 3.0]])  # every task exactly 1 cheaper
    assert rl_stats.mean_difference(*shifted, seed=0) == rl_stats.Estimate(-1.0, -1.0, -1.0)
    rng = np.random.default_rng(3)
    cheaper = 10.0 + rng.normal(0.0, 0.3, size=(5, 50))  # five training seeds on fifty scenarios
    greedy = 12.0 + rng.normal(0.0, 0.3, size=(1, 50))
    estimate = rl_stats.mean_difference(cheaper, greedy, seed=1, n_resamples=2_000)
    assert estimate.high < 0.0 and estimate.value == pytest.approx(cheaper.mean() - greedy.mean())
    with pytest.raises(ValueError, match=r"x, y: got 50 and 3 tasks"):
        rl_stats.mean_difference(cheaper, np.ones((1, 3)), seed=0)
