"""Leaderboards: one Markdown and one CSV table per scenario group of a results store (api.md, harness).

A scenario group is every episode with one ``scenario_hash`` (the hash covers the geometry, the
weights, the profile and the normalisation, so costs inside a group are comparable and costs
across groups are not). Each policy gets one row: episodes, success rate with a Wilson interval,
total cost (ΣJ(k) plus the failure penalty, i.e. minus the return, so a crash never looks cheap)
as mean and interquartile mean with bootstrap intervals, the cost terms, detection, path, fuel,
compute, the Friedman average rank over paired seeds and a Holm-corrected Wilcoxon test against
a reference planner (:mod:`uav_penetration_env.benchmark.stats`).

The Markdown file starts with a provenance block (commands, commits, versions, machine, scenario,
seeds, budget, date) and is generated, never edited by hand. Output is deterministic: every
bootstrap is seeded from ``(seed, policy label)``, rows and groups are sorted stably, and nothing
depends on dict or set order, so the same store and command give the same bytes except the date.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark import stats
from uav_penetration_env.benchmark.columns import (
    EPISODE,
    Column,
    aggregated_columns,
    leaderboard_columns,
    legend_lines,
    numeric_columns,
)
from uav_penetration_env.benchmark.store import ResultsStore

ALPHA = 0.05  # significance level of the pairwise tests (after Holm's correction)
CONFIDENCE = 0.95

# Derived from the column table (benchmark.columns), kept for readers of the old constants.
MEAN_COLUMNS: dict[str, tuple[str, str]] = {
    column.out: (column.name, column.board.header) for column in aggregated_columns("means")
}
NUMERIC_EPISODE_COLUMNS = numeric_columns(EPISODE)


# --- grouping and labels -------------------------------------------------------------------------------


@dataclass(frozen=True)
class ScenarioGroup:
    """The episodes of one scenario hash, with the file stem its outputs use.

    Attributes:
        stem: sanitized scenario name (plus a hash prefix when two hashes share a name).
        scenario_hash: the group's scenario hash.
        name: the scenario's name.
        episodes: its episode rows (error rows included), with a ``label`` column per policy.
    """

    stem: str
    scenario_hash: str
    name: str
    episodes: pd.DataFrame
    scenarios: tuple[str, ...] = ()  # a suite's scenario names; empty for one scenario


def sanitize(name: str) -> str:
    """A file-name-safe version of ``name``: runs of other characters become ``-``."""
    cleaned = re.sub(r"[^A-Za-z0-9._-]+", "-", name).strip("-.")
    return cleaned or "scenario"


def policy_labels(episodes: pd.DataFrame) -> pd.Series:
    """The display name of each row's policy: its name, or ``name@hash8`` if the name has two configurations."""
    hashes_per_name = episodes.groupby("policy")["policy_hash"].nunique()
    ambiguous = set(hashes_per_name[hashes_per_name > 1].index)
    return pd.Series(
        [
            f"{name}@{str(h)[:8]}" if name in ambiguous else str(name)
            for name, h in zip(episodes["policy"], episodes["policy_hash"], strict=True)
        ],
        index=episodes.index,
        dtype=object,
    )


def prepare_episodes(episodes: pd.DataFrame) -> pd.DataFrame:
    """Episode rows with numeric columns coerced, ``error`` as text, an ``is_error`` flag and a ``label``."""
    frame = episodes.copy()
    for column in NUMERIC_EPISODE_COLUMNS:
        if column in frame:
            # An all-NULL SQLite column arrives as object dtype; make it a float column.
            frame[column] = pd.to_numeric(frame[column], errors="coerce").astype(np.float64)
    frame["error"] = frame["error"].fillna("").astype(str) if "error" in frame else ""
    frame["is_error"] = (frame["error"] != "") | (frame["outcome"].astype(str) == "error")
    if "label" not in frame:
        frame["label"] = policy_labels(frame)
    return frame


def scenario_groups(episodes: pd.DataFrame) -> list[ScenarioGroup]:
    """Split episodes by scenario hash, sorted by (name, hash); stems are unique.

    Args:
        episodes: rows of the ``episodes`` table.

    Returns:
        One :class:`ScenarioGroup` per scenario hash.
    """
    if episodes.empty:
        return []
    keys = sorted(
        {(str(n), str(h)) for n, h in zip(episodes["scenario"], episodes["scenario_hash"], strict=True)}
    )
    stems = [sanitize(name) for name, _ in keys]
    groups = []
    for (name, scenario_hash), stem in zip(keys, stems, strict=True):
        if stems.count(stem) > 1:
            stem = f"{stem}-{scenario_hash[:8]}"
        rows = episodes[episodes["scenario_hash"].astype(str) == scenario_hash]
        groups.append(ScenarioGroup(stem, scenario_hash, name, prepare_episodes(rows)))
    return groups


def suite_group(episodes: pd.DataFrame, name: str) -> ScenarioGroup:
    """All episodes as one suite (e.g. the held-out random scenarios): each (scenario, seed) is a block.

    Paired statistics need blocks in which every policy flew the same episode; in a suite that is
    the pair (scenario, seed), so the ``seed`` column becomes a block index (the episode seed stays
    in ``episode_seed``) and the tables, tests and figures work unchanged.
    """
    frame = episodes.copy()
    pairs = list(zip(frame["scenario_hash"].astype(str), frame["seed"].astype(int), strict=True))
    blocks = {pair: i for i, pair in enumerate(sorted(set(pairs)))}
    frame["episode_seed"] = frame["seed"]
    frame["seed"] = [blocks[pair] for pair in pairs]
    hashes = sorted(set(frame["scenario_hash"].astype(str)))
    suite_hash = hashlib.sha256(",".join(hashes).encode()).hexdigest()[:16]
    names = tuple(sorted(set(frame["scenario"].astype(str))))
    frame["episode_scenario_hash"] = frame["scenario_hash"]
    frame["scenario_hash"] = suite_hash
    return ScenarioGroup(sanitize(name), suite_hash, name, prepare_episodes(frame), names)


def cost_table(episodes: pd.DataFrame, column: str = "total_cost") -> pd.DataFrame:
    """Seeds x policies table of one episode column, from finished (non-error) episodes only.

    Args:
        episodes: one scenario group's rows (``prepare_episodes`` is applied if needed).
        column: the value to tabulate.

    Returns:
        Rows = sorted seeds, columns = sorted policy labels, NaN where a policy has no finished episode.
    """
    frame = episodes if "is_error" in episodes else prepare_episodes(episodes)
    valid = frame[~frame["is_error"]]
    labels = sorted(frame["label"].unique())
    table = valid.groupby(["seed", "label"])[column].mean().unstack("label")
    table = table.reindex(columns=labels).sort_index()
    table.index = table.index.astype(int)
    return table


def _label_seed(seed: int, label: str, purpose: int) -> np.random.SeedSequence:
    """A bootstrap seed for one policy and statistic that does not depend on which other policies exist."""
    digest = int.from_bytes(hashlib.sha256(label.encode()).digest()[:8], "little")
    return np.random.SeedSequence([int(seed), digest, purpose])


def resolve_reference(labels: Sequence[str], episodes: pd.DataFrame, reference: str) -> str | None:
    """The label that stands for ``reference``: itself, else the configuration of that name with most episodes."""
    if reference in labels:
        return reference
    named = episodes[(episodes["policy"] == reference) & ~episodes["is_error"]]
    if named.empty:
        return None
    counts = named.groupby("label").size()
    return str(sorted(counts.index, key=lambda label: (-counts[label], label))[0])


# --- the table ----------------------------------------------------------------------------------------


def leaderboard_table(
    episodes: pd.DataFrame, *, reference: str = "ihpso", seed: int = 0, n_resamples: int = 10_000
) -> pd.DataFrame:
    """One row per policy of ONE scenario group, full precision, sorted by Friedman rank then mean cost.

    Args:
        episodes: the group's episode rows (as from :meth:`ResultsStore.episodes`); error rows count
            in ``errors`` and nowhere else.
        reference: the policy the Wilcoxon tests and paired differences compare against.
        seed: seed of every bootstrap (each policy and statistic derives its own stream from it).
        n_resamples: bootstrap resamples.

    Returns:
        A DataFrame with columns ``policy``, ``policy_hash``, ``episodes``, ``errors``, outcome
        counts, ``success_rate`` and its ``_ci_low``/``_ci_high``, ``total_cost_mean`` and
        ``total_cost_iqm`` with their intervals, the aggregates of the column table's "means"
        section, ``friedman_rank``, the comparison with the reference (``delta_mean`` with its
        interval, ``median_difference``, ``n_pairs``, ``wilcoxon_statistic``, ``pvalue``,
        ``pvalue_holm``) and the aggregates of its "training" section. ``attrs`` carries the Friedman result, the
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
    costs = cost_table(frame)
    friedman = stats.friedman_ranks(costs)
    ref = resolve_reference(labels, frame, reference)
    tests = (
        stats.wilcoxon_vs_reference(costs, ref)
        if ref is not None and costs[ref].notna().any()
        else pd.DataFrame(columns=["n_pairs", "median_difference", "statistic", "pvalue", "pvalue_holm"])
    )
    rows = []
    for label in labels:
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
            "errors": int(rows_of["is_error"].sum()),
            "successes": successes,
            "collided": int((valid["outcome"] == "collided").sum()),
            "out_of_area": int((valid["outcome"] == "out_of_area").sum()),
            "truncated": int((valid["outcome"] == "truncated").sum()),
            "success_rate": successes / n if n else np.nan,
            "success_rate_ci_low": success_ci[0],
            "success_rate_ci_high": success_ci[1],
            "total_cost_mean": float(cost.mean()) if n else np.nan,
        }
        low, high = stats.bootstrap_ci(
            cost, np.mean, seed=_label_seed(seed, label, 0), n_resamples=n_resamples
        )
        row["total_cost_mean_ci_low"], row["total_cost_mean_ci_high"] = low, high
        row["total_cost_iqm"] = stats.iqm(cost) if n else np.nan
        low, high = stats.bootstrap_ci(
            cost, stats.iqm, seed=_label_seed(seed, label, 1), n_resamples=n_resamples
        )
        row["total_cost_iqm_ci_low"], row["total_cost_iqm_ci_high"] = low, high
        row.update({column.out: aggregate(column, valid) for column in aggregated_columns("means")})
        row["friedman_rank"] = float(friedman.ranks.get(label, np.nan))
        row.update(_versus_reference(costs, label, ref, tests, seed, n_resamples))
        row.update({column.out: aggregate(column, valid) for column in aggregated_columns("training")})
        rows.append(row)
    table = pd.DataFrame(rows)
    # Stable sort from the alphabetical order: rank first (unranked policies last), then mean cost.
    table = table.sort_values(
        ["friedman_rank", "total_cost_mean"], kind="mergesort", na_position="last"
    ).reset_index(drop=True)
    table.attrs["friedman"] = friedman
    table.attrs["reference"] = ref
    table.attrs["seeds"] = sorted(int(s) for s in frame["seed"].dropna().unique())
    table.attrs["n_resamples"] = int(n_resamples)
    # A suite pairs policies on (scenario, seed) blocks rather than on seeds (see suite_group).
    table.attrs["blocks"] = "(scenario, seed) blocks" if "episode_seed" in frame else "seeds"
    return table


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
        stats.paired_difference_ci(a, b, seed=_label_seed(seed, label, 2), n_resamples=n_resamples)
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


# --- formatting ---------------------------------------------------------------------------------------


def format_number(value: Any, digits: int = 4) -> str:
    """``value`` to ``digits`` significant digits, positional (no exponent); blank for NaN/None.

    Integers with more digits than ``digits`` keep all of them (12346, not 1.235e+04).
    """
    if value is None:
        return ""
    x = float(value)
    if not math.isfinite(x):
        return ""
    if x == 0.0:
        return "0"
    if abs(x) >= 10 ** (digits - 1):
        return f"{round(x):d}"
    return np.format_float_positional(x, precision=digits, unique=False, fractional=False, trim="-")


def format_interval(value: Any, low: Any, high: Any, digits: int = 4) -> str:
    """``value [low, high]``, or just ``value`` when the interval is undefined."""
    text = format_number(value, digits)
    if text and math.isfinite(float(low)) and math.isfinite(float(high)):
        return f"{text} [{format_number(low, digits)}, {format_number(high, digits)}]"
    return text


def format_pvalue(p: Any) -> str:
    """Two significant digits, ``<0.001`` below that; blank for NaN."""
    if p is None or not math.isfinite(float(p)):
        return ""
    if float(p) < 0.001:
        return "<0.001"
    return format_number(p, 2)


def p_text(p: Any) -> str:
    """``p = 0.023`` or ``p < 0.001`` for running text."""
    text = format_pvalue(p)
    return f"p {text[0]} {text[1:]}" if text.startswith("<") else f"p = {text}"


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[str]], align: Sequence[str]) -> str:
    """A GitHub-flavoured Markdown table with padded columns (pandas' ``to_markdown`` needs tabulate).

    Args:
        header: column titles.
        rows: cell texts, one list per row.
        align: ``"l"`` or ``"r"`` per column.

    Returns:
        The table, one line per row, no trailing newline.
    """
    cells = [[str(c).replace("|", "\\|") for c in line] for line in [header, *rows]]
    widths = [max(3, *(len(line[i]) for line in cells)) for i in range(len(header))]

    def render(line: Sequence[str]) -> str:
        padded = [c.rjust(w) if a == "r" else c.ljust(w) for c, w, a in zip(line, widths, align, strict=True)]
        return "| " + " | ".join(padded) + " |"

    rule = ["-" * (w - 1) + ":" if a == "r" else "-" * w for w, a in zip(widths, align, strict=True)]
    return "\n".join([render(cells[0]), "| " + " | ".join(rule) + " |", *(render(c) for c in cells[1:])])


def compact_names(names: Sequence[str]) -> str:
    """``random-10000 ... random-10049``-style summary of a sorted list of names (at most 6 shown)."""
    names = list(names)
    return ", ".join(names) if len(names) <= 6 else f"{', '.join(names[:3])}, ..., {', '.join(names[-2:])}"


def compact_ranges(values: Iterable[int]) -> str:
    """``[0, 1, 2, 3, 5, 7, 8]`` -> ``"0–3, 5, 7–8"``."""
    numbers = sorted({int(v) for v in values})
    parts = []
    start = previous = None
    for number in [*numbers, None]:
        if start is not None and (number is None or number != previous + 1):
            parts.append(str(start) if start == previous else f"{start}–{previous}")
            start = None
        if number is not None and start is None:
            start = number
        previous = number
    return ", ".join(parts)


def _success_cell(r: Any, reference: str | None) -> str:
    if not r.episodes:
        return ""
    return (
        f"{100 * r.success_rate:.0f}% [{100 * r.success_rate_ci_low:.0f}, {100 * r.success_rate_ci_high:.0f}]"
    )


# How each leaderboard statistic (columns.STATISTICS) prints: row of leaderboard_table -> cell.
STATISTIC_CELLS: dict[str, Any] = {
    "policy": lambda r, reference: f"**{r.policy}**" if r.policy == reference else str(r.policy),
    "episodes": lambda r, reference: f"{int(r.episodes)}",
    "errors": lambda r, reference: f"{int(r.errors)}",
    "success_rate": _success_cell,
    "outcome_counts": lambda r, reference: f"{int(r.collided)}/{int(r.out_of_area)}/{int(r.truncated)}",
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


def markdown_rows(table: pd.DataFrame, reference: str | None) -> tuple[list[str], list[list[str]], list[str]]:
    """The Markdown header, cells and alignment of a :func:`leaderboard_table`.

    The columns are the column table's leaderboard columns (:func:`columns.leaderboard_columns`);
    an ``optional`` one is shown only when some policy has a value.
    """
    shown = [
        column
        for column in leaderboard_columns()
        if not column.board.optional or table[column.out].notna().any()
    ]
    header = [column.board.header.format(reference=reference or "reference") for column in shown]
    rows = [[cell(column, r, reference) for column in shown] for _, r in table.iterrows()]
    align = ["l", *(["r"] * (len(header) - 1))]
    return header, rows, align


def statistics_paragraph(table: pd.DataFrame) -> str:
    """The "Statistics" section: Friedman's test and which differences to the reference are significant."""
    friedman: stats.FriedmanResult = table.attrs["friedman"]
    reference = table.attrs["reference"]
    blocks = table.attrs.get("blocks", "seeds")
    k = int(friedman.ranks.notna().sum())
    lines = []
    if friedman.statistic is not None:
        lines.append(
            f"Friedman test over the {friedman.blocks} {blocks} every policy finished ({k} policies): "
            f"χ² = {format_number(friedman.statistic, 3)}, {p_text(friedman.pvalue)}."
        )
    else:
        lines.append(
            f"Friedman test not run: it needs at least 3 policies and 2 {blocks} every policy finished "
            f"(here {k} policies, {friedman.blocks} seeds); ranks are averages over those seeds."
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
        seeds_line = f"- Seeds: {compact_ranges(seeds)} ({len(seeds)} seeds, paired across policies)"
    return [
        "- Generated by `uav-bench leaderboard` from the results store; do not edit this file by hand.",
        f"- Leaderboard command: `{command}`",
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
        f"- Date: {date}",
    ]


def leaderboard_markdown(
    group: ScenarioGroup, table: pd.DataFrame, runs: pd.DataFrame, command: str, date: str
) -> str:
    """The whole Markdown file of one scenario group."""
    header, rows, align = markdown_rows(table, table.attrs["reference"])
    definitions = legend_lines(f"{table.attrs['n_resamples']:,}")
    parts = [
        f"# Leaderboard: {group.name}",
        "",
        *provenance_lines(group, runs, command, date),
        "",
        markdown_table(header, rows, align),
        "",
        "## Statistics",
        "",
        statistics_paragraph(table),
        "",
        "## Columns",
        "",
        *definitions,
        "",
    ]
    return "\n".join(parts)


def write_leaderboards(
    store_path: str | Path,
    out_dir: str | Path,
    *,
    reference: str = "ihpso",
    seed: int = 0,
    command: str | None = None,
    n_resamples: int = 10_000,
    suite: str | None = None,
) -> list[Path]:
    """Write ``<stem>.md`` and ``<stem>.csv`` for every scenario group of a results store.

    With ``suite``, all episodes of the store form one table named ``suite`` whose paired blocks
    are (scenario, seed) pairs: the summary of a scenario set such as the held-out random one.

    Args:
        store_path: the SQLite results store.
        out_dir: output folder (created if needed).
        reference: the policy every other is tested against.
        seed: seed of the bootstraps (the same seed gives the same files).
        command: the command line recorded in the header (default: the equivalent Python call).
        n_resamples: bootstrap resamples.
        suite: write one table over all scenarios, named ``suite``.

    Returns:
        The written paths, Markdown then CSV per group, groups sorted by (name, hash).

    Raises:
        FileNotFoundError: there is no store at ``store_path``.
    """
    store_path, out_dir = Path(store_path), Path(out_dir)
    if not store_path.is_file():
        raise FileNotFoundError(
            f"results store {store_path}: not found; expected an SQLite file from `uav-bench run`"
        )
    with ResultsStore(store_path) as store:
        episodes, runs = store.episodes(), store.runs()
    if command is None:
        command = (
            f"write_leaderboards({str(store_path)!r}, {str(out_dir)!r}, reference={reference!r}, seed={seed})"
        )
    date = dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat()
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    groups = (
        [suite_group(episodes, suite)]
        if suite is not None and not episodes.empty
        else scenario_groups(episodes)
    )
    for group in groups:
        table = leaderboard_table(group.episodes, reference=reference, seed=seed, n_resamples=n_resamples)
        markdown = out_dir / f"{group.stem}.md"
        markdown.write_text(leaderboard_markdown(group, table, runs, command, date), encoding="utf-8")
        csv = out_dir / f"{group.stem}.csv"
        table.to_csv(csv, index=False, lineterminator="\n")
        written += [markdown, csv]
    return written
