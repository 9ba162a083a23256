"""Every ``uav-bench`` command meets a bad results store the same way.

One line ``uav-bench: error: --store PATH: <what is wrong>``, exit status 2, and not one byte of
the bad file changed, for: a store truncated to half its size, a store with garbled pages, a text
file, another application's SQLite database, a store of a newer schema, an empty file (readers),
a folder, and an unreadable file.
"""

from __future__ import annotations

import os
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from conftest import tiny_scenario

from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.store import SCHEMA_VERSION, ResultsStore, StoreError


def run_cli(*argv: object) -> int:
    return cli.main([str(a) for a in argv])


@pytest.fixture(scope="module")
def tiny_yaml(tmp_path_factory) -> Path:
    return tiny_scenario(time={"max_steps": 12}).to_yaml(tmp_path_factory.mktemp("scenario") / "tiny.yaml")


@pytest.fixture(scope="module")
def good_store(tmp_path_factory, tiny_yaml) -> Path:
    """A real schema-2 store: greedy and random on the tiny scenario, seeds 0-2, checkpointed."""
    path = tmp_path_factory.mktemp("good") / "good.sqlite"
    argv = ["run", "--policies", "greedy,random", "--scenarios", tiny_yaml, "--seeds", 3]
    assert run_cli(*argv, "--store", path, "--no-report", "--no-progress") == 0
    connection = sqlite3.connect(path)
    connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")  # fold the WAL in: copies are then whole
    connection.close()
    return path


def truncated(folder: Path, good: Path) -> Path:
    path = folder / "truncated.sqlite"
    data = good.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    return path


def damaged_copy(folder: Path, good: Path, name: str, damage) -> Path:
    """A copy of ``good`` named ``name`` whose bytes ``damage(data, page_size)`` changed in place."""
    data = bytearray(good.read_bytes())
    damage(data, int.from_bytes(data[16:18], "big"))  # the page size, from the SQLite header
    path = folder / name
    path.write_bytes(bytes(data))
    return path


def garbled(folder: Path, good: Path) -> Path:
    """Same size, valid header, pages after the schema overwritten: found only when read."""

    def damage(data: bytearray, page: int) -> None:
        data[2 * page :] = bytes([0xA5]) * (len(data) - 2 * page)

    return damaged_copy(folder, good, "garbled.sqlite", damage)


def text_file(folder: Path, good: Path) -> Path:
    path = folder / "notes.sqlite"
    path.write_text("policy,seed,cost\nihpso,0,1.5\n")
    return path


def other_app(folder: Path, good: Path) -> Path:
    path = folder / "places.sqlite"
    with sqlite3.connect(path) as connection:
        connection.execute("CREATE TABLE moz_places (id INTEGER PRIMARY KEY, url TEXT)")
        connection.execute("INSERT INTO moz_places (url) VALUES ('https://example.org')")
    connection.close()
    return path


def newer_schema(folder: Path, good: Path) -> Path:
    path = folder / "newer.sqlite"
    shutil.copy(good, path)
    connection = sqlite3.connect(path)
    with connection:
        connection.execute("UPDATE schema_version SET version = ?", (SCHEMA_VERSION + 1,))
    connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    connection.close()
    return path


def folder_store(folder: Path, good: Path) -> Path:
    path = folder / "store.sqlite"
    path.mkdir()
    (path / "inside.txt").write_text("a folder named like a store")
    return path


def zeroed(folder: Path, good: Path) -> Path:
    """Same size, valid header, the pages after the schema zeroed (a sparse copy, a failed sync)."""

    def damage(data: bytearray, page: int) -> None:
        data[2 * page :] = bytes(len(data) - 2 * page)

    return damaged_copy(folder, good, "zeroed.sqlite", damage)


def zeroed_middle(folder: Path, good: Path) -> Path:
    """Pages in the middle zeroed, header and size intact: what a run would otherwise write into."""

    def damage(data: bytearray, page: int) -> None:
        pages = len(data) // page
        start, stop = (pages * 2 // 5) * page, (pages * 3 // 5) * page
        data[start:stop] = bytes(stop - start)

    return damaged_copy(folder, good, "zeroed-middle.sqlite", damage)


def random_pages(folder: Path, good: Path) -> Path:
    """200 random bytes into every page after the first (a disk's bad blocks): the schema reads, its rows do not."""

    def damage(data: bytearray, page: int) -> None:
        noise = np.random.default_rng(27)
        for start in range(page, len(data) - page + 1, page):
            data[start + 8 : start + 208] = noise.bytes(200)

    return damaged_copy(folder, good, "random.sqlite", damage)


BAD = {
    "random-pages": (random_pages, "damaged or not a results store"),
    "truncated": (truncated, "damaged"),
    "zeroed-middle": (zeroed_middle, "damaged"),
    "garbled": (garbled, "damaged"),
    "zeroed": (zeroed, "damaged"),
    "text": (text_file, "not a results store"),
    "other-app": (other_app, "not a results store"),
    "newer-schema": (newer_schema, f"schema version {SCHEMA_VERSION + 1} is newer"),
    "folder": (folder_store, "is a folder"),
}
# Stores whose header and schema read fine: a reader opens them and meets the damage mid-read, and
# SQLite keeps the side files of that open (run's integrity check refuses them before opening).
MET_WHILE_READING = {"zeroed-middle", "garbled", "zeroed"}


def commands(store: Path, tiny_yaml: Path, out: Path) -> dict[str, list[object]]:
    return {
        "run": ["run", "--policies", "greedy", "--scenarios", tiny_yaml, "--seeds", 1, "--store", store,
                "--out", out, "--no-progress"],
        "leaderboard": ["leaderboard", "--store", store, "--out", out],
        "plot": ["plot", "--store", store, "--out", out],
        "export": ["export", "--format", "csv", "--store", store, "--out", out / "dump"],
    }  # fmt: skip


def snapshot(path: Path) -> dict[str, bytes]:
    """Every file at ``path`` (one file, or a folder's files) by name, as bytes."""
    if path.is_dir():
        return {p.name: p.read_bytes() for p in sorted(path.iterdir())}
    return {path.name: path.read_bytes()}


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "Traceback" not in err[0]
    return err[0]


@pytest.mark.parametrize("command", ["run", "leaderboard", "plot", "export"])
@pytest.mark.parametrize("kind", list(BAD))
def test_a_bad_store_is_one_line_exit_2_and_left_unchanged(
    kind, command, good_store, tiny_yaml, tmp_path, capsys
):
    make, expected = BAD[kind]
    store = make(tmp_path, good_store)
    before = snapshot(store)
    out = tmp_path / "out"
    assert run_cli(*commands(store, tiny_yaml, out)[command]) == 2
    line = one_error_line(capsys)
    assert line.startswith(f"uav-bench: error: --store {store}: "), line
    assert expected in line
    assert snapshot(store) == before
    if command == "run" or kind not in MET_WHILE_READING:
        assert sorted(tmp_path.glob(f"{store.name}-*")) == []  # no -wal or -shm left by the refused open
    written = sorted(p.name for p in out.rglob("*") if p.is_file()) if out.exists() else []
    assert written == []  # nothing half-made from a bad store either


@pytest.mark.parametrize("command", ["leaderboard", "plot", "export"])
def test_readers_refuse_an_empty_file_and_a_missing_one(command, tiny_yaml, tmp_path, capsys):
    empty = tmp_path / "empty.sqlite"
    empty.write_bytes(b"")
    assert run_cli(*commands(empty, tiny_yaml, tmp_path / "out")[command]) == 2
    assert "an empty file, not a results store" in one_error_line(capsys)
    assert empty.read_bytes() == b""
    missing = tmp_path / "missing.sqlite"
    assert run_cli(*commands(missing, tiny_yaml, tmp_path / "out")[command]) == 2
    assert one_error_line(capsys).startswith(f"uav-bench: error: --store {missing}: not found")
    assert not missing.exists()


@pytest.mark.parametrize("command", ["run", "leaderboard", "plot", "export"])
def test_an_unreadable_store(command, good_store, tiny_yaml, tmp_path, capsys, monkeypatch):
    store = tmp_path / "locked.sqlite"
    shutil.copy(good_store, store)
    before = store.read_bytes()
    store.chmod(0)
    if os.geteuid() == 0:  # root reads a mode-000 file: make the refusal the kernel's would be
        real_open = Path.open

        def refusing_open(self, *args, **kwargs):
            if self == store:
                raise PermissionError(13, "Permission denied", str(self))
            return real_open(self, *args, **kwargs)

        monkeypatch.setattr(Path, "open", refusing_open)
    try:
        assert run_cli(*commands(store, tiny_yaml, tmp_path / "out")[command]) == 2
        line = one_error_line(capsys)
        assert line == f"uav-bench: error: --store {store}: cannot read it (Permission denied)"
    finally:
        store.chmod(0o644)
        monkeypatch.undo()
    assert store.read_bytes() == before


def test_a_store_path_under_a_file(tiny_yaml, tmp_path, capsys):
    blocker = tmp_path / "file.txt"
    blocker.write_text("not a folder")
    store = blocker / "s.sqlite"
    assert run_cli(*commands(store, tiny_yaml, tmp_path / "out")["run"]) == 2
    assert one_error_line(capsys).startswith(f"uav-bench: error: --store {store}: cannot write to {blocker}")
    assert blocker.read_text() == "not a folder"


def test_the_library_raises_store_error_with_path_and_reason(good_store, tmp_path):
    store = other_app(tmp_path, good_store)
    before = store.read_bytes()
    with pytest.raises(StoreError) as raised:
        ResultsStore(store)
    assert raised.value.path == store and "moz_places" in raised.value.reason
    assert str(raised.value).startswith(f"results store {store}: ")
    assert store.read_bytes() == before  # not switched to WAL, no tables added
    with pytest.raises(StoreError, match="damaged, cannot read it"):
        with ResultsStore(garbled(tmp_path, good_store), create=False) as results:
            results.steps()


def test_a_good_store_still_opens_for_every_reader(good_store, tiny_yaml, tmp_path, capsys):
    store = tmp_path / "copy.sqlite"
    shutil.copy(good_store, store)
    for argv in list(commands(store, tiny_yaml, tmp_path / "out").values())[1:]:
        assert run_cli(*argv) == 0
    capsys.readouterr()


def test_a_short_main_file_with_a_pending_write_ahead_log_is_left_to_sqlite(tmp_path, good_store):
    """An interrupted checkpoint leaves the new header in the main file and the pages in the -wal file.

    The size check then cannot tell a truncated copy from a store SQLite reads whole, so it steps
    aside while a non-empty ``-wal`` file is present; without one the short file is still refused.
    """
    from uav_penetration_env.benchmark.store import StoreError, _check_header

    short = truncated(tmp_path, good_store)
    header, size = short.read_bytes()[:100], short.stat().st_size
    with pytest.raises(StoreError, match="truncated or copied while written"):
        _check_header(short, header, size)
    short.with_name(short.name + "-wal").write_bytes(b"\0" * 32)
    _check_header(short, header, size)  # no error: SQLite replays the log when it opens the store


def test_the_integrity_check_reads_every_page(tmp_path, good_store):
    """Pages damaged inside a file of the right size pass the header checks; SQLite's own check finds them."""
    from uav_penetration_env.benchmark.store import StoreError, check_integrity, inspect_store_file

    check_integrity(good_store)
    check_integrity(tmp_path / "absent.sqlite")  # nothing to check: a new store
    damaged = zeroed_middle(tmp_path, good_store)
    inspect_store_file(damaged)  # the header and the size are intact
    with pytest.raises(StoreError, match="damaged"):
        check_integrity(damaged)
