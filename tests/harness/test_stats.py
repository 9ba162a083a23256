"""Leaderboard statistics against hand-computed numbers and scipy on the same data."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
import pytest
from scipy import stats as scipy_stats

from uav_penetration_env.benchmark.stats import (
    bootstrap_ci,
    friedman_ranks,
    holm,
    iqm,
    minimum_wilcoxon_pvalue,
    paired_difference_ci,
    wilcoxon_vs_reference,
    wilson_interval,
)


@pytest.fixture
def no_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        yield


# --- Wilson interval --------------------------------------------------------------------------------


def test_wilson_interval_of_3_of_4_is_the_closed_form():
    successes, n = 3, 4
    z = scipy_stats.norm.ppf(0.975)
    p = successes / n
    centre = (p + z**2 / (2 * n)) / (1 + z**2 / n)
    half = z / (1 + z**2 / n) * math.sqrt(p * (1 - p) / n + z**2 / (4 * n**2))
    low, high = wilson_interval(successes, n)
    assert low == pytest.approx(centre - half, abs=1e-12)
    assert high == pytest.approx(centre + half, abs=1e-12)
    assert low == pytest.approx(0.3006418, abs=1e-6)


def test_wilson_interval_edges():
    assert wilson_interval(0, 5)[0] == 0.0
    assert wilson_interval(5, 5)[1] == pytest.approx(1.0)
    assert all(math.isnan(v) for v in wilson_interval(0, 0))
    with pytest.raises(ValueError, match="successes"):
        wilson_interval(5, 4)


# --- IQM and bootstrap --------------------------------------------------------------------------------


def test_iqm_by_hand():
    # 8 values: drop the 2 smallest and the 2 largest, mean of 3, 4, 5, 6 = 4.5 (the outlier 100 is gone).
    assert iqm([100, 1, 2, 3, 4, 5, 6, 7]) == pytest.approx(4.5)
    assert iqm([[1, 2], [3, 100]], axis=None) == pytest.approx(2.5)
    assert np.allclose(iqm(np.array([[1, 2, 3, 4], [10, 20, 30, 40]]), axis=1), [2.5, 25.0])
    assert math.isnan(iqm([]))


def test_bootstrap_ci_contains_the_sample_statistic_and_is_reproducible(no_warnings):
    values = np.array([3.0, 5.0, 4.0, 9.0, 6.0, 5.5, 4.5, 30.0])
    low, high = bootstrap_ci(values, np.mean, seed=1, n_resamples=2000)
    assert low < values.mean() < high
    assert bootstrap_ci(values, np.mean, seed=1, n_resamples=2000) == (low, high)
    assert bootstrap_ci(values, np.mean, seed=2, n_resamples=2000) != (low, high)
    iqm_low, iqm_high = bootstrap_ci(values, iqm, seed=1, n_resamples=2000)
    assert iqm_low <= iqm(values) <= iqm_high
    # A statistic without an `axis` parameter works too (one call per resample).
    assert bootstrap_ci(values, lambda x: float(np.median(x)), seed=1, n_resamples=200)[0] <= np.median(
        values
    )


def test_bootstrap_ci_is_the_percentile_interval_of_scipy():
    values = np.array([1.0, 2.0, 4.0, 8.0, 16.0])
    expected = scipy_stats.bootstrap(
        (values,), np.mean, n_resamples=999, method="percentile", rng=np.random.default_rng(7)
    ).confidence_interval
    assert bootstrap_ci(values, np.mean, seed=7, n_resamples=999) == (expected.low, expected.high)


def test_bootstrap_ci_degenerate_inputs_do_not_warn(no_warnings):
    assert all(math.isnan(v) for v in bootstrap_ci([4.2], np.mean, seed=0))
    assert all(math.isnan(v) for v in bootstrap_ci([], np.mean, seed=0))
    assert bootstrap_ci([2.0, 2.0, 2.0], np.mean, seed=0) == (2.0, 2.0)
    assert bootstrap_ci([2.0, 2.0, 2.0, 2.0, 2.0], iqm, seed=0) == (2.0, 2.0)
    # Mostly ties (BCa would give NaN and warn here; the percentile interval is defined).
    low, high = bootstrap_ci([1.0, 1.0, 1.0, 1.0, 2.0], iqm, seed=0, n_resamples=500)
    assert 1.0 <= low <= high <= 2.0
    with pytest.raises(ValueError, match="non-finite"):
        bootstrap_ci([1.0, np.nan], np.mean, seed=0)


def test_paired_difference_ci(no_warnings):
    b = np.array([10.0, 20.0, 30.0, 40.0, 50.0])
    assert paired_difference_ci(b + 1.5, b, seed=0) == (1.5, 1.5)  # a constant shift: no uncertainty
    a = b + np.array([1.0, -0.5, 2.0, 0.5, 1.0])
    low, high = paired_difference_ci(a, b, seed=0, n_resamples=2000)
    assert low < 0.8 < high  # the mean difference
    assert high - low < 3.0  # pairing removes the 10..50 spread between seeds
    with pytest.raises(ValueError, match="paired"):
        paired_difference_ci([1.0, 2.0], [1.0], seed=0)


# --- Friedman -----------------------------------------------------------------------------------------


def test_friedman_ranks_by_hand_with_ties(no_warnings):
    table = pd.DataFrame(
        {"a": [1.0, 2.0, 5.0, 9.0], "b": [2.0, 2.0, 3.0, np.nan], "c": [3.0, 1.0, 4.0, 1.0]},
        index=pd.Index([0, 1, 2, 3], name="seed"),
    )
    result = friedman_ranks(table)
    # Seed 3 is incomplete and left out. Ranks per seed: (1, 2, 3), (2.5, 2.5, 1), (3, 1, 2).
    assert result.blocks == 3
    assert result.ranks["a"] == pytest.approx(6.5 / 3)
    assert result.ranks["b"] == pytest.approx(5.5 / 3)
    assert result.ranks["c"] == pytest.approx(2.0)
    expected = scipy_stats.friedmanchisquare([1, 2, 5], [2, 2, 3], [3, 1, 4])
    assert result.statistic == pytest.approx(expected.statistic)
    assert result.pvalue == pytest.approx(expected.pvalue)


def test_friedman_same_order_on_every_seed():
    # k = 4 policies, n = 8 seeds, the same order each time: chi2 = 12/(n k (k+1)) sum R^2 - 3 n (k+1) = 24.
    seeds = np.arange(8.0)
    table = pd.DataFrame({"w": 20 + seeds, "x": 8 + seeds, "y": 10 + seeds, "z": 12 + seeds})
    result = friedman_ranks(table)
    assert result.ranks.tolist() == [4.0, 1.0, 2.0, 3.0]
    assert result.statistic == pytest.approx(24.0)
    assert result.pvalue == pytest.approx(scipy_stats.chi2.sf(24.0, 3))


def test_friedman_small_designs_and_all_ties(no_warnings):
    two = friedman_ranks(pd.DataFrame({"a": [1.0, 2.0], "b": [2.0, 1.0]}))
    assert two.statistic is None and two.pvalue is None
    assert two.ranks.tolist() == [1.5, 1.5]
    one_block = friedman_ranks(pd.DataFrame({"a": [1.0], "b": [2.0], "c": [3.0]}))
    assert one_block.statistic is None and one_block.ranks.tolist() == [1.0, 2.0, 3.0]
    tied = friedman_ranks(pd.DataFrame({"a": [1.0, 1.0], "b": [1.0, 1.0], "c": [1.0, 1.0]}))
    assert (tied.statistic, tied.pvalue) == (0.0, 1.0)
    # A policy that never finished does not empty the design; it gets no rank.
    absent = friedman_ranks(pd.DataFrame({"a": [1.0, 2.0], "b": [2.0, 1.0], "gone": [np.nan, np.nan]}))
    assert absent.blocks == 2 and math.isnan(absent.ranks["gone"])
    empty = friedman_ranks(pd.DataFrame({"a": [1.0, np.nan], "b": [np.nan, 1.0]}))
    assert empty.blocks == 0 and empty.ranks.isna().all()


# --- Holm and Wilcoxon ---------------------------------------------------------------------------------


def test_holm_by_hand():
    # Sorted 0.01, 0.03, 0.04 -> 3 x 0.01, 2 x 0.03, max(0.06, 1 x 0.04): back in input order.
    assert np.allclose(holm([0.01, 0.04, 0.03]), [0.03, 0.06, 0.06])
    assert np.allclose(holm([0.5, 0.6]), [1.0, 1.0])  # capped at 1
    adjusted = holm([0.01, np.nan, 0.04])  # NaN: no test, not counted in the family
    assert np.allclose(adjusted[[0, 2]], [0.02, 0.04]) and math.isnan(adjusted[1])
    assert holm([]).size == 0
    raw = np.array([0.2, 0.001, 0.04, 0.03, 0.5])
    adjusted = holm(raw)
    order = np.argsort(raw)
    assert np.all(np.diff(adjusted[order]) >= 0) and np.all(adjusted >= raw)


def test_wilcoxon_vs_reference_equals_scipy(no_warnings):
    ref = np.array([10.0, 12.0, 9.0, 14.0, 11.0, 13.0, 10.5])
    other = ref + np.array([1.0, 2.5, -0.5, 3.0, 0.7, 1.6, 2.2])
    table = pd.DataFrame({"ref": ref, "other": other, "same": ref.copy(), "worse": ref + 5.0})
    table.loc[6, "worse"] = np.nan  # pairwise complete: 6 pairs for `worse`
    result = wilcoxon_vs_reference(table, "ref")
    assert list(result.index) == ["other", "same", "worse"]
    expected = scipy_stats.wilcoxon(other, ref)
    assert result.loc["other", "pvalue"] == pytest.approx(expected.pvalue)
    assert result.loc["other", "statistic"] == pytest.approx(expected.statistic)
    assert result.loc["other", "median_difference"] == pytest.approx(1.6)
    assert result.loc["same", "pvalue"] == 1.0  # all differences zero: no warning, p = 1
    assert result.loc["worse", "n_pairs"] == 6
    assert result.loc["worse", "pvalue"] == pytest.approx(2 / 2**6)  # exact: every difference positive
    assert np.allclose(result["pvalue_holm"], holm(result["pvalue"]))
    with pytest.raises(KeyError, match="reference"):
        wilcoxon_vs_reference(table, "nope")


def test_minimum_wilcoxon_pvalue():
    assert minimum_wilcoxon_pvalue(4) == 0.125
    assert minimum_wilcoxon_pvalue(6) == pytest.approx(0.03125)
    assert minimum_wilcoxon_pvalue(0) == 1.0


def test_minimum_wilcoxon_pvalue_of_1024_pairs_or_more_underflows_instead_of_raising():
    # 2.0 ** 1024 overflows a float; the floor 2 / 2^n is exact down to 2^-1074 and 0.0 below.
    assert minimum_wilcoxon_pvalue(1024) == 2.0**-1023
    assert minimum_wilcoxon_pvalue(1075) == 2.0**-1074
    assert minimum_wilcoxon_pvalue(1100) == 0.0
    assert minimum_wilcoxon_pvalue(10**20) == 0.0
