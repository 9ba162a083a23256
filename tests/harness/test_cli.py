"""The uav-bench CLI: grammar, config files, errors that protect the store, SIGKILL and resume."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
import yaml
from conftest import tiny_scenario

from uav_penetration_env import load_scenario
from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.store import ResultsStore

HERE = Path(__file__).parent
TIMING = ["planning_seconds", "objective_seconds", "episode_seconds", "finished", "run_id", "episode_id"]


@pytest.fixture(scope="module")
def tiny_yaml(tmp_path_factory):
    return str(
        tiny_scenario(time={"max_steps": 20}).to_yaml(tmp_path_factory.mktemp("scenario") / "tiny.yaml")
    )


def run_cli(*argv):
    return cli.main([str(a) for a in argv])


def test_no_flags_is_the_main_job():
    args = cli.build_parser().parse_args(["run"])
    args.argv = ["run"]
    settings = cli.run_settings(args)
    assert settings["policies"] == [
        "ihpso",
        "hpso",
        "lpso",
        "ps2o",
        "mcpso",
        "ccpso-ism",
        "pso",
        "cem",
        "greedy",
    ]
    assert settings["scenarios"] == ["paper"]
    assert cli.parse_seeds(settings["seeds"]) == [0, 1, 2, 3, 4]
    assert settings["store"] == "results/uav-bench.sqlite" and settings["out"] == "results"
    assert settings["jobs"] is None and settings["max_evals"] == 10_000 and settings["horizon"] == 5


def test_seed_and_scenario_grammar():
    assert cli.parse_seeds("3") == [0, 1, 2]
    assert cli.parse_seeds("5:8") == [5, 6, 7]
    for bad in ("x", "0", "5:5", "-2:3"):
        with pytest.raises(cli.CLIError, match="--seeds"):
            cli.parse_seeds(bad)
    names = [
        s.name for s in cli.resolve_scenarios(["paper", "paper-w2", "random:3-5", "random:9"], None, None)
    ]
    assert names == ["paper-2022-sec5", "paper-2022-sec5-w2", "random-3", "random-4", "random-5", "random-9"]
    (weighted,) = cli.resolve_scenarios(["paper"], "paper", (0.3, 0.5, 0.2))
    assert weighted.cost.weights == (0.3, 0.5, 0.2) and weighted.profile == "paper"
    with pytest.raises(cli.CLIError, match="did you mean 'paper'"):
        cli.resolve_scenarios(["papr"], None, None)
    with pytest.raises(cli.CLIError, match="weights"):
        cli.resolve_scenarios(["paper"], None, (0.3, 0.3, 0.3))
    with pytest.raises(cli.CLIError, match="--weights"):
        cli.parse_weights("0.3,0.7")


def test_config_file_and_flags(tmp_path, tiny_yaml):
    config = tmp_path / "experiment.yaml"
    config.write_text(
        yaml.safe_dump(
            {"policies": ["greedy", "random"], "seeds": 2, "scenarios": [tiny_yaml], "max_evals": 50}
        )
    )
    store = tmp_path / "cfg.sqlite"
    assert (
        run_cli(
            "run",
            "--config",
            config,
            "--seeds",
            "3",
            "--store",
            store,
            "--no-report",
            "--no-progress",
            "--jobs",
            1,
        )
        == 0
    )
    with ResultsStore(store) as results:
        episodes = results.episodes()
    assert sorted(set(episodes["policy"])) == ["greedy", "random"] and sorted(set(episodes["seed"])) == [
        0,
        1,
        2,
    ]
    config.write_text(yaml.safe_dump({"policy": ["greedy"]}))
    assert run_cli("run", "--config", config, "--store", store) == 2


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--policies", "ihspo"], "did you mean 'ihpso'"),
        (["--scenarios", "nowhere.yaml"], "unknown scenario 'nowhere.yaml'"),
        (["--seeds", "many"], "--seeds"),
        (["--backend", "spark"], "--backend"),
        (["--weights", "1,2"], "--weights"),
        (["--import", "no_such_plugin_module"], "--import"),
    ],
)
def test_bad_input_names_the_problem_and_leaves_the_store_untouched(
    tmp_path, tiny_yaml, capsys, argv, message
):
    store = tmp_path / "kept.sqlite"
    assert (
        run_cli(
            "run",
            "--policies",
            "greedy",
            "--scenarios",
            tiny_yaml,
            "--seeds",
            2,
            "--store",
            store,
            "--no-report",
            "--no-progress",
        )
        == 0
    )
    before = store.read_bytes()
    base = [
        "run",
        "--policies",
        "greedy",
        "--scenarios",
        tiny_yaml,
        "--seeds",
        2,
        "--store",
        store,
        "--no-report",
    ]
    override = {argv[0]: argv[1]}
    full = []
    i = 0
    while i < len(base):
        if base[i] in override:
            full += [base[i], override.pop(base[i])]
            i += 2
        else:
            full.append(base[i])
            i += 1
    full += [item for pair in override.items() for item in pair]
    assert run_cli(*full) == 2
    assert message in capsys.readouterr().err
    assert store.read_bytes() == before


def test_broken_scenario_file_and_unwritable_store(tmp_path, capsys):
    broken = tmp_path / "broken.yaml"
    broken.write_text(
        yaml.safe_dump(
            {**tiny_scenario().to_dict(), "radars": [{"name": "A", "x_km": 500, "y_km": 0, "z_m": 10}]}
        )
    )
    assert (
        run_cli("run", "--scenarios", broken, "--policies", "greedy", "--store", tmp_path / "s.sqlite") == 2
    )
    assert "radars[0].x_km" in capsys.readouterr().err
    assert not (tmp_path / "s.sqlite").exists()
    assert (
        run_cli("run", "--scenarios", "paper", "--policies", "greedy", "--store", "/proc/nope/s.sqlite") == 2
    )
    assert "--store" in capsys.readouterr().err
    assert run_cli("leaderboard", "--store", tmp_path / "missing.sqlite") == 2


def test_export_and_scenario_commands(tmp_path, tiny_yaml, capsys):
    store = tmp_path / "e.sqlite"
    assert (
        run_cli(
            "run",
            "--policies",
            "greedy",
            "--scenarios",
            tiny_yaml,
            "--seeds",
            2,
            "--store",
            store,
            "--no-report",
            "--no-progress",
        )
        == 0
    )
    assert run_cli("export", "--format", "csv", "--store", store, "--out", tmp_path / "dump") == 0
    episodes = pd.read_csv(tmp_path / "dump-episodes.csv")
    steps = pd.read_csv(tmp_path / "dump-steps.csv")
    assert len(episodes) == 2 and len(steps) == episodes["steps"].sum()
    assert run_cli("export", "--format", "parquet", "--store", store, "--out", tmp_path / "dump") == 0
    assert len(pd.read_parquet(tmp_path / "dump-episodes.parquet")) == 2
    capsys.readouterr()
    assert run_cli("scenario", "show", "paper-w2") == 0
    shown = capsys.readouterr().out
    assert "weights: [0.3, 0.5, 0.2]" in shown
    assert run_cli("scenario", "validate", tiny_yaml) == 0
    assert run_cli("scenario", "generate", "random:7", "--out", tmp_path / "r7.yaml") == 0
    assert load_scenario(tmp_path / "r7.yaml").name == "random-7"
    assert run_cli("scenario", "generate", "random:1-2", "--out", tmp_path / "many") == 0
    assert sorted(p.name for p in (tmp_path / "many").iterdir()) == ["random-1.yaml", "random-2.yaml"]


def test_calibrate_writes_constants_and_provenance(tmp_path, tiny_yaml):
    out = tmp_path / "calibrated.yaml"
    code = run_cli(
        "calibrate",
        "--scenario",
        tiny_yaml,
        "--optimizer",
        "pso",
        "--max-evals",
        60,
        "--runs",
        2,
        "--horizon",
        2,
        "--jobs",
        1,
        "--out",
        out,
    )
    assert code == 0
    scenario = load_scenario(out)
    payoff = scenario.normalisation.payoff
    provenance = dict(payoff.provenance)
    assert (
        provenance["optimizer"] == "pso"
        and provenance["runs"] == 2
        and provenance["horizon"] == 2
        and provenance["max_evals"] == 60
    )
    constants = payoff.constants
    for low, high in (constants.terrain, constants.radar, constants.third):
        assert low < high
    assert constants.crash_penalty_per_step > 0
    from uav_penetration_env.env import UAVPenetrationEnv

    env = UAVPenetrationEnv(scenario, profile="paper")
    env.reset(seed=0)
    assert env.model.crash_penalty_per_step == constants.crash_penalty_per_step


def stored_rows(store: Path) -> pd.DataFrame:
    with ResultsStore(store) as results:
        frame = results.episodes()
    return frame.drop(columns=TIMING).sort_values(["policy", "seed"]).reset_index(drop=True)


def test_sigkill_mid_run_then_resume_equals_an_uninterrupted_run(tmp_path, tiny_yaml):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE.parent), os.environ.get("PYTHONPATH", "")]))
    argv = ["run", "--scenarios", tiny_yaml, "--policies", "pso", "greedy", "--seeds", "8", "--max-evals", "1500",
            "--jobs", "1", "--no-report", "--no-progress"]  # fmt: skip
    killed_store, clean_store = tmp_path / "killed.sqlite", tmp_path / "clean.sqlite"
    command = [sys.executable, "-m", "uav_penetration_env.benchmark.cli", *argv]
    process = subprocess.Popen(
        [*command, "--store", str(killed_store)], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    stored = 0
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and process.poll() is None:
        if killed_store.exists():
            try:
                with sqlite3.connect(killed_store, timeout=1) as connection:
                    stored = connection.execute("SELECT COUNT(*) FROM episodes").fetchone()[0]
            except sqlite3.OperationalError:
                stored = 0
            if stored >= 3:
                break
        time.sleep(0.02)
    assert process.poll() is None, (
        f"the run finished before it could be killed: {process.stderr.read().decode()[-500:]}"
    )
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert 3 <= len(stored_rows(killed_store)) < 16
    resumed = subprocess.run(
        [*command, "--store", str(killed_store)], env=env, capture_output=True, text=True
    )
    assert resumed.returncode == 0, resumed.stderr
    clean = subprocess.run([*command, "--store", str(clean_store)], env=env, capture_output=True, text=True)
    assert clean.returncode == 0, clean.stderr
    after = stored_rows(killed_store)
    assert len(after) == 16 and not after.duplicated(["policy_hash", "scenario_hash", "seed"]).any()
    pd.testing.assert_frame_equal(after, stored_rows(clean_store))


def test_plugin_import_flag_reaches_workers(tmp_path, tiny_yaml, monkeypatch):
    monkeypatch.syspath_prepend(str(HERE))
    store = tmp_path / "plugin.sqlite"
    code = run_cli("run", "--import", "plugin_optimizer", "--policies", "test-random-search", "--scenarios", tiny_yaml,
                   "--seeds", 2, "--max-evals", 100, "--jobs", 2, "--store", store, "--no-report", "--no-progress")  # fmt: skip
    assert code == 0
    rows = stored_rows(store)
    assert (rows["error"] == "").all() and (rows["nfev"] > 0).all()
