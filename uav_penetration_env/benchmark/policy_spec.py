r"""The grammar of a policy name and its typed parameters: ``kind[param=value,...]`` (api.md §4.1).

A policy name is read once, here, into a frozen :class:`PolicySpec`; every consumer
(:func:`~uav_penetration_env.benchmark.policies.make_policy`, the store label, the fast refusal
of ``uav-bench run``) reads the spec, never the text. This module knows the syntax and how a
parameter dataclass converts text to typed values; which kinds exist, their parameters and the
published (legacy) names live in :mod:`~uav_penetration_env.benchmark.policy_names`. It imports
neither numpy nor any compiled module.

Grammar (DECISION, api.md §4.1)::

    name      := term ["+" term]                  the second term warm-starts the first (a hybrid)
    term      := KIND ["[" [param ("," param)*] "]"]
               | PREFIX ":" ARGUMENT              a published plug-in form; ARGUMENT runs to the end
    param     := KEY "=" value
    value     := BARE | '"' (CHAR | '\"' | '\\')* '"'
    KIND, PREFIX := [A-Za-z0-9_.-]+     KEY := [A-Za-z_][A-Za-z0-9_]*
    BARE      := one or more characters other than , [ ] = "

A value holding ``,``, ``[``, ``]``, ``=`` or ``"``, or empty, is written in double quotes, in
which ``\"`` is a quote and ``\\`` a backslash (any other backslash is refused); a bare value
is taken verbatim, backslashes and spaces included (a Windows path needs no escaping). A hybrid
is a ``+`` between two terms rather than a nested value, so the published ``ihpso+sb3:PATH``
and ``ihpso[terminal=none]+sb3[model=PATH]`` read alike.
"""

from __future__ import annotations

import dataclasses
import re
import typing
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from uav_penetration_env.suggest import did_you_mean

HYBRID_SEPARATOR = "+"  # PLANNER+AGENT: an MPC planner warm-started by a plug-in policy
ARGUMENT_SEPARATOR = ":"  # PREFIX:ARGUMENT, the published plug-in forms (sb3:PATH.zip)
KIND_PATTERN = re.compile(r"[A-Za-z0-9_.-]+")
KEY_PATTERN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
SPECIAL = ',[]="'  # the characters a bare value cannot hold
ESCAPED = {'"': '"', "\\": "\\"}  # \" and \\ inside double quotes


# What a policy knows of a dynamic scenario's threats (docs/dynamic.md §4), written as a prefix:
# ``NAME`` plans on the belief, ``oracle:NAME`` on the truth, ``offline:NAME`` flies open loop the
# plan NAME makes on the prior map at the first step (the never-replanning floor).
BELIEF, ORACLE, OFFLINE = "belief", "oracle", "offline"
INFORMATION_PREFIXES = {f"{ORACLE}:": ORACLE, f"{OFFLINE}:": OFFLINE}
ORACLE_PREFIX = f"{ORACLE}:"


class PolicySpecError(Exception):
    """A policy name that cannot be read: bad syntax, an unknown kind or parameter, a bad value."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class UnknownPolicyError(PolicySpecError, KeyError):
    """A kind or a published name that no policy has (a KeyError, as unknown names have always been)."""


class PolicyValueError(PolicySpecError, ValueError):
    """Bad syntax, an unknown or missing parameter, or a value outside its domain."""


@dataclass(frozen=True)
class Term:
    """One term of a name as written: its kind and either its ``[...]`` parameters or a ``:ARGUMENT``.

    Attributes:
        kind: the text before ``[``, ``:``, ``+`` or the end.
        params: (key, value text) pairs of ``kind[...]`` in order; ``None`` when no brackets.
        argument: the text after ``PREFIX:`` (a published plug-in form); ``None`` otherwise.
    """

    kind: str
    params: tuple[tuple[str, str], ...] | None = None
    argument: str | None = None


@dataclass(frozen=True)
class PolicySpec:
    """A policy name read once: its kind, typed parameters and optional warm start.

    Attributes:
        kind: the policy kind (``ihpso``, ``lattice``, ``greedy``, a plug-in's ``sb3``, ...).
        family: ``"planner"`` (an MPC optimiser), ``"floor"``, ``"value-rule"`` (lattice,
            value-greedy) or ``"plugin"``.
        params: the kind's frozen parameter dataclass, values typed (api.md §4.1).
        base_label: this term's name in result tables, without the warm start.
        warm_start: the plug-in policy that warm-starts this planner (a hybrid), or ``None``.
        text: the name as it was written, for error messages (not compared: two spellings of
            one policy are equal specs).
        information: what the policy knows of a dynamic scenario's threats (docs/dynamic.md §4):
            ``belief`` (the default), ``oracle`` (the truth, ``oracle:NAME``) or ``offline`` (the
            prior map at the first step, flown open loop, ``offline:NAME``); labelled in every table.
    """

    kind: str
    family: str
    params: Any
    base_label: str
    warm_start: PolicySpec | None = None
    text: str = dataclasses.field(default="", compare=False)
    information: str = BELIEF

    @property
    def label(self) -> str:
        """The name in result tables and the store's ``policy`` column (the published name where one exists)."""
        label = self.base_label if self.warm_start is None else f"{self.base_label}{HYBRID_SEPARATOR}{self.warm_start.label}"
        return label if self.information == BELIEF else f"{self.information}:{label}"

    def canonical(self) -> str:
        """The bracket form, every non-default parameter written (``lattice-c60`` -> ``lattice[clearance=60]``)."""
        text = format_term(self.kind, param_items(self.params))
        if self.warm_start is not None:
            text = f"{text}{HYBRID_SEPARATOR}{self.warm_start.canonical()}"
        return text if self.information == BELIEF else f"{self.information}:{text}"


# --- syntax -------------------------------------------------------------------------------------


def parse_terms(text: str) -> tuple[Term, Term | None]:
    """The one or two terms of a policy name (the second: the warm start of a hybrid).

    Raises:
        PolicyValueError: text outside the grammar, naming the character position and what was expected.
    """
    first, end = _term(text, 0)
    if end == len(text):
        return first, None
    if text[end] != HYBRID_SEPARATOR:
        raise _syntax(text, end, "'+', '[' or the end")
    second, end = _term(text, end + 1)
    if end != len(text):
        raise _syntax(text, end, "the end (a hybrid has one '+')")
    return first, second


def _term(text: str, start: int) -> tuple[Term, int]:
    """The term starting at ``start`` and the position after it."""
    match = KIND_PATTERN.match(text, start)
    if match is None:
        raise _syntax(text, start, "a policy kind (letters, digits, '-', '_', '.')")
    kind, at = match.group(), match.end()
    if at < len(text) and text[at] == ARGUMENT_SEPARATOR:
        return Term(kind, argument=text[at + 1 :]), len(text)
    if at < len(text) and text[at] == "[":
        params, at = _params(text, at + 1)
        return Term(kind, params=params), at
    return Term(kind), at


def _params(text: str, at: int) -> tuple[tuple[tuple[str, str], ...], int]:
    """``key=value,...]`` from ``at`` (just after ``[``): the pairs and the position after ``]``."""
    pairs: list[tuple[str, str]] = []
    if at < len(text) and text[at] == "]":
        return (), at + 1
    while True:
        match = KEY_PATTERN.match(text, at)
        if match is None:
            raise _syntax(text, at, "a parameter name")
        key, at = match.group(), match.end()
        if key in dict(pairs):
            raise PolicyValueError(f"policy {text!r}: parameter {key!r} given twice")
        if at >= len(text) or text[at] != "=":
            raise _syntax(text, at, f"'=' after the parameter {key!r}")
        value, at = _value(text, at + 1)
        pairs.append((key, value))
        if at < len(text) and text[at] == ",":
            at += 1
        elif at < len(text) and text[at] == "]":
            return tuple(pairs), at + 1
        else:
            raise _syntax(text, at, "',' or ']'")


def _value(text: str, at: int) -> tuple[str, int]:
    """A bare or double-quoted value from ``at``: its text and the position after it."""
    if at < len(text) and text[at] == '"':
        chars: list[str] = []
        at += 1
        while at < len(text) and text[at] != '"':
            if text[at] == "\\":
                escaped = text[at + 1 : at + 2]
                if escaped not in ESCAPED:
                    raise _syntax(text, at, 'an escape \\" or \\\\ inside quotes')
                chars.append(ESCAPED[escaped])
                at += 2
            else:
                chars.append(text[at])
                at += 1
        if at >= len(text):
            raise _syntax(text, at, "the closing '\"'")
        return "".join(chars), at + 1
    end = at
    while end < len(text) and text[end] not in SPECIAL:
        end += 1
    if end == at:
        raise _syntax(text, at, 'a value (quote one that is empty or holds , [ ] = ")')
    return text[at:end], end


def _syntax(text: str, at: int, expected: str) -> PolicyValueError:
    got = repr(text[at]) if at < len(text) else "the end"
    return PolicyValueError(f"policy {text!r}: at character {at + 1}, expected {expected}, got {got}")


def quote(value: str) -> str:
    """``value`` as the grammar writes it: bare when it can be, else double-quoted with backslash and quote escaped."""
    if value and not any(c in SPECIAL for c in value):
        return value
    return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'


def format_term(kind: str, items: Sequence[tuple[str, str]]) -> str:
    """``kind`` or ``kind[key=value,...]`` with each value quoted as needed."""
    if not items:
        return kind
    return f"{kind}[{','.join(f'{key}={quote(value)}' for key, value in items)}]"


# --- typed parameters ---------------------------------------------------------------------------


def _field_type(params: type, field: dataclasses.Field[Any]) -> tuple[type, bool]:
    """(the value type, whether ``None`` is allowed) of a parameter field: str, int or float, maybe optional."""
    hint = typing.get_type_hints(params)[field.name]
    args = [a for a in typing.get_args(hint) if a is not type(None)]
    optional = len(args) < len(typing.get_args(hint))
    base = args[0] if optional and len(args) == 1 else hint
    if base not in (str, int, float):
        raise TypeError(
            f"{params.__qualname__}.{field.name}: a policy parameter is str, int or float (maybe | None)"
        )
    return base, optional


def expected_value(params: type, field: dataclasses.Field[Any]) -> str:
    """What a parameter accepts, in words (``one of none, distance``, ``an integer number of metres in [10, 1000]``)."""
    meta = field.metadata
    if "expected" in meta:
        return str(meta["expected"])
    if "choices" in meta:
        return "one of " + ", ".join(meta["choices"])
    base, _ = _field_type(params, field)
    words = {str: "a non-empty text", int: "an integer", float: "a number"}[base]
    if "unit" in meta:
        words += f" number of {meta['unit']}" if base is int else f" of {meta['unit']}"
    if "range" in meta:
        low, high = meta["range"]
        words += f" in [{low}, {high}]"
    return words


def _convert(params: type, field: dataclasses.Field[Any], text: str, where: str) -> Any:
    """One parameter's text -> its typed value, checked against its choices or range."""
    base, _ = _field_type(params, field)
    meta = field.metadata
    try:
        value: Any = base(text) if base is not int or re.fullmatch(r"[+-]?[0-9]+", text) else None
    except ValueError:
        value = None
    ok = value is not None and (base is not str or value != "")
    if ok and "choices" in meta:
        ok = value in meta["choices"]
    if ok and "range" in meta:
        low, high = meta["range"]
        ok = low <= value <= high
    if not ok:
        raise PolicyValueError(
            f"{where}: {field.name}: got {text!r}, expected {expected_value(params, field)}"
        )
    return value


def build_params(params: type, given: Mapping[str, str], kind: str, where: str) -> Any:
    """The parameter dataclass ``params`` from the texts ``given``, each converted and checked.

    Raises:
        PolicyValueError: a key that is not a field of ``params`` (with did-you-mean), a missing
            field without a default, or a value outside its field's domain, naming the parameter and
            the expected value.
    """
    fields = {f.name: f for f in dataclasses.fields(params)}
    for key in given:
        if key not in fields:
            known = ", ".join(fields) or "none"
            raise PolicyValueError(
                f"{where}: unknown parameter {key!r} of the kind {kind!r} — {did_you_mean(key, fields)}"
                f"its parameters: {known}"
            )
    values: dict[str, Any] = {}
    for name, field in fields.items():
        if name in given:
            values[name] = _convert(params, field, given[name], where)
        elif field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING:
            raise PolicyValueError(
                f"{where}: the kind {kind!r} needs the parameter {name!r} ({expected_value(params, field)})"
            )
    return params(**values)


def param_items(params: Any) -> list[tuple[str, str]]:
    """The non-default parameters of a parameter dataclass as (key, text) pairs, in field order."""
    items = []
    for field in dataclasses.fields(params):
        value = getattr(params, field.name)
        if field.default is not dataclasses.MISSING and value == field.default:
            continue
        items.append((field.name, repr(value) if isinstance(value, float) else str(value)))
    return items
