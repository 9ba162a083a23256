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

The package holds one idea per module: :mod:`.groups` (scenario groups and policy labels),
:mod:`.table` (the statistics table), :mod:`.formatting` and :mod:`.markdown` (the Markdown
file); :func:`write_leaderboards` writes the files of a store.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import pandas as pd

from uav_penetration_env.atomic import write_text_atomic
from uav_penetration_env.benchmark.failure_kinds import with_failure_kinds
from uav_penetration_env.benchmark.leaderboard.formatting import (
    compact_names,
    compact_ranges,
    format_interval,
    format_number,
    format_pvalue,
    markdown_table,
    p_text,
)
from uav_penetration_env.benchmark.leaderboard.groups import (
    NUMERIC_EPISODE_COLUMNS,
    ScenarioGroup,
    cost_table,
    policy_labels,
    prepare_episodes,
    resolve_reference,
    sanitize,
    scenario_groups,
    suite_group,
)
from uav_penetration_env.benchmark.leaderboard.markdown import (
    STATISTIC_CELLS,
    cell,
    leaderboard_markdown,
    markdown_rows,
    provenance_lines,
    statistics_paragraph,
)
from uav_penetration_env.benchmark.leaderboard.registry import TableContext, register_tables, table_writers
from uav_penetration_env.benchmark.leaderboard.rl import compute_points, rl_markdown, rl_table
from uav_penetration_env.benchmark.leaderboard.table import (
    ALPHA,
    CONFIDENCE,
    aggregate,
    leaderboard_table,
)
from uav_penetration_env.benchmark.rows import ResultTables, store_tables
from uav_penetration_env.benchmark.safe_text import write_csv_table

# Imported for its registration (@register_tables("suite")): the frozen suites' tables.
from uav_penetration_env.benchmark.leaderboard import suite as _suite_tables  # noqa: F401  # isort: skip
# Imported for its registration (@register_tables("information")): the price of information (docs/dynamic.md §7).
from uav_penetration_env.benchmark.leaderboard import information as _information_tables  # noqa: F401  # isort: skip

__all__ = [
    "ALPHA",
    "CONFIDENCE",
    "NUMERIC_EPISODE_COLUMNS",
    "STATISTIC_CELLS",
    "ScenarioGroup",
    "TableContext",
    "aggregate",
    "cell",
    "compact_names",
    "compact_ranges",
    "compute_points",
    "cost_table",
    "format_interval",
    "format_number",
    "format_pvalue",
    "leaderboard_markdown",
    "leaderboard_table",
    "markdown_rows",
    "markdown_table",
    "p_text",
    "policy_labels",
    "prepare_episodes",
    "provenance_lines",
    "register_tables",
    "resolve_reference",
    "rl_markdown",
    "rl_table",
    "sanitize",
    "scenario_groups",
    "statistics_paragraph",
    "suite_group",
    "table_writers",
    "write_leaderboards",
]


def write_leaderboards(
    store_path: str | Path | ResultTables,
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
        store_path: the SQLite results store, or its row tables (:func:`~..rows.read_rows`: the
            same tables give the same files).
        out_dir: output folder (created if needed).
        reference: the policy every other is tested against.
        seed: seed of the bootstraps (the same seed gives the same files).
        command: the command line recorded in the header (default: the equivalent Python call).
        n_resamples: bootstrap resamples.
        suite: write one table over all scenarios, named ``suite``.

    The tables count failed episodes by kind (goal pass, terrain, edge, ceiling, truncation) when
    the store or rows hold their step rows (api.md §4.11).

    A group with RL agents gets an "RL agents over training seeds" section in its Markdown file
    and ``<stem>-rl.csv`` (:func:`~.rl.rl_table`, docs/rl-statistics.md §2).

    Returns:
        The written paths, Markdown then CSV per group (then the RL CSV, when written), groups
        sorted by (name, hash), then the files of the registered table writers (:mod:`.registry`;
        a frozen suite's tables, :mod:`.suite`), unless ``suite``. The fixed-target tables of
        window runs are written by
        :func:`~.fixedtarget.write_fixed_target`.

    Raises:
        FileNotFoundError: there is no store at ``store_path``.
    """
    out_dir = Path(out_dir)
    tables = _tables_of(store_path)
    # The failure kind of each failed episode, from its step rows (api.md §4.11).
    episodes, runs = with_failure_kinds(tables), tables.runs
    if command is None:
        source = "rows" if isinstance(store_path, ResultTables) else str(store_path)
        command = f"write_leaderboards({source!r}, {str(out_dir)!r}, reference={reference!r}, seed={seed})"
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
        rl = rl_table(group.episodes, seed=seed, n_resamples=n_resamples)
        text = leaderboard_markdown(group, table, runs, command, date)
        written += _write_group(out_dir, group.stem, text, table, rl)
    if suite is None and not episodes.empty:
        # The registered tables (registry.register_tables), e.g. a frozen suite's (leaderboard.suite).
        context = TableContext(
            store_path, out_dir, episodes, runs, reference, seed, command, n_resamples, date
        )
        for writer in table_writers().values():
            written += writer(context)
    return written


def _tables_of(store_path: str | Path | ResultTables) -> ResultTables:
    """The row tables of a store file, or ``store_path`` itself when it already is row tables."""
    if isinstance(store_path, ResultTables):
        return store_path
    path = Path(store_path)
    if not path.is_file():
        raise FileNotFoundError(f"results store {path}: not found; expected an SQLite file from `uav-bench run`")
    return store_tables(path)


def _write_group(out_dir: Path, stem: str, text: str, table: pd.DataFrame, rl: pd.DataFrame) -> list[Path]:
    """One group's Markdown (with its RL section), CSV and RL CSV, each whole or not at all."""
    markdown = out_dir / f"{stem}.md"
    write_text_atomic(markdown, text + ("\n" + rl_markdown(rl) if not rl.empty else ""))
    written = [markdown]
    for path, frame in ((out_dir / f"{stem}.csv", table), (out_dir / f"{stem}-rl.csv", rl)):
        if frame is rl and rl.empty:
            continue
        written.append(write_csv_table(frame, path))  # whole, formula-like names neutralised (safe_text)
    return written
