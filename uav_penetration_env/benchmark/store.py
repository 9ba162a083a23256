"""The results store: one SQLite file that survives interruption (api.md, harness).

Tables: ``schema_version``; ``runs`` (provenance of each ``evaluate`` call); ``policies`` and
``scenarios`` (configurations by hash, so a store is self-describing); ``episodes`` (one row per
episode, unique by ``(policy_hash, scenario_hash, seed)``); ``steps`` (one row per track point,
step 0 being the start state); ``window_runs`` (optimiser runs on MPC window states of stored
episodes, ``uav-bench windows``, api.md §4.8). The columns of ``episodes``, ``steps`` and
``window_runs`` are declared in :mod:`uav_penetration_env.benchmark.columns`.

Opening a store upgrades it in place, once: tables and columns declared since it was written are
added (``CREATE TABLE IF NOT EXISTS``, ``ALTER TABLE ... ADD COLUMN``, NULL in old rows), and a version-1 store gains the step-0 row of
every episode that has steps, computed from the scenario it names (:func:`migrate_start_rows`).

Only the parent process writes, one transaction per finished episode (its row and all its steps
together), in WAL mode: an interrupted sweep leaves every finished episode and nothing partial,
and a rerun skips what is done and retries ``error`` rows.
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import sqlite3
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark.columns import EPISODE, STEP, WINDOW_RUN, sql_types, start_row
from uav_penetration_env.benchmark.store_cells import cell_problem, configuration_problem

# Version 2 (this one) stores each episode's start state as a step-0 row; version 1 had none.
SCHEMA_VERSION = 2

EPISODE_COLUMNS: dict[str, str] = sql_types(EPISODE)  # name -> SQLite type, from benchmark.columns
STEP_COLUMNS: dict[str, str] = sql_types(STEP)
WINDOW_RUN_COLUMNS: dict[str, str] = sql_types(WINDOW_RUN)
# The step columns a track is read from (ResultsStore.tracks; the failure kinds, api.md §4.11).
TRACK_COLUMNS = ("episode_id", "step", "x_km", "y_km", "z_m")
# A window run is unique by its window, its MPC configuration and its seed (a rerun skips it).
WINDOW_RUN_KEY = ("scenario_hash", "source_policy_hash", "episode_seed", "step", "optimizer_hash", "seed")


class StoreError(RuntimeError):
    """The results store cannot be opened, created, read or written.

    Attributes:
        path: the store's path.
        reason: what is wrong, without the path (``uav-bench`` prints ``--store PATH: REASON``).
    """

    def __init__(self, path: str | Path, reason: str) -> None:
        super().__init__(f"results store {path}: {reason}")
        self.path = Path(path)
        self.reason = reason


class StoreWriteError(StoreError):
    """Writing to a store that opened failed (its disk is full, it became read-only): finished work is kept.

    Failed work rather than a bad input: ``uav-bench`` prints its one line with exit status 1.
    """


SQLITE_MAGIC = b"SQLite format 3\x00"


def inspect_store_file(path: str | Path, *, must_exist: bool = False) -> None:
    """Check, by reading only, that ``path`` is absent, empty, or a results store this version can use.

    Run before any write, so that a file that is not one of ours (a text file, another
    application's database, a store of a newer schema, a truncated copy) is never modified: SQLite
    itself would happily switch another application's database to WAL mode and add our tables.

    DECISION (api.md §4.7, truncation check): a file shorter than the size its SQLite header declares (page size x
    page count, header bytes 16-17 and 28-31, valid when bytes 24-27 equal bytes 92-95) is
    refused as damaged, rather than opened and failing on the first missing page, which for a
    store truncated mid-copy may be deep inside a leaderboard build. The check reads 100 bytes;
    a full ``PRAGMA integrity_check`` would read the whole store on every command. It steps aside
    while a non-empty ``-wal`` file is beside the store: a checkpoint interrupted by a full disk or
    a kill leaves a short main file whose missing pages SQLite reads back from the log.

    Args:
        path: the store's path.
        must_exist: refuse a missing or empty file too (readers: leaderboard, plot, export).

    Raises:
        StoreError: a folder, an unreadable path, not an SQLite file, damaged, an SQLite file
            without our tables, or a schema version this version does not know.
    """
    path = Path(path)
    read = _read_header(path, must_exist)
    if read is None:
        return
    _check_header(path, *read)
    tables, version = _schema_version(path, must_exist)
    if not tables:
        return
    if version == SCHEMA_VERSION or version in MIGRATIONS:
        return
    if isinstance(version, int) and version > SCHEMA_VERSION:
        raise StoreError(
            path,
            f"schema version {version} is newer than this uav-penetration reads ({SCHEMA_VERSION}); "
            "upgrade uav-penetration to use it",
        )
    raise StoreError(
        path,
        f"schema version {version!r}, expected {SCHEMA_VERSION} or an older one this version migrates "
        f"({', '.join(map(str, sorted(MIGRATIONS)))})",
    )


@contextlib.contextmanager
def _side_files_removed_on_failure(path: Path) -> Iterator[None]:
    """Remove the ``-wal``/``-shm`` files an open of ``path`` created, if it is refused as damaged.

    A store refused as damaged is left as it was found, not with two new files beside it.
    """
    side = [path.with_name(path.name + suffix) for suffix in ("-wal", "-shm")]
    before = {file for file in side if file.exists()}
    try:
        yield
    except StoreError:
        for file in side:
            if file not in before:
                file.unlink(missing_ok=True)
        raise


def _read_only(path: Path) -> sqlite3.Connection:
    """A connection that cannot write to ``path`` and leaves no file beside it (checks, read-only media).

    DECISION (api.md §4.7, read-only media): a WAL-mode store's readers share a ``-shm`` file,
    which SQLite creates, with an empty ``-wal``, even for a read-only connection and leaves
    behind: a damaged store refused by the checks would gain two files, and in a folder nobody
    can write (a read-only mount, a published store) the open fails. So unless a ``-wal`` file
    holds a writer's pages, the store is opened ``immutable=1``: read as the file is, with no
    locks and no side files. On read-only media a ``-wal`` left beside the store is ignored; a
    store closed by its writer has none.
    """
    wal = path.with_name(path.name + "-wal")
    live = wal.is_file() and wal.stat().st_size > 0 and _writable_folder(path)
    flags = "mode=ro" if live else "mode=ro&immutable=1"
    return sqlite3.connect(f"{path.resolve().as_uri()}?{flags}", uri=True, timeout=60.0)


def _writable_folder(path: Path) -> bool:
    """Whether files can be created beside ``path`` (False on a read-only file system)."""
    return os.access(path.resolve().parent, os.W_OK)


def _read_only_media(path: Path) -> bool:
    """Whether ``path`` exists but neither it nor its folder can be written (read-only media)."""
    return path.is_file() and not (os.access(path, os.W_OK) and _writable_folder(path))


def check_integrity(path: str | Path) -> None:
    """SQLite's own ``PRAGMA quick_check`` of an existing store, read-only (before ``run`` writes into it).

    The header checks of :func:`inspect_store_file` cannot see pages damaged inside a file of the
    right size (zeroed by a failed sync, overwritten); SQLite reads every page here, so a run refuses
    such a store instead of adding episodes to it and failing mid-way. It reads the whole file:
    about a second per few hundred MB.

    Raises:
        StoreError: SQLite reports the file damaged.
    """
    path = Path(path)
    if not path.is_file() or path.stat().st_size == 0:
        return
    try:
        connection = _read_only(path)
        try:
            rows = connection.execute("PRAGMA quick_check").fetchall()
        finally:
            connection.close()
    except sqlite3.DatabaseError as error:
        raise StoreError(path, f"damaged ({error})") from None
    if rows != [("ok",)]:
        more = f" (and {len(rows) - 1} more problems)" if len(rows) > 1 else ""
        raise StoreError(path, f"damaged: SQLite's integrity check reports {rows[0][0]!r}{more}")


def _read_header(path: Path, must_exist: bool) -> tuple[bytes, int] | None:
    """The file's first 100 bytes and its size; None for an absent or empty file a writer may create."""
    try:
        if path.is_dir():
            raise StoreError(
                path, "is a folder; expected a results store file (e.g. results/uav-bench.sqlite)"
            )
        if not path.exists():
            if must_exist:
                raise StoreError(path, "not found; run `uav-bench run` first or pass --store PATH")
            return None
        with path.open("rb") as handle:
            header = handle.read(100)
        size = path.stat().st_size
    except OSError as error:
        raise StoreError(path, f"cannot read it ({error.strerror or error})") from None
    if size == 0:
        if must_exist:
            raise StoreError(path, "an empty file, not a results store")
        return None
    return header, size


def _check_header(path: Path, header: bytes, size: int) -> None:
    """Refuse a file that is not SQLite, or shorter than its header declares (the truncation check)."""
    if not header.startswith(SQLITE_MAGIC):
        raise StoreError(path, "not a results store (not an SQLite database file)")
    if len(header) < 100:
        raise StoreError(path, f"damaged: {size} bytes, shorter than an SQLite header (100 bytes)")
    page_size = int.from_bytes(header[16:18], "big")
    page_size = 65536 if page_size == 1 else page_size
    pages = int.from_bytes(header[28:32], "big")
    header_valid = header[24:28] == header[92:96]
    wal = path.with_name(path.name + "-wal")
    # A checkpoint interrupted by a full disk or a kill leaves the new header in the main file and the
    # pages still in the write-ahead log, which SQLite reads back: the store is short, not damaged.
    pending_wal = wal.is_file() and wal.stat().st_size > 0
    if header_valid and pages and size < page_size * pages and not pending_wal:
        raise StoreError(
            path,
            f"damaged: the file has {size} bytes but its SQLite header declares {pages} pages of "
            f"{page_size} bytes ({pages * page_size} bytes); was it truncated or copied while written?",
        )


def _schema_version(path: Path, must_exist: bool) -> tuple[set[str], Any]:
    """The database's tables and its ``schema_version``, read-only.

    A database without any table is a new store (no version) unless ``must_exist``.

    Raises:
        StoreError: unreadable, damaged, or an SQLite database without the table every store has.
    """
    try:
        connection = _read_only(path)
    except sqlite3.Error as error:
        raise StoreError(path, f"cannot read it ({error})") from None
    try:
        tables = {row[0] for row in connection.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        if not tables and not must_exist:
            return tables, None
        if "schema_version" not in tables:  # the table every results store has, from its creation
            shown = ", ".join(sorted(tables)[:5]) + (", ..." if len(tables) > 5 else "") or "none"
            raise StoreError(path, f"an SQLite database but not a results store (its tables: {shown})")
        row = connection.execute("SELECT version FROM schema_version").fetchone()
    except sqlite3.DatabaseError as error:
        raise StoreError(path, f"damaged or not a results store ({error})") from None
    finally:
        connection.close()
    if row is None or not isinstance(row[0], int):  # every store writes its version on creation
        found = "no version" if row is None else f"the version {row[0]!r}"
        raise StoreError(path, f"damaged or not a results store (its schema_version table holds {found})")
    return tables, row[0]


def _json(value: Any) -> str:
    return json.dumps(
        value, sort_keys=True, default=lambda o: o.tolist() if isinstance(o, np.ndarray) else str(o)
    )


_Reader = TypeVar("_Reader", bound=Callable[..., Any])


def _reading(method: _Reader) -> _Reader:
    """A reader of the store whose SQLite errors (a damaged page) become :class:`StoreError`."""

    @functools.wraps(method)
    def read(self: ResultsStore, *args: Any, **kwargs: Any) -> Any:
        try:
            return method(self, *args, **kwargs)
        except (sqlite3.DatabaseError, pd.errors.DatabaseError) as error:
            raise StoreError(self.path, f"damaged, cannot read it ({error})") from error

    return read  # type: ignore[return-value]


def _writing(method: _Reader) -> _Reader:
    """A writer of the store whose SQLite errors (a full disk) become :class:`StoreWriteError`.

    Each write is one transaction, so what was written before the failure stays whole.
    """

    @functools.wraps(method)
    def write(self: ResultsStore, *args: Any, **kwargs: Any) -> Any:
        try:
            return method(self, *args, **kwargs)
        except sqlite3.OperationalError as error:
            hint = "; free space on its disk and rerun: what was stored before is kept" if "full" in str(error) else ""
            raise StoreWriteError(self.path, f"cannot write to it ({error}){hint}") from error

    return write  # type: ignore[return-value]


class ResultsStore:
    """An SQLite results file. Opening creates it (and its folder) if needed.

    Args:
        path: the SQLite file.
        create: create the store if there is none (``False``: readers, which need an existing one).

    Raises:
        StoreError: the path is a folder, unreadable or not writable; the file is damaged, not a
            results store, or of a schema version this version does not know
            (:func:`inspect_store_file`). Reads that meet a damaged page raise it too.
    """

    def __init__(self, path: str | Path, *, create: bool = True) -> None:
        self.path = Path(path)
        # Reads only: a file that is not ours is refused unchanged.
        inspect_store_file(self.path, must_exist=not create)
        if not create and _read_only_media(self.path):
            self._connection = _read_only(self.path)
            self._check_readable_as_is()
            return
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._connection = sqlite3.connect(self.path, timeout=60.0)
        except (OSError, sqlite3.Error) as error:
            raise StoreError(
                self.path, f"cannot open or create it ({error}); expected a writable file path"
            ) from error
        with _side_files_removed_on_failure(self.path):
            try:
                self._connection.execute("PRAGMA journal_mode=WAL")
                self._connection.execute("PRAGMA synchronous=NORMAL")
                self._connection.execute("PRAGMA foreign_keys=ON")
                self._create()
            except (sqlite3.DatabaseError, StoreError) as error:
                self._connection.close()
                if isinstance(error, StoreError):
                    raise
                raise StoreError(self.path, f"damaged or not writable ({error})") from error

    def _check_readable_as_is(self) -> None:
        """A store on read-only media is read unchanged: refuse one that needs the upgrade opening does."""
        try:
            (version,) = self._connection.execute("SELECT version FROM schema_version").fetchone()
            missing = [
                f"{table}.{name}"
                for table, declared in (("episodes", EPISODE_COLUMNS), ("steps", STEP_COLUMNS), ("window_runs", WINDOW_RUN_COLUMNS))
                for name in declared
                if name not in {r[1] for r in self._connection.execute(f"PRAGMA table_info({table})")}
            ]  # fmt: skip
        except (sqlite3.DatabaseError, TypeError) as error:
            self._connection.close()
            raise StoreError(self.path, f"damaged or not a results store ({error})") from None
        if version != SCHEMA_VERSION or missing:
            self._connection.close()
            what = f"schema version {version}" if version != SCHEMA_VERSION else f"no column {missing[0]}"
            raise StoreError(
                self.path,
                f"written by an older version ({what}) and read-only here, so it cannot be upgraded; "
                "copy it to a writable folder and rerun",
            )

    def _create(self) -> None:
        connection = self._connection
        with connection:
            connection.execute("CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL)")
            row = connection.execute("SELECT version FROM schema_version").fetchone()
            if row is None:
                connection.execute("INSERT INTO schema_version VALUES (?)", (SCHEMA_VERSION,))
                version = SCHEMA_VERSION
            elif row[0] in MIGRATIONS or row[0] == SCHEMA_VERSION:
                version = int(row[0])
            else:
                raise StoreError(
                    self.path,
                    f"schema version {row[0]}, expected {SCHEMA_VERSION} "
                    f"or an older one this version migrates ({', '.join(map(str, sorted(MIGRATIONS)))})",
                )
            connection.execute(
                "CREATE TABLE IF NOT EXISTS runs (run_id INTEGER PRIMARY KEY AUTOINCREMENT, started TEXT, "
                "provenance TEXT, settings TEXT)"
            )
            connection.execute(
                "CREATE TABLE IF NOT EXISTS policies (policy_hash TEXT PRIMARY KEY, policy TEXT, config TEXT)"
            )
            connection.execute(
                "CREATE TABLE IF NOT EXISTS scenarios (scenario_hash TEXT PRIMARY KEY, scenario TEXT, yaml TEXT)"
            )
            columns = ", ".join(f"{name} {kind}" for name, kind in EPISODE_COLUMNS.items())
            connection.execute(
                f"CREATE TABLE IF NOT EXISTS episodes (episode_id INTEGER PRIMARY KEY AUTOINCREMENT, {columns}, "
                "UNIQUE (policy_hash, scenario_hash, seed))"
            )
            columns = ", ".join(f"{name} {kind}" for name, kind in STEP_COLUMNS.items())
            connection.execute(
                "CREATE TABLE IF NOT EXISTS steps (episode_id INTEGER NOT NULL REFERENCES episodes(episode_id) "
                f"ON DELETE CASCADE, {columns}, PRIMARY KEY (episode_id, step))"
            )
            columns = ", ".join(f"{name} {kind}" for name, kind in WINDOW_RUN_COLUMNS.items())
            connection.execute(
                "CREATE TABLE IF NOT EXISTS window_runs (window_run_id INTEGER PRIMARY KEY AUTOINCREMENT, "
                f"{columns}, UNIQUE ({', '.join(WINDOW_RUN_KEY)}))"
            )
            for table, declared in (
                ("episodes", EPISODE_COLUMNS),
                ("steps", STEP_COLUMNS),
                ("window_runs", WINDOW_RUN_COLUMNS),
            ):
                present = {r[1] for r in connection.execute(f"PRAGMA table_info({table})")}
                for name, kind in declared.items():
                    if name not in present:  # a column declared after the store was written
                        connection.execute(f"ALTER TABLE {table} ADD COLUMN {name} {kind}")
            while version != SCHEMA_VERSION:
                MIGRATIONS[version](connection)
                version += 1
                connection.execute("UPDATE schema_version SET version = ?", (version,))

    # --- writing ---------------------------------------------------------------------------------------

    @_writing
    def start_run(self, provenance: Mapping[str, Any], settings: Mapping[str, Any]) -> int:
        """Record a sweep's provenance; returns its ``run_id``."""
        with self._connection:
            cursor = self._connection.execute(
                "INSERT INTO runs (started, provenance, settings) VALUES (?, ?, ?)",
                (provenance.get("date", ""), _json(dict(provenance)), _json(dict(settings))),
            )
        return int(cursor.lastrowid)

    @_writing
    def register(
        self, policies: Mapping[str, tuple[str, Mapping[str, Any]]], scenarios: Mapping[str, tuple[str, str]]
    ) -> None:
        """Store configurations: ``policies[hash] = (name, config)``, ``scenarios[hash] = (name, yaml)``."""
        with self._connection:
            self._connection.executemany(
                "INSERT OR REPLACE INTO policies VALUES (?, ?, ?)",
                [(h, n, _json(dict(c))) for h, (n, c) in policies.items()],
            )
            self._connection.executemany(
                "INSERT OR REPLACE INTO scenarios VALUES (?, ?, ?)",
                [(h, n, y) for h, (n, y) in scenarios.items()],
            )

    @_writing
    def write_episode(self, episode: Mapping[str, Any], steps: Sequence[Mapping[str, Any]]) -> int:
        """Write one finished episode and its steps in one transaction (replacing an ``error`` row).

        Returns:
            The new ``episode_id``.
        """
        row = {name: _sql_value(episode.get(name)) for name in EPISODE_COLUMNS}
        row["error"] = row["error"] or ""
        key = (row["policy_hash"], row["scenario_hash"], row["seed"])
        with self._connection:
            self._connection.execute(
                "DELETE FROM episodes WHERE policy_hash = ? AND scenario_hash = ? AND seed = ?", key
            )
            names = ", ".join(row)
            marks = ", ".join("?" for _ in row)
            cursor = self._connection.execute(
                f"INSERT INTO episodes ({names}) VALUES ({marks})", tuple(row.values())
            )
            episode_id = int(cursor.lastrowid)
            if steps:
                step_names = list(STEP_COLUMNS)
                self._connection.executemany(
                    f"INSERT INTO steps (episode_id, {', '.join(step_names)}) VALUES (?, {', '.join('?' for _ in step_names)})",
                    [(episode_id, *(_sql_value(s.get(name)) for name in step_names)) for s in steps],
                )
        return episode_id

    @_writing
    def drop_policy(self, policy_hash: str) -> tuple[int, int]:
        """Delete every episode of one policy configuration, its steps and its ``policies`` row.

        One transaction: the store holds all of the policy's rows or none of them, whatever
        interrupts it. Other policies' rows and the runs table are untouched.

        Args:
            policy_hash: the full configuration hash (``policies.policy_hash``).

        Returns:
            (episodes deleted, steps deleted).
        """
        with self._connection:
            ids = "SELECT episode_id FROM episodes WHERE policy_hash = ?"
            steps = self._connection.execute(f"DELETE FROM steps WHERE episode_id IN ({ids})", (policy_hash,))
            episodes = self._connection.execute("DELETE FROM episodes WHERE policy_hash = ?", (policy_hash,))
            self._connection.execute("DELETE FROM policies WHERE policy_hash = ?", (policy_hash,))
        return int(episodes.rowcount), int(steps.rowcount)

    @_writing
    def write_window_runs(self, rows: Sequence[Mapping[str, Any]]) -> None:
        """Write optimiser runs on stored window states (``uav-bench windows``) in one transaction.

        A row with the key of a stored one (:data:`WINDOW_RUN_KEY`) replaces it.
        """
        names = list(WINDOW_RUN_COLUMNS)
        with self._connection:
            self._connection.executemany(
                f"INSERT OR REPLACE INTO window_runs ({', '.join(names)}) VALUES ({', '.join('?' for _ in names)})",
                [tuple(_sql_value(row.get(name)) for name in names) for row in rows],
            )

    @_writing
    def load_exported(self, tables: Mapping[str, pd.DataFrame]) -> None:
        """Fill an empty store with exported rows, keeping every id (``uav-bench import``, api.md §4.9).

        Args:
            tables: ``runs``, ``episodes``, ``steps``, ``window_runs``, ``scenarios`` and
                ``policies`` frames as ``uav-bench export`` writes them (any may be empty or
                missing). Columns the export lacks (an older version) are NULL; the step-0 rows,
                which an export leaves out (:meth:`steps`), are recomputed from the scenarios
                (:func:`migrate_start_rows`), so ``scenarios`` must hold every episode's scenario.

        Raises:
            StoreError: the store already holds results, or cannot be written.
            ValueError: rows that cannot form a store (nothing is written): a column this version
                does not declare (a newer export), rows SQLite refuses (a step whose episode is
                missing, a repeated id, NULL where a value is required), or episodes whose scenario
                no longer builds to the hash they recorded (their start rows could not be computed).
        """
        held = sum(self.count(table) for table in ("runs", "episodes", "window_runs"))
        if held:
            raise StoreError(self.path, f"holds {held} rows already; expected an empty store to import into")
        declared = {
            "runs": ["run_id", "started", "provenance", "settings"],
            "policies": ["policy_hash", "policy", "config"],
            "scenarios": ["scenario_hash", "scenario", "yaml"],
            "episodes": ["episode_id", *EPISODE_COLUMNS],
            "steps": ["episode_id", *STEP_COLUMNS],
            "window_runs": ["window_run_id", *WINDOW_RUN_COLUMNS],
        }
        with self._connection:  # one transaction: an interrupted import leaves an empty store
            for table, columns in declared.items():  # parents before children (foreign keys)
                frame = tables.get(table)
                if frame is None or frame.empty:
                    continue
                unknown = [c for c in frame.columns if c not in columns]
                if unknown:
                    raise ValueError(
                        f"the {table} table has column {unknown[0]!r}, which this version does not store "
                        "(an export of a newer version?); expected the columns of this version's export"
                    )
                names = [c for c in columns if c in frame.columns]
                cells = frame[names].astype(object).where(frame[names].notna(), None)
                try:
                    self._connection.executemany(
                        f"INSERT INTO {table} ({', '.join(names)}) VALUES ({', '.join('?' for _ in names)})",
                        [tuple(_sql_value(v) for v in row) for row in cells.itertuples(index=False, name=None)],
                    )
                except sqlite3.IntegrityError as error:
                    raise ValueError(f"the {table} table has rows a store refuses ({error})") from None
            migrate_start_rows(self._connection)
            # migrate_start_rows passes by an episode whose scenario no longer builds to its hash;
            # an import must not: its rows would read differently from the exported store's.
            (startless,) = self._connection.execute(
                "SELECT COUNT(DISTINCT episode_id) FROM steps WHERE episode_id NOT IN "
                "(SELECT episode_id FROM steps WHERE step = 0)"
            ).fetchone()
            if startless:
                raise ValueError(
                    f"{startless} episodes have steps but no start row: their scenario YAML no longer builds to "
                    "the hash they recorded; expected an export of this version's scenarios"
                )

    # --- reading ---------------------------------------------------------------------------------------

    @contextlib.contextmanager
    def snapshot(self) -> Iterator[None]:
        """One read transaction: every read inside sees the store as it was at the first one.

        A ``run`` writing the same store commits episodes between two reads; read in one
        transaction, an export's tables agree with each other (no step of an episode its
        episodes table lacks). In WAL mode the writer carries on meanwhile. Nothing is written.
        """
        if self._connection.in_transaction:
            yield  # already inside one (nested): its snapshot holds
            return
        self._connection.execute("BEGIN")
        try:
            # The snapshot starts at the first read, so take it now, not at the first table.
            self._connection.execute("SELECT COUNT(*) FROM sqlite_master").fetchone()
            yield
        finally:
            self._connection.rollback()

    @_reading
    def window_runs(self) -> pd.DataFrame:
        """All window-run rows (``history``/``history_nfev``/``state`` as JSON text), in write order."""
        return self._checked(
            "window_runs",
            pd.read_sql_query(
                f"SELECT {', '.join(['window_run_id', *WINDOW_RUN_COLUMNS])} FROM window_runs ORDER BY window_run_id",
                self._connection,
            ),
            WINDOW_RUN_COLUMNS,
            "window_run_id",
        )

    @_reading
    def done_window_keys(self) -> set[tuple[Any, ...]]:
        """Keys (:data:`WINDOW_RUN_KEY`) of the stored window runs (skipped on rerun)."""
        rows = self._connection.execute(f"SELECT {', '.join(WINDOW_RUN_KEY)} FROM window_runs").fetchall()
        return {(a, b, int(c), int(d), e, int(f)) for a, b, c, d, e, f in rows}

    @_reading
    def done_keys(self) -> set[tuple[str, str, int]]:
        """Keys of episodes that finished without error (these are skipped on rerun)."""
        rows = self._connection.execute(
            "SELECT policy_hash, scenario_hash, seed FROM episodes WHERE error = ''"
        ).fetchall()
        return {(p, s, int(seed)) for p, s, seed in rows}

    @_reading
    def episodes(self, include_errors: bool = True) -> pd.DataFrame:
        """All episode rows as a DataFrame (in write order)."""
        # Declared columns in declared order: a migrated store (columns added at its end) reads
        # like a new one.
        query = (
            f"SELECT {', '.join(['episode_id', *EPISODE_COLUMNS])} FROM episodes"
            + ("" if include_errors else " WHERE error = ''")
            + " ORDER BY episode_id"
        )
        return self._checked("episodes", pd.read_sql_query(query, self._connection), EPISODE_COLUMNS, "episode_id")

    @_reading
    def steps(self, episode_ids: Iterable[int] | None = None, *, include_start: bool = False) -> pd.DataFrame:
        """Step rows (optionally of some episodes), ordered by episode and step.

        DECISION (api.md §4.4): the step-0 rows (start states) are left out unless
        ``include_start``, so that any sum, mean or count over the returned rows is one over the
        episode's K transitions, as the episode totals are, and readers written before step 0
        existed read the same rows.

        Args:
            episode_ids: the episodes (default: all).
            include_start: also return each episode's step-0 row (its start state).
        """
        where = "" if include_start else " AND step > 0"
        columns = ", ".join(["episode_id", *STEP_COLUMNS])
        if episode_ids is None:
            frame = pd.read_sql_query(
                f"SELECT {columns} FROM steps WHERE 1{where} ORDER BY episode_id, step", self._connection
            )
        else:
            ids = [int(i) for i in episode_ids]
            marks = ", ".join("?" for _ in ids)
            frame = pd.read_sql_query(
                f"SELECT {columns} FROM steps WHERE episode_id IN ({marks}){where} ORDER BY episode_id, step",
                self._connection,
                params=ids,
            )
        return self._checked("steps", frame, STEP_COLUMNS, "episode_id")

    @_reading
    def tracks(self) -> pd.DataFrame:
        """The positions of every step row from step 1 (the failure kinds' input, api.md §4.11).

        Columns :data:`TRACK_COLUMNS` (``episode_id``, ``step``, ``x_km``, ``y_km``, ``z_m``),
        ordered by episode and step; the step-0 rows are left out, as
        :meth:`steps` and an export leave them out, so a store and its exported rows give the
        same kinds.
        """
        frame = pd.read_sql_query(
            f"SELECT {', '.join(TRACK_COLUMNS)} FROM steps WHERE step > 0 ORDER BY episode_id, step",
            self._connection,
        )
        return self._checked("steps", frame, {"step": "INTEGER", **STEP_COLUMNS}, "episode_id")

    @_reading
    def count(self, table: str) -> int:
        """Rows in one table (``episodes``, ``steps`` with the step-0 rows, ``runs``, ...)."""
        if table not in ("runs", "policies", "scenarios", "episodes", "steps", "window_runs"):
            raise ValueError(f"table: got {table!r}, expected a table of the results store")
        return int(self._connection.execute(f"SELECT COUNT(*) FROM {table}").fetchone()[0])

    @_reading
    def runs(self) -> pd.DataFrame:
        """Run provenance rows (``provenance`` and ``settings`` are JSON text)."""
        return pd.read_sql_query("SELECT * FROM runs ORDER BY run_id", self._connection)

    @_reading
    def scenarios(self) -> dict[str, tuple[str, str]]:
        """Stored scenarios: ``hash -> (name, yaml text)``."""
        rows = self._connection.execute("SELECT scenario_hash, scenario, yaml FROM scenarios").fetchall()
        for _, name, text in rows:
            self._refuse(configuration_problem("scenarios", name, text))
        return {h: (n, y) for h, n, y in rows}

    @_reading
    def policies(self) -> dict[str, tuple[str, dict[str, Any]]]:
        """Stored policy configurations: ``hash -> (name, config)``."""
        found = {}
        for h, name, text in self._connection.execute("SELECT policy_hash, policy, config FROM policies"):
            self._refuse(configuration_problem("policies", name, text))
            try:
                found[h] = (name, json.loads(text))
            except ValueError as error:
                self._refuse(f"policies row {name!r} holds a configuration that is not JSON ({error})")
        return found

    def _refuse(self, problem: str | None) -> None:
        """Raise the store's one-line ``damaged`` error for ``problem`` (nothing when it is None)."""
        if problem is not None:
            raise StoreError(self.path, f"damaged, cannot read it: {problem}")

    def _checked(self, table: str, frame: pd.DataFrame, declared: Mapping[str, str], key: str) -> pd.DataFrame:
        """``frame`` after checking each cell against its declared type (:mod:`~.store_cells`)."""
        self._refuse(cell_problem(table, frame, declared, key))
        return frame

    def close(self) -> None:
        """Close the connection."""
        self._connection.close()

    def __enter__(self) -> ResultsStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _sql_value(value: Any) -> Any:
    if value is None or isinstance(value, (str, int, float)):
        return value
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    return _json(value)


# --- migrations: MIGRATIONS[v] upgrades a version-v store to version v + 1 ------------------------------


def migrate_start_rows(connection: sqlite3.Connection) -> None:
    """Version 1 -> 2: add the step-0 row (start state) of every episode that has step rows.

    The start state of an episode is a function of its scenario and seed (paired seeding), so it is
    recomputed here from the scenario YAML the store holds, seeded with the scenario hash the
    episode recorded (api.md §4.2). DECISION (api.md §4.4): an episode whose scenario is missing
    from the store, no longer loads, or loads with another hash than the one recorded (the file is
    not the scenario that was flown, or this version reads it differently) keeps no step-0 row, and
    readers draw its track from step 1, rather than receiving a start that may be wrong or failing
    the whole store.
    """
    import yaml

    from uav_penetration_env.benchmark.seeding import start_info
    from uav_penetration_env.scenario import load_scenario

    episodes = connection.execute(
        "SELECT e.episode_id, e.scenario_hash, e.seed, s.yaml FROM episodes e "
        "LEFT JOIN scenarios s ON s.scenario_hash = e.scenario_hash "
        "WHERE EXISTS (SELECT 1 FROM steps t WHERE t.episode_id = e.episode_id) "
        "AND NOT EXISTS (SELECT 1 FROM steps t WHERE t.episode_id = e.episode_id AND t.step = 0) "
        "ORDER BY e.episode_id"
    ).fetchall()
    scenarios: dict[str, Any] = {}
    names = list(STEP_COLUMNS)
    rows = []
    for episode_id, scenario_hash, seed, text in episodes:
        if scenario_hash not in scenarios:
            try:
                scenario = load_scenario(yaml.safe_load(text)) if text else None
            except (ValueError, KeyError, TypeError, yaml.YAMLError):  # ScenarioError is a ValueError
                scenario = None
            scenarios[scenario_hash] = (
                scenario if scenario is not None and scenario.hash == scenario_hash else None
            )
        scenario = scenarios[scenario_hash]
        if scenario is None:
            continue
        row = start_row(start_info(scenario, int(seed), scenario_hash))
        rows.append((episode_id, *(_sql_value(row[name]) for name in names)))
    connection.executemany(
        f"INSERT INTO steps (episode_id, {', '.join(names)}) VALUES (?, {', '.join('?' for _ in names)})",
        rows,
    )


MIGRATIONS: dict[int, Callable[[sqlite3.Connection], None]] = {1: migrate_start_rows}
