"""Statistics for leaderboards: interval estimates and paired tests over seeds (api.md, harness).

Pure functions over arrays and DataFrames, built on :mod:`scipy.stats`; nothing here knows about
UAVs. Episodes are paired across policies by seed (``evaluate`` gives every policy the same start
for a seed), so a seeds x policies table is a randomised complete block design: Friedman's test
and average ranks over the blocks, Wilcoxon signed-rank tests of each policy against a reference
with Holm's step-down correction, and bootstrap intervals of means and interquartile means
(Agarwal et al. 2021, "Deep RL at the edge of the statistical precipice", for IQM and intervals
over few seeds).

DECISION: bootstrap intervals are *percentile* intervals, not BCa. With the 5-20 seeds a benchmark
runs, BCa's jackknife acceleration is itself noisy, and it is undefined when the jackknife
values coincide (an IQM of ``[1, 1, 1, 1, 2]`` gives NaN and a warning), which happens often with
ties and crash penalties. The percentile interval is always defined, respects monotone
transformations and is what ``rliable`` reports for IQM.
"""

from __future__ import annotations

import hashlib
import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from scipy import stats

RNGLike = int | np.random.SeedSequence | np.random.Generator
Statistic = Callable[..., float | np.ndarray]


def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a success proportion (scipy's ``binomtest(...).proportion_ci``).

    Args:
        successes: number of successes, 0 <= successes <= n.
        n: number of trials.
        confidence: confidence level in (0, 1).

    Returns:
        (low, high); (NaN, NaN) when ``n == 0``.

    Raises:
        ValueError: ``successes`` outside [0, n].
    """
    successes, n = int(successes), int(n)
    if n == 0:
        return (float("nan"), float("nan"))
    if not 0 <= successes <= n:
        raise ValueError(f"successes: got {successes}, expected 0 <= successes <= n={n}")
    interval = stats.binomtest(successes, n).proportion_ci(confidence_level=confidence, method="wilson")
    return (float(interval.low), float(interval.high))


def iqm(values: ArrayLike, *, axis: int | None = None) -> float | np.ndarray:
    """Interquartile mean: the mean of the middle 50 % (``scipy.stats.trim_mean(x, 0.25)``).

    Args:
        values: the sample (any shape).
        axis: axis to reduce (None: all values), so :func:`scipy.stats.bootstrap` can vectorise it.

    Returns:
        The IQM (NaN for an empty sample).
    """
    x = np.asarray(values, dtype=np.float64)
    if x.size == 0:
        return float("nan")
    result = stats.trim_mean(x, 0.25, axis=axis)
    return float(result) if np.ndim(result) == 0 else result


def _finite_sample(values: ArrayLike, name: str) -> np.ndarray:
    x = np.asarray(values, dtype=np.float64).ravel()
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name}: got non-finite values {x[~np.isfinite(x)][:3]}, expected finite numbers")
    return x


def _vectorised(statistic: Statistic) -> bool:
    try:
        return "axis" in inspect.signature(statistic).parameters
    except (TypeError, ValueError):  # some numpy ufunc-likes have no signature
        return False


def bootstrap_ci(
    values: ArrayLike,
    statistic: Statistic = np.mean,
    *,
    seed: RNGLike,
    n_resamples: int = 10_000,
    confidence: float = 0.95,
) -> tuple[float, float]:
    """Percentile bootstrap interval of ``statistic(values)`` (module docstring: why percentile).

    Args:
        values: 1-D sample of finite numbers.
        statistic: a function of the sample; if it takes ``axis`` (``np.mean``, :func:`iqm`), the
            resamples are evaluated in one vectorised call.
        seed: anything :func:`numpy.random.default_rng` accepts; the same seed gives the same interval.
        n_resamples: bootstrap resamples.
        confidence: confidence level in (0, 1).

    Returns:
        (low, high). A sample of fewer than two values gives (NaN, NaN); a sample whose values are
        all equal gives the degenerate interval (v, v). Neither case warns.

    Raises:
        ValueError: non-finite values.
    """
    x = _finite_sample(values, "values")
    if x.size < 2:
        return (float("nan"), float("nan"))
    if np.all(x == x[0]):
        # Every resample is the sample itself; scipy would compute the same point, at a cost.
        point = float(statistic(x))
        return (point, point)
    result = stats.bootstrap(
        (x,),
        statistic,
        n_resamples=int(n_resamples),
        vectorized=_vectorised(statistic),
        confidence_level=confidence,
        method="percentile",
        rng=np.random.default_rng(seed),
    )
    return (float(result.confidence_interval.low), float(result.confidence_interval.high))


def paired_difference_ci(
    a: ArrayLike,
    b: ArrayLike,
    *,
    seed: RNGLike,
    n_resamples: int = 10_000,
    confidence: float = 0.95,
) -> tuple[float, float]:
    """Bootstrap interval of mean(a - b) over paired observations (the same seeds, in the same order).

    Resampling the differences keeps each pair together, so the seed-to-seed variation that both
    policies share cancels.

    Args:
        a: 1-D sample, e.g. one policy's costs per seed.
        b: 1-D sample of the same length, the other policy's costs for the same seeds.
        seed: anything :func:`numpy.random.default_rng` accepts.
        n_resamples: bootstrap resamples.
        confidence: confidence level in (0, 1).

    Returns:
        (low, high) as :func:`bootstrap_ci` of the differences.

    Raises:
        ValueError: different lengths or non-finite values.
    """
    x, y = _finite_sample(a, "a"), _finite_sample(b, "b")
    if x.shape != y.shape:
        raise ValueError(f"a, b: got lengths {x.size} and {y.size}, expected paired samples of one length")
    return bootstrap_ci(x - y, np.mean, seed=seed, n_resamples=n_resamples, confidence=confidence)


@dataclass(frozen=True)
class FriedmanResult:
    """Average ranks over complete blocks and Friedman's chi-square test.

    Attributes:
        ranks: average rank per policy (1 = lowest cost, ties share the mean rank), indexed like the
            table's columns; NaN for a policy with no observation at all.
        statistic: Friedman's chi-square, None with fewer than 3 policies or 2 blocks.
        pvalue: its p-value, None likewise.
        blocks: number of complete blocks (seeds) used.
    """

    ranks: pd.Series
    statistic: float | None
    pvalue: float | None
    blocks: int


def friedman_ranks(table: pd.DataFrame) -> FriedmanResult:
    """Average ranks and Friedman's test for a seeds x policies table of costs.

    Only complete blocks (rows where every policy has a value) enter; a policy with no value in
    any row is left out first, so one policy that never ran does not empty the design.

    Args:
        table: rows = blocks (seeds), columns = policies, values = costs (lower is better), NaN = missing.

    Returns:
        A :class:`FriedmanResult`.
    """
    present = [c for c in table.columns if table[c].notna().any()]
    complete = table[present].dropna(axis=0, how="any")
    ranks = pd.Series(np.nan, index=table.columns, dtype=np.float64)
    blocks = len(complete)
    if blocks == 0 or not present:
        return FriedmanResult(ranks, None, None, 0)
    values = complete.to_numpy(dtype=np.float64)
    ranks[present] = stats.rankdata(values, method="average", axis=1).mean(axis=0)
    if len(present) < 3 or blocks < 2:
        return FriedmanResult(ranks, None, None, blocks)
    if np.all(values == values[:, :1]):
        # Every block is one big tie: no evidence of any difference (scipy would divide 0 by 0).
        return FriedmanResult(ranks, 0.0, 1.0, blocks)
    result = stats.friedmanchisquare(*values.T)
    return FriedmanResult(ranks, float(result.statistic), float(result.pvalue), blocks)


def holm(pvalues: ArrayLike) -> np.ndarray:
    """Holm-Bonferroni step-down adjusted p-values (monotone in the raw order, capped at 1).

    NaN entries (tests that could not be run) are kept as NaN and do not count in the family size.

    Args:
        pvalues: raw p-values, any order.

    Returns:
        Adjusted p-values in the input order.
    """
    p = np.asarray(pvalues, dtype=np.float64).ravel()
    adjusted = np.full_like(p, np.nan)
    finite = np.flatnonzero(~np.isnan(p))
    order = finite[np.argsort(p[finite], kind="stable")]
    m = order.size
    scaled = (m - np.arange(m)) * p[order]  # the i-th smallest times (m - i + 1)
    adjusted[order] = np.minimum(np.maximum.accumulate(scaled), 1.0)
    return adjusted


def wilcoxon_vs_reference(table: pd.DataFrame, reference: str) -> pd.DataFrame:
    """Two-sided Wilcoxon signed-rank test of every other policy against ``reference``, Holm-corrected.

    Each comparison uses the seeds where both policies have a value (pairwise complete).

    Args:
        table: rows = seeds, columns = policies, values = costs, NaN = missing.
        reference: the column every other column is compared with.

    Returns:
        One row per other policy (columns' order), indexed by policy: ``n_pairs``,
        ``median_difference`` (other - reference; positive = costlier than the reference),
        ``statistic``, ``pvalue`` and ``pvalue_holm``. All-zero differences give p = 1; fewer than
        one pair gives NaN.

    Raises:
        KeyError: ``reference`` is not a column.
    """
    if reference not in table.columns:
        raise KeyError(f"reference: got {reference!r}, expected one of the columns {list(table.columns)}")
    rows = []
    others = [c for c in table.columns if c != reference]
    for other in others:
        pairs = table[[other, reference]].dropna(axis=0, how="any")
        differences = (pairs[other] - pairs[reference]).to_numpy(dtype=np.float64)
        n = differences.size
        if n == 0:
            statistic = pvalue = median = np.nan
        elif np.all(differences == 0.0):
            # No signed differences at all: scipy's normal approximation would divide by zero.
            statistic, pvalue, median = 0.0, 1.0, 0.0
        else:
            result = stats.wilcoxon(differences, alternative="two-sided")
            statistic, pvalue, median = (
                float(result.statistic),
                float(result.pvalue),
                float(np.median(differences)),
            )
        rows.append({"n_pairs": n, "median_difference": median, "statistic": statistic, "pvalue": pvalue})
    frame = pd.DataFrame(
        rows,
        index=pd.Index(others, name="policy"),
        columns=["n_pairs", "median_difference", "statistic", "pvalue"],
    )
    frame["pvalue_holm"] = holm(frame["pvalue"].to_numpy(dtype=np.float64))
    return frame


def label_seed(seed: int, label: str, purpose: int) -> np.random.SeedSequence:
    """A bootstrap seed for one label and statistic that does not depend on which other labels exist.

    Args:
        seed: the table's base seed.
        label: the policy, method or comparison the interval belongs to (its SHA-256 enters the seed).
        purpose: a small integer per statistic, so two intervals of one label draw apart.
    """
    digest = int.from_bytes(hashlib.sha256(label.encode()).digest()[:8], "little")
    return np.random.SeedSequence([int(seed), digest, purpose])


def extended_median(values: ArrayLike, *, axis: int = -1) -> float | np.ndarray:
    """The median over the extended reals: ``±inf`` are ordinary values at the ends of the order.

    An even count averages the two middle values (``inf`` with a finite value is ``inf``); two
    middle values of opposite infinite sign give 0, the midpoint of a symmetric split.

    Args:
        values: any shape, no NaN.
        axis: the axis reduced.

    Raises:
        ValueError: a NaN value.
    """
    x = np.sort(np.asarray(values, dtype=np.float64), axis=axis)
    if np.isnan(x).any():
        raise ValueError("values: got NaN, expected numbers or ±inf")
    n = x.shape[axis]
    if n == 0:
        return float("nan")
    low = np.take(x, (n - 1) // 2, axis=axis)
    high = np.take(x, n // 2, axis=axis)
    opposite = np.isinf(low) & np.isinf(high) & (np.sign(low) != np.sign(high))
    with np.errstate(invalid="ignore"):
        middle = np.where(opposite, 0.0, (low + high) / 2.0)
    return float(middle) if np.ndim(middle) == 0 else middle


def unit_comparison(
    differences: ArrayLike,
    *,
    seed: RNGLike,
    n_resamples: int = 10_000,
    confidence: float = 0.95,
) -> dict[str, float]:
    """Paired differences over units of replication (windows, maps): median, its interval and a test.

    Each value is one unit's difference other − reference; ``+inf`` means only the reference
    succeeded on that unit, ``-inf`` only the other (fixed-target runtimes, api.md §4.8); NaN units
    (neither succeeded) are left out and counted.

    * ``median``: :func:`extended_median` of the differences;
    * ``ci_low``, ``ci_high``: percentile bootstrap of that median over the units (resampled with
      replacement, ``n_resamples`` times); the bounds are order statistics of the resampled medians
      (``lower`` and ``higher`` quantiles), so they stay defined with infinite values;
    * ``statistic``, ``pvalue``: the two-sided Wilcoxon signed-rank test over the units, an infinite
      difference ranked above every finite one (it is replaced by ±(1 + the largest finite
      magnitude), which keeps every rank); zero differences are dropped (scipy's ``wilcox``); all
      zero gives p = 1;
    * ``units``, ``other_better`` (difference < 0), ``reference_better`` (> 0), ``undefined`` (NaN).

    Args:
        differences: (n,) one value per unit.
        seed: the bootstrap's seed (anything :func:`numpy.random.default_rng` accepts).
        n_resamples: bootstrap resamples.
        confidence: the interval's level in (0, 1).
    """
    d = np.asarray(differences, dtype=np.float64).ravel()
    defined = d[~np.isnan(d)]
    out = {
        "units": int(defined.size),
        "other_better": int(np.sum(defined < 0)),
        "reference_better": int(np.sum(defined > 0)),
        "undefined": int(d.size - defined.size),
        "median": float("nan"),
        "ci_low": float("nan"),
        "ci_high": float("nan"),
        "statistic": float("nan"),
        "pvalue": float("nan"),
    }
    if defined.size == 0:
        return out
    out["median"] = float(extended_median(defined))
    if defined.size >= 2:
        rng = np.random.default_rng(seed)
        resampled = defined[rng.integers(0, defined.size, size=(int(n_resamples), defined.size))]
        medians = extended_median(resampled, axis=1)
        alpha = (1.0 - confidence) / 2.0
        out["ci_low"] = float(np.quantile(medians, alpha, method="lower"))
        out["ci_high"] = float(np.quantile(medians, 1.0 - alpha, method="higher"))
    nonzero = defined[defined != 0.0]
    if nonzero.size == 0:
        out["statistic"], out["pvalue"] = 0.0, 1.0
        return out
    finite = nonzero[np.isfinite(nonzero)]
    cap = 1.0 + (float(np.max(np.abs(finite))) if finite.size else 0.0)
    ranked = np.where(np.isinf(nonzero), np.sign(nonzero) * cap, nonzero)
    result = stats.wilcoxon(ranked, alternative="two-sided")
    out["statistic"], out["pvalue"] = float(result.statistic), float(result.pvalue)
    return out


def minimum_wilcoxon_pvalue(n_pairs: int) -> float:
    """The smallest two-sided exact Wilcoxon p-value attainable with ``n_pairs`` non-zero pairs: 2 / 2^n.

    With 4 seeds it is 0.125, so no difference can be significant at 0.05; leaderboards say so.
    Computed as 2**(1 - n) with ``math.ldexp``, which is exact and underflows to 0.0 for huge n
    (``2.0 ** n`` overflows from n = 1024 on).
    """
    n = int(n_pairs)
    return min(1.0, math.ldexp(1.0, 1 - n)) if n > 0 else 1.0


__all__ = [
    "FriedmanResult",
    "bootstrap_ci",
    "extended_median",
    "friedman_ranks",
    "holm",
    "iqm",
    "label_seed",
    "minimum_wilcoxon_pvalue",
    "paired_difference_ci",
    "unit_comparison",
    "wilcoxon_vs_reference",
    "wilson_interval",
]
