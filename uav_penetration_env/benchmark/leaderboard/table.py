"""The statistics table of one scenario group: one row per policy (api.md, harness).

Each policy gets one row: episodes, success rate with a Wilson interval, total cost (ΣJ(k) plus
the failure penalty, i.e. minus the return, so a crash never looks cheap) as mean and
interquartile mean with bootstrap intervals, the columns the column table
(:mod:`uav_penetration_env.benchmark.columns`) aggregates, the Friedman average rank over paired
seeds and a Holm-corrected Wilcoxon test against a reference planner
(:mod:`uav_penetration_env.benchmark.stats`). Every bootstrap is seeded from ``(seed, policy
label)``, so a policy's intervals do not depend on which other policies are in the table.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark import stats
from uav_penetration_env.benchmark.columns import SECTIONS, Column, aggregated_columns
from uav_penetration_env.benchmark.failure_kinds import FAILURE_COLUMNS, failure_counts
from uav_penetration_env.benchmark.leaderboard.groups import cost_table, prepare_episodes, resolve_reference

ALPHA = 0.05  # significance level of the pairwise tests (after Holm's correction)
CONFIDENCE = 0.95
GAP_THRESHOLDS = {"within_1pct": 0.01, "within_5pct": 0.05, "within_10pct": 0.10}
GAP_COLUMNS = (
    "gap_mean",
    "gap_mean_ci_low",
    "gap_mean_ci_high",
    "gap_iqm",
    "gap_iqm_ci_low",
    "gap_iqm_ci_high",
    *GAP_THRESHOLDS,
)

BestKnownLookup = Callable[[str], "float | None"]


def leaderboard_table(
    episodes: pd.DataFrame,
    *,
    reference: str = "ihpso",
    seed: int = 0,
    n_resamples: int = 10_000,
    best_known: BestKnownLookup | None = None,
) -> pd.DataFrame:
    """One row per policy of ONE scenario group, full precision, sorted by Friedman rank then mean cost.

    Args:
        episodes: the group's episode rows (as from :meth:`ResultsStore.episodes`); error rows count
            in ``errors`` and nowhere else. A ``failure_kind`` column
            (:func:`~uav_penetration_env.benchmark.failure_kinds.with_failure_kinds`) adds the
            failure counts by kind.
        reference: the policy the Wilcoxon tests and paired differences compare against.
        seed: seed of every bootstrap (each policy and statistic derives its own stream from it).
        n_resamples: bootstrap resamples.
        best_known: scenario hash -> best-known total J* or ``None`` (default: the committed
            records, :func:`~uav_penetration_env.benchmark.bestknown.best_known_total`). Each
            episode is compared with the record of its own scenario (``episode_scenario_hash`` in
            a suite group).

    Returns:
        A DataFrame with columns ``policy``, ``policy_hash``, ``episodes``, ``errors``, outcome
        counts, the failures by kind (``fail_goal_pass`` ... ``fail_truncation``, nullable
        integers; only with a ``failure_kind`` column, api.md §4.11), ``success_rate`` and its ``_ci_low``/``_ci_high``, ``total_cost_mean`` and
        ``total_cost_iqm`` with their intervals, the aggregates of the column table's "means"
        section, ``friedman_rank``, the comparison with the reference (``delta_mean`` with its
        interval, ``median_difference``, ``n_pairs``, ``wilcoxon_statistic``, ``pvalue``,
        ``pvalue_holm``), the gaps to the best-known total (``gap_mean``, ``gap_iqm`` with their
        intervals, ``within_1pct``, ``within_5pct``, ``within_10pct``; left out when no episode's
        scenario has a record) and the aggregates of its "training" section. ``attrs`` carries the Friedman result, the
        resolved reference, the seeds and ``n_resamples``.

    Raises:
        ValueError: the rows span more than one scenario hash.
    """
    frame = prepare_episodes(episodes)
    if frame["scenario_hash"].nunique() > 1:
        raise ValueError(
            f"episodes: got {frame['scenario_hash'].nunique()} scenario hashes, expected one scenario group "
            "(costs of different scenarios are not comparable; use scenario_groups)"
        )
    labels = sorted(frame["label"].unique())
    frame["gap"] = relative_gaps(frame, best_known)
    ref = resolve_reference(labels, frame, reference)
    seeds, ranked = table_seeds(frame, ref)
    on_seeds = frame[frame["label"].isin(ranked) & frame["seed"].isin(seeds)]
    costs = cost_table(on_seeds)
    friedman = stats.friedman_ranks(costs)
    tests = (
        stats.wilcoxon_vs_reference(costs, ref)
        if ref is not None and ref in costs and costs[ref].notna().any()
        else pd.DataFrame(columns=["n_pairs", "median_difference", "statistic", "pvalue", "pvalue_holm"])
    )
    errors = frame.groupby("label")["is_error"].sum()  # a harness error counts whichever seed it hit
    rows = [
        _policy_row(on_seeds if label in ranked else frame, label, costs, friedman, ref, tests, seed,
                    n_resamples, errors=int(errors[label]))
        for label in labels
    ]  # fmt: skip
    table = _drop_unrecorded(pd.DataFrame(rows), gaps_recorded=bool(frame["gap"].notna().any()))
    # Stable sort from the alphabetical order: rank first (unranked policies last), then mean cost.
    table = table.sort_values(
        ["friedman_rank", "total_cost_mean"], kind="mergesort", na_position="last"
    ).reset_index(drop=True)
    unranked = {
        label: sorted(int(s) for s in frame.loc[frame["label"] == label, "seed"].unique())
        for label in labels
        if label not in ranked
    }
    # A suite pairs policies on (scenario, seed) blocks rather than on seeds (see suite_group).
    blocks = "(scenario, seed) blocks" if "episode_seed" in frame else "seeds"
    table.attrs.update(friedman=friedman, reference=ref, seeds=seeds, unranked=unranked,
                       n_resamples=int(n_resamples), blocks=blocks)  # fmt: skip
    return table


def table_seeds(frame: pd.DataFrame, reference: str | None) -> tuple[list[int], set[str]]:
    """The seeds every statistic of the table is computed on, and the policies ranked on them.

    DECISION (api.md §4.5): one stated seed set per table, so adding a policy flown on fewer (or
    other) seeds never moves the others' numbers, ranks or order. The set is the seeds of the
    reference's finished episodes; without a reference in the group, the set of finished seeds
    the most policies share (ties: the larger set, then the one of smaller seeds). A policy with
    a row on each of these seeds (an error row counts: it is flown, and rerunning fixes it) is
    ranked, with every statistic over exactly these seeds (its episodes on other seeds are left
    out; an error row drops its seed from the paired statistics, as before); any other policy is
    listed after them, unranked, with statistics over its own seeds and no paired comparison.

    Args:
        frame: one group's prepared episodes (``seed`` is the block index in a suite group).
        reference: the resolved reference label, or None.

    Returns:
        (sorted seeds, labels of the ranked policies).
    """

    def seed_sets(rows: pd.DataFrame) -> dict[str, frozenset[int]]:
        return {
            str(label): frozenset(int(s) for s in seeds)
            for label, seeds in rows.groupby("label")["seed"].unique().items()
        }

    finished = seed_sets(frame[~frame["is_error"]])
    flown = seed_sets(frame)
    if reference is not None and reference in finished:
        chosen = finished[reference]
    else:
        counts: dict[frozenset[int], int] = {}
        for seeds in finished.values():
            counts[seeds] = counts.get(seeds, 0) + 1
        chosen = min(counts, key=lambda s: (-counts[s], -len(s), sorted(s)), default=frozenset())
    ranked = {label for label, seeds in flown.items() if chosen <= seeds}
    return sorted(chosen), ranked


def _policy_row(
    frame: pd.DataFrame,
    label: str,
    costs: pd.DataFrame,
    friedman: Any,
    ref: str | None,
    tests: pd.DataFrame,
    seed: int,
    n_resamples: int,
    *,
    errors: int,
) -> dict[str, Any]:
    """One policy's leaderboard row: outcome counts, success, cost statistics, aggregates, tests, gaps."""
    rows_of = frame[frame["label"] == label]
    valid = rows_of[~rows_of["is_error"]]
    cost = valid["total_cost"].to_numpy(dtype=np.float64)
    if not np.all(np.isfinite(cost)):
        seeds = valid.loc[~np.isfinite(cost), "seed"].astype(int).tolist()
        raise ValueError(
            f"episodes: policy {label!r} has no finite total_cost for seeds {seeds}; expected a number "
            "for every episode without an error"
        )
    n = len(valid)
    successes = int((valid["outcome"] == "success").sum())
    success_ci = stats.wilson_interval(successes, n, CONFIDENCE)
    row: dict[str, Any] = {
        "policy": label,
        "policy_hash": ",".join(sorted(rows_of["policy_hash"].astype(str).unique())),
        "episodes": n,
        "errors": errors,
        "successes": successes,
        "collided": int((valid["outcome"] == "collided").sum()),
        "out_of_area": int((valid["outcome"] == "out_of_area").sum()),
        "truncated": int((valid["outcome"] == "truncated").sum()),
        **failure_counts(valid),  # fail_goal_pass ... fail_truncation, when the tracks are known
        "success_rate": successes / n if n else np.nan,
        "success_rate_ci_low": success_ci[0],
        "success_rate_ci_high": success_ci[1],
        "total_cost_mean": float(cost.mean()) if n else np.nan,
    }
    low, high = stats.bootstrap_ci(cost, np.mean, seed=stats.label_seed(seed, label, 0), n_resamples=n_resamples)
    row["total_cost_mean_ci_low"], row["total_cost_mean_ci_high"] = low, high
    row["total_cost_iqm"] = stats.iqm(cost) if n else np.nan
    low, high = stats.bootstrap_ci(cost, stats.iqm, seed=stats.label_seed(seed, label, 1), n_resamples=n_resamples)
    row["total_cost_iqm_ci_low"], row["total_cost_iqm_ci_high"] = low, high
    row.update({column.out: aggregate(column, valid) for column in aggregated_columns("means")})
    row["friedman_rank"] = float(friedman.ranks.get(label, np.nan))
    row.update(_versus_reference(costs, label, ref, tests, seed, n_resamples))
    row.update(_gaps(valid["gap"].to_numpy(dtype=np.float64), label, seed, n_resamples))
    row.update({column.out: aggregate(column, valid) for column in aggregated_columns("training")})
    return row


def _drop_unrecorded(table: pd.DataFrame, gaps_recorded: bool) -> pd.DataFrame:
    """``table`` without the columns that no episode recorded, and without the gaps when nothing has a record.

    A column marked ``Board.recorded_only`` is left out when every row lacks it, so the table of an
    older store is unchanged; the gap columns likewise when no scenario has a best-known record,
    and the failure counts when no policy's failures could be classified (api.md §4.11).
    """
    unrecorded = [
        column.out
        for section in SECTIONS
        for column in aggregated_columns(section)
        if column.board.recorded_only and column.out in table and table[column.out].isna().all()
    ]
    if table.empty or not gaps_recorded:
        unrecorded += [name for name in GAP_COLUMNS if name in table]
    kinds = [name for name in FAILURE_COLUMNS if name in table]
    if kinds and table[kinds].isna().all().all():
        unrecorded += kinds  # no policy's failures could all be classified: as a store without tracks
    elif kinds:
        table = table.astype(dict.fromkeys(kinds, "Int64"))  # counts stay integers beside a blank
    return table.drop(columns=unrecorded)


def relative_gaps(frame: pd.DataFrame, best_known: BestKnownLookup | None = None) -> pd.Series:
    """Each episode's relative gap (J - J*) / J* to the best-known total of its own scenario.

    Args:
        frame: episode rows; ``episode_scenario_hash`` (a suite group) or ``scenario_hash`` names
            each row's scenario.
        best_known: scenario hash -> J* or ``None`` (default: the committed records).

    Returns:
        (rows,) float gaps; NaN where the scenario has no record or the episode has no cost.

    DECISION (docs/best-known.md §4): the gap is relative to J* (not to the
    policy's cost) so that it reads as "x % above the best known", as in COCO's targets and
    Shehadeh & Kudela's relative error; J* > 0 always holds for this cost (every term >= 0 and
    a flight of one step costs > 0), and a record with J* <= 0 gives no gap.
    """
    if best_known is None:
        from uav_penetration_env.benchmark.bestknown import best_known_total

        best_known = best_known_total
    hashes = frame["episode_scenario_hash"] if "episode_scenario_hash" in frame else frame["scenario_hash"]
    lookup = {h: best_known(h) for h in sorted(set(hashes.astype(str)))}
    reference = np.array(
        [np.nan if lookup[h] is None or not lookup[h] > 0 else lookup[h] for h in hashes.astype(str)],
        dtype=np.float64,
    )
    cost = pd.to_numeric(frame["total_cost"], errors="coerce").to_numpy(dtype=np.float64)
    return pd.Series((cost - reference) / reference, index=frame.index, dtype=np.float64)


def _gaps(gaps: np.ndarray, label: str, seed: int, n_resamples: int) -> dict[str, float]:
    """A policy's gap statistics over its finished episodes that have a record (NaN when none)."""
    gaps = gaps[np.isfinite(gaps)]
    if not gaps.size:
        return dict.fromkeys(GAP_COLUMNS, np.nan)
    mean_low, mean_high = stats.bootstrap_ci(
        gaps, np.mean, seed=stats.label_seed(seed, label, 3), n_resamples=n_resamples
    )
    iqm_low, iqm_high = stats.bootstrap_ci(
        gaps, stats.iqm, seed=stats.label_seed(seed, label, 4), n_resamples=n_resamples
    )
    row = {
        "gap_mean": float(gaps.mean()),
        "gap_mean_ci_low": mean_low,
        "gap_mean_ci_high": mean_high,
        "gap_iqm": float(stats.iqm(gaps)),
        "gap_iqm_ci_low": iqm_low,
        "gap_iqm_ci_high": iqm_high,
    }
    # A small tolerance so that an episode equal to the record up to rounding counts as within 1 %.
    row.update({name: float(np.mean(gaps <= limit + 1e-12)) for name, limit in GAP_THRESHOLDS.items()})
    return row


def aggregate(column: Column, valid: pd.DataFrame) -> float:
    """A policy's value of an aggregated column over its finished episodes (``column.board.aggregate``).

    ``mean``: the mean over every finished episode (NaN if one has no value); ``mean_recorded``:
    the mean over the episodes that recorded a value (NaN if none did).
    """
    values = valid[column.name].to_numpy(dtype=np.float64) if column.name in valid else np.array([])
    if column.board.aggregate == "mean_recorded":
        values = values[~np.isnan(values)]
    return float(values.mean()) if values.size else np.nan


def _versus_reference(
    costs: pd.DataFrame, label: str, ref: str | None, tests: pd.DataFrame, seed: int, n_resamples: int
) -> dict[str, float]:
    empty = {
        "delta_mean": np.nan,
        "delta_mean_ci_low": np.nan,
        "delta_mean_ci_high": np.nan,
        "median_difference": np.nan,
        "n_pairs": np.nan,
        "wilcoxon_statistic": np.nan,
        "pvalue": np.nan,
        "pvalue_holm": np.nan,
    }
    if ref is None or label == ref or label not in tests.index:
        return empty
    pairs = costs[[label, ref]].dropna(axis=0, how="any")
    a, b = pairs[label].to_numpy(dtype=np.float64), pairs[ref].to_numpy(dtype=np.float64)
    test = tests.loc[label]
    low, high = (
        stats.paired_difference_ci(a, b, seed=stats.label_seed(seed, label, 2), n_resamples=n_resamples)
        if len(pairs)
        else (np.nan, np.nan)
    )
    return {
        "delta_mean": float((a - b).mean()) if len(pairs) else np.nan,
        "delta_mean_ci_low": low,
        "delta_mean_ci_high": high,
        "median_difference": float(test["median_difference"]),
        "n_pairs": float(test["n_pairs"]),
        "wilcoxon_statistic": float(test["statistic"]),
        "pvalue": float(test["pvalue"]),
        "pvalue_holm": float(test["pvalue_holm"]),
    }
