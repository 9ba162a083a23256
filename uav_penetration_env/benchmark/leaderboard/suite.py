"""The leaderboards of a frozen suite (docs/suite.md §5): overall, per member group, per member.

A store holds a frozen suite's episodes when one of its runs recorded ``suite: NAME`` in its
settings (``uav-bench run --suite NAME``); the tables then cover every episode of the store on a
member of that suite, whichever run flew it (a member is identified by its scenario hash).

* ``<suite>``: every member; ``<suite>-<group>``: the members of one group (``fixed``: the paper
  scenario in both weightings and the DEM scenario; ``d0.25``, ``d0.50``, ``d0.75``: the
  procedural ones). Each member weighs the same: a policy's finished episodes on a member are
  averaged first, then the columns average over members, and the paired statistics pair the
  policies on members (:func:`equal_weight_table`).
* ``<suite>-members``: one table per member (the statistics of one scenario group), and a matrix
  of mean total J, member x policy. Any column the column table adds to a leaderboard (the gap
  to the best-known solution, ``gap*``) appears in it and its CSV with no change here.

DECISION (docs/suite.md §5): members rather than (scenario, seed) pairs are the blocks. With the
suite's seed rule a deterministic policy flies one seed on a fixed member and a stochastic one
five, so (scenario, seed) blocks would be incomplete for every fixed member, and a member flown
with five seeds would weigh five times as much in a pooled mean.
"""

from __future__ import annotations

import hashlib
import json
import math
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from uav_penetration_env.atomic import write_text_atomic
from uav_penetration_env.benchmark import stats
from uav_penetration_env.benchmark.columns import legend_lines
from uav_penetration_env.benchmark.leaderboard.formatting import format_number, markdown_table
from uav_penetration_env.benchmark.leaderboard.groups import (
    NUMERIC_EPISODE_COLUMNS,
    prepare_episodes,
    suite_group,
)
from uav_penetration_env.benchmark.leaderboard.markdown import (
    markdown_rows,
    provenance_lines,
    statistics_and_columns,
    statistics_paragraph,
)
from uav_penetration_env.benchmark.leaderboard.registry import TableContext, register_tables
from uav_penetration_env.benchmark.leaderboard.rl import rl_markdown, rl_table
from uav_penetration_env.benchmark.leaderboard.table import CONFIDENCE, leaderboard_table
from uav_penetration_env.benchmark.safe_text import write_csv_table
from uav_penetration_env.benchmark.stats import label_seed

if TYPE_CHECKING:  # imported where used: the suites package reads YAML and builds scenarios
    from uav_penetration_env.suites import Suite, SuiteMember

OUTCOMES = ("success", "collided", "out_of_area", "truncated")
ESTIMATOR = (
    "each member weighs the same. A policy's finished episodes on a member are averaged first (a "
    "member flown with 5 seeds counts once, like one flown with 1 seed); every column is then the "
    "mean over the members the policy finished. The 95 % intervals of total J and of its IQM "
    "bootstrap over members; success is the mean over members of each member's share of "
    "successful episodes, its interval a bootstrap over members; episodes, errors and the outcome "
    "counts are plain episode counts. The gap to the best known is that of the member means (the "
    "mean of their episodes' gaps), and the shares within 1/5/10 % of it are means over members of "
    "each member's share of episodes within. Ranks, Friedman's test and the Wilcoxon tests pair the "
    "policies on members (the blocks are members)"
)


def recorded_suites(runs: pd.DataFrame) -> list[str]:
    """The frozen suites a store's runs were made for (``settings["suite"]``), sorted."""
    names = set()
    for text in runs.get("settings", pd.Series(dtype=object)):
        try:
            settings = json.loads(text or "{}")
        except (TypeError, json.JSONDecodeError):
            continue
        if isinstance(settings, dict) and isinstance(settings.get("suite"), str):
            names.add(settings["suite"])
    return sorted(names)


def suite_episodes(episodes: pd.DataFrame, suite: Suite) -> pd.DataFrame:
    """The episode rows on members of ``suite``, with ``member``, ``member_group``, ``member_index``.

    Args:
        episodes: store rows.
        suite: a :class:`~uav_penetration_env.suites.Suite`.
    """
    members = {m.fingerprint.scenario_hash: (i, m) for i, m in enumerate(suite.members)}
    frame = episodes[episodes["scenario_hash"].astype(str).isin(members)].copy()
    found = [members[str(h)] for h in frame["scenario_hash"]]
    frame["member"] = [m.name for _, m in found]
    frame["member_group"] = [m.group for _, m in found]
    frame["member_index"] = [i for i, _ in found]
    return frame


def _member_shares(valid: pd.DataFrame) -> pd.DataFrame:
    """Per (label, member): the share of each outcome among the finished episodes."""
    shares = pd.crosstab([valid["label"], valid["member_index"]], valid["outcome"], normalize="index")
    return shares.reindex(columns=list(OUTCOMES), fill_value=0.0)


def equal_weight_table(
    frame: pd.DataFrame, *, reference: str = "ihpso", seed: int = 0, n_resamples: int = 10_000
) -> pd.DataFrame:
    """One row per policy over several members, each member weighted equally (see :data:`ESTIMATOR`).

    The rows are :func:`~.table.leaderboard_table` of the member means: one pseudo-episode per
    (policy, member) holding the means of the policy's finished episodes there, with the member as
    the block (``seed``); the success columns and the counts are then replaced by the
    member-weighted success share (bootstrap interval over members) and the plain episode counts.

    Args:
        frame: the episodes of some members (:func:`suite_episodes`: ``member``, ``member_index``).
        reference: the policy the paired tests compare against.
        seed: bootstrap seed.
        n_resamples: bootstrap resamples.

    Returns:
        The leaderboard table plus ``members`` (members the policy finished); ``attrs["blocks"]``
        is ``"members"``.
    """
    prepared = prepare_episodes(frame)
    valid = prepared[~prepared["is_error"]]
    numeric = [c for c in NUMERIC_EPISODE_COLUMNS if c in valid and c not in ("seed", "episode_id", "run_id")]
    keys = ["label", "member_index"]
    collapsed = valid.groupby(keys, sort=True)[numeric].mean().reset_index()
    first = valid.groupby(keys, sort=True)[
        ["policy", "policy_hash", "scenario", "scenario_hash", "member"]
    ].first()
    collapsed = collapsed.merge(first.reset_index(), on=keys)
    hashes = sorted(set(valid["scenario_hash"].astype(str)))
    collapsed["episode_scenario_hash"] = collapsed["scenario_hash"]
    collapsed["scenario_hash"] = hashlib.sha256(",".join(hashes).encode()).hexdigest()[:16]
    collapsed["seed"] = collapsed["member_index"]
    collapsed["episode_seed"] = collapsed["member_index"]
    collapsed["outcome"] = "success"  # replaced below by the member-weighted shares
    collapsed["error"] = ""
    table = leaderboard_table(collapsed, reference=reference, seed=seed, n_resamples=n_resamples)
    shares = _member_shares(valid)
    for position, label in enumerate(table["policy"]):
        rows = prepared[prepared["label"] == label]
        good = rows[~rows["is_error"]]
        success = (
            shares.loc[label, "success"].to_numpy(dtype=np.float64) if label in shares.index else np.array([])
        )
        low, high = stats.bootstrap_ci(
            success,
            np.mean,
            seed=label_seed(seed, str(label), 7),
            n_resamples=n_resamples,
            confidence=CONFIDENCE,
        )
        update = {
            "episodes": len(good),
            "errors": int(rows["is_error"].sum()),
            "successes": int((good["outcome"] == "success").sum()),
            "collided": int((good["outcome"] == "collided").sum()),
            "out_of_area": int((good["outcome"] == "out_of_area").sum()),
            "truncated": int((good["outcome"] == "truncated").sum()),
            "success_rate": float(success.mean()) if success.size else np.nan,
            "success_rate_ci_low": low,
            "success_rate_ci_high": high,
        }
        for column, value in update.items():
            table.loc[position, column] = value
    _member_weighted_within(table, valid)
    members = valid.groupby("label")["member_index"].nunique()
    table.insert(3, "members", [int(members.get(label, 0)) for label in table["policy"]])
    table.attrs["blocks"] = "members"
    return table


def _member_weighted_within(table: pd.DataFrame, valid: pd.DataFrame) -> None:
    """Replace the shares of episodes within 1/5/10 % of the best known by member-weighted shares.

    On the member means the leaderboard would count members whose MEAN episode is within the
    threshold; here each member contributes the share of its episodes within it (the same
    threshold and tolerance as :func:`~.table.leaderboard_table`), averaged over the members that
    have a record. The gap's mean and IQM need no change: the gap is linear in the total, so the
    gap of a member mean is the mean of its episodes' gaps.
    """
    from uav_penetration_env.benchmark.leaderboard.table import GAP_THRESHOLDS, relative_gaps

    if not any(name in table for name in GAP_THRESHOLDS):
        return
    gaps = valid[["label", "member_index"]].assign(gap=relative_gaps(valid))
    gaps = gaps[np.isfinite(gaps["gap"])]
    for name, limit in GAP_THRESHOLDS.items():
        if name not in table:
            continue
        within = (
            gaps.assign(hit=gaps["gap"] <= limit + 1e-12).groupby(["label", "member_index"])["hit"].mean()
        )
        shares = within.groupby(level="label").mean()
        table[name] = [float(shares.get(label, np.nan)) for label in table["policy"]]


def member_tables(
    frame: pd.DataFrame, *, reference: str = "ihpso", seed: int = 0, n_resamples: int = 10_000
) -> pd.DataFrame:
    """The leaderboard table of each member present, stacked into one frame.

    Columns: ``member``, ``member_group``, ``scenario``, ``scenario_hash``, then every column of
    :func:`~.table.leaderboard_table`. Rows follow the suite's member order, then each member's table order. ``attrs["tables"]``
    holds the per-member tables (their ``attrs`` carry the statistics of each).
    """
    parts, tables = [], []
    for _, rows in frame.groupby("member_index", sort=True):
        table = leaderboard_table(rows, reference=reference, seed=seed, n_resamples=n_resamples)
        first = rows.iloc[0]
        identity = {
            "member": first["member"],
            "member_group": first["member_group"],
            "scenario": first["scenario"],
            "scenario_hash": first["scenario_hash"],
        }
        tables.append((identity, table))
        parts.append(pd.concat([pd.DataFrame([identity] * len(table)), table.reset_index(drop=True)], axis=1))
    stacked = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()
    stacked.attrs["tables"] = tables
    return stacked


def member_matrix(stacked: pd.DataFrame, column: str) -> pd.DataFrame:
    """Member x policy matrix of one column of :func:`member_tables` (NaN where not flown)."""
    matrix = stacked.pivot_table(index="member", columns="policy", values=column, aggfunc="first", sort=False)
    order = list(dict.fromkeys(stacked["member"]))
    return matrix.reindex(index=order, columns=sorted(matrix.columns))


def group_overview(frame: pd.DataFrame, suite: Suite) -> pd.DataFrame:
    """Policy x member group: the member-weighted mean total J (no bootstrap; a quick overview).

    Returns:
        Rows = policy labels; columns ``members`` (finished), ``all`` and one per group of the
        suite present in ``frame``.
    """
    prepared = prepare_episodes(frame)
    valid = prepared[~prepared["is_error"]]
    per_member = valid.groupby(["label", "member_index", "member_group"])["total_cost"].mean().reset_index()
    overview = pd.DataFrame(index=sorted(per_member["label"].unique()))
    overview["members"] = per_member.groupby("label")["member_index"].nunique()
    overview["all"] = per_member.groupby("label")["total_cost"].mean()
    for group in suite.groups:
        rows = per_member[per_member["member_group"] == group]
        if not rows.empty:
            overview[group] = rows.groupby("label")["total_cost"].mean()
    return overview


# --- Markdown -------------------------------------------------------------------------------------------


def _suite_lines(suite: Suite, frame: pd.DataFrame, members: list[SuiteMember]) -> list[str]:
    present = set(frame["member"])
    groups = ", ".join(
        f"{group} {sum(m.group == group and m.name in present for m in members)}/{sum(m.group == group for m in members)}"
        for group in dict.fromkeys(m.group for m in members)
    )
    frozen = suite.frozen
    file = suite.path.name if suite.path is not None else suite.name
    return [
        f"- Frozen suite: {suite.name}, members with episodes {len(present)} of {len(members)} ({groups}); "
        f"suite file `{file}` frozen {frozen.get('date', '?')} at commit `{frozen.get('commit', '?')}`; "
        "every member verified against its fingerprint before it was flown (docs/suite.md)",
    ]


def _incomplete(table: pd.DataFrame, total: int) -> list[str]:
    short = [
        f"`{r.policy}` ({int(r.members)} of {total})" for r in table.itertuples() if int(r.members) < total
    ]
    if not short:
        return []
    return [
        "",
        f"**Not every member finished:** {', '.join(short)}. Their means cover fewer members and are not "
        "comparable with the others'; the paired statistics use only the members every compared policy finished.",
    ]


def equal_weight_markdown(
    title: str,
    suite: Suite,
    frame: pd.DataFrame,
    table: pd.DataFrame,
    members: list[SuiteMember],
    context: TableContext,
) -> str:
    """The Markdown file of one member-weighted table (overall or one group)."""
    group = suite_group(frame, title)
    header, rows, align = markdown_rows(table, table.attrs["reference"])
    provenance = [
        line
        if not line.startswith("- Blocks:")
        else f"- Blocks: {len(set(frame['member']))} members, paired across policies (each policy's episodes on a "
        f"member averaged first); {line[len('- Blocks: ') :]}"
        for line in provenance_lines(group, context.runs, context.command, context.date)
    ]
    parts = [
        f"# Leaderboard: {title} (each member weighted equally)",
        "",
        *provenance,
        *_suite_lines(suite, frame, members),
        f"- Estimator: {ESTIMATOR}.",
        "",
        markdown_table(header, rows, align),
        *_incomplete(table, len(set(frame["member"]))),
    ]
    groups_present = [g for g in suite.groups if g in set(frame["member_group"])]
    if len(groups_present) > 1:
        overview = group_overview(frame, suite)
        labels = list(table["policy"])
        columns = ["members", "all", *groups_present]
        matrix_rows = [
            [str(label)]
            + [
                str(int(overview.loc[label, c])) if c == "members" else format_number(overview.loc[label, c])
                for c in columns
            ]
            for label in labels
            if label in overview.index
        ]
        parts += [
            "",
            "## By member group",
            "",
            "Mean total J (incl. penalty) over the members of each group, each member weighing the same "
            "(the per-group files hold the full statistics).",
            "",
            markdown_table(["policy", *columns], matrix_rows, ["l", *(["r"] * len(columns))]),
        ]
    parts += statistics_and_columns(
        table,
        [
            "In this table every interval, rank and test is over members, not episodes, and success is the "
            "member-weighted share with a bootstrap interval (see the estimator above); the definitions below "
            "are those of a one-scenario leaderboard.",
            "",
        ],
    )
    return "\n".join(parts)


def members_markdown(suite: Suite, frame: pd.DataFrame, stacked: pd.DataFrame, context: TableContext) -> str:
    """The Markdown file of the per-member tables: the member x policy matrices, then each table."""
    from uav_penetration_env.benchmark.summary import gap_column

    group = suite_group(frame, f"{suite.name} per member")
    matrices = [("total_cost_mean", "Mean total J (incl. penalty); the lowest of each member in bold")]
    gap = gap_column(list(stacked.columns))
    if gap is not None:  # the column table's gap to the best-known solution
        matrices.append(
            (
                gap,
                "Gap (J − J*)/J* of the mean total J to the best-known total J* (docs/best-known.md), in %; blank without a record",
            )
        )
    parts = [
        f"# Leaderboard: {suite.name} per member",
        "",
        *provenance_lines(group, context.runs, context.command, context.date),
        *_suite_lines(suite, frame, list(suite.members)),
        "",
    ]
    for column, caption in matrices:
        matrix = member_matrix(stacked, column)
        best = matrix.min(axis=1) if column == "total_cost_mean" else None
        rows = []
        for member, values in matrix.iterrows():
            cells = []
            for value in values:
                text = (
                    format_number(value)
                    if column == "total_cost_mean" or not math.isfinite(value)
                    else f"{100 * value:.1f}%"
                )
                bold = best is not None and math.isfinite(value) and value == best[member]
                cells.append(f"**{text}**" if bold else text)
            rows.append([str(member), *cells])
        parts += [
            f"## {caption}",
            "",
            markdown_table(["member", *matrix.columns], rows, ["l", *(["r"] * len(matrix.columns))]),
            "",
        ]
    parts += ["## Every member's leaderboard", ""]
    for identity, table in stacked.attrs["tables"]:
        header, rows, align = markdown_rows(table, table.attrs["reference"])
        parts += [
            f"### {identity['member']} ({identity['scenario']}, hash `{identity['scenario_hash']}`)",
            "",
            markdown_table(header, rows, align),
            "",
            statistics_paragraph(table),
            "",
        ]
    resamples = (
        stacked.attrs["tables"][0][1].attrs["n_resamples"] if stacked.attrs["tables"] else context.n_resamples
    )
    parts += ["## Columns", "", *legend_lines(f"{resamples:,}", set(stacked.columns)), ""]
    return "\n".join(parts)


def _write_pair(out_dir: Path, stem: str, markdown: str, table: pd.DataFrame) -> list[Path]:
    path = out_dir / f"{stem}.md"
    write_text_atomic(path, markdown)
    return [path, write_csv_table(table, out_dir / f"{stem}.csv")]  # whole, formula-like names neutralised


def write_suite_tables(context: TableContext, suite_name: str) -> list[Path]:
    """Write the tables of one frozen suite (module docstring); none when the store has no member episodes.

    Returns:
        Markdown then CSV (then ``-rl.csv`` when RL agents flew the members: the RL table over the
        members, whose section the Markdown also gets) of ``<suite>``, of each ``<suite>-<group>``
        present, then Markdown and CSV of ``<suite>-members``.
    """
    from uav_penetration_env.suites import load_suite

    suite = load_suite(suite_name)
    frame = suite_episodes(context.episodes, suite)
    prepared = prepare_episodes(frame) if not frame.empty else frame
    if frame.empty or prepared["is_error"].all():
        return []
    settings = {"reference": context.reference, "seed": context.seed, "n_resamples": context.n_resamples}
    written = []
    selections = [(suite.name, frame, list(suite.members))]
    for group in suite.groups:
        rows = frame[frame["member_group"] == group]
        if not rows.empty and len(suite.groups) > 1:
            selections.append((f"{suite.name}-{group}", rows, [m for m in suite.members if m.group == group]))
    for title, rows, members in selections:
        if prepare_episodes(rows)["is_error"].all():
            continue
        table = equal_weight_table(rows, **settings)
        markdown = equal_weight_markdown(title, suite, rows, table, members, context)
        # The RL table over the members (docs/rl-statistics.md §2): the members are its tasks, the
        # strata of the bootstraps, as the RL field reports agents over a benchmark's environments.
        rl = rl_table(rows, seed=context.seed, n_resamples=context.n_resamples)
        written += _write_pair(context.out_dir, title, markdown + ("\n" + rl_markdown(rl) if not rl.empty else ""), table)
        if not rl.empty:
            written.append(write_csv_table(rl, context.out_dir / f"{title}-rl.csv"))
    stacked = member_tables(frame, **settings)
    written += _write_pair(
        context.out_dir, f"{suite.name}-members", members_markdown(suite, frame, stacked, context), stacked
    )
    return written


@register_tables("suite")
def _suite_tables(context: TableContext) -> list[Path]:
    """The tables of every frozen suite a run of the store was made for (``run --suite``)."""
    from uav_penetration_env.suites import SuiteError

    written = []
    for name in recorded_suites(context.runs):
        try:
            written += write_suite_tables(context, name)
        except SuiteError as error:
            # A suite this package does not ship (a store from a newer version, or a custom suite file
            # that has moved): the other tables are still written, and the reader is told why this is not.
            warnings.warn(
                f"suite {name} (recorded by a `run --suite` of this store): its member-weighted tables "
                f"are left out, because the suite cannot be loaded ({error})",
                UserWarning,
                stacklevel=2,
            )
    return written
