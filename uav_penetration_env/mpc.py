"""The MPC planner's settings, declared once: fields, defaults, help text and domains (model.md §7).

:class:`MPCSettings` is the one object that carries the horizon, discount, budget and terminal
cost from the command line (``uav-bench run`` and ``windows`` build their flags and ``--config``
keys from its fields) through :func:`~uav_penetration_env.benchmark.policies.make_policy` to the
planner and its objective. Each field's metadata holds its help text and its domain; the
dataclass checks every field against it, and :func:`parse_settings` converts text or YAML values
under the same rules, so a bad value is refused in one place, in one line naming the field.

The model never sees this object: ``PenetrationModel.rollout_cost`` takes the window's discount and
a terminal cost already built from the form (the ``value`` form reads the lattice value function,
which is built on the model), and ``policies.mpc_objective`` turns the settings into those
arguments (docs/architecture.md, "The MPC settings").
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from uav_penetration_env.types import TERMINAL_FORMS

FORMS_TEXT = ", ".join(TERMINAL_FORMS)
# The forms that read a c_T; the others ('none', 'value') have no scale to set.
SCALED_FORMS = ("distance", "dubins")


class SettingError(ValueError):
    """A setting outside its domain: ``FIELD: got VALUE, expected DOMAIN`` (one line).

    Attributes:
        field: the :class:`MPCSettings` field (``max_evals``; the command line's ``--max-evals``).
        value: the value as given.
        expected: the domain, in words.
        context: words between the value and ``expected`` (the form a c_T was given with).
    """

    def __init__(self, field: str, value: Any, expected: str, context: str = "") -> None:
        self.field, self.value, self.expected, self.context = field, value, expected, context
        super().__init__(f"{field}: {self.body}")

    @property
    def body(self) -> str:
        """The message without the field name: ``got VALUE, expected DOMAIN``."""
        return f"got {self.value!r}{self.context}, expected {self.expected}"


def _setting(
    default: Any, kind: type, expected: str, allowed: Callable[[Any], bool], help: str, **extra: Any
) -> Any:
    """A dataclass field with its command-line help and its domain (``kind``, ``allowed``) as metadata."""
    metadata = {"kind": kind, "expected": expected, "allowed": allowed, "help": help, **extra}
    return dataclasses.field(default=default, metadata=metadata)


@dataclass(frozen=True)
class MPCSettings:
    """The MPC planner's settings; :data:`MPC_DEFAULTS` is the benchmark's one set of defaults.

    ``MPCPolicy``, ``make_policy``, the window runs and ``uav-bench run``/``windows`` all take
    their settings as one such object and their defaults from :data:`MPC_DEFAULTS` (model.md §7).
    Values are kept as given (an ``int`` discount stays one: it is hashed into the policy key);
    :func:`parse_settings` converts command-line and YAML values.

    Attributes:
        horizon: H, control steps per plan (paper §5: 5).
        discount: gamma of eq. 37, in (0, 1].
        max_evals: objective evaluations per planning step, >= 1 (paper §5: 10 000).
        terminal: the form of the terminal cost that prices the state a window ends in
            (model.md §7e: ``none``, the paper's literal eq. 37 and the ``NAME-eq37`` policies;
            ``distance``; ``dubins``; ``value``, the lattice value function).
        terminal_cost: c_T of the ``distance`` and ``dubins`` forms; None takes the form's default
            (``distance``: 0.06; ``dubins``: the scenario's calibrated J per step).

    Raises:
        SettingError: (a ``ValueError``) a field outside its domain, naming the field.
    """

    horizon: int = _setting(
        5, int, "an integer >= 1", lambda v: v >= 1, "MPC horizon H, control steps per plan"
    )
    discount: float = _setting(
        1.0, float, "a number in (0, 1]", lambda v: 0.0 < v <= 1.0, "MPC discount gamma of eq. 37"
    )
    max_evals: int = _setting(
        10_000,
        int,
        "an integer >= 1",
        lambda v: v >= 1,
        "objective evaluations per planning step (per window run)",
    )
    # DECISION (model.md §7e.4): the lattice value function, chosen on procedural scenarios
    # outside every published table.
    terminal: str = _setting(
        "value",
        str,
        f"one of {FORMS_TEXT}",
        lambda v: v in TERMINAL_FORMS,
        f"form of the MPC terminal cost (docs/model.md §7e): {FORMS_TEXT}",
    )
    terminal_cost: float | None = _setting(
        None,
        float,
        "a finite number >= 0",
        lambda v: math.isfinite(v) and v >= 0.0,
        "c_T of the distance and dubins terminal forms",
        optional=True,
        default_text="0.06 for distance, the scenario's calibrated J per step for dubins",
    )

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if value is None and field.metadata.get("optional"):
                continue
            if not _in_domain(field, value):
                expected = field.metadata["expected"]
                optional = field.metadata.get("optional", False)
                raise SettingError(field.name, value, f"None or {expected}" if optional else expected)

    def with_form(self, form: str | None) -> MPCSettings:
        """The settings of a planner whose name fixes the terminal form (``NAME-ctg-distance``, ``NAME-eq37``).

        ``form`` None (a plain name) keeps these settings. A form replaces ``terminal``, and c_T
        reaches it only if the form has one (``distance``, ``dubins``): ``--terminal-cost 0.3``
        then prices every planner whose form reads a c_T.
        """
        if form is None:
            return self
        scale = self.terminal_cost if form in SCALED_FORMS else None
        return dataclasses.replace(self, terminal=form, terminal_cost=scale)

    def check_terminal_pair(self) -> None:
        """Refuse a c_T given with a form that has none (``none``, ``value``): never silently ignored.

        DECISION (api.md §4.1): the pair is checked where a planner is built (``MPCPolicy``), not
        by the dataclass, since the command line's settings are a request that a name suffix may
        still change (``--terminal-cost 0.3 --policies hpso-ctg-distance`` under the default
        ``value`` form is a c_T for the distance planner, not a contradiction).

        Raises:
            SettingError: ``terminal_cost: got C with the 'FORM' terminal form, expected None (...)``.
        """
        if self.terminal_cost is not None and self.terminal not in SCALED_FORMS:
            raise SettingError(
                "terminal_cost",
                self.terminal_cost,
                "None (c_T belongs to the 'distance' and 'dubins' forms: --terminal distance or dubins)",
                context=f" with the {self.terminal!r} terminal form",
            )


def _in_domain(field: dataclasses.Field[Any], value: Any) -> bool:
    """Whether ``value`` has the field's kind (a bool is no number) and lies in its domain."""
    kind = field.metadata["kind"]
    required = {str: str, int: numbers.Integral, float: numbers.Real}[kind]
    if isinstance(value, bool) or not isinstance(value, required):
        return False
    return bool(field.metadata["allowed"](value))


MPC_DEFAULTS = MPCSettings()
SETTING_FIELDS = tuple(field.name for field in dataclasses.fields(MPCSettings))


def _converted(field: dataclasses.Field[Any], value: Any) -> Any:
    """``value`` (text from a flag, a YAML scalar) converted to the field's kind, or raise ValueError."""
    kind = field.metadata["kind"]
    if kind is str:
        return value
    if isinstance(value, bool) or (kind is int and isinstance(value, float) and not value.is_integer()):
        raise ValueError(value)
    return kind(value)


def parse_settings(values: Mapping[str, Any], base: MPCSettings = MPC_DEFAULTS) -> MPCSettings:
    """``base`` with the given fields replaced, each converted to its kind first (``"5"`` -> 5, ``1`` -> 1.0).

    Args:
        values: field name -> value from a command line or a YAML file; a None value is not given
            (the field keeps ``base``'s value). Names that are not fields are ignored, so a whole
            ``argparse`` namespace may be passed.
        base: the settings the values change.

    Raises:
        SettingError: the first value that cannot be converted or lies outside its domain, with
            the value as given (``max_evals: got 'lots', expected an integer >= 1``).
    """
    changes = {}
    for field in dataclasses.fields(MPCSettings):
        value = values.get(field.name)
        if value is None:
            continue
        try:
            converted = _converted(field, value)
            ok = _in_domain(field, converted)
        except (TypeError, ValueError, OverflowError):
            ok = False
        if not ok:
            raise SettingError(field.name, value, field.metadata["expected"])
        changes[field.name] = converted
    return dataclasses.replace(base, **changes) if changes else base


__all__ = ["MPC_DEFAULTS", "SETTING_FIELDS", "MPCSettings", "SettingError", "parse_settings"]
