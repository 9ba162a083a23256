"""The MPC planner's settings, declared once: fields, defaults, help text and domains (model.md §7).

:class:`MPCSettings` is the one object that carries the horizon, discount, budget and terminal
cost from the command line (``uav-bench run`` and ``windows`` build their flags and ``--config``
keys from its fields) through :func:`~uav_penetration_env.benchmark.policies.make_policy` to the
planner and its objective. Each field's metadata holds its help text and its domain; the
dataclass checks every field against it, and :func:`parse_settings` converts text or YAML values
under the same rules, so a bad value is refused in one place, in one line naming the setting.

The terminal cost is one field, a :class:`Terminal` (its form and its scale c_T), set by two
flags (``--terminal`` and ``--terminal-cost``, the ``--config`` keys ``terminal`` and
``terminal_cost``). The model never sees the settings: ``PenetrationModel.rollout_cost`` takes
the window's discount and a terminal cost built from the :class:`Terminal`
(:func:`uav_penetration_env.terminal.terminal_cost`: the ``value`` form reads the lattice value
function, which is built on the model), and ``policies.mpc_objective`` turns the settings into
those arguments (docs/architecture.md, "The MPC settings").
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from uav_penetration_env.settings_fields import SettingError, converted, in_domain
from uav_penetration_env.types import TERMINAL_FORMS

FORMS_TEXT = ", ".join(TERMINAL_FORMS)
# The forms that read a c_T; the others ('none', 'value') have no scale to set.
SCALED_FORMS = ("distance", "dubins")
SCALE_EXPECTED = "a finite number >= 0"


@dataclass(frozen=True)
class Terminal:
    """The terminal cost of MPC windows as a setting: its form and its scale c_T (model.md §7e).

    The one representation of the terminal cost in the settings, the planners and the window
    runs; :func:`uav_penetration_env.terminal.terminal_cost` builds it on a scenario's model into
    what ``PenetrationModel.rollout_cost`` reads.

    Attributes:
        form: what prices the pose a window ends in: ``none`` (nothing: the paper's literal eq. 37,
            the ``NAME-eq37`` planners), ``distance`` (c_T per straight-line step to the goal),
            ``dubins`` (c_T per step of the shortest forward path) or ``value`` (the lattice
            value function).
        scale: c_T >= 0 [J per remaining step at v_max] of the ``distance`` and ``dubins`` forms;
            None takes the form's default (``distance``: 0.06; ``dubins``: the scenario's
            calibrated J per step). Kept as given (it is hashed into the policy key).

    Raises:
        SettingError: ``terminal: got 'euclid', expected one of none, distance, dubins, value``,
            or ``terminal_cost: got -1.0, expected None or a finite number >= 0``.
    """

    form: str = "value"
    scale: float | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.form, str) and self.form in TERMINAL_FORMS):
            raise SettingError("terminal", self.form, f"one of {FORMS_TEXT}")
        if self.scale is not None and not _is_scale(self.scale):
            raise SettingError("terminal_cost", self.scale, f"None or {SCALE_EXPECTED}")

    def with_form(self, form: str | None) -> Terminal:
        """This terminal cost with the form a planner's name fixes (``NAME-ctg-distance``, ``NAME-eq37``).

        ``form`` None (a plain name) keeps it. A form replaces ``form``, and c_T reaches it only
        if the form has one (``distance``, ``dubins``): ``--terminal-cost 0.3`` then prices every
        planner whose form reads a c_T.
        """
        if form is None:
            return self
        return Terminal(form, self.scale if form in SCALED_FORMS else None)

    def check_pair(self) -> None:
        """Refuse a c_T given with a form that has none (``none``, ``value``): never silently ignored.

        DECISION (api.md §4.1): the pair is checked where a planner is built (``MPCPolicy``), not
        by the dataclass, since the command line's settings are a request that a name suffix may
        still change (``--terminal-cost 0.3 --policies hpso-ctg-distance`` under the default
        ``value`` form is a c_T for the distance planner, not a contradiction).

        Raises:
            SettingError: ``terminal_cost: got C with the 'FORM' terminal form, expected None (...)``.
        """
        if self.scale is not None and self.form not in SCALED_FORMS:
            raise SettingError(
                "terminal_cost",
                self.scale,
                "None (c_T belongs to the 'distance' and 'dubins' forms: --terminal distance or dubins)",
                context=f" with the {self.form!r} terminal form",
            )


def _is_scale(value: Any) -> bool:
    """Whether ``value`` is a c_T: a real number (no bool), finite and >= 0."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return False
    scale = float(value)
    return math.isfinite(scale) and scale >= 0.0


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
        terminal: the terminal cost that prices the state a window ends in, its form and c_T
            (:class:`Terminal`; model.md §7e).

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
    terminal: Terminal = _setting(  # noqa: RUF009  (a dataclasses.field; Terminal is frozen)
        Terminal(),
        Terminal,
        "a Terminal(form, scale)",
        lambda v: True,  # a Terminal checks itself
        "the terminal cost of MPC windows (docs/model.md §7e)",
        keys=(
            (
                "terminal",
                str,
                f"form of the MPC terminal cost (docs/model.md §7e): {FORMS_TEXT}",
                "value",
            ),
            (
                "terminal_cost",
                float,
                "c_T of the distance and dubins terminal forms",
                "0.06 for distance, the scenario's calibrated J per step for dubins",
            ),
        ),
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
        """The settings of a planner whose name fixes the terminal form (:meth:`Terminal.with_form`)."""
        terminal = self.terminal.with_form(form)
        return self if terminal is self.terminal else dataclasses.replace(self, terminal=terminal)

    def check_terminal_pair(self) -> None:
        """Refuse a c_T given with a form that has none (:meth:`Terminal.check_pair`)."""
        self.terminal.check_pair()

    def with_keys(self, changes: Mapping[str, Any]) -> MPCSettings:
        """These settings with settings keys replaced, values kept as given (``make_policy``'s ``**changes``).

        DECISION (api.md §4.1): the keywords are the settings keys of the command line and of
        ``run --config`` (``terminal``: the form's name; ``terminal_cost``: its c_T), not the
        dataclass's fields, so a script writes what a user types
        (``make_policy("hpso", terminal="distance", terminal_cost=0.2)``); the two keys build the
        one :class:`Terminal`, and a whole ``Terminal`` is accepted as ``terminal``.

        Args:
            changes: settings key (:data:`SETTING_FIELDS`) -> value: ``horizon``, ``discount``,
                ``max_evals``, ``terminal`` (a form name, or a whole :class:`Terminal`) and
                ``terminal_cost`` (c_T, or None for the form's default).

        Raises:
            TypeError: a key that names no setting.
            SettingError: a value outside its domain.
        """
        unknown = sorted(set(changes) - set(SETTING_FIELDS))
        if unknown:
            raise TypeError(f"{unknown[0]}: not an MPC setting, expected one of {', '.join(SETTING_FIELDS)}")
        fields = {k: v for k, v in changes.items() if k not in ("terminal", "terminal_cost")}
        if "terminal" in changes or "terminal_cost" in changes:
            terminal = changes.get("terminal", self.terminal)
            if isinstance(terminal, Terminal):
                scale = changes.get("terminal_cost", terminal.scale)
                fields["terminal"] = terminal if scale is terminal.scale else Terminal(terminal.form, scale)
            else:
                fields["terminal"] = Terminal(terminal, changes.get("terminal_cost", self.terminal.scale))
        return dataclasses.replace(self, **fields) if fields else self


def _in_domain(field: dataclasses.Field[Any], value: Any) -> bool:
    """Whether ``value`` has the field's kind (a bool is no number) and lies in its domain."""
    return in_domain(field.metadata["kind"], field.metadata["allowed"], value)


MPC_DEFAULTS = MPCSettings()


def setting_keys(field: dataclasses.Field[Any]) -> tuple[tuple[str, type, str, str], ...]:
    """The keys that set one field, each ``(key, kind, help, default text)``: one per field, two for ``terminal``.

    A key is a ``--config`` key and, with dashes, a flag (``max_evals``, ``--max-evals``).
    """
    meta = field.metadata
    if "keys" in meta:
        return tuple(meta["keys"])
    default = meta.get("default_text", field.default)
    return ((field.name, meta["kind"], meta["help"], str(default)),)


# Every settings key, in field order: what the command line and ``run --config`` accept.
SETTING_FIELDS = tuple(key[0] for field in dataclasses.fields(MPCSettings) for key in setting_keys(field))


def parse_settings(values: Mapping[str, Any], base: MPCSettings = MPC_DEFAULTS) -> MPCSettings:
    """``base`` with the given settings replaced, each converted to its kind first (``"5"`` -> 5, ``1`` -> 1.0).

    Args:
        values: settings key (:data:`SETTING_FIELDS`) -> value from a command line or a YAML file;
            a None value is not given (the setting keeps ``base``'s value). Other names are
            ignored, so a whole ``argparse`` namespace may be passed. ``terminal`` (the form) and
            ``terminal_cost`` (c_T) each replace their part of ``base.terminal``.
        base: the settings the values change.

    Raises:
        SettingError: the first value that cannot be converted or lies outside its domain, with
            the value as given (``max_evals: got 'lots', expected an integer >= 1``).
    """
    changes: dict[str, Any] = {}
    for field in dataclasses.fields(MPCSettings):
        given = {}
        for key, kind, _, _ in setting_keys(field):
            value = values.get(key)
            if value is None:
                continue
            try:
                given[key] = converted(kind, value)
            except (TypeError, ValueError, OverflowError):
                raise SettingError(key, value, _expected(field, key)) from None
        if not given:
            continue
        if field.name == "terminal":
            if "terminal_cost" in given and not _is_scale(given["terminal_cost"]):
                raise SettingError("terminal_cost", values["terminal_cost"], SCALE_EXPECTED)
            changes["terminal"] = Terminal(
                given.get("terminal", base.terminal.form), given.get("terminal_cost", base.terminal.scale)
            )
            continue
        value = given[field.name]
        if not _in_domain(field, value):
            raise SettingError(field.name, values[field.name], field.metadata["expected"])
        changes[field.name] = value
    return dataclasses.replace(base, **changes) if changes else base


def _expected(field: dataclasses.Field[Any], key: str) -> str:
    """The domain of a settings key, in words."""
    if key == "terminal":
        return f"one of {FORMS_TEXT}"
    if key == "terminal_cost":
        return SCALE_EXPECTED
    return str(field.metadata["expected"])


__all__ = [
    "MPC_DEFAULTS",
    "SCALED_FORMS",
    "SETTING_FIELDS",
    "MPCSettings",
    "SettingError",
    "Terminal",
    "parse_settings",
    "setting_keys",
]
