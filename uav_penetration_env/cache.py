"""Disk cache for scenario precomputation (terrain grids, visibility floors, RCS tables).

model.md §7a: arrays are cached under ``$UAV_PENETRATION_CACHE``, else the platform's user cache
folder, keyed by a hash of their inputs and the package version. Writes are atomic (a temporary
file in the same folder, then ``os.replace``), so parallel workers never read a half-written
file. An unwritable cache folder degrades to building in memory, with one warning.
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings
import zipfile
from collections import OrderedDict
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from uav_penetration_env._version import __version__
from uav_penetration_env.atomic import atomic_open

ENV_VAR = "UAV_PENETRATION_CACHE"
_MEMORY_ENTRIES = 128


class CacheWarning(UserWarning):
    """The disk cache could not be used; builds stay in memory."""


_memory: OrderedDict[str, dict[str, np.ndarray]] = OrderedDict()
_warned = False


def cache_dir() -> Path:
    """The cache folder: ``$UAV_PENETRATION_CACHE`` or the user cache folder of this package."""
    configured = os.environ.get(ENV_VAR)
    if configured:
        return Path(configured)
    import platformdirs

    return Path(platformdirs.user_cache_dir("uav-penetration"))


def cache_key(kind: str, inputs: Any) -> str:
    """A stable key from the kind, the JSON-serialisable inputs and the package version."""
    text = json.dumps([kind, __version__, inputs], sort_keys=True, separators=(",", ":"), default=str)
    return f"{kind}-{hashlib.sha256(text.encode()).hexdigest()[:24]}"


def cached_arrays(
    kind: str, inputs: Any, build: Callable[[], dict[str, np.ndarray]]
) -> dict[str, np.ndarray]:
    """Load the arrays for ``inputs`` from memory or disk, or build and store them.

    Args:
        kind: a short name for the artefact (``terrain``, ``floor``, ``rcs``).
        inputs: everything the arrays depend on (JSON-serialisable).
        build: computes the arrays when they are not cached.

    Returns:
        A mapping of array name to (read-only) array.
    """
    key = cache_key(kind, inputs)
    if key in _memory:
        _memory.move_to_end(key)
        return _memory[key]
    arrays = _load(key)
    if arrays is None:
        arrays = {name: np.asarray(value) for name, value in build().items()}
        _store(key, arrays)
    for value in arrays.values():
        value.setflags(write=False)
    _memory[key] = arrays
    while len(_memory) > _MEMORY_ENTRIES:
        _memory.popitem(last=False)
    return arrays


def clear_memory() -> None:
    """Forget the in-process copies (the disk cache stays)."""
    _memory.clear()


def _path(key: str) -> Path:
    return cache_dir() / f"{key}.npz"


def _load(key: str) -> dict[str, np.ndarray] | None:
    path = _path(key)
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            return {name: data[name] for name in data.files}
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile):
        return None  # a corrupt, truncated or foreign file: rebuild and overwrite it


def _store(key: str, arrays: dict[str, np.ndarray]) -> None:
    global _warned
    folder = cache_dir()
    try:
        with atomic_open(_path(key), "wb") as stream:
            np.savez(stream, **arrays)
    except OSError as error:
        if not _warned:
            warnings.warn(
                f"scenario cache folder {folder} is not writable ({error}); building in memory only. "
                f"Set {ENV_VAR} to a writable folder to cache builds.",
                CacheWarning,
                stacklevel=3,
            )
            _warned = True
