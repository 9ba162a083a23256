"""The terminal summary of ``uav-bench run`` and ``uav-bench leaderboard``: a compact table per group.

The full leaderboard has some 40 columns (api.md §4.5); a terminal gets the few a reader scans
first, one row per policy in the leaderboard's order, and the paths of the full tables and the
HTML report. The table is drawn with ``rich`` and fits :data:`MAX_WIDTH` columns however long the
policy names are (long names wrap inside their cell).

DECISION (api.md §4.6): the columns are policy, success rate, mean total J with its bootstrap CI,
the IQM of total J, the gap to the best-known solution when the leaderboard CSV carries one (a
column whose name starts with ``gap``, added through the column table), the Friedman
rank, and the mean paired difference to the reference with its Holm-corrected p. The reference
row shows "reference" in that column.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import IO, Any

import pandas as pd

from uav_penetration_env.benchmark.leaderboard.formatting import format_interval, format_number, format_pvalue

MAX_WIDTH = 100  # [characters] the summary never needs a wider terminal
GAP_PREFIX = "gap"  # a leaderboard column named gap* is the gap to the best-known solution


def _finite(value: Any) -> bool:
    try:
        return value is not None and math.isfinite(float(value))
    except (TypeError, ValueError):
        return False


def gap_column(columns: Sequence[str]) -> str | None:
    """The leaderboard column holding the gap to the best known, or None when the table has none."""
    for name in columns:
        if name.startswith(GAP_PREFIX) and not name.endswith(("_ci_low", "_ci_high")):
            return name
    return None


def infer_reference(frame: pd.DataFrame) -> str | None:
    """The reference policy of a leaderboard CSV: the one row without a paired difference.

    Returns None when no row has a paired difference (a single policy, or no reference present).
    """
    if "delta_mean" not in frame or not frame["delta_mean"].notna().any():
        return None
    missing = frame.loc[frame["delta_mean"].isna(), "policy"].tolist()
    return str(missing[0]) if len(missing) == 1 else None


def table_reference(frame: pd.DataFrame, requested: str | None = None) -> str | None:
    """The policy a written leaderboard table compares with: what its "Δ vs" header and its tests mean.

    The tables choose it by one rule (:func:`~uav_penetration_env.benchmark.leaderboard.groups.resolve_reference`,
    api.md §4.5): ``--reference`` when given, else ``ihpso`` where the group flew it, else ``greedy``,
    else the policy with the most finished seeds. A written table keeps the choice as its one row
    without a paired difference (:func:`infer_reference`), so the terminal summary and the HTML
    report read it from there rather than from the flag; only when the rows cannot tell (no row has
    a difference, or several lack one) is ``requested`` taken, if it is a row.
    """
    found = infer_reference(frame)
    if found is not None:
        return found
    return requested if requested is not None and requested in set(frame["policy"].astype(str)) else None


def summary_rows(frame: pd.DataFrame, reference: str | None = None) -> tuple[list[str], list[list[str]]]:
    """The header and cell texts of the compact table of one leaderboard CSV.

    Args:
        frame: a leaderboard CSV as read by pandas (columns of :mod:`~uav_penetration_env.benchmark.columns`).
        reference: the reference asked for (``--reference``); the table's own is shown
            (:func:`table_reference`).

    Returns:
        The header and one list of cell texts per policy, in the CSV's order.
    """
    reference = table_reference(frame, reference)
    gap = gap_column(list(frame.columns))
    header = ["policy", "success", "total J [95% CI]", "IQM"]
    if gap is not None:
        header.append("gap to J*")  # the best-known total, as the Markdown names it
    header += ["rank", f"Δ vs {reference} (p)" if reference else "Δ vs reference (p)"]
    rows = []
    for record in frame.to_dict("records"):
        success = (
            f"{100.0 * float(record['success_rate']):.0f}%" if _finite(record.get("success_rate")) else ""
        )
        cells = [
            str(record["policy"]),
            success,
            format_interval(
                record.get("total_cost_mean"),
                record.get("total_cost_mean_ci_low", math.nan),
                record.get("total_cost_mean_ci_high", math.nan),
                digits=3,
            ),
            format_number(record.get("total_cost_iqm"), 3),
        ]
        if gap is not None:
            value = record.get(gap)
            cells.append(f"{100.0 * float(value):.1f}%" if _finite(value) else "")
        cells.append(format_number(record.get("friedman_rank"), 3))
        if str(record["policy"]) == reference:
            cells.append("reference")
        elif _finite(record.get("delta_mean")):
            p = record.get("pvalue_holm")
            p_text = format_pvalue(p) if _finite(p) else ""
            p_text = f" (p{'' if p_text.startswith('<') else '='}{p_text})" if p_text else ""
            cells.append(f"{format_number(record['delta_mean'], 3)}{p_text}")
        else:
            cells.append("")
        rows.append(cells)
    return header, rows


def summary_table(frame: pd.DataFrame, title: str, reference: str | None = None):
    """A ``rich`` table of one leaderboard: numbers right-aligned, policy names folded when long."""
    from rich import box
    from rich.table import Table
    from rich.text import Text

    from uav_penetration_env.benchmark.safe_text import terminal_safe

    header, rows = summary_rows(frame, reference)
    table = Table(title=Text(terminal_safe(title, keep="")), box=box.SIMPLE_HEAD, title_justify="left", pad_edge=False, expand=False)
    for i, name in enumerate(header):
        if i == 0:
            table.add_column(name, overflow="fold", min_width=12, max_width=34, no_wrap=False)
        else:
            table.add_column(name, justify="right", no_wrap=True)  # numbers never break
    for cells in rows:  # as Text: a name's [brackets] are not markup, its control characters escaped
        table.add_row(*(Text(terminal_safe(cell, keep="")) for cell in cells))
    return table


def print_summary(
    tables: Sequence[Path],
    *,
    report: Path | None = None,
    figures: Path | None = None,
    reference: str | None = None,
    file: IO[str] | None = None,
    width: int | None = None,
) -> None:
    """Print the compact table of each leaderboard CSV, then where the full results are.

    Args:
        tables: the written leaderboard files (CSV shown, Markdown listed).
        report: the HTML report, when one was written.
        figures: the folder of the figures, when they were written.
        reference: the reference asked for; each table's own is shown (:func:`table_reference`).
        file: the stream (default: standard output at call time).
        width: console width (default: the terminal's, at most :data:`MAX_WIDTH`; a pipe or
            file gets :data:`MAX_WIDTH`).
    """
    from rich.console import Console

    from uav_penetration_env.benchmark.safe_text import unescaped

    stream = sys.stdout if file is None else file
    # rich styles the table itself, from cells made safe in summary_table, so it writes unescaped
    console = Console(file=unescaped(stream), width=width, highlight=False, soft_wrap=False)
    if width is None:  # a terminal's own width up to MAX_WIDTH; a file or pipe gets MAX_WIDTH
        console.width = min(console.width, MAX_WIDTH) if console.is_terminal else MAX_WIDTH
    for path in (Path(p) for p in tables):
        if path.suffix != ".csv":
            continue
        frame = pd.read_csv(path)
        if frame.empty or "total_cost_mean" not in frame or "member" in frame:
            # only a leaderboard is summarised: the RL table (<stem>-rl.csv), a table stacking several
            # members' leaderboards (leaderboard.suite) and the paired tables (information.csv) are listed
            continue
        console.print(summary_table(frame, f"{path.stem} (lower total J is better)", reference))
    # Paths are printed whole, never wrapped, so they can be copied (a long path may pass the width).
    lines = [f"full table: {path}" for path in tables]
    if figures is not None:
        lines.append(f"figures: {figures}")
    if report is not None:
        lines.append(f"report: {report}")
    for line in lines:
        print(line, file=stream)
