"""Files a scenario reads (DEM rasters, RCS tables): where they are and what they contain.

A scenario's identity must follow the content of the files it reads, not their names: a raster
rewritten in place is another terrain (model.md §7a, "content-keyed identities"). This leaf module
resolves a file name and digests its bytes; ``Scenario.hash`` and the build caches use the digest.
"""

from __future__ import annotations

import hashlib
import time
from pathlib import Path

_digests: dict[tuple[str, int, int, int, int], tuple[str, int]] = {}
# A memoised digest is trusted only for a file that was already this old when it was hashed: file
# timestamps advance in clock ticks (milliseconds on Linux), so a same-size rewrite within the tick
# of the hash would keep the memo key; a file older than this cannot be rewritten unseen.
_SETTLED_NS = 2_000_000_000


def resolve_data_file(name: str) -> Path | None:
    """The path of ``name``: a file on disk, else a matplotlib sample file of that name, else None.

    DECISION (model.md §2.5, the sample rasters): matplotlib's sample files (``topobathy.npz``, the
    DEM id's raster) are found in its installed package folder (``mpl-data/sample_data``, where
    ``matplotlib.cbook.get_sample_data`` reads them) without importing matplotlib, which is not a
    core dependency: a core install without it gets None here, and the DEM scenario's one-line
    error naming what to install (:func:`sample_data_missing`).
    """
    try:
        path = Path(name).expanduser()
        if path.exists():
            return path
    except (OSError, ValueError):  # a name the OS cannot take (too long, a NUL byte): no such file
        return None
    folder = _sample_data_folder()
    if folder is None or Path(name).name != name:
        return None
    sample = folder / name
    return sample if sample.is_file() else None


def _sample_data_folder() -> Path | None:
    """The ``mpl-data/sample_data`` folder of matplotlib, found without importing it; None when it is not installed."""
    import importlib.util

    try:
        spec = importlib.util.find_spec("matplotlib")
    except (ImportError, ValueError):  # not importable (a hidden or a None entry in sys.modules)
        return None
    if spec is None or spec.origin is None:
        return None
    return Path(spec.origin).parent / "mpl-data" / "sample_data"


def sample_data_missing() -> str:
    """What to install for matplotlib's sample files, or ``""`` when matplotlib is installed."""
    if _sample_data_folder() is not None:
        return ""
    return (
        "; matplotlib is not installed, and its sample files are found in its package "
        "(pip install matplotlib, or the harness extra: pip install 'uav-penetration[harness]')"
    )


def file_digest(name: str) -> str:
    """SHA-256 (hex) of the bytes of file ``name`` (resolved as :func:`resolve_data_file` does).

    Memoised per (path, inode, size, modification and change times), so a file rewritten in place
    gets a new digest in the same process. DECISION (model.md §7a): as git does for "racily clean"
    files, the memo is used only if the file was at least 2 s old when it was hashed; a file
    modified more recently than that is hashed again on every call, since a same-size rewrite in
    the same timestamp tick would otherwise keep its old digest. A file that does not exist
    digests to ``"missing"``: the scenario still has an identity, and building it raises the
    loader's clear error.
    """
    path = resolve_data_file(name)
    if path is None or not path.is_file():
        return "missing"
    path = path.resolve()
    status = path.stat()
    key = (str(path), status.st_ino, status.st_size, status.st_mtime_ns, status.st_ctime_ns)
    memo = _digests.get(key)
    if memo is not None and memo[1] - max(status.st_mtime_ns, status.st_ctime_ns) >= _SETTLED_NS:
        return memo[0]
    hashed_at = time.time_ns()
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    _digests[key] = (digest.hexdigest(), hashed_at)
    return digest.hexdigest()
