"""A script that is not part of a package (a benchmark, a docs hook), imported by path for a test."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType


def load_script(path: Path) -> ModuleType:
    """The module of the Python file ``path``, named after its stem and run once.

    It is in ``sys.modules`` only while it runs (dataclasses look their module up while the class is
    created), so loading the same script twice gives two fresh modules.
    """
    spec = importlib.util.spec_from_file_location(path.stem, path)
    assert spec is not None and spec.loader is not None, f"{path} is not a Python file"
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
    finally:
        sys.modules.pop(spec.name, None)
    return module
