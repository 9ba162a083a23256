"""A package's public names imported on first use (PEP 562), so importing the package stays light."""

from __future__ import annotations

import importlib
import sys
import types
from collections.abc import Callable, Mapping, Sequence
from typing import Any


def lazy_exports(
    package: str, modules: Mapping[str, Sequence[str]], namespace: dict[str, Any]
) -> tuple[Callable, Callable]:
    """The ``__getattr__`` and ``__dir__`` of ``package`` for the names each of its ``modules`` defines.

    ``modules`` maps a module, relative to the package (``".build"``) or absolute, to the names it
    exports. A name is imported from its module when first read and kept in ``namespace`` (the
    package's globals), so later reads cost nothing. An export named like the submodule that defines
    it (``benchmark.evaluate``, the function in ``benchmark/evaluate.py``) stays the export: importing
    the submodule binds the module object to that name on the package, which would otherwise hide
    the function from ``from package import name``.

    Raises:
        ValueError: a name exported by two modules.
    """
    exports = exported_modules(modules)
    shadowed = frozenset(name for name, module in exports.items() if module.rsplit(".", 1)[-1] == name)
    if shadowed:
        sys.modules[package].__class__ = _package_class(shadowed)

    def __getattr__(name: str) -> Any:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module, package), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted({*namespace, *exports})

    return __getattr__, __dir__


def exported_modules(modules: Mapping[str, Sequence[str]]) -> dict[str, str]:
    """Each exported name of ``modules`` (module -> names) with its module: name -> module.

    Raises:
        ValueError: a name exported by two modules.
    """
    exports: dict[str, str] = {}
    for module, names in modules.items():
        for name in names:
            if name in exports:
                raise ValueError(f"{name}: exported by {exports[name]} and {module}, expected one module")
            exports[name] = module
    return exports


def _package_class(shadowed: frozenset[str]) -> type:
    """A module type whose ``shadowed`` attributes, when a submodule of that name was bound, read as its export."""

    class Package(types.ModuleType):
        def __getattribute__(self, name: str) -> Any:
            value = super().__getattribute__(name)
            if name in shadowed and isinstance(value, types.ModuleType):
                return getattr(value, name)
            return value

    return Package
