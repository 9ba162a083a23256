"""Cells of a store read back against their declared types: a hostile or damaged cell is named, not met later.

SQLite keeps any value in any column (``'many'`` in an INTEGER column stays text), so a shared or
downloaded store can hold cells no reader expects; they used to surface as tracebacks deep in the
statistics or the Parquet writer. Each reader of the store checks the frame it returns here, and
the store turns a problem into its one-line ``damaged`` error (``--store PATH: damaged ...``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

import pandas as pd

from uav_penetration_env.scenario.errors import shown

NUMBER_TYPES = ("INTEGER", "REAL")
# JSON text columns whose every non-NULL cell is a JSON list (the readers index them).
JSON_LISTS = ("history", "history_nfev", "state")


def cell_problem(table: str, frame: pd.DataFrame, declared: Mapping[str, str], key: str) -> str | None:
    """What is wrong with the first cell of ``frame`` that does not fit its declared type, or None.

    Args:
        table: the table's name, for the message.
        frame: rows as read.
        declared: ``column -> SQLite type`` (``"REAL"``, ``"TEXT NOT NULL DEFAULT ''"``, ...).
        key: the id column that names the row in the message.
    """
    for column, kind in declared.items():
        if column not in frame.columns:
            continue
        values = frame[column]
        if kind.split()[0] in NUMBER_TYPES:
            if values.dtype.kind in "iuf":  # read as numbers: nothing else can be there
                continue
            bad = values.notna() & (
                pd.to_numeric(values, errors="coerce").isna() | values.map(lambda v: isinstance(v, (str, bytes)))
            )
            expected = "a number"
        elif column in JSON_LISTS and table == "window_runs":
            bad = values.notna() & ~values.map(_is_json_list)
            expected = "a JSON list"
        else:
            continue
        if bad.any():
            row = frame.loc[bad].iloc[0]
            where = f" ({key} {row[key]})" if key in frame.columns else ""
            return f"{table}.{column} holds {shown(row[column])}{where}; expected {expected}"
    return None


def _is_json_list(value: Any) -> bool:
    if not isinstance(value, str):
        return False
    try:
        return isinstance(json.loads(value), list)
    except ValueError:
        return False


def configuration_problem(table: str, name: Any, text: Any) -> str | None:
    """What is wrong with a ``scenarios``/``policies`` row (its name text, its YAML or JSON text), or None."""
    if not isinstance(name, str):
        return f"{table} holds the name {shown(name)}; expected text"
    if not isinstance(text, str):
        return f"{table} row {name!r} holds {shown(text)}; expected text"
    return None


__all__ = ["cell_problem", "configuration_problem"]
