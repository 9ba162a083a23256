"""Result rows outside the store: the tables a leaderboard is computed from, as plain files (api.md §4.9).

A published leaderboard must be recomputable by anyone from committed rows alone, without the
SQLite store that produced them. ``uav-bench export`` writes the store's ``episodes``, ``runs``
and ``window_runs`` tables (and ``steps``) as ``<stem>-<table>.<format>``; ``uav-bench leaderboard
--rows <stem>`` reads the first three back and writes the same Markdown and CSV files as
``--store`` would, byte for byte apart from the date line.

DECISION (api.md §4.9): Parquet is the exact format (types, NULL versus empty text, every float bit), so the
published rows are committed as Parquet; CSV is read as well, with each column's type taken from
the store's declared schema (:data:`~.store.EPISODE_COLUMNS`) and floats read back exactly (pandas' default parser round-trips them), which
reproduces the tables too, except that a NULL text cell and an empty one cannot be told apart in
CSV: both read as empty text, which every reader of the plain text columns treats alike, and as
NULL in the JSON columns (:data:`JSON_TEXT_COLUMNS`), where empty text cannot occur.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

ROW_TABLES = ("episodes", "runs", "window_runs")  # what a leaderboard reads
# What ``export`` writes: the leaderboard's tables, the step rows, and the configurations by hash,
# so that ``uav-bench import`` rebuilds the whole store from them (:mod:`~.restore`).
EXPORT_TABLES = (*ROW_TABLES, "steps", "scenarios", "policies")
ROW_FORMATS = ("parquet", "csv")  # the order --rows looks for them in
# Text columns that hold JSON (or NULL): an empty CSV cell there can only have been NULL, since ""
# is not JSON, so the CSV reader restores the NULL and readers that parse the column never meet "".
JSON_TEXT_COLUMNS = ("history", "history_nfev", "state", "provenance", "settings", "config")


class RowsError(ValueError):
    """A rows stem that names no files, or files that are not result rows."""


@dataclass(frozen=True)
class ResultTables:
    """The tables of a results store a leaderboard is computed from.

    Attributes:
        episodes: one row per episode (:meth:`~.store.ResultsStore.episodes`).
        runs: run provenance rows (:meth:`~.store.ResultsStore.runs`).
        window_runs: fixed-target window runs (:meth:`~.store.ResultsStore.window_runs`), maybe empty.
        tracks: the step rows' positions (:data:`~.store.TRACK_COLUMNS`, steps >= 1), which
            the failure kinds are read from (api.md §4.11); ``None`` when the rows have no steps.
        scenarios: scenario hash -> its stored YAML; ``None`` when the rows have no scenarios.
    """

    episodes: pd.DataFrame
    runs: pd.DataFrame
    window_runs: pd.DataFrame
    tracks: pd.DataFrame | None = None
    scenarios: Mapping[str, str] | None = None


def store_tables(store_path: str | Path) -> ResultTables:
    """The row tables of an existing SQLite results store (read only), in one read transaction."""
    from uav_penetration_env.benchmark.store import ResultsStore

    with ResultsStore(store_path, create=False) as store, store.snapshot():  # tables that agree mid-run
        return ResultTables(
            store.episodes(),
            store.runs(),
            store.window_runs(),
            store.tracks(),
            {h: text for h, (_, text) in store.scenarios().items()},
        )


def row_path(stem: str | Path, table: str, extension: str) -> Path:
    """``<stem>-<table>.<extension>``: where ``export`` writes a table and ``--rows`` reads it."""
    stem = Path(stem)
    return stem.parent / f"{stem.name}-{table}.{extension}"


def write_table(frame: pd.DataFrame, path: Path, extension: str) -> None:
    """Write one table atomically (an interrupted export never looks complete)."""
    from uav_penetration_env.atomic import atomic_path

    with atomic_path(path) as temporary:
        if extension == "csv":
            # lineterminator fixed so the bytes do not depend on the platform
            frame.to_csv(temporary, index=False, lineterminator="\n")
        else:
            # zstd: the step table's per-iteration histories shrink to about 2/3 of snappy's size
            # (53 -> 34 MB for leaderboard v2), and every published install is a commit.
            frame.to_parquet(temporary, index=False, compression="zstd")


def _declared_types(table: str) -> dict[str, str]:
    """SQLite type per column of a store table (``TEXT``, ``REAL``, ``INTEGER``), where declared."""
    from uav_penetration_env.benchmark import store

    declared = {
        "episodes": store.EPISODE_COLUMNS,
        "window_runs": store.WINDOW_RUN_COLUMNS,
        "steps": store.STEP_COLUMNS,
    }
    # "TEXT NOT NULL DEFAULT ''" -> "TEXT"
    types = {name: kind.split()[0] for name, kind in declared.get(table, {}).items()}
    types.update({"episode_id": "INTEGER", "run_id": "INTEGER", "window_run_id": "INTEGER"})
    return types


def _read_csv(path: Path, table: str) -> pd.DataFrame:
    """A CSV table with the store's column types (text stays text, floats exact)."""
    header = pd.read_csv(path, nrows=0).columns
    types = _declared_types(table)
    untyped_text = table in ("runs", "scenarios", "policies")  # JSON, YAML and names: all text
    text = [c for c in header if types.get(c) == "TEXT" or (untyped_text and c not in types)]
    frame = pd.read_csv(
        path,
        dtype={c: str for c in text},
        keep_default_na=False,
        na_values={c: [""] for c in header if c not in text},
    )
    for column in header:
        if types.get(column) == "INTEGER" and frame[column].dtype.kind == "f" and frame[column].notna().all():
            frame[column] = frame[column].astype("int64")
        if column in JSON_TEXT_COLUMNS and column in text:
            frame[column] = frame[column].astype(object).where(frame[column] != "", None)
    return frame


def read_table(stem: str | Path, table: str, columns: tuple[str, ...] | None = None) -> pd.DataFrame | None:
    """One exported table under ``stem`` (``None`` where neither format exists), or some of its ``columns``.

    Raises:
        RowsError: the table in both formats, or a file that cannot be read as a table.
    """
    found = [row_path(stem, table, ext) for ext in ROW_FORMATS if row_path(stem, table, ext).is_file()]
    if len(found) > 1:  # two exports under one stem: which one is meant cannot be guessed
        raise RowsError(
            f"--rows {stem}: both {found[0].name} and {found[1].name} exist; expected one format per "
            "stem (remove the older export or export to another stem)"
        )
    if not found:
        return None
    path = found[0]
    try:
        if path.suffix == ".parquet":
            return pd.read_parquet(path, columns=list(columns) if columns is not None else None)
        frame = _read_csv(path, table)
        return frame if columns is None else frame[list(columns)]
    except (OSError, ValueError, KeyError) as error:
        raise RowsError(f"--rows {stem}: {path} is not a readable {table} table ({error})") from None


def read_rows(stem: str | Path) -> ResultTables:
    """The row tables exported under ``stem`` (``<stem>-episodes.parquet`` or ``.csv``, ...).

    ``episodes`` and ``runs`` are required; ``window_runs`` is optional (empty when absent; an
    export always writes it, so a stale one cannot join newer tables); the positions of ``steps``
    and the YAML of ``scenarios`` are read where exported (the failure kinds, api.md §4.11).

    Raises:
        RowsError: no ``<stem>-episodes`` or ``<stem>-runs`` file in either format, a table in
            both formats, or a file that cannot be read as a table.
    """
    frames: dict[str, pd.DataFrame] = {}
    for table in ROW_TABLES:
        frame = read_table(stem, table)
        if frame is None:
            if table == "window_runs":
                frame = pd.DataFrame()
            else:
                expected = " or ".join(str(row_path(stem, table, ext)) for ext in ROW_FORMATS)
                raise RowsError(
                    f"--rows {stem}: no {table} table; expected {expected} (from `uav-bench export`)"
                )
        frames[table] = frame
    if "scenario_hash" not in frames["episodes"].columns:
        raise RowsError(f"--rows {stem}: the episodes table has no scenario_hash column; expected an export")
    from uav_penetration_env.benchmark.store import TRACK_COLUMNS

    tracks = read_table(stem, "steps", TRACK_COLUMNS)
    scenarios = read_table(stem, "scenarios", ("scenario_hash", "yaml"))
    return ResultTables(
        frames["episodes"],
        frames["runs"],
        frames["window_runs"],
        tracks,
        None if scenarios is None else dict(zip(scenarios["scenario_hash"], scenarios["yaml"], strict=True)),
    )


# The id each table is ordered by, as the store reads it (``ORDER BY``), so joined chunks read alike.
_ORDER = {"episodes": ["episode_id"], "runs": ["run_id"], "window_runs": ["window_run_id"],
          "tracks": ["episode_id", "step"]}  # fmt: skip


CHECKPOINT_MANIFEST = "manifest.json"


def concat_pieces(frames: Sequence[pd.DataFrame]) -> pd.DataFrame:
    """One table from its pieces (checkpoint chunks of one export), typed as one export would be.

    An empty piece (a chunk without window runs, or of window runs only) has untyped columns that
    would turn the others' numbers into objects, so it is left out (unless all are empty); a column
    all NULL in one piece reads as object there, so the joined columns' types are inferred again.

    Raises:
        ValueError: no pieces.
    """
    filled = [f for f in frames if not f.empty] or list(frames[:1])
    if not filled:
        raise ValueError("concat_pieces: no pieces; expected at least one table")
    return pd.concat(filled, ignore_index=True).infer_objects() if len(filled) > 1 else filled[0]


def checkpoint_stems(path: str | Path) -> list[Path]:
    """The stems ``path`` stands for: a checkpoint folder's chunks in its manifest's order, else ``[path]``.

    A checkpoint folder (``uav-bench campaign FILE --checkpoint``, docs/publishing.md §5.2) holds
    ``chunk-NNN-<table>.parquet`` files and a ``manifest.json`` naming the chunks that are whole.

    Raises:
        RowsError: an unreadable manifest, or one with seed rows (exports of another store, whose
            ids must be joined with ``uav-bench import`` first).
    """
    import json

    folder = Path(path)
    manifest = folder / CHECKPOINT_MANIFEST
    if not (folder.is_dir() and manifest.is_file()):
        return [folder]
    try:
        content = json.loads(manifest.read_text(encoding="utf-8"))
        names = [str(chunk["name"]) for chunk in content["chunks"]]
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise RowsError(f"--rows {folder}: {manifest.name} is not a checkpoint manifest ({error}); "
                        "expected {\"chunks\": [{\"name\": ...}, ...]}") from None  # fmt: skip
    if content.get("seeds"):
        raise RowsError(f"--rows {folder}: the checkpoint names seed rows of another store; expected "
                        "chunks of one store (rebuild its store with uav-bench campaign FILE --resume and use --store)")  # fmt: skip
    if not names:
        raise RowsError(f"--rows {folder}: the manifest names no chunk; expected at least one")
    return [folder / name for name in names]


def read_chunks(stems: Sequence[str | Path]) -> ResultTables:
    """The row tables of several exports of one store (``--rows STEM [STEM ...]``), read as one.

    A store exported in pieces (a publication's checkpoint chunks, docs/publishing.md §5.2) has
    disjoint run, episode and window-run ids, so the pieces are concatenated, each table ordered
    by its id as the store orders it, and the scenarios kept once by hash. A checkpoint folder
    stands for the chunks its manifest names (:func:`checkpoint_stems`). One stem is
    :func:`read_rows` itself.

    Raises:
        RowsError: a stem :func:`read_rows` refuses, an id in two stems (exports of different
            stores: join them with ``uav-bench import`` first), or one scenario hash with two YAML texts.
    """
    stems = [piece for stem in stems for piece in checkpoint_stems(stem)]
    if len(stems) == 1:
        return read_rows(stems[0])
    pieces = [read_rows(stem) for stem in stems]
    joined: dict[str, pd.DataFrame | None] = {}
    for table in ("episodes", "runs", "window_runs", "tracks"):
        frames = [getattr(piece, table) for piece in pieces]
        present = [f for f in frames if f is not None]
        if table == "tracks" and len(present) < len(frames):
            joined[table] = None  # some piece has no steps: no failure kinds, as for one such stem
            continue
        frame = concat_pieces(present)
        key = _ORDER[table][0]
        if table != "tracks" and key in frame.columns and frame[key].duplicated().any():
            repeated = int(frame.loc[frame[key].duplicated(), key].iloc[0])
            raise RowsError(
                f"--rows: {table} {key} {repeated} is in two of {', '.join(map(str, stems))}; expected "
                "exports of one store with disjoint ids (join other stores with `uav-bench import` first)"
            )
        order = [column for column in _ORDER[table] if column in frame.columns]
        if order:
            frame = frame.sort_values(order, kind="stable", ignore_index=True)
        joined[table] = frame
    scenarios: dict[str, str] | None = {}
    for piece in pieces:
        if piece.scenarios is None:
            scenarios = None
            break
        for digest, text in piece.scenarios.items():
            if scenarios.setdefault(digest, text) != text:
                raise RowsError(f"--rows: scenario {digest} has two different YAML texts among the stems; "
                                "expected exports of one store")  # fmt: skip
    return ResultTables(
        joined["episodes"], joined["runs"], joined["window_runs"], joined["tracks"], scenarios
    )
