"""Outputs are written whole or not at all: a failure mid-write keeps the old file.

Each test makes the real writer fail halfway: it writes its bytes, the file is cut to half its
size, and ``OSError("No space left on device")`` is raised, as a full disk would. Afterwards the
old file must be there byte for byte, and no temporary file left behind.
"""

from __future__ import annotations

import os
from pathlib import Path

import pandas as pd
import pytest
from conftest import tiny_scenario
from matplotlib.figure import Figure

from uav_penetration_env import atomic
from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.figures import write_figures
from uav_penetration_env.benchmark.leaderboard import write_leaderboards


def run_cli(*argv: object) -> int:
    return cli.main([str(a) for a in argv])


def half_then_fail(real):
    """A writer that writes through ``real``, cuts the file to half and raises like a full disk."""

    def writer(self, target, *args, **kwargs):
        real(self, target, *args, **kwargs)
        path = Path(target)
        size = path.stat().st_size
        with open(path, "r+b") as stream:
            stream.truncate(size // 2)
        raise OSError(28, "No space left on device")

    return writer


def folder_files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


@pytest.fixture(scope="module")
def store(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("atomic")
    scenario = tiny_scenario(time={"max_steps": 10}).to_yaml(folder / "tiny.yaml")
    path = folder / "s.sqlite"
    argv = ["run", "--policies", "greedy,random", "--scenarios", scenario, "--seeds", 3, "--store", path]
    assert run_cli(*argv, "--no-report", "--no-progress") == 0
    return path


def test_the_helper_keeps_the_old_file_when_the_writer_fails(tmp_path):
    path = tmp_path / "table.md"
    path.write_text("old table\n")
    with pytest.raises(OSError, match="No space left"):
        with atomic.atomic_open(path, "w") as stream:
            stream.write("new table, first half")
            raise OSError(28, "No space left on device")
    assert path.read_text() == "old table\n"
    assert [p.name for p in tmp_path.iterdir()] == ["table.md"]  # no temporary left behind
    with pytest.raises(KeyboardInterrupt):
        with atomic.atomic_path(path) as temporary:
            temporary.write_text("half")
            raise KeyboardInterrupt
    assert path.read_text() == "old table\n" and len(list(tmp_path.iterdir())) == 1
    atomic.write_text_atomic(path, "new table\n")
    assert path.read_text() == "new table\n"
    mask = os.umask(0)
    os.umask(mask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~mask  # the mode a plain open gives, not 0o600


def test_a_leaderboard_csv_that_fails_midway_leaves_the_old_one(store, tmp_path, monkeypatch):
    out = tmp_path / "lb"
    write_leaderboards(store, out)
    before = folder_files(out)
    assert any(name.endswith(".csv") for name in before)
    monkeypatch.setattr(pd.DataFrame, "to_csv", half_then_fail(pd.DataFrame.to_csv))
    with pytest.raises(OSError, match="No space left"):
        write_leaderboards(store, out, command="a second run")
    after = folder_files(out)
    csvs = [name for name in before if name.endswith(".csv")]
    assert {name: after[name] for name in csvs} == {name: before[name] for name in csvs}
    assert set(after) == set(before)  # no temporary left behind


def test_a_figure_that_fails_midway_leaves_the_old_one(store, tmp_path, monkeypatch):
    out = tmp_path / "fig"
    write_figures(store, out, formats=("png",))
    before = folder_files(out)
    assert before and all(len(data) > 1000 for data in before.values())
    monkeypatch.setattr(Figure, "savefig", half_then_fail(Figure.savefig))
    with pytest.raises(OSError, match="No space left"):
        write_figures(store, out, formats=("png",))
    assert folder_files(out) == before


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_an_export_that_fails_midway_leaves_the_old_one(store, tmp_path, monkeypatch, capsys, fmt):
    stem = tmp_path / "dump"
    assert run_cli("export", "--format", fmt, "--store", store, "--out", stem) == 0
    before = folder_files(tmp_path)
    writer = "to_csv" if fmt == "csv" else "to_parquet"
    monkeypatch.setattr(pd.DataFrame, writer, half_then_fail(getattr(pd.DataFrame, writer)))
    assert run_cli("export", "--format", fmt, "--store", store, "--out", stem) == 1  # failed work
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith(f"uav-bench: error: --out {stem}: cannot write {tmp_path}/dump-")
    assert last.endswith(": No space left on device")
    assert folder_files(tmp_path) == before


def test_a_scenario_file_that_fails_midway_leaves_the_old_one(tmp_path, monkeypatch):
    path = tiny_scenario().to_yaml(tmp_path / "s.yaml")
    before = path.read_bytes()

    def failing(target, text, encoding="utf-8"):
        with atomic.atomic_open(target, "w", encoding=encoding) as stream:
            stream.write(text[: len(text) // 2])
            raise OSError(28, "No space left on device")

    import uav_penetration_env.scenario.files as files

    monkeypatch.setattr(files, "write_text_atomic", failing)
    with pytest.raises(ValueError, match="No space left on device"):
        tiny_scenario(name="changed").to_yaml(path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["s.yaml"]
