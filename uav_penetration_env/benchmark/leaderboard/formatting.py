"""Text formatting of leaderboard numbers and Markdown tables (deterministic, no exponents)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from uav_penetration_env.benchmark.safe_text import markdown_cell


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
    cells = [[markdown_cell(c) for c in line] for line in [header, *rows]]  # one line each, | escaped
    widths = [max(3, *(len(line[i]) for line in cells)) for i in range(len(header))]

    def render(line: Sequence[str]) -> str:
        padded = [c.rjust(w) if a == "r" else c.ljust(w) for c, w, a in zip(line, widths, align, strict=True)]
        return "| " + " | ".join(padded) + " |"

    rule = ["-" * (w - 1) + ":" if a == "r" else "-" * w for w, a in zip(widths, align, strict=True)]
    return "\n".join([render(cells[0]), "| " + " | ".join(rule) + " |", *(render(c) for c in cells[1:])])


def markdown_section(
    title: str, text: str, header: Sequence[str], rows: Sequence[Sequence[str]], align: Sequence[str]
) -> list[str]:
    """The lines of a page section: ``## title``, the paragraph ``text`` (none when empty), the table.

    Args:
        title: the heading, without ``## ``.
        text: the paragraph under it (``""``: none).
        header: the table's column titles (:func:`markdown_table`).
        rows: its cell texts, one list per row.
        align: ``"l"`` or ``"r"`` per column.

    Returns:
        The lines, a blank line after each part.
    """
    paragraph = [text, ""] if text else []
    return [f"## {title}", "", *paragraph, markdown_table(header, rows, align), ""]


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

