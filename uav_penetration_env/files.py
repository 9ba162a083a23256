"""Files a scenario reads (DEM rasters, RCS tables): where they are and what they contain.

A scenario's identity must follow the content of the files it reads, not their names: a raster
rewritten in place is another terrain (model.md §7a, "content-keyed identities"). This leaf module
resolves a file name and digests its bytes; ``Scenario.hash`` and the build caches use the digest.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

_digests: dict[tuple[str, int, int], str] = {}


def resolve_data_file(name: str) -> Path | None:
    """The path of ``name``: a file on disk, else a matplotlib sample file of that name, else None."""
    path = Path(name).expanduser()
    if path.exists():
        return path
    try:
        from matplotlib import cbook

        return Path(cbook.get_sample_data(name, asfileobj=False))
    except (OSError, ValueError):
        return None


def file_digest(name: str) -> str:
    """SHA-256 (hex) of the bytes of file ``name`` (resolved as :func:`resolve_data_file` does).

    Memoised per (path, size, modification time), so a file rewritten in place gets a new digest
    in the same process. A file that does not exist digests to ``"missing"``: the scenario still
    has an identity, and building it raises the loader's clear error.
    """
    path = resolve_data_file(name)
    if path is None or not path.is_file():
        return "missing"
    path = path.resolve()
    status = path.stat()
    key = (str(path), status.st_size, status.st_mtime_ns)
    if key not in _digests:
        digest = hashlib.sha256()
        with path.open("rb") as stream:
            for block in iter(lambda: stream.read(1 << 20), b""):
                digest.update(block)
        _digests[key] = digest.hexdigest()
    return _digests[key]
