"""The policy kinds, their typed parameters and the published names, without the policies' code.

:func:`parse_policy` reads a policy name (the grammar: :mod:`~.policy_spec`) into a
:class:`~.policy_spec.PolicySpec`; :func:`~uav_penetration_env.benchmark.policies.make_policy`
builds the policy from it. This module only knows which kinds exist and what their parameters
are, so ``uav-bench run`` refuses a mistyped name or a bad value before it imports the physics
and the compiled code (a second, not the ten of the first episode's imports; api.md §4.7). It
imports no numba-compiled module: the optimiser registry (numpy, scipy) and the plug-in entry
points only.

Kinds (api.md §4.1): every optimiser name is an MPC planner (:class:`PlannerParams`:
``terminal``); ``greedy`` and ``random`` are the floors (no parameter); ``lattice`` and
``value-greedy`` are the value rules (:class:`ClearanceParams`: ``clearance``); a plug-in adds
its own kinds with their parameters (:class:`~.plugins.PolicyKind`, e.g. ``sb3``, ``distill``).

DECISION (api.md §4.1, published names): every name a leaderboard row holds stays a name and
stays its label. The alias table below reads ``NAME-eq37``, ``NAME-ctg-FORM``, ``lattice-cN``
and ``value-greedy-cN``; a plug-in's ``prefixes`` read ``PREFIX:ARGUMENT``
(``distill-shield:DIR``, ``sb3:PATH?vecnormalize=STATS``); ``PLANNER+AGENT`` is a hybrid in
both grammars. The label (the store's ``policy`` column) is the published name where one exists,
written from the parameters by the inverse of the same table, so ``lattice[clearance=60]`` and
``lattice-c60`` are one policy with one label, ``lattice-c60``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from uav_penetration_env.benchmark.plugins import (
    POLICY_GROUP,
    Plugin,
    PluginUnavailable,
    PolicyKind,
    plugin_policy_forms,
    policy_kinds,
)
from uav_penetration_env.benchmark.policy_spec import (
    BELIEF,
    INFORMATION_PREFIXES,
    PolicySpec,
    PolicyValueError,
    Term,
    UnknownPolicyError,
    build_params,
    format_term,
    param_items,
    parse_terms,
)
from uav_penetration_env.suggest import did_you_mean

FLOOR_NAMES = ("greedy", "random")  # policies.FLOOR_POLICIES
VALUE_RULE_NAMES = ("lattice", "value-greedy")  # policies.BASELINE_POLICIES: the classical global planners
CLEARANCES_M = (10, 1000)  # the clearance a value rule accepts, metres
TERMINAL_FORMS = ("none", "distance", "dubins", "value")  # types.TERMINAL_FORMS (model.md §7e)


@dataclass(frozen=True)
class NoParams:
    """The parameters of a kind that has none (``greedy``, ``random``)."""


@dataclass(frozen=True)
class PlannerParams:
    """An MPC planner's parameters (every optimiser name).

    Attributes:
        terminal: the terminal cost's form (model.md §7e), or ``None`` for the run's ``--terminal``.
    """

    terminal: str | None = field(default=None, metadata={"choices": TERMINAL_FORMS})


@dataclass(frozen=True)
class ClearanceParams:
    """A value rule's parameters (``lattice``, ``value-greedy``).

    Attributes:
        clearance: the terrain-following clearance its moves aim at, whole metres in
            :data:`CLEARANCES_M`, or ``None`` for the lattice's own (``LATTICE_GUIDANCE``); the
            value function itself is the lattice's either way (model.md §7e.3).
    """

    clearance: int | None = field(default=None, metadata={"range": CLEARANCES_M, "unit": "metres"})


# The alias table of the built-in kinds: a published suffix -> the parameter it sets. Parsing
# reads it one way, the label writes it the other, so a name and its label cannot drift apart.
TERMINAL_SUFFIXES = {
    "-eq37": "none",
    "-ctg-distance": "distance",
    "-ctg-dubins": "dubins",
    "-ctg-value": "value",
}
CLEARANCE_SUFFIX = "-c"  # lattice-cN, value-greedy-cN: clearance=N


@dataclass(frozen=True)
class BuiltinKind:
    """A kind of the core: its name, family (:attr:`PolicySpec.family`), parameters and usage."""

    name: str
    family: str
    params: type
    usage: str


def builtin_kinds() -> dict[str, BuiltinKind]:
    """The core's kinds by name: floors, value rules, then one MPC planner per optimiser name."""
    from optimizers import available_optimizers

    kinds = {name: BuiltinKind(name, "floor", NoParams, name) for name in FLOOR_NAMES}
    for name in VALUE_RULE_NAMES:
        kinds[name] = BuiltinKind(name, "value-rule", ClearanceParams, f"{name}[clearance=N]")
    for name in available_optimizers():
        kinds.setdefault(name, BuiltinKind(name, "planner", PlannerParams, f"{name}[terminal=FORM]"))
    return kinds


def builtin_label(kind: str, params: Any) -> str:
    """A built-in kind's label: the published name its parameters have (``lattice-c60``, ``ihpso-eq37``)."""
    if isinstance(params, PlannerParams) and params.terminal is not None:
        suffix = {form: suffix for suffix, form in TERMINAL_SUFFIXES.items()}[params.terminal]
        return f"{kind}{suffix}"
    if isinstance(params, ClearanceParams) and params.clearance is not None:
        return f"{kind}{CLEARANCE_SUFFIX}{params.clearance}"
    return kind


def _published_alias(name: str, kinds: dict[str, BuiltinKind]) -> tuple[str, dict[str, str]] | None:
    """(kind, parameter texts) of a published suffixed name (``ihpso-eq37``, ``lattice-c60``), else None."""
    for suffix, form in TERMINAL_SUFFIXES.items():
        base = name.removesuffix(suffix)
        if base != name and base in kinds and kinds[base].family == "planner":
            return base, {"terminal": form}
    base, mark, digits = name.rpartition(CLEARANCE_SUFFIX)
    if mark and base in VALUE_RULE_NAMES:
        return base, {"clearance": digits}
    return None


def parse_policy(text: str) -> PolicySpec:
    """The :class:`PolicySpec` of a policy name, in either grammar (api.md §4.1).

    ``ihpso``, ``ihpso[terminal=none]`` = ``ihpso-eq37``, ``lattice[clearance=60]`` =
    ``lattice-c60``, ``distill[run=DIR,guard=shield]`` = ``distill-shield:DIR``,
    ``sb3[model=m.zip,vecnormalize=s.pkl]`` = ``sb3:m.zip?vecnormalize=s.pkl``,
    ``ihpso[terminal=none]+sb3[model=m.zip]`` = ``ihpso-eq37+sb3:m.zip``; ``oracle:NAME`` is NAME
    planning on the truth of a dynamic scenario, ``offline:NAME`` NAME's plan on the prior map flown
    open loop (docs/dynamic.md §4).

    Raises:
        UnknownPolicyError: (a KeyError) an unknown kind or published name, with suggestions and
            the known forms; a hybrid whose parts cannot form one.
        PolicyValueError: (a ValueError) bad syntax, an unknown or missing parameter, a value
            outside its domain; one line naming the parameter and the expected value.
        PluginUnavailable: the name's kind belongs to a plug-in that failed to import.
    """
    for prefix, information in INFORMATION_PREFIXES.items():
        if text.startswith(prefix):
            inner = parse_policy(text[len(prefix) :])
            if inner.information != BELIEF:
                raise PolicyValueError(
                    f"policy {text!r}: expected at most one of the prefixes {', '.join(INFORMATION_PREFIXES)}"
                )
            return dataclasses.replace(inner, information=information, text=text)
    first, second = parse_terms(text)
    builtins = builtin_kinds()
    plugins = policy_kinds()
    spec = _resolve(first, text, builtins, plugins)
    if second is None:
        return dataclasses.replace(spec, text=text)
    warm = _resolve(second, text, builtins, plugins)
    if spec.family != "planner":
        raise UnknownPolicyError(
            f"unknown policy {text!r} — a hybrid is PLANNER+AGENT with an MPC planner (an optimiser name, "
            f"NAME-eq37, NAME[terminal=FORM]) before the '+', got {spec.label!r}"
        )
    plugin = plugins.get(warm.kind) if warm.family == "plugin" else None
    if not isinstance(plugin, PolicyKind) or plugin.hybrid is None:
        what = "the plug-in kind" if plugin is not None else "the kind"
        raise UnknownPolicyError(
            f"unknown policy {text!r} — {what} {warm.kind!r} cannot warm-start a planner"
        )
    return PolicySpec(spec.kind, spec.family, spec.params, spec.base_label, warm_start=warm, text=text)


def _resolve(
    term: Term, text: str, builtins: dict[str, BuiltinKind], plugins: dict[str, PolicyKind | Plugin]
) -> PolicySpec:
    """One term's spec: a published ``PREFIX:ARGUMENT``, a kind with its parameters, or a published suffixed name."""
    where = f"policy {text!r}"
    if term.argument is not None:
        return _resolve_prefixed(term, text, builtins, plugins)
    kind: BuiltinKind | PolicyKind | Plugin | None = builtins.get(term.kind) or plugins.get(term.kind)
    given = dict(term.params or ())
    if kind is None and term.params is None:
        alias = _published_alias(term.kind, builtins)
        if alias is not None:
            kind, given = builtins[alias[0]], alias[1]
    if kind is None:
        raise UnknownPolicyError(_unknown(text, term.kind, builtins, plugins, prefixed=False))
    if isinstance(kind, Plugin):
        raise PluginUnavailable(f"{where}: the plug-in {kind.error}")
    params = build_params(kind.params, given, kind.name, where)
    if isinstance(kind, BuiltinKind):
        return PolicySpec(kind.name, kind.family, params, builtin_label(kind.name, params))
    return _plugin_spec(kind, params)


def _resolve_prefixed(
    term: Term, text: str, builtins: dict[str, BuiltinKind], plugins: dict[str, PolicyKind | Plugin]
) -> PolicySpec:
    """A published ``PREFIX:ARGUMENT``: the plug-in kind that declares the prefix reads the argument."""
    where = f"policy {text!r}"
    for kind in plugins.values():
        if isinstance(kind, PolicyKind) and term.kind in kind.prefixes:
            try:
                given = kind.prefixes[term.kind](term.argument or "")
            except ValueError as error:
                raise PolicyValueError(f"{where}: {error}") from None
            return _plugin_spec(kind, build_params(kind.params, given, kind.name, where))
    broken = plugins.get(term.kind)
    if isinstance(broken, Plugin):
        raise PluginUnavailable(f"{where}: the plug-in {broken.error}")
    raise UnknownPolicyError(_unknown(text, term.kind, builtins, plugins, prefixed=True))


def _plugin_spec(kind: PolicyKind, params: Any) -> PolicySpec:
    label = kind.label(params) if kind.label is not None else format_term(kind.name, param_items(params))
    return PolicySpec(kind.name, "plugin", params, label)


def _prefixes(plugins: dict[str, PolicyKind | Plugin]) -> list[str]:
    return [p for kind in plugins.values() if isinstance(kind, PolicyKind) for p in kind.prefixes]


def _unknown(
    text: str,
    name: str,
    builtins: dict[str, BuiltinKind],
    plugins: dict[str, PolicyKind | Plugin],
    prefixed: bool,
) -> str:
    """The one-line error of an unknown kind or prefix, with suggestions and the known forms."""
    if prefixed:  # name the mechanism: the kind may belong to a package that is not installed
        hint = (
            f"no installed plug-in provides the kind {name!r} (entry points {POLICY_GROUP}); "
            f"{did_you_mean(name, _prefixes(plugins))}"
        )
    else:
        hint = did_you_mean(name, [*policy_names(), *plugins])
    planners = [k for k, kind in builtins.items() if kind.family == "planner"]
    known = ", ".join(
        ["greedy", "random", "lattice[clearance=N] (lattice-cN)", "value-greedy[clearance=N] (value-greedy-cN)",
         "NAME[terminal=FORM] (NAME-eq37, NAME-ctg-FORM)", "oracle:NAME", "offline:NAME", *plugin_policy_forms()]
    )  # fmt: skip
    named = repr(text) if name == text else f"{name!r} (in {text!r})"
    return f"unknown policy {named} — {hint}known: {known} and the optimisers {', '.join(planners)}"


def policy_names() -> list[str]:
    """Every plain name :func:`parse_policy` accepts without parameters (plug-in kinds aside)."""
    planners = [k for k, kind in builtin_kinds().items() if kind.family == "planner"]
    suffixed = [f"{n}{suffix}" for n in planners for suffix in TERMINAL_SUFFIXES]
    return sorted([*FLOOR_NAMES, *VALUE_RULE_NAMES, *planners, *suffixed])


def unknown_policy(text: str) -> str | None:
    """The one-line error of a name that cannot be read (unknown kind, bad parameter), else None.

    What needs the policy's files or extra (a plug-in's model file, torch) is checked when the
    policy is built; a plug-in that failed to import is reported there too.
    """
    try:
        parse_policy(text)
    except (UnknownPolicyError, PolicyValueError) as error:
        return str(error)
    except PluginUnavailable:
        return None
    return None
