"""Names from plug-ins and stores, made safe for where they are shown: the terminal, Markdown tables, spreadsheets.

A policy, optimiser or scenario name is whatever a plug-in registered or a (shared) store holds,
so it may carry an escape sequence that recolours or retitles a terminal, a line break that splits
a Markdown table row, or a leading ``=`` that a spreadsheet runs as a formula. Each output has one
place where text reaches it, and that place uses this module:

* the terminal: :func:`safe_stdout` wraps standard output for a whole ``uav-bench`` command;
  every control character but the newline and the tab is written as its escape, as ``repr`` shows it;
* Markdown tables: :func:`markdown_cell`, used by ``leaderboard.formatting.markdown_table``;
* CSV tables for people (leaderboards, fixed-target tables): :func:`write_csv_table`.

DECISION (api.md §4.7): in those CSV tables a text cell that starts with ``=``, ``+``, ``-``,
``@``, a tab or a carriage return and is not a number gets a leading apostrophe (the OWASP rule
against CSV injection), so a spreadsheet shows it as text, and control characters other than the
newline and the tab are escaped; numbers, ``-0.5`` written as text
included, are never changed, so ordinary tables are written byte for byte as before. Exported
rows (``uav-bench export``) are data for ``import`` and are written unchanged.
"""

from __future__ import annotations

import sys
import unicodedata
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

if TYPE_CHECKING:  # pandas only where a table is written: `uav-bench --help` imports this module
    import pandas as pd

UNSAFE_CATEGORIES = ("Cc", "Cf", "Zl", "Zp")  # controls, format (bidi overrides), line/paragraph separators
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def _escape(character: str) -> str:
    return character.encode("unicode_escape").decode("ascii")


def terminal_safe(text: str, keep: str = "\n\t") -> str:
    """``text`` with every control or format character outside ``keep`` written as its escape."""
    return "".join(
        c if c in keep or unicodedata.category(c) not in UNSAFE_CATEGORIES else _escape(c) for c in str(text)
    )


def markdown_cell(text: Any) -> str:
    """One Markdown table cell: on one line (control characters escaped, the newline too), ``|`` escaped."""
    return terminal_safe(str(text), keep="").replace("|", "\\|")


class SafeStream:
    """A text stream that escapes control characters (:func:`terminal_safe`) and passes the rest through.

    Attributes:
        unescaped: the wrapped stream, for a writer that styles its own output (rich) from text it
            has made safe itself.
    """

    def __init__(self, stream: IO[str]) -> None:
        self.unescaped = stream

    def write(self, text: str) -> int:
        """Write ``text`` with its control characters escaped; returns its length, as ``write`` does."""
        self.unescaped.write(terminal_safe(text))
        return len(text)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.unescaped, name)


def unescaped(stream: IO[str]) -> IO[str]:
    """The stream under a :class:`SafeStream` (``stream`` itself otherwise)."""
    return getattr(stream, "unescaped", stream) if isinstance(stream, SafeStream) else stream


@contextmanager
def safe_stdout() -> Iterator[None]:
    """Standard output wrapped in a :class:`SafeStream` for the block (restored after it)."""
    previous = sys.stdout
    wrapped = SafeStream(previous)
    sys.stdout = wrapped  # type: ignore[assignment]
    try:
        yield
    finally:
        if sys.stdout is wrapped:
            sys.stdout = previous


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def spreadsheet_cell(value: Any) -> Any:
    """``value``, made safe if it is text (see the module docstring).

    Control characters but the newline and the tab are escaped first (a carriage return is not
    quoted by a CSV writer whose lines end in a newline, so it would split the row); then text a
    spreadsheet would run as a formula gets a leading apostrophe.
    """
    if not isinstance(value, str):
        return value
    value = terminal_safe(value)
    if value.startswith(FORMULA_STARTS) and not _is_number(value):
        return "'" + value
    return value


def write_csv_table(frame: pd.DataFrame, path: str | Path) -> Path:
    """Write a table meant for people as CSV, atomically, its formula-like text cells neutralised."""
    import pandas as pd

    from uav_penetration_env.atomic import atomic_path

    safe = frame.copy()
    for column in safe.columns:
        if safe[column].dtype == object or pd.api.types.is_string_dtype(safe[column]):
            safe[column] = safe[column].map(spreadsheet_cell)
    safe.columns = [spreadsheet_cell(c) if isinstance(c, str) else c for c in safe.columns]
    with atomic_path(path) as temporary:
        safe.to_csv(temporary, index=False, lineterminator="\n")
    return Path(path)


__all__ = [
    "SafeStream",
    "markdown_cell",
    "safe_stdout",
    "spreadsheet_cell",
    "terminal_safe",
    "unescaped",
    "write_csv_table",
]
