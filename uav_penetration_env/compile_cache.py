"""Where numba caches the compiled physics, keyed by the compiled sources (model.md §8).

numba invalidates a cached function when its own file changes, but not when a compiled function it
calls from another file does: a kernel in ``kernels.py`` that inlines ``terminal_kernels.value_lookup``
keeps running the old lookup after ``terminal_kernels.py`` changes. So the cache lives in a folder named
by a digest of every package source that uses numba: any change to any of them starts a fresh
cache, and no process ever mixes two versions of the physics.

The folder is ``__pycache__/numba-DIGEST`` next to the package when the package folder is
writable (older digests' folders there, this install's own, are removed, so the cache does not
grow with every edit), else ``$UAV_PENETRATION_CACHE/numba/DIGEST`` (the project's cache folder,
:func:`cache.cache_dir`, which other installed versions may share: a digest goes there only after
30 days unused, beyond the 4 most recent, :func:`prune_shared`); a user's ``NUMBA_CACHE_DIR`` is
honoured as the parent, ``NUMBA_CACHE_DIR/uav-penetration-DIGEST`` (never pruned: the folder is theirs).

Every module that defines compiled functions imports this one before its first definition
(``kernels.py``, ``terminal_kernels.py``, ``value_function.py``, ``checks.py``), so the folder is set however
the package is entered; ``import uav_penetration_env`` alone loads no compiled code (the package's
exports load on first use).
"""

from __future__ import annotations

import hashlib
import io
import os
import pickletools
import shutil
import tempfile
import warnings
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


SHARED_KEEP = 4  # digests kept in a shared cache folder (each about 1-3 MB)
SHARED_IDLE_DAYS = 30  # ... and older ones only while some process used them this recently


def prune_shared(parent: Path, keep: Path, *, now: float | None = None) -> list[Path]:
    """Remove old digests' folders from a shared cache folder; returns the removed folders.

    DECISION (model.md §8, the compile cache): the shared folder (``$UAV_PENETRATION_CACHE/numba``,
    used when the package folder is read-only) may serve other installed versions, so nothing there is
    removed while it may be in use: ``keep`` (this process's digest) is touched on every start,
    the ``SHARED_KEEP`` most recently used digests stay, and an older one goes only once no
    process has started with it for ``SHARED_IDLE_DAYS`` days. The cache thus stays at a few
    digests (a few MB) however many edits or versions passed through.
    """
    import time

    now = time.time() if now is None else now
    try:
        keep.mkdir(parents=True, exist_ok=True)
        os.utime(keep)
        others = sorted(
            (path for path in parent.iterdir() if path.is_dir() and path != keep),
            key=lambda path: path.stat().st_mtime,
            reverse=True,
        )
    except OSError:
        return []
    removed = []
    for path in others[SHARED_KEEP - 1 :]:
        try:
            idle = now - path.stat().st_mtime
        except OSError:
            continue
        if idle > SHARED_IDLE_DAYS * 86_400:
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path)
    return removed


def damaged_files(folder: Path) -> list[Path]:
    """The cache files under ``folder`` whose pickle streams are cut short or garbled.

    numba writes each file whole (a temporary file, then a rename), so a damaged one comes from
    outside: a full disk, a copy made while it was written, a bad sync. The streams are walked
    opcode by opcode (``pickletools``), not unpickled: about 5 ms for the whole cache.
    """
    damaged = []
    for path in sorted(folder.rglob("*.nb[ci]")):
        try:
            stream = io.BytesIO(path.read_bytes())
            for _ in pickletools.genops(stream):  # .nbc: one pickle; .nbi: numba's version, then the index
                pass
            if path.suffix == ".nbi":
                for _ in pickletools.genops(stream):
                    pass
        except (OSError, ValueError, EOFError):
            damaged.append(path)
    return damaged


def repair_compile_cache(folder: Path) -> bool:
    """Clear ``folder`` with a warning naming it if any cache file there is damaged; returns whether it did.

    DECISION (model.md §8, a damaged cache): numba unpickles its cache files on a function's first
    call and a cut one kills the process there (``UnpicklingError``), in every later process. So
    each process checks the folder when it sets it and clears the whole folder (an index and its
    data files go together) rather than dying: the physics is compiled again, once.
    """
    damaged = damaged_files(folder) if folder.is_dir() else []
    if not damaged:
        return False
    warnings.warn(
        f"the compile cache {folder} was damaged ({len(damaged)} files cut short or garbled, e.g. "
        f"{damaged[0].name}); cleared it: the physics is compiled again (about a minute)",
        RuntimeWarning,
        stacklevel=2,
    )
    shutil.rmtree(folder, ignore_errors=True)
    return True


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
        # A shared folder another installed version may be using: only long-unused digests go.
        folder = cache.cache_dir() / "numba" / digest
        prune_shared(folder.parent, folder)
    repair_compile_cache(folder)
    numba.config.CACHE_DIR = str(folder)
    return str(folder)


COMPILE_CACHE_DIR = configure_compile_cache()
