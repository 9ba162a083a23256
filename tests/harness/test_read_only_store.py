"""A healthy store on read-only media (a published store, a read-only mount) is read as it is."""

from __future__ import annotations

import os
import shutil
import sqlite3
import subprocess
from pathlib import Path

import pytest
from conftest import tiny_scenario

from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark import store as store_module


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("written")
    scenario = tiny_scenario(time={"max_steps": 8}).to_yaml(folder / "tiny.yaml")
    path = folder / "s.sqlite"
    argv = ["run", "--policies", "greedy", "--scenarios", str(scenario), "--seeds", "2", "--jobs", "1",
            "--no-report", "--no-progress", "--store", str(path)]  # fmt: skip
    assert cli.main(argv) == 0
    return path


@pytest.fixture
def media(tmp_path, written, monkeypatch) -> Path:
    """A copy of the store in a folder the file system reports unwritable, as a read-only mount does."""
    folder = tmp_path / "media"
    folder.mkdir()
    shutil.copy(written, folder / "s.sqlite")
    real = os.access

    def access(path, mode, **kwargs):
        inside = Path(path).resolve() == folder or folder in Path(path).resolve().parents
        return False if inside and mode & os.W_OK else real(path, mode, **kwargs)

    monkeypatch.setattr(store_module.os, "access", access)
    return folder


def test_read_commands_read_a_store_on_read_only_media_and_change_nothing(media, tmp_path, capsys):
    path = media / "s.sqlite"
    before = path.read_bytes()
    assert cli.main(["leaderboard", "--store", str(path), "--out", str(tmp_path / "lb")]) == 0
    assert cli.main(["export", "--store", str(path), "--format", "csv", "--out", str(tmp_path / "x")]) == 0
    assert len((tmp_path / "x-episodes.csv").read_text().splitlines()) == 3
    with store_module.ResultsStore(path, create=False) as results:  # replay, plot and report read so
        assert len(results.episodes()) == 2 and len(results.steps(include_start=True)) > 2
    # opened immutable: no -shm or -wal file, which SQLite could not create on read-only media
    assert sorted(p.name for p in media.iterdir()) == ["s.sqlite"]
    assert path.read_bytes() == before


def test_an_older_store_on_read_only_media_is_refused_in_one_line(media, tmp_path, capsys):
    path = media / "s.sqlite"
    with sqlite3.connect(path) as connection:
        connection.execute("UPDATE schema_version SET version = 1")
    connection.close()
    assert cli.main(["leaderboard", "--store", str(path), "--out", str(tmp_path / "lb")]) == 2
    assert capsys.readouterr().err.strip() == (
        f"uav-bench: error: --store {path}: written by an older version (schema version 1) and read-only "
        "here, so it cannot be upgraded; copy it to a writable folder and rerun"
    )


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0, reason="mounts a read-only file system")
def test_a_real_read_only_mount(written, tmp_path, capsys):
    folder = tmp_path / "ro"
    folder.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=4m", "tmpfs", str(folder)], capture_output=True).returncode:
        pytest.skip("cannot mount a tmpfs here")
    try:
        shutil.copy(written, folder / "s.sqlite")
        subprocess.run(["mount", "-o", "remount,ro", str(folder)], check=True)
        path = folder / "s.sqlite"
        assert cli.main(["leaderboard", "--store", str(path), "--out", str(tmp_path / "lb")]) == 0
        capsys.readouterr()
        run = ["run", "--policies", "greedy", "--seeds", "1", "--no-report", "--no-progress", "--store", str(path)]
        assert cli.main(run) == 2
        assert "(Read-only file system)" in capsys.readouterr().err.strip().splitlines()[-1]
    finally:
        subprocess.run(["umount", str(folder)], check=False)
