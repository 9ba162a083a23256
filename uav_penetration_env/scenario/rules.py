"""Checked fields: each schema field declares its own rule, and one ``__post_init__`` runs them all.

A schema dataclass inherits :class:`Checked` and declares a field as ``height_m: float =
non_negative(200.0)``; construction then raises :class:`ScenarioError` naming the field (relative
to its dataclass; the converter prefixes the path), the value and what was expected. Rules that
relate two fields stay in the dataclass's own ``__post_init__`` (after ``super().__post_init__()``)
through :func:`require`.

DECISION (model.md §7b): the rules of a dataclass run in field order, before its cross-field checks; a value that
breaks several rules is reported for the first field in the file's order.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from uav_penetration_env.scenario.errors import ScenarioError

__all__ = [
    "Checked",
    "Rule",
    "checked",
    "interval",
    "non_negative",
    "one_of",
    "positive",
    "require",
    "rule",
]

_RULES = "rules"  # the dataclasses.Field.metadata key holding a field's rules


def require(condition: bool, field_name: str, value: Any, expected: str) -> None:
    """Raise ``ScenarioError(field_name, value, expected)`` unless ``condition`` holds."""
    if not condition:
        raise ScenarioError(field_name, value, expected)


@dataclass(frozen=True)
class Rule:
    """A test one field's value must pass, and the wording of what a valid value looks like."""

    test: Callable[[Any], bool]
    expected: str

    def check(self, field_name: str, value: Any) -> None:
        """Raise :class:`ScenarioError` if ``value`` fails; tuples are shown as lists (as in YAML)."""
        if not self.test(value):
            raise ScenarioError(field_name, list(value) if isinstance(value, tuple) else value, self.expected)


POSITIVE = Rule(lambda v: v > 0, "a positive number")
NON_NEGATIVE = Rule(lambda v: v >= 0, "a number >= 0")
INTERVAL = Rule(lambda v: v[0] < v[1], "[low, high] with low < high")


def checked(default: Any = dataclasses.MISSING, *rules: Rule) -> Any:
    """A dataclass field with ``default`` (``MISSING``: required) whose non-null value must pass ``rules``."""
    return dataclasses.field(default=default, metadata={_RULES: rules})


def rule(default: Any, test: Callable[[Any], bool], expected: str) -> Any:
    """A field checked by one ad-hoc ``test`` with its ``expected`` wording."""
    return checked(default, Rule(test, expected))


def positive(default: Any = dataclasses.MISSING) -> Any:
    """A field holding a number > 0."""
    return checked(default, POSITIVE)


def non_negative(default: Any = dataclasses.MISSING) -> Any:
    """A field holding a number >= 0."""
    return checked(default, NON_NEGATIVE)


def interval(default: Any = dataclasses.MISSING, *more: Rule) -> Any:
    """A ``(low, high)`` field with low < high, then any ``more`` rules."""
    return checked(default, INTERVAL, *more)


def one_of(options: tuple[Any, ...], default: Any = dataclasses.MISSING) -> Any:
    """A field holding one of ``options``."""
    return checked(default, Rule(lambda v: v in options, "one of " + ", ".join(repr(o) for o in options)))


class Checked:
    """Base of the schema dataclasses: checks every field against the rules it declares.

    ``None`` is never checked: whether a field may be null is its type's business (the converter
    refuses null where the type is not optional).
    """

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):  # type: ignore[arg-type]
            value = getattr(self, field.name)
            if value is not None:
                for field_rule in field.metadata.get(_RULES, ()):
                    field_rule.check(field.name, value)
