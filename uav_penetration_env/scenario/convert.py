"""Plain data <-> frozen dataclasses, driven by the type hints alone (model.md §7b).

:func:`from_mapping` builds a dataclass from nested mappings and lists as read from YAML, checking
every value against its field's type and naming the path of the first bad one (``radars[2].x_km``);
an unknown key gets a did-you-mean hint (:mod:`uav_penetration_env.suggest`). :func:`to_plain` is
its inverse. Nothing here knows the scenario schema; a dataclass steers the conversion with
class attributes:

* ``OMIT_NONE``: fields written out only when not ``None``;
* ``MAPPINGS``: ``tuple[tuple[str, Any], ...]`` fields written as a mapping of plain scalars;
* a union of dataclasses is *tagged*: each variant's first field (``method``, ``model``) has the
  variant's tag as its default, and a mapping without the tag is the union's first variant.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Callable, Mapping
from functools import cache
from typing import Any, Union, get_args, get_origin

import numpy as np

from uav_penetration_env.scenario.errors import ScenarioError
from uav_penetration_env.suggest import did_you_mean

__all__ = ["deep_merge", "from_mapping", "to_plain"]


def from_mapping(cls: type, data: Any, path: str = "") -> Any:
    """Build dataclass ``cls`` from plain ``data``; ``path`` prefixes every error's field.

    Raises:
        ScenarioError: ``data`` is not a mapping, a key is unknown, a required field is missing,
            a value has the wrong type, or the dataclass's own checks fail.
    """
    if isinstance(data, cls):
        return data
    if not isinstance(data, Mapping):
        raise ScenarioError(path or "scenario", data, f"a mapping of {cls.__name__} fields")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    hints = _hints(cls)
    kwargs: dict[str, Any] = {}
    for key, value in data.items():
        if key not in fields:
            allowed = list(fields)
            raise ScenarioError(
                _join(path, str(key)),
                value,
                f"a known key ({did_you_mean(key, allowed)}allowed: {', '.join(allowed)})",
            )
        kwargs[key] = _convert(hints[key], value, _join(path, key), cls, key)
    for name, f in fields.items():
        if (
            name not in kwargs
            and f.default is dataclasses.MISSING
            and f.default_factory is dataclasses.MISSING
        ):
            raise ScenarioError(_join(path, name), None, "a value (this field is required)")
    try:
        return cls(**kwargs)
    except ScenarioError as error:
        raise error.within(path) from None


def to_plain(obj: Any) -> Any:
    """``obj`` (a dataclass, tuple or scalar) as YAML-ready dicts, lists and Python scalars."""
    if dataclasses.is_dataclass(obj):
        out: dict[str, Any] = {}
        for f in dataclasses.fields(obj):
            value = getattr(obj, f.name)
            if value is None and f.name in getattr(obj, "OMIT_NONE", ()):
                continue
            if f.name in getattr(obj, "MAPPINGS", ()):
                out[f.name] = {k: to_plain(v) for k, v in value}
            else:
                out[f.name] = to_plain(value)
        return out
    if isinstance(obj, tuple):
        return [to_plain(v) for v in obj]
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return obj


def deep_merge(
    base: dict[str, Any], changes: Mapping[str, Any], tag_fields: tuple[str, ...]
) -> dict[str, Any]:
    """``base`` with ``changes`` merged in, key by key at every depth.

    A nested mapping whose tag (one of ``tag_fields``) changes replaces the old one outright: a
    tagged union switched to another variant starts from that variant's defaults.
    """
    merged = dict(base)
    for key, value in changes.items():
        if isinstance(value, Mapping) and isinstance(merged.get(key), dict):
            current = merged[key]
            tag = next((t for t in tag_fields if t in value and t in current), None)
            if tag is not None and value[tag] != current[tag]:
                merged[key] = dict(value)
            else:
                merged[key] = deep_merge(current, value, tag_fields)
        else:
            merged[key] = value
    return merged


@cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _convert(tp: Any, value: Any, path: str, owner: type, name: str) -> Any:
    """``value`` as type ``tp`` (field ``name`` of dataclass ``owner``), or ScenarioError at ``path``."""
    if get_origin(tp) in (Union, types.UnionType):
        options = [a for a in get_args(tp) if a is not type(None)]
        if value is None:
            if len(options) < len(get_args(tp)):
                return None
            raise ScenarioError(path, value, "a value (null is not allowed here)")
        if len(options) == 1:
            return _convert(options[0], value, path, owner, name)
        return _convert_tagged(options, value, path)
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        return from_mapping(tp, value, path)
    if tp in _SCALARS:
        accepts, expected = _SCALARS[tp]
        if not accepts(value):
            raise ScenarioError(path, value, expected)
        return tp(value)
    if get_origin(tp) is tuple:
        return _convert_tuple(get_args(tp), value, path, owner, name)
    if tp is Any:
        return _plain_scalar(value, path)
    raise TypeError(f"unsupported schema type {tp!r} at {path}")  # a bug in the schema, not user input


def _is_number(value: Any) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)


# Scalar field types: which plain values each accepts (then converted by calling the type) and
# the wording of what it expected.
# DECISION (model.md §7b, "limits"): a float field's magnitude is at most MAX_MAGNITUDE in its own
# unit, far above any physical value of a scenario (km, m, s, degrees, m^2), so that squares and
# products inside the physics stay finite in float64 (1e308 passed "finite" and overflowed there).
MAX_MAGNITUDE = 1e12
_SCALARS: dict[type, tuple[Callable[[Any], bool], str]] = {
    float: (lambda v: _is_number(v) and abs(v) <= MAX_MAGNITUDE, f"a finite number of magnitude at most {MAX_MAGNITUDE:g}"),
    int: (lambda v: _is_number(v) and float(v) == int(v), "an integer"),
    bool: (lambda v: isinstance(v, bool), "true or false"),
    str: (lambda v: isinstance(v, str), "a string"),
}


def _convert_tuple(args: tuple[Any, ...], value: Any, path: str, owner: type, name: str) -> tuple[Any, ...]:
    if name in getattr(owner, "MAPPINGS", ()):
        if not isinstance(value, Mapping):
            raise ScenarioError(path, value, "a mapping")
        return tuple((str(k), _plain_scalar(v, f"{path}.{k}")) for k, v in value.items())
    variadic = len(args) == 2 and args[1] is Ellipsis
    described = (
        f"items of {getattr(args[0], '__name__', args[0])}"
        if variadic
        else ", ".join(getattr(a, "__name__", str(a)) for a in args)
    )
    if not isinstance(value, (list, tuple)):
        raise ScenarioError(path, value, f"a list ({described})")
    if variadic:
        item_types = [args[0]] * len(value)
    elif len(value) != len(args):
        raise ScenarioError(path, list(value), f"a list of {len(args)} values ({described})")
    else:
        item_types = list(args)
    return tuple(
        _convert(tp, v, f"{path}[{i}]", owner, name)
        for i, (tp, v) in enumerate(zip(item_types, value, strict=True))
    )


def _tag(variant: type) -> Any:
    return dataclasses.fields(variant)[0].default


def _convert_tagged(options: list[type], value: Any, path: str) -> Any:
    """A union of dataclasses told apart by their first field (``method`` or ``model``)."""
    tag_field = dataclasses.fields(options[0])[0].name
    tags = {_tag(opt): opt for opt in options}
    if not isinstance(value, Mapping):
        raise ScenarioError(path, value, f"a mapping with '{tag_field}' in {sorted(tags)}")
    tag = value.get(tag_field, _tag(options[0]))
    if not isinstance(tag, str) or tag not in tags:  # a list or mapping is no tag (and unhashable)
        hint = did_you_mean(tag, tags) if isinstance(tag, str) else ""
        raise ScenarioError(
            f"{path}.{tag_field}", tag, f"a known {tag_field} ({hint}one of {', '.join(tags)})"
        )
    return from_mapping(tags[tag], value, path)


def _plain_scalar(value: Any, path: str) -> Any:
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (list, tuple)):
        return tuple(_plain_scalar(v, path) for v in value)
    raise ScenarioError(path, value, "a scalar, string or list")
