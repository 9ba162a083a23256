"""Name -> optimiser registry, with entry-point plug-ins (optimizers.md §1, §10).

A registration maps a name to a class or a zero-argument factory (``functools.partial(Class,
**overrides)`` for a configuration variant). ``get_optimizer(name, **params)`` builds an instance and
applies ``params`` as dataclass overrides. Other packages add optimisers through the entry-point group
``uav_penetration.optimizers``: each entry point names a module (or an object inside one) whose import
registers optimisers. Plug-ins are loaded once, lazily, on the first ``get_optimizer`` or
``available_optimizers`` call.
"""

from __future__ import annotations

import difflib
import importlib.metadata
import types
import warnings
from collections.abc import Callable
from typing import Any, TypeVar

from optimizers.base import Optimizer, replace_params

ENTRY_POINT_GROUP = "uav_penetration.optimizers"

F = TypeVar("F", bound=Callable[..., Any])

_REGISTRY: dict[str, Callable[[], Optimizer]] = {}
_plugins_loaded = False


class OptimizerPluginWarning(UserWarning):
    """A plug-in from the ``uav_penetration.optimizers`` entry-point group could not be loaded."""


def register_optimizer(name: str) -> Callable[[F], F]:
    """Register a class or zero-argument factory under ``name`` (decorator).

    Example::

        @register_optimizer("my-pso")
        @dataclass(frozen=True)
        class MyPSO: ...

        register_optimizer("my-pso-big")(functools.partial(MyPSO, swarm_size=200))

    Args:
        name: The registry name (a non-empty string).

    Returns:
        A decorator that registers its argument and returns it unchanged.

    Raises:
        ValueError: If ``name`` is empty or already registered.
    """
    if not isinstance(name, str) or not name:
        raise ValueError(f"optimizer name: got {name!r}, expected a non-empty string")

    def decorator(factory: F) -> F:
        if not callable(factory):
            raise TypeError(f"register_optimizer({name!r}): got {factory!r}, expected a class or factory")
        if name in _REGISTRY:
            raise ValueError(f"optimizer {name!r} is already registered ({_REGISTRY[name]!r})")
        _REGISTRY[name] = factory
        return factory

    return decorator


def _load_plugins() -> None:
    """Import every entry point of the plug-in group once; a broken one gives a warning.

    DECISION: an entry point may name a module (its import registers optimisers) or an object
    inside one (``pkg.mod:MyOptimizer``). Importing it is what registers; if the entry point's own
    name is still unregistered afterwards and the object is callable, it is registered under that
    name, so a plug-in can also be a bare class without a decorator.
    """
    global _plugins_loaded
    if _plugins_loaded:
        return
    _plugins_loaded = True  # set first: a plug-in that lists optimisers while importing must not recurse
    try:
        entry_points = importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)
    except Exception as exc:  # a broken installation must not break the registry
        warnings.warn(f"could not list optimizer plug-ins ({exc!r})", OptimizerPluginWarning, stacklevel=3)
        return
    for ep in entry_points:
        try:
            loaded = ep.load()
            if ep.name not in _REGISTRY and callable(loaded) and not isinstance(loaded, types.ModuleType):
                register_optimizer(ep.name)(loaded)
        except Exception as exc:  # a third-party import error of any kind
            warnings.warn(
                f"optimizer plug-in {ep.name!r} ({ep.value}) could not be loaded: {exc!r}",
                OptimizerPluginWarning,
                stacklevel=3,
            )


def available_optimizers() -> list[str]:
    """Return the sorted registered names (plug-ins included)."""
    _load_plugins()
    return sorted(_REGISTRY)


def get_optimizer(name: str, **params: Any) -> Optimizer:
    """Build the optimiser registered as ``name``, with ``params`` as hyper-parameter overrides.

    Args:
        name: A registered name, e.g. ``"ihpso"``.
        **params: Dataclass field overrides, e.g. ``swarm_size=50``; validated by the class.

    Returns:
        A new optimiser instance.

    Raises:
        KeyError: If ``name`` is unknown; the message suggests close names and lists all of them.
        TypeError: If a parameter is not a field of the optimiser.
        ValueError: If a parameter value is invalid.
    """
    _load_plugins()
    if name not in _REGISTRY:
        names = sorted(_REGISTRY)
        close = difflib.get_close_matches(str(name), names, n=3, cutoff=0.6)
        hint = f" — did you mean {', '.join(repr(c) for c in close)}?" if close else " —"
        raise KeyError(f"unknown optimizer {name!r}{hint} available: {', '.join(names)}")
    instance = _REGISTRY[name]()
    if params:
        instance = replace_params(instance, **params)  # type: ignore[assignment]
    return instance
