"""Leaderboard tables beyond one table per scenario group, registered once each (api.md, harness).

:func:`~uav_penetration_env.benchmark.leaderboard.write_leaderboards` writes one table per
scenario group, then calls every registered table writer with a :class:`TableContext`; a writer
returns the files it wrote (none when the store holds nothing it tabulates). A new kind of table
is one ``@register_tables("key")`` on its writer, never an edit of ``write_leaderboards``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

if TYPE_CHECKING:
    from uav_penetration_env.benchmark.rows import ResultTables


@dataclass(frozen=True)
class TableContext:
    """What a table writer reads: the store's rows and the leaderboard's settings.

    Attributes:
        store_path: the results store, or its row tables (:class:`~..rows.ResultTables`, ``--rows``).
        out_dir: the output folder (exists).
        episodes: every episode row of the store (as :meth:`ResultsStore.episodes` returns them).
        runs: the store's run rows (provenance and settings as JSON text).
        reference: the policy the paired tests compare against.
        seed: the bootstrap seed.
        command: the command line for the provenance block.
        n_resamples: bootstrap resamples.
        date: the date line of the provenance block.
    """

    store_path: Path | ResultTables
    out_dir: Path
    episodes: pd.DataFrame
    runs: pd.DataFrame
    reference: str
    seed: int
    command: str
    n_resamples: int
    date: str


TableWriter = Callable[[TableContext], list[Path]]

_WRITERS: dict[str, TableWriter] = {}


def register_tables(key: str) -> Callable[[TableWriter], TableWriter]:
    """Register a table writer (decorator); writers run in registration order.

    Raises:
        ValueError: ``key`` is already registered.
    """

    def decorator(writer: TableWriter) -> TableWriter:
        if key in _WRITERS:
            raise ValueError(f"leaderboard tables {key!r} are already registered")
        _WRITERS[key] = writer
        return writer

    return decorator


def table_writers() -> dict[str, TableWriter]:
    """The registered table writers by key, in registration order."""
    return dict(_WRITERS)
