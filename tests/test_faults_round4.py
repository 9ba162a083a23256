"""Round four of issue 42's faults: each test fails on the code before its fix.

Hostile or impossible input (file names, device files, oversized or foreign files, names with
control characters, seeds and scenarios no run can use) gets a one-line error naming its field,
and nothing is written where it should not be.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import numpy as np
import pytest
from conftest import tiny_scenario

from uav_penetration_env.benchmark import cli
from uav_penetration_env.build import build_scenario
from uav_penetration_env.dem import load_raster
from uav_penetration_env.scenario import DEMTerrain, ScenarioError


def run_cli(*argv: object) -> int:
    return cli.main([str(a) for a in argv])


def one_error_line(capsys: pytest.CaptureFixture[str]) -> str:
    """The command's stderr, which must be exactly one line without a traceback."""
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    return err


# --- scenario generate --out DIR: the file name stays inside DIR ------------------------------------


@pytest.mark.parametrize("name", ["../../../escaped", "{tmp}/escaped-absolute", "a/../../b"])
def test_scenario_generate_writes_a_sanitised_name_inside_out(tmp_path, name, capsys):
    source = tiny_scenario(name=name.format(tmp=tmp_path)).to_yaml(tmp_path / "hostile.yaml")
    out = tmp_path / "a" / "b" / "out"
    out.mkdir(parents=True)
    before = set(tmp_path.rglob("*"))
    assert run_cli("scenario", "generate", source, "--out", out) == 0
    (written,) = set(tmp_path.rglob("*")) - before
    assert written.parent == out and written.suffix == ".yaml"


# --- scenario validate: a start or goal the ceiling makes unreachable ------------------------------


def test_a_goal_on_terrain_above_the_ceiling_is_refused_naming_the_goal():
    scenario = tiny_scenario(terrain={"mountains": [{"x_km": 25, "y_km": 25, "height_m": 5000}]})
    with pytest.raises(ScenarioError, match=r"^goal: .*ceiling 3000 m") as error:
        build_scenario(scenario)
    assert "\n" not in str(error.value)


def test_a_start_whose_terrain_plus_agl_is_above_the_ceiling_is_refused_naming_start_z_agl_m():
    scenario = tiny_scenario(terrain={"mountains": [{"x_km": 0, "y_km": 0, "height_m": 5000}]})
    with pytest.raises(ScenarioError, match=r"^start\.z_agl_m: .*below the ceiling 3000 m"):
        build_scenario(scenario)


def test_a_goal_with_some_ground_below_the_ceiling_and_an_ordinary_start_still_build():
    # A peak beside the goal disc leaves low ground inside it: reachable, so not refused.
    scenario = tiny_scenario(terrain={"mountains": [{"x_km": 33, "y_km": 25, "height_m": 5000}]})
    assert build_scenario(scenario).terrain.max() > scenario.map.ceiling_m
    build_scenario(tiny_scenario())


# --- the DEM loader reads regular files of a bounded size only ------------------------------------


def dem_config(file: str) -> DEMTerrain:
    return DEMTerrain(file=file, lat_deg=(49.5, 50.0), lon_deg=(10.0, 10.5))


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="needs /dev/zero")
def test_the_dem_loader_refuses_a_device_file_without_reading_it():
    with pytest.raises(ScenarioError, match=r"^terrain\.natural\.file: got '/dev/zero', expected a regular file"):
        load_raster(dem_config("/dev/zero"))


def test_the_dem_loader_refuses_a_fifo_without_blocking_on_it(tmp_path):
    fifo = tmp_path / "raster.npz"
    os.mkfifo(fifo)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    with pytest.raises(ScenarioError, match=r"^terrain\.natural\.file: .*expected a regular file"):
        load_raster(dem_config(str(fifo)))


def test_the_dem_loader_refuses_a_file_above_its_size_limit(tmp_path, monkeypatch):
    from uav_penetration_env import dem

    big = tmp_path / "big.npz"
    np.savez(big, topo=np.zeros((40, 40)), latitude=np.linspace(49, 51, 40), longitude=np.linspace(9, 11, 40))
    monkeypatch.setattr(dem, "MAX_RASTER_BYTES", big.stat().st_size - 1)
    with pytest.raises(ScenarioError, match=r"^terrain\.natural\.file: .*at most \d+ bytes"):
        load_raster(dem_config(str(big)))
    monkeypatch.setattr(dem, "MAX_RASTER_BYTES", big.stat().st_size)
    assert load_raster(dem_config(str(big))).heights.shape == (40, 40)


# --- the atomic writer never replaces a device, FIFO or folder -------------------------------------


def test_the_atomic_writer_refuses_to_replace_a_fifo_and_leaves_it(tmp_path):
    from uav_penetration_env.atomic import NotRegularFileError, write_text_atomic

    fifo = tmp_path / "out.md"
    os.mkfifo(fifo)
    with pytest.raises(NotRegularFileError, match="not a regular file") as error:
        write_text_atomic(fifo, "text")
    assert error.value.filename == str(fifo)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and os.listdir(tmp_path) == ["out.md"]


def test_a_command_whose_out_is_a_fifo_says_so_in_one_line_naming_out(tmp_path, capsys):
    fifo = tmp_path / "scenario.yaml"
    os.mkfifo(fifo)
    assert run_cli("scenario", "generate", "paper", "--out", fifo) == 2
    assert one_error_line(capsys).startswith(f"uav-bench: error: --out {fifo}: ")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


@pytest.mark.skipif(os.geteuid() != 0, reason="mknod of a character device needs root")
def test_the_atomic_writer_refuses_to_replace_a_character_device(tmp_path):
    from uav_penetration_env.atomic import NotRegularFileError, write_bytes_atomic

    node = tmp_path / "null"
    os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # a private /dev/null
    with pytest.raises(NotRegularFileError):
        write_bytes_atomic(node, b"x")
    assert stat.S_ISCHR(os.lstat(node).st_mode)


# --- windows --scenario names ONE stored scenario: a range is refused before anything is built ----


def test_windows_refuses_a_scenario_range_without_generating_it(tmp_path, monkeypatch, capsys):
    from uav_penetration_env import catalogue

    def never(*args, **kwargs):
        raise AssertionError("windows --scenario generated a random scenario")

    store = tmp_path / "s.sqlite"
    store.touch()
    monkeypatch.setattr(catalogue, "random_scenario", never)
    code = run_cli(
        "windows", "--store", store, "--scenario", "random:0-99999", "--steps", "0",
        "--optimizers", "pso", "--seeds", "1", "--max-evals", "10", "--horizon", "1",
    )  # fmt: skip
    assert code == 2
    assert one_error_line(capsys).startswith("uav-bench: error: --scenario: got 'random:0-99999', expected one")


def test_random_seeds_of_a_huge_range_are_lazy():
    from uav_penetration_env.catalogue import random_seeds

    seeds = random_seeds(f"random:0-{10**15}")
    assert len(seeds) == 10**15 + 1 and seeds[-1] == 10**15


# --- a small store shared by the export, import and hostile-store tests ----------------------------


@pytest.fixture(scope="module")
def small_store(tmp_path_factory):
    folder = tmp_path_factory.mktemp("store")
    scenario = tiny_scenario(time={"max_steps": 6}).to_yaml(folder / "tiny.yaml")
    store = folder / "s.sqlite"
    assert run_cli("run", "--policies", "greedy", "pso", "--scenarios", scenario, "--seeds", "2",
                   "--max-evals", "20", "--horizon", "1", "--jobs", "1", "--no-report", "--no-progress",
                   "--store", store) == 0  # fmt: skip
    assert run_cli("windows", "--store", store, "--scenario", "tiny", "--steps", "0", "--optimizers", "pso",
                   "--seeds", "1", "--max-evals", "10", "--horizon", "1") == 0  # fmt: skip
    return store


def copied(store: Path, tmp_path: Path, sql: str | None = None) -> Path:
    import shutil
    import sqlite3

    target = tmp_path / "copy.sqlite"
    shutil.copy(store, target)
    if sql is not None:
        with sqlite3.connect(target) as connection:
            connection.execute(sql)
        connection.close()
    return target


# --- export reads every table in one transaction ---------------------------------------------------


def test_export_during_a_write_gives_tables_that_agree(small_store, tmp_path, monkeypatch):
    import sqlite3

    import pandas as pd

    from uav_penetration_env.benchmark.store import EPISODE_COLUMNS, STEP_COLUMNS, ResultsStore

    store = copied(small_store, tmp_path)
    read_episodes = ResultsStore.episodes

    def episodes_then_a_run_commits_one(self, *args, **kwargs):
        frame = read_episodes(self, *args, **kwargs)
        # a concurrent `uav-bench run` commits another episode and its steps between two reads
        with sqlite3.connect(store, timeout=5) as writer:
            columns = [c for c in EPISODE_COLUMNS if c != "seed"]
            new = writer.execute(
                f"INSERT INTO episodes ({', '.join(columns)}, seed) SELECT {', '.join(columns)}, 99 "
                "FROM episodes WHERE episode_id = 1"
            ).lastrowid
            writer.execute(
                f"INSERT INTO steps (episode_id, {', '.join(STEP_COLUMNS)}) SELECT ?, {', '.join(STEP_COLUMNS)} "
                "FROM steps WHERE episode_id = 1",
                (new,),
            )
        writer.close()
        return frame

    monkeypatch.setattr(ResultsStore, "episodes", episodes_then_a_run_commits_one)
    assert run_cli("export", "--store", store, "--format", "csv", "--out", tmp_path / "rows") == 0
    episodes = pd.read_csv(tmp_path / "rows-episodes.csv")
    steps = pd.read_csv(tmp_path / "rows-steps.csv")
    assert set(steps["episode_id"]) == set(episodes.loc[episodes["error"].isna(), "episode_id"])
    monkeypatch.undo()
    assert run_cli("import", "--rows", tmp_path / "rows", "--store", tmp_path / "back.sqlite") == 0


# --- import refuses an export that stopped part-way ------------------------------------------------


@pytest.fixture
def exported(small_store, tmp_path):
    assert run_cli("export", "--store", small_store, "--format", "csv", "--out", tmp_path / "rows") == 0
    return tmp_path / "rows"


@pytest.mark.parametrize("keep_manifest", [True, False])
def test_import_refuses_an_export_without_its_last_tables_before_writing(exported, capsys, keep_manifest):
    for table in ("steps", "scenarios", "policies"):  # the state a kill after window_runs leaves
        exported.with_name(f"rows-{table}.csv").unlink()
    if not keep_manifest:
        exported.with_name("rows-manifest.json").unlink()
    capsys.readouterr()
    target = exported.parent / "imported.sqlite"
    assert run_cli("import", "--rows", exported, "--store", target) == 2
    assert "incomplete export" in one_error_line(capsys)
    assert not target.exists() and not list(exported.parent.glob("*imported*"))


def test_import_refuses_a_table_of_another_export_under_the_same_stem(exported, capsys):
    steps = exported.with_name("rows-steps.csv")
    steps.write_text(steps.read_text().replace("\n", "\n", 1) + "")  # same bytes: accepted
    assert run_cli("import", "--rows", exported, "--store", exported.parent / "same.sqlite") == 0
    lines = steps.read_text().splitlines(keepends=True)
    steps.write_text("".join(lines[:-1]))  # one row short: another export's table
    capsys.readouterr()
    assert run_cli("import", "--rows", exported, "--store", exported.parent / "mixed.sqlite") == 2
    assert "rows-steps.csv is not the file rows-manifest.json lists" in one_error_line(capsys)


# --- a store with one hostile cell: read-only commands give the one-line damaged error --------------


HOSTILE_CELLS = [
    ("UPDATE policies SET config = '{\"a\":' WHERE policy = 'greedy'", ["store", "list"]),
    ("UPDATE policies SET config = '{\"a\":' WHERE policy = 'greedy'", ["export", "--format", "csv", "--out", "x/rows"]),
    ("UPDATE policies SET policy = NULL WHERE policy = 'greedy'", ["store", "list"]),
    ("UPDATE episodes SET nfev = 'many' WHERE episode_id = 1", ["export", "--format", "parquet", "--out", "x/rows"]),
    ("UPDATE window_runs SET nfev = 'abc'", ["leaderboard", "--out", "lb"]),
    ("UPDATE episodes SET seed = '[]' WHERE episode_id = 1", ["leaderboard", "--out", "lb"]),
    ("UPDATE window_runs SET history_nfev = -1e308", ["leaderboard", "--out", "lb"]),
    ("UPDATE steps SET x_km = ' ' WHERE step = 3", ["export", "--format", "csv", "--tracks", "--out", "x/tr"]),
]


@pytest.mark.parametrize(("sql", "argv"), HOSTILE_CELLS, ids=[f"{i}" for i in range(len(HOSTILE_CELLS))])
def test_a_hostile_cell_gives_the_one_line_damaged_error(small_store, tmp_path, monkeypatch, capsys, sql, argv):
    store = copied(small_store, tmp_path, sql)
    monkeypatch.chdir(tmp_path)
    head = argv[:2] if argv[0] == "store" else argv[:1]
    code = run_cli(*head, "--store", store, *argv[len(head) :])
    line = one_error_line(capsys)
    assert code == 2 and line.startswith(f"uav-bench: error: --store {store}: damaged"), line


# --- best-known checkpoints: never unpickled -------------------------------------------------------


class _Payload:
    """Unpickling this runs ``touch MARKER``."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


@pytest.mark.parametrize("suffix", [".pkl", ".json"])
def test_a_foreign_checkpoint_is_refused_without_running_its_code(tmp_path, suffix):
    import pickle

    from uav_penetration_env.benchmark.bestknown.checkpoint import checkpoint_path, load_checkpoint

    marker = tmp_path / "CODE_RAN"
    path = checkpoint_path(tmp_path, "0db1ca29d98736f3", "unseeded")
    path.with_suffix(suffix).write_bytes(pickle.dumps(_Payload(marker)))
    with pytest.raises(ValueError, match=r"^--work .*: not a best-known search checkpoint; expected") as error:
        load_checkpoint(path, "0db1ca29d98736f3", {"seed": 0})
    assert "\n" not in str(error.value) and not marker.exists()


@pytest.mark.parametrize("stops", [(7,), (3, 40, 41)])
def test_a_checkpoint_state_continues_through_json_to_the_uninterrupted_result(stops):
    import json

    from optimizers.sep_cma_restarts import SepCMARestarts, Start
    from uav_penetration_env.benchmark.bestknown.checkpoint import state_from_json, state_to_json

    search = SepCMARestarts(population=6, stall_generations=4)
    target = np.array([0.3, -0.2, 0.5])

    def sphere(x):
        return ((x - target) ** 2).sum(axis=1)

    def started():
        return search.begin(sphere, [(-1.0, 1.0)] * 3, [Start("corner", -np.ones(3))], np.random.default_rng(2))

    def outcome(state):
        return (state.best_x.tobytes(), state.best_f, state.evals, state.generations, state.runs, state.trace)

    whole = outcome(search.run(started(), sphere, max_evals=900))
    state = started()
    for stop in stops:
        search.run(state, sphere, max_evals=900, callback=lambda s, _share, at=stop: s.generations == at)
        assert state.optimizer is not None  # stopped inside a CMA-ES run
        state = state_from_json(json.loads(json.dumps(state_to_json(state))))
    search.run(state, sphere, max_evals=900)
    assert outcome(state)[:-1] == whole[:-1]
    assert [(e, f) for e, _, f in outcome(state)[-1]] == [(e, f) for e, _, f in whole[-1]]  # not the seconds
