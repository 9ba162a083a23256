"""Where numba caches the compiled physics, keyed by the compiled sources (model.md §8).

numba invalidates a cached function when its own file changes, but not when a compiled function it
calls from another file does: a kernel in ``kernels.py`` that inlines ``costtogo.value_lookup``
keeps running the old lookup after ``costtogo.py`` changes. So the cache lives in a folder named
by a digest of every package source that uses numba: any change to any of them starts a fresh
cache, and no process ever mixes two versions of the physics.

The folder is ``__pycache__/numba-DIGEST`` next to the package when the package folder is
writable (older digests' folders there, this install's own, are removed, so the cache does not
grow with every edit), else ``$UAV_PENETRATION_CACHE/numba/DIGEST`` (the project's cache folder,
:func:`cache.cache_dir`, which other installed versions may share: nothing is removed there); a
user's ``NUMBA_CACHE_DIR`` is honoured as the parent, ``NUMBA_CACHE_DIR/uav-penetration-DIGEST``.

Every module that defines compiled functions imports this one before its first definition
(``kernels.py``, ``costtogo.py``, ``value_function.py``, ``checks.py``), so the folder is set however
the package is entered; ``import uav_penetration_env`` alone loads no compiled code (the package's
exports load on first use).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from pathlib import Path

import numba

from uav_penetration_env import cache

PACKAGE = Path(__file__).resolve().parent


def source_digest(package: Path = PACKAGE) -> str:
    """A digest of every ``.py`` file under ``package`` that uses numba (path and bytes), 16 hex digits."""
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        text = path.read_bytes()
        if b"numba" in text:
            digest.update(str(path.relative_to(package)).encode())
            digest.update(text)
    return digest.hexdigest()[:16]


def _package_cache_writable(folder: Path) -> bool:
    """Whether numba can write its cache next to the sources (``__pycache__`` in the package)."""
    target = folder / "__pycache__"
    try:
        target.mkdir(exist_ok=True)
        handle, name = tempfile.mkstemp(dir=target, prefix=".numba-probe-")
        os.close(handle)
        os.unlink(name)
    except OSError:
        return False
    return True


def _remove_other_digests(parent: Path, keep: Path, prefix: str) -> None:
    try:
        for other in parent.iterdir():
            if other != keep and other.is_dir() and other.name.startswith(prefix):
                shutil.rmtree(other, ignore_errors=True)
    except OSError:
        pass


def configure_compile_cache() -> str:
    """Point numba's cache at the folder of the current sources' digest (see the module docstring).

    Returns:
        The folder in force.
    """
    digest = source_digest()
    user = os.environ.get("NUMBA_CACHE_DIR")
    if user:
        folder = Path(user) / f"uav-penetration-{digest}"
    elif _package_cache_writable(PACKAGE):
        folder = PACKAGE / "__pycache__" / f"numba-{digest}"
        if not folder.exists():  # this install's own folder: older digests are of this install only
            _remove_other_digests(folder.parent, folder, "numba-")
    else:
        # A shared folder another installed version may be using: nothing is removed there.
        folder = cache.cache_dir() / "numba" / digest
    numba.config.CACHE_DIR = str(folder)
    return str(folder)


COMPILE_CACHE_DIR = configure_compile_cache()
