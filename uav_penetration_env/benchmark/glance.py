"""The report at a glance: the headline sentence of a leaderboard and its most-read columns.

A reader of the HTML report (:mod:`~uav_penetration_env.benchmark.report`) first wants to know who
is cheapest, by how much and how sure that is; :func:`headline` says it in one sentence computed
from a leaderboard CSV (the statistics the leaderboard already computed: mean total J with its
bootstrap interval, the paired difference to the reference with its interval, the
Holm-corrected Wilcoxon p), and :func:`split_columns` picks the leaderboard columns the page shows
first (:data:`GLANCE_COLUMNS`), the others going behind a toggle.

DECISION (api.md §4.6, "the page at a glance"): the cheapest policy is the one with the lowest mean
total J (incl. penalty), the leaderboard's headline statistic, not the lowest Friedman rank (rows
are sorted by rank, which can differ when one seed crashed); it is compared with the reference
(the leaderboard row without a paired difference) when it is not the reference itself, else the
next cheapest is compared with it; with no reference in the table there is no paired test and the
sentence says so. Significance is Holm-adjusted p < ``ALPHA``, as in the leaderboard's Statistics.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import pandas as pd

from uav_penetration_env.benchmark import stats
from uav_penetration_env.benchmark.columns import Column, leaderboard_columns
from uav_penetration_env.benchmark.leaderboard.formatting import (
    compact_ranges,
    format_interval,
    format_number,
    p_text,
)
from uav_penetration_env.benchmark.leaderboard.table import ALPHA
from uav_penetration_env.benchmark.summary import infer_reference
from uav_penetration_env.wording import counted

# The leaderboard columns (names in the column registry) a reader scans first, in page order; the
# others follow behind a toggle. Friedman rank first: the rows are sorted by it.
GLANCE_COLUMNS = (
    "friedman_rank",
    "policy",
    "total_cost_mean",
    "total_cost_iqm",
    "delta_mean",
    "pvalue_holm",
    "success_rate",
    "planning_seconds",
)


def split_columns(shown: Sequence[Column]) -> tuple[list[Column], list[Column]]:
    """The columns of a leaderboard as the page shows them: the glance columns, then the others.

    Args:
        shown: the leaderboard's columns (those :func:`~.leaderboard.markdown.markdown_rows` shows).

    Returns:
        The columns of :data:`GLANCE_COLUMNS` that are in ``shown``, in that order, and the other
        columns of ``shown`` in their leaderboard order.
    """
    by_name = {column.name: column for column in shown}
    first = [by_name[name] for name in GLANCE_COLUMNS if name in by_name]
    return first, [column for column in shown if column.name not in GLANCE_COLUMNS]


def column_label(name: str, reference: str | None = None, *, short: bool = False) -> str:
    """The leaderboard header of a registered column (``{reference}`` filled in).

    Args:
        name: the column's name in the registry (``total_cost_mean``).
        reference: the reference policy of the table.
        short: the column's name in the legend instead (``total J (incl. penalty)``, no interval).

    Raises:
        KeyError: no leaderboard column has that name.
    """
    for column in leaderboard_columns():
        if column.name == name:
            text = (column.board.name or column.board.header) if short else column.board.header
            return text.format(reference=reference or "reference")
    raise KeyError(f"column {name!r}: not a leaderboard column of benchmark.columns")


def _finite(value: Any) -> bool:
    try:
        return value is not None and math.isfinite(float(value))
    except (TypeError, ValueError):
        return False


def _mean_text(row: Any) -> str:
    """``14.6 [95% CI 14.5, 14.7]``: a mean total J with its bootstrap interval, three digits."""
    text = format_interval(row.total_cost_mean, row.total_cost_mean_ci_low, row.total_cost_mean_ci_high, 3)
    return text.replace(" [", " [95% CI ", 1)


def _difference(row: Any, reference: str, reference_mean: float, words: tuple[str, str] = ("below", "above")) -> str:
    """``0.697 (4.5%) below the reference ihpso (paired Δ -0.697 [-1.28, -0.0575])``.

    ``words``: the direction when the row is cheaper and when it is costlier than the reference.
    """
    delta = float(row.delta_mean)
    share = f" ({100.0 * abs(delta) / abs(reference_mean):.1f}%)" if _finite(reference_mean) and reference_mean else ""
    direction = words[0] if delta < 0 else words[1]
    interval = format_interval(delta, row.delta_mean_ci_low, row.delta_mean_ci_high, 3)
    return f"{format_number(abs(delta), 3)}{share} {direction} the reference {reference} (paired Δ {interval})"


def _verdict(row: Any) -> str:
    """The paired test of ``row`` against the reference, as a sentence."""
    if not _finite(getattr(row, "pvalue_holm", None)):
        return "No paired test: the two share no finished seed."
    significant = float(row.pvalue_holm) < ALPHA
    text = (
        f"{'Significant' if significant else 'Not significant'} at α = {ALPHA}: Wilcoxon signed-rank test "
        f"over the table's seeds, Holm-adjusted {p_text(row.pvalue_holm)}"
    )
    pairs = int(row.n_pairs) if _finite(getattr(row, "n_pairs", None)) else 0
    if not significant and stats.minimum_wilcoxon_pvalue(pairs) > ALPHA:
        text += f" ({counted(pairs, 'paired seed')} cannot reach p < {ALPHA}: run more seeds)"
    return text + "."


def headline(
    table: pd.DataFrame,
    name: str,
    seeds: Sequence[int] = (),
    scenarios: Sequence[str] = (),
) -> str:
    """The headline of one leaderboard: who is cheapest, by how much, how sure, on what.

    Args:
        table: a leaderboard CSV as read by pandas (columns of :mod:`~.columns`).
        name: the scenario group's (or suite's) name.
        seeds: the episode seeds of the group (default: not named, the episode count is).
        scenarios: the scenarios of a suite group (default: one scenario, ``name``); a frozen
            suite's table (a ``members`` column) names its members instead.

    Returns:
        Plain text (no markup), a few sentences: ``pso is cheapest on paper: mean total J ...``.
    """
    rows = table[table["total_cost_mean"].map(_finite)] if "total_cost_mean" in table else table.iloc[:0]
    if rows.empty:
        return f"{name}: no policy finished an episode, so there is nothing to compare."
    # Only the ranked rows share the table's seed set (api.md §4.5): an unranked policy's mean is
    # over other seeds, so it is named apart, never "cheapest".
    ranked = rows[rows["friedman_rank"].map(_finite)] if "friedman_rank" in rows else rows
    unranked = [str(p) for p in rows["policy"] if str(p) not in set(ranked["policy"].astype(str))]
    rows = ranked if len(ranked) else rows
    ordered = rows.sort_values(["total_cost_mean", "policy"], kind="mergesort")
    best, *others = list(ordered.itertuples(index=False))
    nxt = others[0] if others else None
    reference = infer_reference(table)
    by_policy = {str(r.policy): r for r in ordered.itertuples(index=False)}
    lead = f"{best.policy} is cheapest on {name}: mean total J (incl. penalty) {_mean_text(best)}"
    if reference is not None and reference in by_policy:
        reference_mean = float(by_policy[reference].total_cost_mean)
        if str(best.policy) == reference:
            compared = nxt
            text = f"{lead}, and it is the reference."
            if nxt is not None:
                text += f" The next, {nxt.policy} at {_mean_text(nxt)}, costs "
                text += (
                    _difference(nxt, reference, reference_mean, ("less than", "more than")) + "."
                    if _finite(nxt.delta_mean)
                    else "more."
                )
        else:
            compared = best
            text = f"{lead}, {_difference(best, reference, reference_mean)}."
        if compared is not None:
            text += f" {_verdict(compared)}"
        if nxt is not None and str(best.policy) != reference and str(nxt.policy) != reference:
            text += f" Next: {nxt.policy} at {_mean_text(nxt)}."
    elif nxt is not None:
        text = (
            f"{lead}; next: {nxt.policy} at {_mean_text(nxt)}. No paired test: the table has no reference "
            "policy (--reference)."
        )
    else:
        text = f"{lead}, the only policy in this table."
    episodes = int(pd.to_numeric(rows["episodes"], errors="coerce").fillna(0).sum()) if "episodes" in rows else 0
    where = f"{len(scenarios)} scenarios" if len(scenarios) > 1 else "one scenario"
    members = pd.to_numeric(rows["members"], errors="coerce").dropna() if "members" in rows else ()
    if len(members):  # a frozen suite's table (leaderboard.suite): its means cover members
        where = f"{int(members.max())} suite members"
    over = f"{counted(len(seeds), 'seed')} ({compact_ranges(seeds)})" if len(seeds) else "the stored seeds"
    text = (
        f"{text} Over {over} on {where}: {counted(len(rows), 'policy', 'policies')}, "
        f"{counted(episodes, 'finished episode')}."
    )
    if unranked:
        text += f" Not ranked (flown on other seeds): {', '.join(unranked)}."
    return text
