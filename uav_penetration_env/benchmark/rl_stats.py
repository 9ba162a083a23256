"""RL statistics over runs and tasks: IQM, stratified bootstrap, performance profiles, P(X < Y).

The estimators of Agarwal et al. 2021, "Deep RL at the edge of the statistical precipice"
(NeurIPS), as their ``rliable`` package defines them (docs/rl-statistics.md §1). A method's scores
form a ``(runs, tasks)`` matrix: a *run* is one independent realisation of the method (a training
seed of an agent, an episode seed of a stochastic planner) and a *task* one scenario.

* :func:`iqm_score`: the interquartile mean of all ``runs x tasks`` scores pooled
  (``rliable.metrics.aggregate_iqm``: ``scipy.stats.trim_mean(scores, 0.25, axis=None)``).
* :func:`stratified_bootstrap`: resamples with replacement, *within each task*, as many runs as
  the task has (``rliable.library.StratifiedBootstrap``, ``task_bootstrap=False``); intervals are
  percentile intervals (rliable's default method).
* :func:`performance_profile`: the fraction of all runs x tasks scores better than a threshold
  tau (rliable's "run-score distribution", ``create_performance_profile`` with
  ``use_score_distribution=True``).
* :func:`probability_of_improvement`: per task the Mann-Whitney U statistic over ``n x m``, i.e.
  P(X better than Y) + ½ P(tie), averaged over tasks; its interval resamples X and Y
  independently, each stratified by task (``StratifiedIndependentBootstrap``).
* :func:`mean_difference`: the paired difference of X and Y (mean over tasks of the difference
  of their per-task means), with a two-stage bootstrap interval (tasks, then runs in each); not
  an rliable estimator: the leaderboard's paired Δ, for methods whose runs are training seeds.

DECISION (docs/rl-statistics.md §1): our scores are COSTS, lower is better, whereas rliable's are
returns, higher is better. Every function here takes ``higher_is_better`` (default ``False``);
with costs, "better than tau" is ``cost < tau`` and "X improves on Y" is ``cost_X < cost_Y``, which
is rliable's definition applied to the negated scores. IQM is the same in both directions.

DECISION (docs/rl-statistics.md §1): implemented with numpy and scipy rather than by depending on ``rliable``: its release
pulls ``arch``, ``statsmodels``, ``seaborn`` and ``absl-py`` into the core install (a pip dry
run, 2026-11-29), for some fifty lines of estimators; tests check these against values computed
by hand from rliable's published definitions and against ``scipy.stats.mannwhitneyu``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats

RNGLike = int | np.random.SeedSequence | np.random.Generator
MatrixStatistic = Callable[[np.ndarray], np.ndarray]
# Resamples are drawn in chunks so that (chunk, runs, tasks) stays small whatever n_resamples is.
_CHUNK_ELEMENTS = 2_000_000


def score_matrix(scores: ArrayLike, name: str = "scores") -> np.ndarray:
    """Check and return a ``(runs, tasks)`` float64 matrix of finite scores.

    Args:
        scores: (runs, tasks) array-like; a 1-D array is one task's runs.
        name: the argument's name, for errors.

    Returns:
        A new float64 array of shape (runs, tasks).

    Raises:
        ValueError: not 1-D or 2-D, no run or no task, or a non-finite score.
    """
    matrix = np.array(scores, dtype=np.float64)
    if matrix.ndim == 1:
        matrix = matrix[:, None]
    if matrix.ndim != 2 or matrix.shape[0] == 0 or matrix.shape[1] == 0:
        raise ValueError(f"{name}: got shape {np.shape(scores)}, expected a (runs, tasks) matrix, both >= 1")
    if not np.all(np.isfinite(matrix)):
        raise ValueError(
            f"{name}: got non-finite values {matrix[~np.isfinite(matrix)][:3]}, expected finite scores"
        )
    return matrix


def _check_level(confidence: float, n_resamples: int) -> None:
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence: got {confidence!r}, expected a number in (0, 1)")
    if not (isinstance(n_resamples, (int, np.integer)) and n_resamples >= 1):
        raise ValueError(f"n_resamples: got {n_resamples!r}, expected an integer >= 1")


def _bootstrap_scores(scores: ArrayLike, confidence: float, n_resamples: int) -> np.ndarray:
    """The (runs, tasks) matrix of ``scores`` once it, ``confidence`` and ``n_resamples`` are checked."""
    matrix = score_matrix(scores)
    _check_level(confidence, n_resamples)
    return matrix


# --- statistics of a (..., runs, tasks) stack -----------------------------------------------------------


def iqm_score(scores: ArrayLike) -> float:
    """Interquartile mean of every score of a ``(runs, tasks)`` matrix pooled (rliable ``aggregate_iqm``).

    Args:
        scores: (runs, tasks) scores (or one task's runs).

    Returns:
        ``scipy.stats.trim_mean(scores, 0.25, axis=None)``: the mean of the middle 50 %.
    """
    return float(_iqm_stack(score_matrix(scores)[None])[0])


def _iqm_stack(stack: np.ndarray) -> np.ndarray:
    """(n, runs, tasks) -> (n,) IQM of each matrix."""
    return stats.trim_mean(stack.reshape(stack.shape[0], -1), 0.25, axis=1)


def _mean_stack(stack: np.ndarray) -> np.ndarray:
    """(n, runs, tasks) -> (n,) mean over runs and tasks (rliable ``aggregate_mean``: tasks weigh alike)."""
    return stack.mean(axis=1).mean(axis=1)


STACK_STATISTICS: dict[str, MatrixStatistic] = {"iqm": _iqm_stack, "mean": _mean_stack}


def _better(a: np.ndarray, b: np.ndarray, higher_is_better: bool) -> np.ndarray:
    return a > b if higher_is_better else a < b


def _profile_stack(stack: np.ndarray, taus: np.ndarray, higher_is_better: bool) -> np.ndarray:
    """(n, runs, tasks) -> (n, len(taus)) fraction of scores better than each tau."""
    flat = stack.reshape(stack.shape[0], -1)
    return _better(flat[:, :, None], taus[None, None, :], higher_is_better).mean(axis=1)


def _improvement_stack(x: np.ndarray, y: np.ndarray, higher_is_better: bool) -> np.ndarray:
    """(n, runs_x, tasks), (n, runs_y, tasks) -> (n,) P(X better than Y) + ½ P(tie), mean over tasks."""
    a, b = x[:, :, None, :], y[:, None, :, :]
    wins = _better(a, b, higher_is_better).mean(axis=(1, 2))
    ties = (a == b).mean(axis=(1, 2))
    return (wins + 0.5 * ties).mean(axis=1)


# --- the stratified bootstrap ----------------------------------------------------------------------------


def stratified_resamples(scores: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` stratified bootstrap resamples of a ``(runs, tasks)`` matrix: (n, runs, tasks).

    Each resample draws, for every task independently, ``runs`` indices with replacement from that
    task's runs (rliable ``StratifiedBootstrap``): runs are never mixed across tasks.
    """
    runs, tasks = scores.shape
    index = rng.integers(0, runs, size=(n, runs, tasks))
    return np.take_along_axis(np.broadcast_to(scores, (n, runs, tasks)), index, axis=1)


def _chunks(n_resamples: int, *shapes: tuple[int, int]) -> list[int]:
    size = max(1, sum(r * t for r, t in shapes))
    step = max(1, _CHUNK_ELEMENTS // size)
    return [min(step, n_resamples - start) for start in range(0, n_resamples, step)]


def stratified_bootstrap(
    scores: ArrayLike,
    statistic: str | MatrixStatistic = "iqm",
    *,
    seed: RNGLike,
    n_resamples: int = 10_000,
) -> np.ndarray:
    """The bootstrap distribution of a statistic under stratified resampling of runs within tasks.

    Args:
        scores: (runs, tasks) finite scores.
        statistic: ``"iqm"``, ``"mean"`` or a function ``(n, runs, tasks) -> (n, ...)``.
        seed: anything :func:`numpy.random.default_rng` accepts; the same seed gives the same draws.
        n_resamples: bootstrap resamples.

    Returns:
        (n_resamples, ...) the statistic of each resample.

    Raises:
        ValueError: bad scores, an unknown statistic name or ``n_resamples < 1``.
    """
    matrix = _bootstrap_scores(scores, 0.5, n_resamples)
    function = _statistic(statistic)
    rng = np.random.default_rng(seed)
    parts = [function(stratified_resamples(matrix, rng, n)) for n in _chunks(n_resamples, matrix.shape)]
    return np.concatenate(parts, axis=0)


def _statistic(statistic: str | MatrixStatistic) -> MatrixStatistic:
    if callable(statistic):
        return statistic
    if statistic not in STACK_STATISTICS:
        raise ValueError(
            f"statistic: got {statistic!r}, expected one of {', '.join(STACK_STATISTICS)} or a function"
        )
    return STACK_STATISTICS[statistic]


def percentile_interval(distribution: np.ndarray, confidence: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """The percentile interval of a bootstrap distribution along axis 0 (rliable's default method).

    Args:
        distribution: (n_resamples, ...) bootstrap values.
        confidence: confidence level in (0, 1).

    Returns:
        (low, high), each of the trailing shape (a 0-d array for a scalar statistic).
    """
    tail = 100.0 * (1.0 - confidence) / 2.0
    low, high = np.percentile(distribution, [tail, 100.0 - tail], axis=0)
    return low, high


@dataclass(frozen=True)
class Estimate:
    """A point estimate with its stratified-bootstrap percentile interval.

    Attributes:
        value: the statistic of the sample itself.
        low: the interval's lower end.
        high: its upper end.
    """

    value: float
    low: float
    high: float


def interval_estimate(
    scores: ArrayLike,
    statistic: str = "iqm",
    *,
    seed: RNGLike,
    n_resamples: int = 10_000,
    confidence: float = 0.95,
) -> Estimate:
    """IQM or mean of a ``(runs, tasks)`` matrix with its stratified-bootstrap interval (docs/rl-statistics.md §1).

    A matrix with one run per task has a degenerate interval (every resample is the sample): the
    stratified bootstrap measures the variation across runs, and there is none to measure.

    Args:
        scores: (runs, tasks) finite scores.
        statistic: ``"iqm"`` or ``"mean"``.
        seed: the bootstrap's seed.
        n_resamples: bootstrap resamples.
        confidence: confidence level in (0, 1).

    Returns:
        The :class:`Estimate`.

    Raises:
        ValueError: bad scores, statistic, confidence or number of resamples.
    """
    matrix = _bootstrap_scores(scores, confidence, n_resamples)
    function = _statistic(statistic)
    value = float(function(matrix[None])[0])
    if matrix.shape[0] == 1 or np.all(matrix == matrix[:1]):
        return Estimate(value, value, value)  # every resample is the sample itself
    low, high = percentile_interval(
        stratified_bootstrap(matrix, function, seed=seed, n_resamples=n_resamples), confidence
    )
    return Estimate(value, float(low), float(high))


# --- performance profiles ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Profile:
    """A performance profile with its pointwise stratified-bootstrap band.

    Attributes:
        taus: (k,) thresholds.
        fraction: (k,) fraction of runs x tasks scores better than each tau.
        low: (k,) lower end of the pointwise interval.
        high: (k,) upper end.
    """

    taus: np.ndarray
    fraction: np.ndarray
    low: np.ndarray
    high: np.ndarray


def performance_profile(
    scores: ArrayLike,
    taus: ArrayLike,
    *,
    higher_is_better: bool = False,
    seed: RNGLike,
    n_resamples: int = 2_000,
    confidence: float = 0.95,
) -> Profile:
    """The run-score distribution: the fraction of scores better than tau, with bands (docs/rl-statistics.md §1).

    With costs (the default) it is the fraction of runs x tasks whose cost is *below* tau, so the
    curve rises with tau; with ``higher_is_better`` it is rliable's fraction of scores above tau.
    The default of 2 000 resamples is rliable's for profiles.

    Args:
        scores: (runs, tasks) finite scores.
        taus: (k,) thresholds, in the scores' units.
        higher_is_better: the scores' direction (False: costs).
        seed: the bootstrap's seed.
        n_resamples: bootstrap resamples.
        confidence: level of the pointwise band.

    Returns:
        The :class:`Profile`.

    Raises:
        ValueError: bad scores, thresholds, confidence or number of resamples.
    """
    matrix = _bootstrap_scores(scores, confidence, n_resamples)
    thresholds = np.array(taus, dtype=np.float64).reshape(-1)
    if thresholds.size == 0 or not np.all(np.isfinite(thresholds)):
        raise ValueError(f"taus: got {np.asarray(taus).tolist()!r}, expected one or more finite thresholds")

    def function(stack: np.ndarray) -> np.ndarray:
        return _profile_stack(stack, thresholds, higher_is_better)

    fraction = function(matrix[None])[0]
    low, high = percentile_interval(
        stratified_bootstrap(matrix, function, seed=seed, n_resamples=n_resamples), confidence
    )
    return Profile(thresholds, fraction, np.asarray(low), np.asarray(high))


# --- probability of improvement ----------------------------------------------------------------------------


def _paired_matrices(x: ArrayLike, y: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """The (runs, tasks) score matrices of two methods compared on the same tasks.

    Raises:
        ValueError: bad scores or different task counts.
    """
    a, b = score_matrix(x, "x"), score_matrix(y, "y")
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"x, y: got {a.shape[1]} and {b.shape[1]} tasks, expected the same tasks in both")
    return a, b


def _seed_sequence(seed: RNGLike) -> np.random.SeedSequence:
    """``seed`` as a SeedSequence (from which a statistic spawns its independent streams)."""
    return seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(_entropy(seed))


def probability_of_improvement(
    x: ArrayLike,
    y: ArrayLike,
    *,
    higher_is_better: bool = False,
    seed: RNGLike | None = None,
    n_resamples: int = 2_000,
    confidence: float = 0.95,
) -> Estimate:
    """P(X improves on Y): the Mann-Whitney U statistic over n x m per task, averaged over tasks.

    Per task, ``P = (#{(i, j): x_i better than y_j} + ½ #{(i, j): x_i = y_j}) / (n m)``, rliable's
    ``probability_of_improvement``; with costs (the default) "better" is "cheaper". The interval
    resamples the runs of X and of Y independently, each stratified by task (rliable
    ``StratifiedIndependentBootstrap``; 2 000 resamples as its default for this statistic).

    Args:
        x: (runs_x, tasks) scores of X.
        y: (runs_y, tasks) scores of Y on the same tasks, in the same column order.
        higher_is_better: the scores' direction (False: costs).
        seed: the bootstrap's seed (``None``: no interval, ``low = high = NaN``).
        n_resamples: bootstrap resamples.
        confidence: confidence level in (0, 1).

    Returns:
        The :class:`Estimate` (in [0, 1]; 0.5 = no preference).

    Raises:
        ValueError: bad scores, different task counts, bad confidence or resamples.
    """
    a, b = _paired_matrices(x, y)
    _check_level(confidence, n_resamples)
    value = float(_improvement_stack(a[None], b[None], higher_is_better)[0])
    if seed is None:
        return Estimate(value, float("nan"), float("nan"))
    base = _seed_sequence(seed)
    rng_x, rng_y = (np.random.default_rng(s) for s in base.spawn(2))
    parts = []
    for n in _chunks(n_resamples, a.shape, b.shape, (a.shape[0] * b.shape[0], a.shape[1])):
        parts.append(
            _improvement_stack(
                stratified_resamples(a, rng_x, n), stratified_resamples(b, rng_y, n), higher_is_better
            )
        )
    low, high = percentile_interval(np.concatenate(parts), confidence)
    return Estimate(value, float(low), float(high))


def mean_difference(
    x: ArrayLike,
    y: ArrayLike,
    *,
    seed: RNGLike,
    n_resamples: int = 10_000,
    confidence: float = 0.95,
) -> Estimate:
    """Mean over tasks of (mean of X's runs − mean of Y's runs) on each task, with a bootstrap interval.

    The paired difference of two methods on the same tasks (scenarios): negative when X is cheaper.
    The interval is a two-stage percentile bootstrap: each resample draws the tasks with
    replacement (the same tasks for X and Y: the pairing), then, within each drawn task, X's runs
    and Y's runs independently with replacement. DECISION (docs/rl-statistics.md §1): both sources
    of variation count, the scenarios and the training seeds; with one task it resamples the runs
    alone (the paper scenario: variation across training seeds), with one run per task it is the
    paired bootstrap over tasks the leaderboard's Δ column uses. With one run and one task, or
    identical differences everywhere, the interval is the point.

    Args:
        x: (runs_x, tasks) scores of X.
        y: (runs_y, tasks) scores of Y on the same tasks, in the same column order.
        seed: the bootstrap's seed.
        n_resamples: bootstrap resamples.
        confidence: confidence level in (0, 1).

    Returns:
        The :class:`Estimate` of the difference (X − Y, in the scores' unit).

    Raises:
        ValueError: bad scores, different task counts, bad confidence or resamples.
    """
    a, b = _paired_matrices(x, y)
    _check_level(confidence, n_resamples)
    value = float((a.mean(axis=0) - b.mean(axis=0)).mean())
    (runs_a, tasks), runs_b = a.shape, b.shape[0]
    if (runs_a == runs_b == 1 and tasks == 1) or (
        np.all(a == a[:1]) and np.all(b == b[:1]) and np.all(a[0] - b[0] == a[0, 0] - b[0, 0])
    ):
        return Estimate(value, value, value)  # every resample gives the sample's difference
    base = _seed_sequence(seed)
    rng_tasks, rng_a, rng_b = (np.random.default_rng(s) for s in base.spawn(3))
    parts = []
    for n in _chunks(n_resamples, a.shape, b.shape):
        drawn = rng_tasks.integers(0, tasks, size=(n, 1, tasks))
        runs_of_a = rng_a.integers(0, runs_a, size=(n, runs_a, tasks))
        runs_of_b = rng_b.integers(0, runs_b, size=(n, runs_b, tasks))
        parts.append((a[runs_of_a, drawn].mean(axis=1) - b[runs_of_b, drawn].mean(axis=1)).mean(axis=1))
    low, high = percentile_interval(np.concatenate(parts), confidence)
    return Estimate(value, float(low), float(high))


def _entropy(seed: int | np.random.Generator) -> int:
    """SeedSequence entropy from an integer or a Generator (one draw)."""
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(2**63))
    return seed


__all__ = [
    "STACK_STATISTICS",
    "Estimate",
    "Profile",
    "interval_estimate",
    "iqm_score",
    "percentile_interval",
    "performance_profile",
    "probability_of_improvement",
    "score_matrix",
    "stratified_bootstrap",
    "stratified_resamples",
]
