"""The one error type of scenario data: which field, what value, what was expected (model.md §7b)."""

from __future__ import annotations

from typing import Any

__all__ = ["ScenarioError"]


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
        super().__init__(f"{field}: got {value!r}, expected {expected}")

    def within(self, prefix: str) -> ScenarioError:
        """The same error with ``prefix`` prepended to the field path."""
        if not prefix:
            return self
        joined = f"{prefix}{self.field}" if self.field.startswith("[") else f"{prefix}.{self.field}"
        return ScenarioError(joined, self.value, self.expected)
