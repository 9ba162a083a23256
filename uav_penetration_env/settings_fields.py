"""Settings declared once: a frozen dataclass field names its flag, config key, help, kind and domain.

A settings class (``uav-bench run``'s :class:`~uav_penetration_env.benchmark.commands.run_settings.RunSettings`,
``uav-bench train``'s ``baselines.plan.TrainConfig``, ``uav-bench distill``'s
``baselines.distill.config.DistillConfig``) declares each setting as one field made by
:func:`setting`: its default, its kind, its help text and its domain. Everything else is generated
from that declaration, here, once:

- :func:`add_flags`: one ``argparse`` flag per field (``batch_size`` -> ``--batch-size``), with
  its help text and ``(default: ...)``; every flag's parser default is None ("not given"), so a
  command knows what was typed and the dataclass keeps the one default;
- :func:`config_keys`: the keys a config file (YAML/JSON mapping) may hold;
- :func:`parse_values`: flags or config values converted to their kinds and checked, into an
  instance, refusing the first bad one in one line (``--rounds: got -1, expected an integer >= 0``);
- :func:`check_fields`: the same check of an instance built from Python.

A new setting is one new field: the flag, the config key, the default and the check follow. The
MPC planner's settings (:class:`~uav_penetration_env.mpc.MPCSettings`) follow the same rule with
their own two-key terminal cost; they share :class:`SettingError` and :func:`converted`.
"""

from __future__ import annotations

import argparse
import dataclasses
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

# The kinds a value is checked against (a bool is no number; numpy integers are integers).
_REQUIRED: dict[Any, Any] = {str: str, int: numbers.Integral, float: numbers.Real, bool: bool}


class SettingError(ValueError):
    """A setting outside its domain: ``NAME: got VALUE, expected DOMAIN`` (one line).

    Attributes:
        field: the setting's name as the caller words it (a field, a config key or a ``--flag``).
        value: the value as given.
        expected: the domain, in words.
        context: words between the value and ``expected``.
    """

    def __init__(self, field: str, value: Any, expected: str, context: str = "") -> None:
        self.field, self.value, self.expected, self.context = field, value, expected, context
        super().__init__(f"{field}: {self.body}")

    @property
    def body(self) -> str:
        """The message without the name: ``got VALUE, expected DOMAIN``."""
        return f"got {self.value!r}{self.context}, expected {self.expected}"


def _anything(value: Any) -> bool:
    return True


@dataclass(frozen=True)
class Setting:
    """How one dataclass field is set: the metadata :func:`setting` attaches to it.

    Attributes:
        kind: what a value is: ``int``, ``float``, ``str``, ``bool``; a tuple of types (kept as
            given if it is one of them: ``(str, int)``); ``object`` (anything, unchecked). For a
            list setting (``many``), the kind of each item.
        help: the flag's help text, before ``(default: ...)``.
        expected: the domain in words, as the one-line error says it.
        allowed: the domain test, on a value already of its kind (each item of a list setting
            with ``each``, else the whole tuple).
        flag: the flag (None: ``--`` and the field with ``-``; ``""``: no flag).
        key: the config-file key (None: the field's name; ``""``: not a config key).
        many: a list setting, argparse's ``nargs`` (``+``, ``*``) or ``append`` (a repeatable
            flag); held as a tuple.
        each: with ``many``, the domain is checked item by item and the error names the item.
        split: with ``many``, each item is split at commas (``--policies a,b`` is ``a b``).
        optional: None is in the domain (a setting that may be left unset).
        default_text: the default as the help says it (None: the field's default; ``""``: none said).
        switch: a flag without a value that sets this constant (``--no-progress``: False).
        choices: the flag's choices (argparse refuses others with its usage error).
        parse: the flag's argparse ``type`` (a path check), instead of ``kind``.
        metavar: the flag's metavar (None: the flag's name, ``--batch-size BATCH_SIZE``).
        required: the flag must be given (the command has no use for the default).
    """

    kind: Any
    help: str
    expected: str = ""
    allowed: Callable[[Any], bool] = _anything
    flag: str | None = None
    key: str | None = None
    many: str = ""
    each: bool = False
    split: bool = False
    optional: bool = False
    default_text: str | None = None
    switch: Any = None
    choices: tuple[str, ...] | None = None
    parse: Callable[[str], Any] | None = None
    metavar: str | None = None
    required: bool = False


def setting(default: Any, kind: Any, help: str, expected: str = "", **spec: Any) -> Any:
    """A dataclass field whose metadata is its :class:`Setting` (the one declaration of a setting)."""
    return dataclasses.field(default=default, metadata={"setting": Setting(kind, help, expected, **spec)})


def at_least(low: int) -> dict[str, Any]:
    """The domain of an integer setting >= ``low`` (:func:`setting`'s ``expected`` and ``allowed``)."""
    return {"expected": f"an integer >= {low}", "allowed": lambda value: value >= low}


def one_of(choices: tuple[str, ...]) -> dict[str, Any]:
    """The domain of a named choice (:func:`setting`'s ``expected`` and ``allowed``)."""
    return {"expected": f"one of {', '.join(choices)}", "allowed": choices.__contains__}


# The domain of a number in [0, 1] (a difficulty, a probability).
UNIT_INTERVAL: dict[str, Any] = {"expected": "a number in [0, 1]", "allowed": lambda value: 0.0 <= value <= 1.0}


def declared(cls: Any) -> tuple[tuple[dataclasses.Field[Any], Setting], ...]:
    """The fields of ``cls`` declared with :func:`setting`, in order, each with its :class:`Setting`."""
    return tuple((f, f.metadata["setting"]) for f in dataclasses.fields(cls) if "setting" in f.metadata)


def flag_of(field: dataclasses.Field[Any], spec: Setting) -> str:
    """The flag of a field: ``spec.flag``, else ``batch_size`` -> ``--batch-size`` (``""``: none)."""
    return ("--" + field.name.replace("_", "-")) if spec.flag is None else spec.flag


def key_of(field: dataclasses.Field[Any], spec: Setting) -> str:
    """The config-file key of a field: ``spec.key``, else its name (``""``: not a config key)."""
    return field.name if spec.key is None else spec.key


def config_keys(cls: Any) -> list[str]:
    """Every config-file key of ``cls``, in field order."""
    return [key for f, spec in declared(cls) if (key := key_of(f, spec))]


def default_text(field: dataclasses.Field[Any], spec: Setting) -> str:
    """The default as ``--help`` says it: ``spec.default_text``, else the default (a list joined by spaces)."""
    if spec.default_text is not None:
        return spec.default_text
    if spec.many and isinstance(field.default, (tuple, list)):
        return " ".join(str(item) for item in field.default) or "none"
    return str(field.default)


def add_flags(parser: argparse.ArgumentParser, cls: Any, fill: Mapping[str, str] | None = None) -> None:
    """One flag per declared field of ``cls``, in field order, each with parser default None (not given).

    A flag's text is converted by its kind (``--rounds x`` is argparse's usage error); its domain
    is checked by :func:`parse_values`, which also fills what was not given from the defaults.

    Args:
        parser: the command's parser.
        cls: the settings class.
        fill: values of ``{name}`` fields in the help texts, known only when the parser is built
            (the plug-in policy forms).
    """
    for field, spec in declared(cls):
        flag = flag_of(field, spec)
        if not flag:
            continue
        text = default_text(field, spec)
        help_text = spec.help.format_map(fill) if fill else spec.help
        options: dict[str, Any] = {
            "dest": field.name,
            "default": None,
            "help": f"{help_text} (default: {text})" if text else help_text,
        }
        if spec.switch is not None:
            options.update(action="store_const", const=spec.switch)
        else:
            kind = spec.parse or (spec.kind if spec.kind in (int, float) else None)
            # The metavar names the flag, as argparse's own would (``--timesteps TIMESTEPS``).
            metavar = spec.metavar or (None if spec.choices else flag.lstrip("-").replace("-", "_").upper())
            options.update(type=kind, choices=spec.choices, metavar=metavar, required=spec.required)
            if spec.many == "append":
                options["action"] = "append"
            elif spec.many:
                options["nargs"] = spec.many
        parser.add_argument(flag, **options)


def converted(kind: Any, value: Any) -> Any:
    """``value`` (text from a flag, a YAML scalar) converted to ``kind``, or raise ValueError.

    A bool is no number, and a float with a fraction is no integer; a tuple kind keeps a value of
    one of its types as it is; ``object`` keeps anything.
    """
    if kind is object or kind is str:
        return value
    if isinstance(kind, tuple):
        if not isinstance(value, kind):
            raise ValueError(value)
        return value
    if kind is bool:
        if not isinstance(value, bool):
            raise ValueError(value)
        return value
    if isinstance(value, bool) or (kind is int and isinstance(value, float) and not value.is_integer()):
        raise ValueError(value)
    return kind(value)


def in_domain(kind: Any, allowed: Callable[[Any], bool], value: Any) -> bool:
    """Whether ``value`` is of ``kind`` (a bool is no number) and ``allowed`` accepts it."""
    if kind is not object:
        required = kind if isinstance(kind, tuple) else _REQUIRED.get(kind, kind)
        if not isinstance(value, required) or (isinstance(value, bool) and kind in (int, float)):
            return False
    return bool(allowed(value))


def _checked(field: dataclasses.Field[Any], spec: Setting, value: Any, name: str, convert: bool) -> Any:
    """One field's value converted (``convert``) and checked; raise :class:`SettingError` naming ``name``."""
    if value is None and (spec.optional or field.default is None):
        return None
    if not spec.many:
        try:
            value = converted(spec.kind, value) if convert else value
        except (TypeError, ValueError, OverflowError):
            raise SettingError(name, value, spec.expected) from None
        if not in_domain(spec.kind, spec.allowed, value):
            raise SettingError(name, value, spec.expected)
        return value
    items = [value] if isinstance(value, str) else value
    if not isinstance(items, (list, tuple)):
        raise SettingError(name, value, spec.expected)
    if spec.split:
        items = [part for item in items for part in str(item).split(",") if part]
    try:
        kept = tuple(converted(spec.kind, item) if convert else item for item in items)
    except (TypeError, ValueError, OverflowError):
        raise SettingError(name, list(items), spec.expected) from None
    for item in kept:
        if spec.each and not in_domain(spec.kind, spec.allowed, item):
            raise SettingError(name, item, spec.expected)
        if not spec.each and not in_domain(spec.kind, _anything, item):
            raise SettingError(name, list(items), spec.expected)
    if not spec.each and not spec.allowed(kept):
        raise SettingError(name, list(items), spec.expected)
    return kept


def given_values(given: Mapping[str, Any] | argparse.Namespace, cls: Any, by: str = "flag") -> dict[str, Any]:
    """What was given (not None) for the declared fields of ``cls``, by field name.

    Args:
        given: a parsed namespace (``by="flag"``: read by field name) or a config mapping
            (``by="key"``: read by config key).
        cls: the settings class.
        by: how ``given`` names the settings.
    """
    values = vars(given) if isinstance(given, argparse.Namespace) else given
    out = {}
    for field, spec in declared(cls):
        name = field.name if by == "flag" else key_of(field, spec)
        if name and values.get(name) is not None:
            out[field.name] = values[name]
    return out


def parse_values(cls: Any, values: Mapping[str, Any], base: Any = None, label: str = "flag") -> Any:
    """``base`` (default: ``cls()``) with the given fields replaced, each converted to its kind and checked.

    Args:
        cls: the settings class.
        values: field name -> value as given (a flag's text or a config file's value; None: not
            given, ``base``'s kept); names of no declared field are ignored.
        base: the settings the values change.
        label: how an error names the setting: ``flag`` (``--batch-size``), ``key`` or ``field``.

    Raises:
        SettingError: the first value that cannot be converted or lies outside its domain, with
            the value as given.
    """
    changes = {}
    for field, spec in declared(cls):
        if values.get(field.name) is None:
            continue
        changes[field.name] = _checked(field, spec, values[field.name], _label(field, spec, label), True)
    base = cls() if base is None else base
    return dataclasses.replace(base, **changes) if changes else base


def check_fields(settings: Any, label: str = "field") -> None:
    """Check every declared field of an instance against its kind and domain (values as they are).

    Raises:
        SettingError: the first field outside its domain, named by ``label`` (``flag``,
            ``key``, ``field``).
    """
    for field, spec in declared(type(settings)):
        _checked(field, spec, getattr(settings, field.name), _label(field, spec, label), False)


def _label(field: dataclasses.Field[Any], spec: Setting, label: str) -> str:
    if label == "flag":
        return flag_of(field, spec) or field.name
    return (key_of(field, spec) or field.name) if label == "key" else field.name


__all__ = [
    "UNIT_INTERVAL",
    "Setting",
    "SettingError",
    "add_flags",
    "at_least",
    "check_fields",
    "config_keys",
    "converted",
    "declared",
    "default_text",
    "flag_of",
    "given_values",
    "in_domain",
    "key_of",
    "one_of",
    "parse_values",
    "setting",
]
