"""The leaderboard's columns in table order, and the legend that explains them.

A leaderboard lays out its sections in :data:`~.definition.SECTIONS` order and the columns of
each section in declaration order (:mod:`.registry`); consecutive columns with the same legend
share one bullet of its "Columns" section.
"""

from __future__ import annotations

from collections.abc import Collection

from uav_penetration_env.benchmark.columns.definition import SECTIONS, Column
from uav_penetration_env.benchmark.columns.registry import EPISODE, STATISTICS


def leaderboard_columns() -> list[Column]:
    """The columns a leaderboard shows, in table order: by section, then in declaration order."""
    shown = [column for column in (*STATISTICS, *EPISODE) if column.board is not None]
    return sorted(shown, key=lambda column: SECTIONS.index(column.board.section))


def aggregated_columns(section: str) -> list[Column]:
    """Episode columns of one leaderboard section that are aggregated (not bespoke statistics)."""
    return [
        column
        for column in leaderboard_columns()
        if column.board.section == section and column.board.aggregate != "statistic"
    ]


def legend_lines(resamples: str, present: Collection[str] | None = None) -> list[str]:
    """The leaderboard's "Columns" section: one bullet per legend (consecutive equal legends merge).

    Args:
        resamples: the number of bootstrap resamples, as printed.
        present: the leaderboard table's columns; a ``recorded_only`` column missing from them has
            no bullet (default: every column has one).
    """
    bullets: list[tuple[list[str], str]] = []
    for column in leaderboard_columns():
        board = column.board
        if board.legend is None or (
            board.recorded_only and present is not None and column.out not in present
        ):
            continue
        name = board.name or board.header
        if bullets and bullets[-1][1] == board.legend:
            bullets[-1][0].append(name)
        else:
            bullets.append(([name], board.legend))
    return [f"- **{', '.join(names)}**: {legend.format(resamples=resamples)}." for names, legend in bullets]
