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


# --- hostile names: the terminal, Markdown tables and spreadsheets --------------------------------

HOSTILE = "\x1b[31mRED\x1b]0;pwned-title\x07"


def test_text_printed_by_a_command_has_its_control_characters_escaped(monkeypatch, capsys):
    from uav_penetration_env.benchmark import cli as cli_module

    def hostile_command(args):
        print(f"policy {HOSTILE}\ttwo\nlines")
        return 0

    class Args:
        extensions = ()
        handler = type("H", (), {"needs": type("N", (), {"check": staticmethod(lambda *a: None)})(),
                                 "run": staticmethod(hostile_command)})()  # fmt: skip
        command = "x"

    parser = type("P", (), {"parse_known_args": staticmethod(lambda argv: (Args(), []))})()
    monkeypatch.setattr(cli_module, "build_parser", lambda argv: parser)
    assert cli_module.main(["x"]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out
    assert out == "policy \\x1b[31mRED\\x1b]0;pwned-title\\x07\ttwo\nlines\n"


def test_markdown_cells_keep_one_row_per_line():
    from uav_penetration_env.benchmark.leaderboard.formatting import markdown_table

    table = markdown_table(["policy", "J"], [["two\nlines", "1"], [HOSTILE, "2"], ["a|b", "3"]], ["l", "r"])
    lines = table.splitlines()
    assert len(lines) == 5 and all(line.startswith("| ") and line.endswith(" |") for line in lines)
    assert "\x1b" not in table and "two\\nlines" in table and "a\\|b" in table


def test_csv_cells_that_a_spreadsheet_would_run_get_a_leading_apostrophe(tmp_path):
    import pandas as pd

    from uav_penetration_env.benchmark.safe_text import write_csv_table

    frame = pd.DataFrame(
        {
            "policy": ["=cmd|' /C calc'!A0", "+x", "-y", "@z", "\tt", "\rr", "greedy", "-0.5", "-", "pso-2"],
            "total_cost": [-0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, -1e-3],
            "text": ["-1.5", "=1+1", "", None, "ok", "a", "b", "c", "d", "e"],
        }
    )
    path = write_csv_table(frame, tmp_path / "t.csv")
    back = pd.read_csv(path, keep_default_na=False)
    assert list(back["policy"]) == [
        "'=cmd|' /C calc'!A0", "'+x", "'-y", "'@z", "'\tt", "\\rr", "greedy", "-0.5", "'-", "pso-2",
    ]  # fmt: skip
    assert list(back["total_cost"]) == [-0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, -1e-3]
    assert list(back["text"])[:2] == ["-1.5", "'=1+1"]


def test_the_leaderboard_of_hostile_names_keeps_its_table_rows_and_csv_cells(small_store, tmp_path):
    import sqlite3

    store = copied(small_store, tmp_path)
    with sqlite3.connect(store) as connection:
        connection.execute("UPDATE episodes SET policy = 'two' || char(10) || 'lines' WHERE policy = 'pso'")
        connection.execute("UPDATE episodes SET policy = '=cmd|x' WHERE policy = 'greedy'")
    connection.close()
    assert run_cli("leaderboard", "--store", store, "--out", tmp_path / "lb") == 0
    markdown = (tmp_path / "lb" / "tiny.md").read_text().splitlines()
    start = next(i for i, line in enumerate(markdown) if line.startswith("| policy"))
    end = next(i for i in range(start, len(markdown)) if not markdown[i].strip())
    assert all(line.startswith("|") for line in markdown[start:end])
    csv = (tmp_path / "lb" / "tiny.csv").read_text()
    assert "\n=cmd" not in csv and "\n'=cmd" in csv


# --- the env's API edges -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def env():
    from uav_penetration_env.env import UAVPenetrationEnv

    environment = UAVPenetrationEnv(scenario=tiny_scenario())
    environment.reset(seed=0)
    yield environment
    environment.close()


@pytest.mark.parametrize("action", [np.array([0.1 + 5j, 0.0, 0.1]), [0.1, 1j, 0.0], (0j, 0j, 0j)])
def test_a_complex_action_is_refused_naming_action(env, action):
    import warnings

    env.reset(seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ComplexWarning: refused before any conversion
        with pytest.raises(ValueError, match=r"^action: got .*complex.*expected") as error:
            env.step(action)
    assert "\n" not in str(error.value)


def test_the_vector_env_refuses_complex_actions_too():
    from uav_penetration_env.vector_env import UAVPenetrationVectorEnv

    vector = UAVPenetrationVectorEnv(num_envs=2, scenario=tiny_scenario())
    vector.reset(seed=0)
    with pytest.raises(ValueError, match=r"^action: got .*complex"):
        vector.step(np.zeros((2, 3), dtype=complex))
    vector.close()


@pytest.mark.parametrize("state", [["a"] * 6, [1j] * 6, {"x": 1}, None, "abcdef", [[1, 2, 3]] * 2])
def test_a_bad_state_is_refused_naming_state_and_what_was_expected(env, state):
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"^state: got .*, expected 6 finite (real )?numbers") as error:
        env.unwrapped.set_state(state)
    assert "\n" not in str(error.value)


def test_the_env_ids_are_registered_through_a_gymnasium_entry_point():
    from importlib.metadata import entry_points

    import gymnasium

    (point,) = [e for e in entry_points(group="gymnasium.envs") if e.value.startswith("uav_penetration_env")]
    point.load()()
    from uav_penetration_env import ENV_IDS

    assert set(ENV_IDS) <= set(gymnasium.registry)


def test_the_guide_documents_the_module_qualified_id():
    guide = (Path(__file__).parent.parent / "docs" / "guide.md").read_text(encoding="utf-8")
    assert "uav_penetration_env:UAVPenetration-v0" in guide


def test_the_module_qualified_id_works_in_a_fresh_interpreter():
    import subprocess
    import sys

    code = "import gymnasium as gym; e = gym.make('uav_penetration_env:UAVPenetration-v0'); print(e.spec.id)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0 and done.stdout.strip().endswith("UAVPenetration-v0"), done.stderr[-500:]


# --- distill:PATH from an untrusted folder: headers checked before any array is read ---------------


def distill_folder(tmp_path: Path, name: str, write_npz) -> Path:
    import hashlib
    import json

    from uav_penetration_env.model import OBSERVATION_SIZE

    folder = tmp_path / name
    folder.mkdir()
    write_npz(folder / "policy.npz")
    sidecar = {
        "format": "uav-penetration-distill/1", "observation_size": OBSERVATION_SIZE, "input_size": OBSERVATION_SIZE,
        "hidden": [4], "features": [], "head": "controls",
        "weights_sha256": hashlib.sha256((folder / "policy.npz").read_bytes()).hexdigest(),
    }  # fmt: skip
    (folder / "policy.json").write_text(json.dumps(sidecar))
    return folder


def tiny_network() -> dict[str, np.ndarray]:
    from uav_penetration_env.model import OBSERVATION_SIZE

    rng = np.random.default_rng(0)
    return {
        "obs_mean": np.zeros(OBSERVATION_SIZE, np.float32), "obs_scale": np.ones(OBSERVATION_SIZE, np.float32),
        "W0": rng.normal(size=(4, OBSERVATION_SIZE)).astype(np.float32), "b0": np.zeros(4, np.float32),
        "W1": rng.normal(size=(3, 4)).astype(np.float32), "b1": np.zeros(3, np.float32),
    }  # fmt: skip


def test_a_well_formed_distilled_network_still_loads(tmp_path):
    pytest.importorskip("baselines.distill.policy")
    from baselines.distill.policy import load_distill_policy

    folder = distill_folder(tmp_path, "ok", lambda p: np.savez(p, **tiny_network()))
    assert load_distill_policy(folder).arrays["W0"].shape == (4, 67)


def test_a_member_declaring_a_huge_array_is_refused_from_its_header(tmp_path):
    import io
    import zipfile

    pytest.importorskip("baselines.distill.policy")
    from baselines.distill.policy import load_distill_policy

    def bomb(path):
        with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
            for key, value in tiny_network().items():
                if key != "W0":
                    buffer = io.BytesIO()
                    np.lib.format.write_array(buffer, value)
                    archive.writestr(f"{key}.npy", buffer.getvalue())
            header = io.BytesIO()  # 512 MiB declared, none of it stored
            np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": (16, 2**22)})
            archive.writestr("W0.npy", header.getvalue() + bytes(64))

    folder = distill_folder(tmp_path, "bomb", bomb)
    with pytest.raises(ValueError, match=r"member 'W0' declares shape \(16, 4194304\), beyond the sizes") as error:
        load_distill_policy(folder)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("dtype", [np.complex128, np.complex64])
def test_complex_weights_are_refused(tmp_path, dtype):
    pytest.importorskip("baselines.distill.policy")
    from baselines.distill.policy import load_distill_policy

    network = tiny_network()
    network["W0"] = network["W0"].astype(dtype) * (1 + 1j)
    folder = distill_folder(tmp_path, "complex", lambda p: np.savez(p, **network))
    with pytest.raises(ValueError, match=r"member 'W0' declares dtype complex\d+, not real floating point"):
        load_distill_policy(folder)


def test_a_sidecar_declaring_absurd_widths_is_refused(tmp_path):
    import json

    pytest.importorskip("baselines.distill.policy")
    from baselines.distill.policy import load_distill_policy

    folder = distill_folder(tmp_path, "wide", lambda p: np.savez(p, **tiny_network()))
    sidecar = json.loads((folder / "policy.json").read_text())
    (folder / "policy.json").write_text(json.dumps({**sidecar, "hidden": [10**9]}))
    with pytest.raises(ValueError, match=r"policy\.json: sidecar: input_size and hidden got"):
        load_distill_policy(folder)


# --- sb3:PATH.zip without a sidecar: the header is read without unpickling ------------------------


def pickled_space_model(path: Path, marker: Path, *, low: str = "[-10.]", shape=(1,)) -> Path:
    import base64
    import json
    import pickle
    import zipfile

    blob = base64.b64encode(pickle.dumps(_Payload(marker))).decode()
    box = "<class 'gymnasium.spaces.box.Box'>"

    def space(lo, hi, size):
        return {":type:": box, ":serialized:": blob, "dtype": "float32", "_shape": list(size), "low": lo, "high": hi}

    data = {
        "policy_class": {":type:": "<class 'abc.ABCMeta'>", "__module__": "stable_baselines3.common.policies"},
        "observation_space": space(low, low.replace("-", ""), shape),
        "action_space": space("[-1. -1. -1.]", "[1. 1. 1.]", (3,)),
        "num_timesteps": 1, "clip_range": {},
    }  # fmt: skip
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("data", json.dumps(data))
        archive.writestr("policy.pth", b"")
    return path


def test_the_sb3_header_reader_never_unpickles(tmp_path):
    pytest.importorskip("gymnasium")
    from baselines.foreign import read_model_header

    marker = tmp_path / "CODE_RAN"
    model = pickled_space_model(tmp_path / "model.zip", marker, low="[" + " ".join(["-10."] * 67) + "]", shape=(67,))
    header = read_model_header(model)
    assert not marker.exists()
    assert header.algorithm == "ppo" and header.observation_space.shape == (67,)
    assert float(header.observation_space.low.min()) == -10.0 and float(header.action_space.high.max()) == 1.0


def test_a_model_without_a_sidecar_needs_the_trust_opt_in(tmp_path, monkeypatch):
    pytest.importorskip("stable_baselines3")
    from baselines.foreign import TRUST_VARIABLE
    from baselines.policy import load_policy

    marker = tmp_path / "CODE_RAN"
    low = "[" + " ".join(["-10."] * 67) + "]"
    model = pickled_space_model(tmp_path / "model.zip", marker, low=low, shape=(67,))
    monkeypatch.delenv(TRUST_VARIABLE, raising=False)
    with pytest.raises(ValueError, match=rf"model\.zip: a model without a sidecar .*expected {TRUST_VARIABLE}=1"):
        load_policy(model, vecnormalize="none")
    assert not marker.exists()


def test_the_sb3_reproducer_model_is_refused_without_running_its_code(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    marker = tmp_path / "CODE_RAN"
    model = pickled_space_model(tmp_path / "model.zip", marker)
    code = run_cli("run", "--policies", f"sb3:{model}?vecnormalize=none", "--seeds", "1", "--jobs", "1",
                   "--no-report", "--no-progress", "--store", tmp_path / "s.sqlite")  # fmt: skip
    assert code == 2 and not marker.exists()
    assert "sb3 model" in one_error_line(capsys)
