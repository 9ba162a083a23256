"""The one error type of scenario data: which field, what value, what was expected (model.md §7b)."""

from __future__ import annotations

from typing import Any

__all__ = ["ScenarioError"]


MAX_SHOWN = 240  # characters of a bad value's repr in a message


def one_line(text: str) -> str:
    """``text`` with every non-printable character (a newline in a YAML key) written as its escape."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))


def shown(value: Any) -> str:
    """``repr(value)`` on one line, cut to :data:`MAX_SHOWN` characters (a 5 000-character path still says what it is)."""
    text = repr(value)
    if len(text) > MAX_SHOWN:
        text = f"{text[: MAX_SHOWN - 40]}... ({len(text)} characters)"
    return one_line(text)


class ScenarioError(ValueError):
    """A scenario field holds an invalid value.

    Attributes:
        field: dotted path of the offending field, e.g. ``radars[2].x_km``.
        value: the value received.
        expected: what a valid value looks like.
    """

    def __init__(self, field: str, value: Any, expected: str) -> None:
        self.field = field
        self.value = value
        self.expected = expected
        super().__init__(f"{one_line(field)}: got {shown(value)}, expected {one_line(expected)}")

    def within(self, prefix: str) -> ScenarioError:
        """The same error with ``prefix`` prepended to the field path."""
        if not prefix:
            return self
        joined = f"{prefix}{self.field}" if self.field.startswith("[") else f"{prefix}.{self.field}"
        return ScenarioError(joined, self.value, self.expected)
