"""The manifest an export writes last, and the completeness check ``uav-bench import`` makes first (api.md §4.9).

``uav-bench export`` writes its six tables one file at a time, each atomically, so a kill or a
full disk between two of them leaves an export that looks whole table by table but lacks the
rest. The export's last file, ``<stem>-manifest.json``, lists each table's file, row count and
SHA-256; its presence says the export finished, and its digests say that every table is the one
that export wrote (not a table of an earlier export under the same stem).

DECISION (api.md §4.9): an import with a manifest needs every table it lists, byte for byte; an
import without one (an export written before manifests existed, or rows merged by ``uav-bench campaign --resume``)
needs the episodes, runs and steps tables, and the scenarios and policies tables both or neither
(the legacy form without them is rebuilt from the package, each scenario checked against its
hash); the window runs are optional, as ``leaderboard --rows`` reads them. Anything less
is refused in one line before anything is written. Each table is written atomically, so a table
that exists is whole; the rows' agreement with each other is the store's to check (a step of a
missing episode is refused by its foreign key).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from pathlib import Path

from uav_penetration_env.benchmark.rows import EXPORT_TABLES, ROW_FORMATS, RowsError, row_path

MANIFEST_KIND = "uav-bench export"
MAX_MANIFEST_BYTES = 1 << 20  # six entries take a few hundred bytes: anything far larger is not ours
LEGACY_OPTIONAL = ("scenarios", "policies")  # absent together from exports before version 2's tables


def manifest_path(stem: str | Path) -> Path:
    """``<stem>-manifest.json``."""
    return row_path(stem, "manifest", "json")


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def write_manifest(stem: str | Path, written: Mapping[str, tuple[Path, int]]) -> Path:
    """Write the manifest of the tables ``written`` (table -> (file, rows)); call it after the last table."""
    from uav_penetration_env.atomic import write_text_atomic

    tables = {
        table: {"file": path.name, "rows": int(rows), "sha256": _sha256(path)}
        for table, (path, rows) in written.items()
    }
    text = json.dumps({"kind": MANIFEST_KIND, "version": 1, "tables": tables}, indent=1, sort_keys=True)
    return write_text_atomic(manifest_path(stem), text + "\n")


def _incomplete(stem: str | Path, what: str) -> RowsError:
    return RowsError(f"--rows {stem}: incomplete export: {what}; expected a complete `uav-bench export` (export again)")


def _read_manifest(stem: str | Path, path: Path) -> dict[str, dict[str, object]]:
    try:
        if path.stat().st_size > MAX_MANIFEST_BYTES:
            raise ValueError(f"larger than {MAX_MANIFEST_BYTES} bytes")
        data = json.loads(path.read_text(encoding="utf-8"))
        tables = data["tables"] if isinstance(data, dict) and data.get("kind") == MANIFEST_KIND else None
        if not isinstance(tables, dict) or not all(isinstance(entry, dict) for entry in tables.values()):
            raise ValueError(f"not a manifest of {MANIFEST_KIND}")
    except (OSError, ValueError, KeyError, UnicodeDecodeError) as error:
        raise RowsError(f"--rows {stem}: {path.name} is not an export manifest ({error})") from None
    return tables


def check_export(stem: str | Path) -> None:
    """Refuse an export that is incomplete or mixes two exports (see the module docstring).

    Raises:
        RowsError: one line naming ``--rows STEM`` and what is missing or differs.
    """
    stem = Path(stem)
    manifest = manifest_path(stem)
    if manifest.is_file():
        tables = _read_manifest(stem, manifest)
        for table in EXPORT_TABLES:
            entry = tables.get(table)
            name = entry.get("file") if entry else None
            if not isinstance(name, str) or Path(name).name != name or not name.startswith(f"{stem.name}-{table}."):
                raise _incomplete(stem, f"{manifest.name} lists no {table} table")
            path = stem.parent / name
            if not path.is_file():
                raise _incomplete(stem, f"{name} is missing ({manifest.name} lists it)")
            if _sha256(path) != entry.get("sha256"):
                raise _incomplete(stem, f"{name} is not the file {manifest.name} lists (another export's?)")
        return
    present = {t for t in EXPORT_TABLES if any(row_path(stem, t, ext).is_file() for ext in ROW_FORMATS)}
    if "episodes" not in present:
        return  # read_rows says what is missing, as before
    optional = {"window_runs"} | (set() if present & set(LEGACY_OPTIONAL) else set(LEGACY_OPTIONAL))
    needed = [t for t in EXPORT_TABLES if t not in optional]
    missing = [t for t in needed if t not in present]
    if missing:
        raise _incomplete(stem, f"no {manifest.name} (an export writes it last) and no {missing[0]} table")


__all__ = ["check_export", "manifest_path", "write_manifest"]
