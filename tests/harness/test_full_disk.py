"""A disk that fills up mid-command: one line naming the store or --out, exit 1, finished work kept."""

from __future__ import annotations

import errno
import os
import sqlite3
from pathlib import Path

import pytest
from conftest import tiny_scenario

from uav_penetration_env import atomic
from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.store import ResultsStore


@pytest.fixture
def tiny_yaml(tmp_path) -> Path:
    return tiny_scenario(time={"max_steps": 8}).to_yaml(tmp_path / "tiny.yaml")


def run_argv(tiny_yaml: Path, store: Path, seeds: int) -> list[str]:
    return ["run", "--policies", "greedy", "--scenarios", str(tiny_yaml), "--seeds", str(seeds), "--jobs", "1",
            "--no-report", "--no-progress", "--store", str(store)]  # fmt: skip


def test_run_on_a_disk_that_fills_up_keeps_the_finished_episodes_and_exits_1(tmp_path, tiny_yaml, monkeypatch, capsys):
    store = tmp_path / "s.sqlite"
    assert cli.main(run_argv(tiny_yaml, store, 1)) == 0
    opened = ResultsStore.__init__

    def small_disk(self, *args, **kwargs):
        opened(self, *args, **kwargs)
        # SQLite's own "database or disk is full" (SQLITE_FULL), as a full disk gives it: room for
        # a few more episodes only.
        (pages,) = self._connection.execute("PRAGMA page_count").fetchone()
        self._connection.execute(f"PRAGMA max_page_count = {pages + 3}")

    monkeypatch.setattr(ResultsStore, "__init__", small_disk)
    capsys.readouterr()
    assert cli.main(run_argv(tiny_yaml, store, 40)) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith(f"uav-bench: error: --store {store}: cannot write to it (database or disk is full)")
    assert "Traceback" not in "\n".join(err)
    with sqlite3.connect(store) as connection:
        (kept,) = connection.execute("SELECT COUNT(*) FROM episodes").fetchone()
    assert 1 < kept < 40  # the first run's episode and those written before the disk filled
    monkeypatch.setattr(ResultsStore, "__init__", opened)  # space freed: the rerun completes the sweep
    assert cli.main(run_argv(tiny_yaml, store, 40)) == 0
    with ResultsStore(store) as results:
        assert len(results.done_keys()) == 40


def test_leaderboard_on_a_full_disk_names_out_and_exits_1(tmp_path, tiny_yaml, monkeypatch, capsys):
    store = tmp_path / "s.sqlite"
    assert cli.main(run_argv(tiny_yaml, store, 1)) == 0

    def full(*_args):  # what closing a file on a full disk raises: no file name in the error
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(atomic, "_file_mode", full)
    capsys.readouterr()
    out = tmp_path / "lb"
    assert cli.main(["leaderboard", "--store", str(store), "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"uav-bench: error: --out {out}: cannot write {out}/")
    assert err[0].endswith(": No space left on device")
    assert not list(out.glob(".*tmp*"))  # no temporary file left behind
