"""Plug-ins found through entry points: extra policy kinds and extra ``uav-bench`` commands.

The harness knows no optional package by name. A package extends it by declaring entry points
in its ``pyproject.toml`` (``baselines`` does so for the ``rl`` extra)::

    [project.entry-points."uav_penetration.policies"]
    sb3 = "baselines.plugin:SB3_POLICY_KIND"        # a PolicyKind: policies named "sb3[...]"

    [project.entry-points."uav_penetration.commands"]
    train = "baselines.cli:TRAIN_COMMAND"           # a Command: `uav-bench train`
    "plot.models" = "baselines.cli:LEARNING_CURVES" # a CommandExtension: `uav-bench plot --models`

Each entry point names a module-level object that the plug-in's module builds without importing
anything heavy; what the plug-in needs at run time (torch, ...) it lists in a :class:`Needs`,
which the harness checks before it uses the plug-in, so a missing extra is refused with one line
saying what to install, never half-way through a run.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import os
import sys
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

POLICY_GROUP = "uav_penetration.policies"
COMMAND_GROUP = "uav_penetration.commands"


class PluginUnavailable(ImportError):
    """A plug-in whose modules are missing (its extra is not installed) or that failed to import."""


@dataclass(frozen=True)
class Needs:
    """What a plug-in needs at run time, and how to install it.

    Attributes:
        modules: importable module names (e.g. ``("stable_baselines3", "torch")``).
        install: how to get them, e.g. ``"the rl extra (pip install 'uav-penetration[rl]')"``.
    """

    modules: tuple[str, ...] = ()
    install: str = ""

    def missing(self) -> list[str]:
        """The modules that cannot be imported here (found without importing them)."""
        absent = []
        for module in self.modules:
            try:
                found = importlib.util.find_spec(module) is not None
            except (ImportError, ValueError):  # a parent package missing, or a module set to None
                found = False
            if not found:
                absent.append(module)
        return absent

    def check(self, what: str) -> None:
        """Raise :class:`PluginUnavailable` (one line) when a needed module is missing.

        Args:
            what: the thing that needs them, e.g. ``"policy 'sb3:m.zip'"``.
        """
        absent = self.missing()
        if absent:
            how = f"; install {self.install}" if self.install else ""
            raise PluginUnavailable(f"{what} needs {', '.join(absent)} (not installed){how}")


@dataclass(frozen=True)
class PolicyKind:
    """A policy kind provided by a plug-in: ``NAME[param=value,...]`` (e.g. ``sb3[model=models/ppo.zip]``).

    The harness reads the name (:mod:`~.policy_spec`) into the kind's typed parameters, then
    calls the kind with them; it never parses a plug-in's text itself.

    Attributes:
        name: the kind, as written before ``[``.
        params: a frozen dataclass of the kind's parameters, each ``str``, ``int`` or ``float``
            (``| None`` for an optional one), with ``metadata`` ``choices``, ``range``, ``unit`` or
            ``expected`` where the domain is narrower (api.md §4.1).
        load: builds the policy from a ``params`` instance (may raise ``FileNotFoundError``,
            ``ValueError``).
        usage: the form shown in help and error messages, e.g. ``sb3[model=PATH.zip]``.
        label: the policy's name in result tables, from its ``params`` (default: the bracket form).
        needs: what :attr:`load` and the policy need at run time.
        hybrid: builds ``PLANNER+NAME[...]`` from ``params`` and the planner's
            :class:`~.policies.MPCPolicy` (built by the harness): the planner warm-started by this
            kind's policy (docs/rl-statistics.md §3); ``None`` when the kind offers no hybrid.
        prefixes: the published ``PREFIX:ARGUMENT`` forms of this kind: prefix -> a function from
            ARGUMENT to parameter texts (:func:`argument_as`); a ``ValueError`` it raises is the
            name's error. ``distill-shield:DIR`` is ``distill[run=DIR,guard=shield]``.
    """

    name: str
    params: type
    load: Callable[[Any], Any]
    usage: str
    label: Callable[[Any], str] | None = None
    needs: Needs = field(default_factory=Needs)
    hybrid: Callable[[Any, Any], Any] | None = None
    prefixes: Mapping[str, Callable[[str], Mapping[str, str]]] = field(default_factory=dict, hash=False)


def argument_as(param: str, **fixed: str) -> Callable[[str], dict[str, str]]:
    """The reader of a ``PREFIX:ARGUMENT`` form that gives ARGUMENT to ``param`` and fixes the others.

    ``argument_as("run", guard="shield")("DIR")`` -> ``{"run": "DIR", "guard": "shield"}``.
    """

    def read(argument: str) -> dict[str, str]:
        return {param: argument, **fixed}

    read.__qualname__ = read.__name__ = f"argument_as_{param}"
    return read


@dataclass(frozen=True)
class Plugin:
    """One entry point of a group: its name, the loaded object, or why it could not be loaded."""

    name: str
    value: Any = None
    error: str | None = None


def discover(group: str) -> dict[str, Plugin]:
    """Load every entry point of ``group``; a failing one is kept with its error (never raised).

    Returns:
        Entry-point name -> :class:`Plugin`, in name order.
    """
    found: dict[str, Plugin] = {}
    for entry in sorted(importlib.metadata.entry_points(group=group), key=lambda e: e.name):
        if entry.name in found:
            continue  # the same distribution seen twice on sys.path: the first one wins, as imports do
        try:
            found[entry.name] = Plugin(entry.name, entry.load())
        except Exception as error:  # a broken plug-in must not break the harness or `uav-bench --help`
            found[entry.name] = Plugin(entry.name, error=f"{entry.value} failed to import ({error})")
    return found


def policy_kinds() -> dict[str, PolicyKind | Plugin]:
    """The policy kinds of the installed plug-ins by name; a :class:`Plugin` with its error when broken."""
    kinds: dict[str, PolicyKind | Plugin] = {}
    for name, plugin in discover(POLICY_GROUP).items():
        if plugin.error is not None:
            kinds[name] = plugin
        elif isinstance(plugin.value, PolicyKind):
            kinds[plugin.value.name] = plugin.value
        else:
            kinds[name] = Plugin(name, error=f"entry point {name!r} of {POLICY_GROUP} is not a PolicyKind")
    return kinds


def plugin_policy_forms() -> list[str]:
    """The forms of the installed plug-in policy kinds, for help and errors (e.g. ``sb3[model=PATH.zip]``).

    A kind that warm-starts planners adds its hybrid form, ``PLANNER+sb3[...]``.
    """
    forms = []
    for name, kind in policy_kinds().items():
        if isinstance(kind, Plugin):
            forms.append(f"{name}[...]")
            continue
        forms.append(kind.usage)
        if kind.hybrid is not None:
            forms.append(f"PLANNER+{kind.name}[...]")
    return forms


def has_address_repr(obj: Any) -> bool:
    """Whether ``repr(obj)`` names a memory address (``<... at 0x...>``), so differs in every process."""
    import re

    return re.search(r" at 0x[0-9a-fA-F]+", repr(obj)) is not None


def stable_parameters(obj: Any, what: str) -> Any:
    """Plain data describing ``obj``'s configuration, the same in every process (hashed into store keys).

    A dataclass gives its fields; another object its ``repr`` when that names no memory address,
    else its attributes when they are plain JSON data.

    Raises:
        ValueError: ``obj`` has no stable description (a default ``repr`` holding ``at 0x...`` and
            attributes that are not plain data), naming ``what`` and how to make it hashable: every
            process would give it another hash, so a resumed run would fly everything again.
    """
    import dataclasses
    import json

    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return dataclasses.asdict(obj)
    if not has_address_repr(obj):
        return repr(obj)
    attributes = {k: v for k, v in vars(obj).items() if not k.startswith("_")} if hasattr(obj, "__dict__") else None
    try:
        json.dumps(attributes, allow_nan=True)
    except (TypeError, ValueError):
        attributes = None
    if attributes is None:
        raise ValueError(
            f"{what}: {type(obj).__qualname__} has no stable configuration (its repr names a memory address "
            "and its attributes are not plain data); make it a dataclass, or give it a repr or a config() of plain data"
        )
    return {"class": f"{type(obj).__module__}.{type(obj).__qualname__}", "attributes": attributes}


def import_plugins(modules: Iterable[str]) -> None:
    """Import plug-in modules (``--import``) so their registrations exist in this process.

    A module in the current folder is found as ``python -m`` finds it: the folder joins
    ``sys.path`` (an installed console script such as ``uav-bench`` does not put it there), in this
    process and in every worker, which imports the same list from the same folder.
    """
    modules = list(modules)
    here = os.getcwd()
    if modules and here not in sys.path and "" not in sys.path:
        sys.path.insert(0, here)
    for module in modules:
        importlib.import_module(module)
