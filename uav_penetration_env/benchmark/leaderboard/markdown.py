"""The Markdown file of one scenario group: provenance block, table, statistics, column legend.

The file is generated, never edited by hand. Its columns, headers, cell formats and legend come
from the column table (:mod:`uav_penetration_env.benchmark.columns`); the statistics' cells are
printed by :data:`STATISTIC_CELLS`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Sequence
from typing import Any

import pandas as pd

from uav_penetration_env.benchmark import stats
from uav_penetration_env.benchmark.columns import Column, leaderboard_columns, legend_lines
from uav_penetration_env.benchmark.failure_kinds import FAILURE_COLUMNS
from uav_penetration_env.benchmark.leaderboard.formatting import (
    compact_names,
    compact_ranges,
    format_interval,
    format_number,
    format_pvalue,
    markdown_table,
    p_text,
)
from uav_penetration_env.benchmark.leaderboard.groups import ScenarioGroup
from uav_penetration_env.benchmark.leaderboard.table import ALPHA
from uav_penetration_env.wording import counted


def _success_cell(r: Any, reference: str | None) -> str:
    if not r.episodes:
        return ""
    return (
        f"{100 * r.success_rate:.0f}% [{100 * r.success_rate_ci_low:.0f}, {100 * r.success_rate_ci_high:.0f}]"
    )


def _percent_interval(value: Any, low: Any, high: Any) -> str:
    """A relative gap (a fraction) as ``x% [lo, hi]``; blank without a value (no record)."""
    scaled = [100.0 * float(v) if v is not None else math.nan for v in (value, low, high)]
    text = format_interval(*scaled, 4)
    return f"{text.split(' ')[0]}%{text[len(text.split(' ')[0]) :]}" if text else ""


def _share(value: Any) -> str:
    """A share as a whole percentage; blank without a value (no record)."""
    if value is None or not math.isfinite(float(value)):
        return ""
    return f"{100 * float(value):.0f}%"


def _counts(values: Iterable[Any]) -> str:
    """Counts as ``a/b/c``; blank when any is missing (a policy whose failures are not all classified)."""
    counts = list(values)
    return "" if any(pd.isna(v) for v in counts) else "/".join(f"{int(v)}" for v in counts)


# How each leaderboard statistic (columns.STATISTICS) prints: row of leaderboard_table -> cell.
STATISTIC_CELLS: dict[str, Any] = {
    "policy": lambda r, reference: f"**{r.policy}**" if r.policy == reference else str(r.policy),
    "episodes": lambda r, reference: f"{int(r.episodes)}",
    "members": lambda r, reference: f"{int(r.members)}",  # frozen-suite tables only (leaderboard.suite)
    "errors": lambda r, reference: f"{int(r.errors)}",
    "success_rate": _success_cell,
    "outcome_counts": lambda r, reference: f"{int(r.collided)}/{int(r.out_of_area)}/{int(r.truncated)}",
    "failure_kinds": lambda r, reference: _counts(r[column] for column in FAILURE_COLUMNS),
    "total_cost_mean": lambda r, reference: format_interval(
        r.total_cost_mean, r.total_cost_mean_ci_low, r.total_cost_mean_ci_high
    ),
    "total_cost_iqm": lambda r, reference: format_interval(
        r.total_cost_iqm, r.total_cost_iqm_ci_low, r.total_cost_iqm_ci_high
    ),
    "friedman_rank": lambda r, reference: format_number(r.friedman_rank, 3),
    "delta_mean": lambda r, reference: format_interval(
        r.delta_mean, r.delta_mean_ci_low, r.delta_mean_ci_high, 3
    ),
    "median_difference": lambda r, reference: format_number(r.median_difference, 3),
    "pvalue_holm": lambda r, reference: format_pvalue(r.pvalue_holm),
    "gap_mean": lambda r, reference: _percent_interval(r.gap_mean, r.gap_mean_ci_low, r.gap_mean_ci_high),
    "gap_iqm": lambda r, reference: _percent_interval(r.gap_iqm, r.gap_iqm_ci_low, r.gap_iqm_ci_high),
    "within_1pct": lambda r, reference: _share(r.within_1pct),
    "within_5pct": lambda r, reference: _share(r.within_5pct),
    "within_10pct": lambda r, reference: _share(r.within_10pct),
}


def cell(column: Column, r: Any, reference: str | None) -> str:
    """The Markdown cell of one column for one row of a :func:`leaderboard_table`."""
    board = column.board
    if board.aggregate == "statistic":
        return STATISTIC_CELLS[column.name](r, reference)
    value = r[column.out]
    if board.style == "count":
        return f"{int(value):,}" if math.isfinite(value) else ""
    return format_number(value, board.digits)


def shown_columns(table: pd.DataFrame) -> list[Column]:
    """The leaderboard columns a :func:`leaderboard_table` (or its CSV) shows, in table order.

    The columns are the column table's leaderboard columns (:func:`columns.leaderboard_columns`);
    an ``optional`` one is shown only when some policy has a value, a ``recorded_only`` one only when
    the table has it.
    """
    return [
        column
        for column in leaderboard_columns()
        if (column.out in table or not column.board.recorded_only)
        and (not column.board.optional or table[column.out].notna().any())
    ]


def markdown_rows(table: pd.DataFrame, reference: str | None) -> tuple[list[str], list[list[str]], list[str]]:
    """The Markdown header, cells and alignment of a :func:`leaderboard_table` (:func:`shown_columns`)."""
    shown = shown_columns(table)
    header = [column.board.header.format(reference=reference or "reference") for column in shown]
    rows = [[cell(column, r, reference) for column in shown] for _, r in table.iterrows()]
    align = ["l", *(["r"] * (len(header) - 1))]
    return header, rows, align


def seed_set_sentence(table: pd.DataFrame) -> str:
    """Which seeds the ranked rows' statistics are over, and which policies are listed unranked (api.md §4.5)."""
    blocks = table.attrs.get("blocks", "seeds")
    seeds = table.attrs.get("seeds", [])
    whose = "the reference's" if table.attrs.get("reference") is not None else "those most policies were flown on"
    sentence = (
        f"Every statistic of a ranked policy is over the same {counted(len(seeds), blocks.rstrip('s'))} ({whose}: "
        f"{compact_ranges(seeds)})."
    )
    unranked = table.attrs.get("unranked", {})
    if unranked:
        listed = "; ".join(f"`{label}` ({compact_ranges(own)})" for label, own in sorted(unranked.items()))
        sentence += (
            f" Not ranked, because not flown on each of them (statistics over their own {blocks}, "
            f"no comparison): {listed}."
        )
    return sentence


def statistics_paragraph(table: pd.DataFrame) -> str:
    """The "Statistics" section: the seed set, Friedman's test and which differences to the reference are significant."""
    friedman: stats.FriedmanResult = table.attrs["friedman"]
    reference = table.attrs["reference"]
    blocks = table.attrs.get("blocks", "seeds")
    k = int(friedman.ranks.notna().sum())
    lines = [seed_set_sentence(table)]
    if friedman.statistic is not None:
        lines.append(
            f"Friedman test over the {friedman.blocks} {blocks} every policy finished ({counted(k, 'policy', 'policies')}): "
            f"χ² = {format_number(friedman.statistic, 3)}, {p_text(friedman.pvalue)}."
        )
    else:
        lines.append(
            f"Friedman test not run: it needs at least 3 policies and 2 {blocks} every policy finished "
            f"(here {counted(k, 'policy', 'policies')}, {counted(friedman.blocks, 'seed')}); ranks are averages over those seeds."
        )
    if reference is None:
        lines.append("No reference policy in this group, so no pairwise tests.")
        return " ".join(lines)
    compared = table[table["policy"] != reference].dropna(subset=["pvalue_holm"])
    if compared.empty:
        lines.append(
            f"No policy shares a finished seed with the reference `{reference}`, so no pairwise tests."
        )
        return " ".join(lines)
    significant = compared[compared["pvalue_holm"] < ALPHA]
    # The direction is the sign of the median paired difference: the location the signed-rank
    # test judges. The mean difference can point the other way when one episode crashed.
    lower = [
        f"`{r.policy}` ({p_text(r.pvalue_holm)})" for r in significant.itertuples() if r.median_difference < 0
    ]
    higher = [
        f"`{r.policy}` ({p_text(r.pvalue_holm)})"
        for r in significant.itertuples()
        if r.median_difference >= 0
    ]
    lines.append(
        f"Wilcoxon signed-rank tests of total J against `{reference}` (two-sided, paired over {blocks}, "
        f"Holm-corrected over {len(compared)} comparisons, α = {ALPHA})."
    )
    if lower:
        lines.append(f"Significantly cheaper than `{reference}`: {', '.join(lower)}.")
    if higher:
        lines.append(f"Significantly costlier than `{reference}`: {', '.join(higher)}.")
    if not lower and not higher:
        lines.append(f"No difference to `{reference}` is significant at {ALPHA}.")
    most_pairs = int(compared["n_pairs"].max())
    floor = stats.minimum_wilcoxon_pvalue(most_pairs)
    if floor > ALPHA:
        lines.append(
            f"With at most {most_pairs} paired {blocks} the smallest attainable p-value is {format_number(floor, 3)} "
            f"> {ALPHA}, so no difference can be significant: run more seeds."
        )
    return " ".join(lines)


# --- provenance ---------------------------------------------------------------------------------------


def _run_provenance(runs: pd.DataFrame, run_ids: Iterable[Any]) -> list[dict[str, Any]]:
    wanted = sorted({int(r) for r in run_ids if r is not None and not pd.isna(r)})
    found = []
    for run_id in wanted:
        match = runs[runs["run_id"] == run_id]
        if match.empty:
            continue
        try:
            record = json.loads(match["provenance"].iloc[0] or "{}")
        except json.JSONDecodeError:
            record = {}
        found.append({"run_id": run_id, **record})
    return found


def _unique(values: Iterable[Any]) -> list[str]:
    """Distinct texts in first-seen order (deterministic: the input is in run or row order)."""
    seen: list[str] = []
    for value in values:
        text = str(value)
        if value is not None and text not in seen:
            seen.append(text)
    return seen


def _versions(record: dict[str, Any]) -> str:
    versions = dict(record.get("versions") or {})
    first = [k for k in ("uav-penetration", "python") if k in versions]
    keys = first + sorted(k for k in versions if k not in first)
    return ", ".join(f"{k} {versions[k]}" for k in keys)


def _budget(frame: pd.DataFrame) -> str:
    by_budget: dict[str, list[str]] = {}
    for label in sorted(frame["label"].unique()):
        rows = frame[frame["label"] == label]
        evals = rows["max_evals"].dropna().unique() if "max_evals" in rows else []
        horizon = rows["horizon"].dropna().unique() if "horizon" in rows else []
        parts = []
        if len(evals):
            parts.append("max_evals " + "/".join(format_number(v, 12) for v in sorted(evals)))
        if len(horizon):
            parts.append("horizon " + "/".join(format_number(v, 12) for v in sorted(horizon)))
        by_budget.setdefault(", ".join(parts) or "no planning budget", []).append(label)
    return "; ".join(f"{budget} ({', '.join(labels)})" for budget, labels in sorted(by_budget.items()))


def provenance_lines(group: ScenarioGroup, runs: pd.DataFrame, command: str, date: str) -> list[str]:
    """The provenance block of one leaderboard, as Markdown bullet lines."""
    frame = group.episodes
    records = _run_provenance(runs, frame["run_id"] if "run_id" in frame else [])
    commands = [f"`{c}`" for c in _unique(r.get("command") for r in records)]
    commits = [f"`{c}`" for c in _unique(r.get("commit") for r in records)]
    versions = _unique(_versions(r) for r in records if r.get("versions"))
    machines = _unique(f"{r.get('cpu', 'unknown CPU')}, {r.get('cores', '?')} cores" for r in records)
    not_recorded = "not recorded (episodes written without a run record)"
    seeds = sorted(int(s) for s in frame["seed"].dropna().unique())
    errors = int(frame["is_error"].sum())
    if group.scenarios:
        episode_seeds = sorted(int(s) for s in frame["episode_seed"].dropna().unique())
        scenario_line = (
            f"- Suite: {group.name} ({len(group.scenarios)} scenarios: {compact_names(group.scenarios)}; "
            f"suite hash `{group.scenario_hash}`)"
        )
        seeds_line = (
            f"- Blocks: {len(seeds)} (scenario, seed) pairs, paired across policies; "
            f"episode seeds {compact_ranges(episode_seeds)}"
        )
    else:
        scenario_line = f"- Scenario: {group.name} (hash `{group.scenario_hash}`)"
        seeds_line = f"- Seeds: {compact_ranges(seeds)} ({counted(len(seeds), 'seed')}, paired across policies)"
    return [
        # One text for both sources: the tables built from a store and from its exported rows are
        # the same bytes except the date line, which alone names the command (api.md §4.9).
        "- Generated by `uav-bench leaderboard` from a results store or its exported rows (the same "
        "tables); do not edit this file by hand.",
        f"- Run commands: {'; '.join(commands) if commands else not_recorded}",
        f"- Commits: {', '.join(commits) if commits else not_recorded}",
        f"- Versions: {'; '.join(versions) if versions else not_recorded}",
        f"- Machine: {'; '.join(machines) if machines else not_recorded}",
        scenario_line,
        f"- Weights: {', '.join(_unique(frame['weights'].dropna())) or 'not recorded'}; "
        f"profile: {', '.join(_unique(frame['profile'].dropna())) or 'not recorded'}",
        seeds_line,
        f"- Budget: {_budget(frame)}",
        f"- Episodes: {len(frame)} ({errors} {'error' if errors == 1 else 'errors'}, excluded from the statistics)",
        f"- Date: {date}, by `{command}`",
    ]


def leaderboard_markdown(
    group: ScenarioGroup, table: pd.DataFrame, runs: pd.DataFrame, command: str, date: str
) -> str:
    """The whole Markdown file of one scenario group."""
    header, rows, align = markdown_rows(table, table.attrs["reference"])
    parts = [
        f"# Leaderboard: {group.name}",
        "",
        *provenance_lines(group, runs, command, date),
        "",
        markdown_table(header, rows, align),
        *statistics_and_columns(table),
    ]
    return "\n".join(parts)


def statistics_and_columns(table: pd.DataFrame, columns_preface: Sequence[str] = ()) -> list[str]:
    """The closing lines of a leaderboard file: its "Statistics" and "Columns" sections.

    Args:
        table: the leaderboard table (its ``n_resamples`` attribute and its columns).
        columns_preface: lines put before the column definitions (a note on what they are over).

    Returns:
        The lines, starting with the blank line that separates them from what comes before.
    """
    definitions = legend_lines(f"{table.attrs['n_resamples']:,}", set(table.columns))
    return ["", "## Statistics", "", statistics_paragraph(table), "", "## Columns", "", *columns_preface,
            *definitions, ""]  # fmt: skip
