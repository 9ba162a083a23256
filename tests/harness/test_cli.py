"""The uav-bench CLI: grammar, config files, errors that protect the store, SIGKILL and resume."""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from conftest import run_cli, run_into_store, tiny_scenario, wait_for_episodes
from fake_policy_kind import fake_kind

from uav_penetration_env import load_scenario
from uav_penetration_env.benchmark import cli, plugins
from uav_penetration_env.benchmark.columns import MEASURED
from uav_penetration_env.benchmark.commands import common
from uav_penetration_env.benchmark.commands import run as run_command
from uav_penetration_env.benchmark.commands.common import CLIError, Command, CommandExtension
from uav_penetration_env.benchmark.commands.run import run_reference
from uav_penetration_env.benchmark.plugins import Needs
from uav_penetration_env.benchmark.store import ResultsStore
from uav_penetration_env.mpc import MPC_DEFAULTS

HERE = Path(__file__).parent
TIMING = [*MEASURED, "run_id", "episode_id"]  # what another run of the same seeds may change


@pytest.fixture(scope="module")
def greedy_store(tmp_path_factory, tiny_yaml):
    """greedy on the tiny scenario (20 steps), seeds 0-1: flown once, copied by each test that writes."""
    store = tmp_path_factory.mktemp("greedy") / "greedy.sqlite"
    assert run_into_store(store, ["greedy"], tiny_yaml, 2, "--jobs", 1) == 0
    return store


def test_no_flags_is_the_main_job():
    args = cli.build_parser().parse_args(["run"])
    args.argv = ["run"]
    settings = run_command.run_settings(args)
    assert settings.policies == (
        "ihpso",
        "hpso",
        "lpso",
        "ps2o",
        "mcpso",
        "ccpso-ism",
        "pso",
        "cem",
        "greedy",
    )
    assert settings.scenarios == ("paper",)
    assert common.parse_seeds(settings.seeds) == [0, 1, 2, 3, 4]
    assert settings.store == "results/uav-bench.sqlite" and settings.out == "results"
    assert settings.jobs is None and settings.mpc == MPC_DEFAULTS
    assert (settings.mpc.max_evals, settings.mpc.horizon) == (10_000, 5)
    assert settings.explicit == frozenset() and settings.report and settings.progress


def test_seeds_above_sqlites_64_bit_integers_are_refused_when_parsed():
    # The store's seed column is a signed 64-bit SQLite INTEGER: 2**63 used to be flown, then lost
    # with an OverflowError traceback when its row was written.
    last = 2**63 - 1
    assert common.parse_seeds(f"{last}:{last + 1}") == [last]
    for bad in (f"{last}:{last + 2}", f"{2**63}:{2**63 + 1}", f"{2**64}:{2**64 + 1}"):
        with pytest.raises(common.CLIError, match=r"--seeds: .*0 <= START < STOP <= 2\*\*63") as error:
            common.parse_seeds(bad)
        assert "\n" not in str(error.value)


def test_seed_and_scenario_grammar():
    assert common.parse_seeds("3") == [0, 1, 2]
    assert common.parse_seeds("5:8") == [5, 6, 7]
    for bad in ("x", "0", "5:5", "-2:3"):
        with pytest.raises(common.CLIError, match="--seeds"):
            common.parse_seeds(bad)
    names = [
        s.name for s in common.resolve_scenarios(["paper", "paper-w2", "random:3-5", "random:9"], None, None)
    ]
    assert names == ["paper-2022-sec5", "paper-2022-sec5-w2", "random-3", "random-4", "random-5", "random-9"]
    (weighted,) = common.resolve_scenarios(["paper"], "paper", (0.3, 0.5, 0.2))
    assert weighted.cost.weights == (0.3, 0.5, 0.2) and weighted.profile == "paper"
    with pytest.raises(common.CLIError, match="did you mean 'paper'"):
        common.resolve_scenarios(["papr"], None, None)
    with pytest.raises(common.CLIError, match="weights"):
        common.resolve_scenarios(["paper"], None, (0.3, 0.3, 0.3))
    with pytest.raises(common.CLIError, match="--weights"):
        common.parse_weights("0.3,0.7")


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


def test_the_mpc_flags_and_config_keys_come_from_the_settings_dataclass(tmp_path, capsys):
    from uav_penetration_env.benchmark.commands.mpc_flags import mpc_settings
    from uav_penetration_env.mpc import MPCSettings, Terminal

    given = [
        "--horizon",
        "4",
        "--discount",
        "0.5",
        "--max-evals",
        "9",
        "--terminal",
        "dubins",
        "--terminal-cost",
        "2",
    ]
    for command in (["run"], ["windows", "--steps", "3"]):
        args = cli.build_parser().parse_args([*command, *given])
        assert mpc_settings(args) == MPCSettings(4, 0.5, 9, Terminal("dubins", 2.0))
    assert set(run_command.SETTING_FIELDS) <= set(run_command.CONFIG_KEYS)
    # A config file's values are converted and checked as the flags are; the error names the flag.
    config = tmp_path / "bad.yaml"
    for text, message in (
        ("max_evals: lots\n", "--max-evals: got 'lots', expected an integer >= 1"),
        ("horizon: 2.5\n", "--horizon: got 2.5, expected an integer >= 1"),
        ("discount: 0\n", "--discount: got 0, expected a number in (0, 1]"),
        ("terminal: euclid\n", "--terminal: got 'euclid', expected one of none, distance, dubins, value"),
        ("terminal_cost: -1\n", "--terminal-cost: got -1, expected a finite number >= 0"),
    ):
        config.write_text(text)
        assert run_cli("run", "--config", config, "--store", tmp_path / "s.sqlite") == 2
        assert capsys.readouterr().err.strip() == f"uav-bench: error: {message}"
    # Flags override the file, field by field.
    config.write_text("horizon: 3\nterminal: distance\n")
    args = cli.build_parser().parse_args(["run", "--config", str(config), "--terminal-cost", "0.2"])
    settings = run_command.run_settings(args).mpc
    assert settings == MPCSettings(horizon=3, terminal=Terminal("distance", 0.2))
    # windows refuses, before opening a store, what a planner would refuse mid-way.
    for argv, message in (
        (["--terminal-cost", "0.3"], "--terminal-cost: got 0.3 with the 'value' terminal form"),
        (["--max-evals", "0"], "--max-evals: got 0, expected an integer >= 1"),
        (["--discount", "2"], "--discount: got 2.0, expected a number in (0, 1]"),
    ):
        assert run_cli("windows", "--steps", "3", "--store", tmp_path / "none.sqlite", *argv) == 2
        assert capsys.readouterr().err.strip().startswith(f"uav-bench: error: {message}")
    assert not (tmp_path / "none.sqlite").exists() and not (tmp_path / "s.sqlite").exists()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--policies", "ihspo"], "did you mean 'ihpso'"),
        (["--scenarios", "nowhere.yaml"], "no such scenario file 'nowhere.yaml'"),
        (["--seeds", "many"], "--seeds"),
        (["--backend", "spark"], "--backend"),
        (["--weights", "1,2"], "--weights"),
        (["--import", "no_such_plugin_module"], "--import"),
    ],
)
def test_bad_input_names_the_problem_and_leaves_the_store_untouched(
    tmp_path, tiny_yaml, greedy_store, capsys, argv, message
):
    store = Path(shutil.copy(greedy_store, tmp_path / "kept.sqlite"))
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


def test_export_and_scenario_commands(tmp_path, tiny_yaml, greedy_store, capsys):
    store = greedy_store
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
    wait_for_episodes(killed_store, process, at_least=3, seconds=120, poll_s=0.02)
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


def test_import_finds_a_module_in_the_current_folder_without_pythonpath(tmp_path, tiny_yaml):
    """``uav-bench run --import mod`` as a user types it: the console script, the module beside them."""
    import os
    import shutil
    import subprocess
    import sys

    shutil.copy(HERE / "plugin_optimizer.py", tmp_path / "my_local_optimizer.py")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    script = Path(sys.executable).parent / "uav-bench"
    command = [str(script), "run", "--import", "my_local_optimizer", "--policies", "test-random-search",
               "--scenarios", str(tiny_yaml), "--seeds", "2", "--max-evals", "100", "--jobs", "2",
               "--store", str(tmp_path / "s.sqlite"), "--no-report", "--no-progress"]  # fmt: skip
    done = subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    rows = stored_rows(tmp_path / "s.sqlite")
    assert len(rows) == 2 and (rows["error"] == "").all()


# --- plug-ins: policy kinds and commands found through entry points ---------------------------------

MISSING_EXTRA = Needs(
    modules=("no_such_module_for_uav_tests",), install="the test extra: pip install 'x[test]'"
)


def fake_plugins(monkeypatch, policies=None, commands=None):
    """Make plug-in discovery return these {entry-point name: Plugin} maps instead of the installed ones."""
    groups = {plugins.POLICY_GROUP: policies or {}, plugins.COMMAND_GROUP: commands or {}}
    monkeypatch.setattr(plugins, "discover", lambda group: groups[group])


def spy_kind(needs=MISSING_EXTRA, loaded=None):
    return fake_kind(loaded, needs)


@pytest.mark.parametrize("name", ["fake:dir/agent.zip", "fake[path=dir/agent.zip]"])
def test_plugin_policy_kind_is_used_and_labelled(name, tmp_path, tiny_yaml, monkeypatch):
    loaded = []
    fake_plugins(monkeypatch, policies={"fake": plugins.Plugin("fake", spy_kind(Needs(), loaded))})
    store = tmp_path / "plug.sqlite"
    assert run_cli("run", "--policies", name, "--scenarios", tiny_yaml, "--seeds", 1,
                   "--store", store, "--no-report", "--no-progress", "--jobs", 1) == 0  # fmt: skip
    assert loaded == ["dir/agent.zip"]
    assert stored_rows(store)["policy"].tolist() == ["fake:agent"]


def test_a_hybrid_name_builds_the_planner_and_hands_it_to_the_kind(tmp_path, tiny_yaml, monkeypatch):
    from uav_penetration_env.benchmark.policies import MPCPolicy, make_policy, parse_policy, policy_label

    handed = []

    def hybrid(params, planner):
        handed.append((params.path, planner))
        return planner  # the planner itself stands in for a warm-started one

    fake_plugins(monkeypatch, policies={"fake": plugins.Plugin("fake", fake_kind(hybrid=hybrid))})
    # Only the text before the first colon of a published form is searched for '+': a path may hold one.
    hybrid_spec = parse_policy("pso+fake:dir/a+b.zip")
    assert (hybrid_spec.kind, hybrid_spec.warm_start.params.path) == ("pso", "dir/a+b.zip")
    assert parse_policy("fake:dir/a+b.zip").warm_start is None and parse_policy("pso").warm_start is None
    assert policy_label("ihpso-eq37+fake:dir/agent.zip") == "ihpso-eq37+fake:agent"
    policy = make_policy("ihpso-eq37+fake:dir/agent.zip", horizon=3, max_evals=50)
    ((argument, planner),) = handed
    assert argument == "dir/agent.zip" and planner is policy and isinstance(planner, MPCPolicy)
    assert (planner.horizon, planner.max_evals, planner.settings.terminal.form, planner.name) == (
        3,
        50,
        "none",
        "ihpso-eq37",
    )
    store = tmp_path / "hybrid.sqlite"
    assert run_cli("run", "--policies", "pso+fake:dir/agent.zip", "--scenarios", tiny_yaml, "--seeds", 1,
                   "--max-evals", 30, "--store", store, "--no-report", "--no-progress", "--jobs", 1) == 0  # fmt: skip
    assert stored_rows(store)["policy"].tolist() == ["pso+fake:agent"]


def test_a_hybrid_of_a_kind_without_one_is_an_unknown_name(tmp_path, tiny_yaml, monkeypatch, capsys):
    fake_plugins(monkeypatch, policies={"fake": plugins.Plugin("fake", spy_kind(Needs(), []))})
    assert (
        run_cli("run", "--policies", "pso+fake:m.zip", "--scenarios", tiny_yaml, "--store", tmp_path / "s")
        == 2
    )
    assert "the plug-in kind 'fake' cannot warm-start a planner" in capsys.readouterr().err


def test_a_plugin_kind_whose_extra_is_missing_is_refused_before_the_store_opens(
    tmp_path, tiny_yaml, monkeypatch, capsys
):
    loaded = []
    fake_plugins(monkeypatch, policies={"fake": plugins.Plugin("fake", spy_kind(MISSING_EXTRA, loaded))})
    store = tmp_path / "never.sqlite"
    code = run_cli("run", "--policies", "greedy", "fake:m.zip", "--scenarios", tiny_yaml, "--store", store)
    err = capsys.readouterr().err
    assert code == 2 and loaded == [] and not store.exists()
    assert err.count("\n") == 1 and err.startswith("uav-bench: error: --policies: ")
    assert (
        "no_such_module_for_uav_tests (not installed); install the test extra: pip install 'x[test]'" in err
    )


def test_without_the_plugin_a_prefixed_policy_is_an_unknown_name(tmp_path, tiny_yaml, monkeypatch, capsys):
    fake_plugins(monkeypatch)
    assert run_cli("run", "--policies", "sb3:m.zip", "--scenarios", tiny_yaml, "--store", tmp_path / "s") == 2
    assert "no installed plug-in provides the kind 'sb3'" in capsys.readouterr().err


def test_a_plugin_that_fails_to_import_is_refused_with_its_error(tmp_path, tiny_yaml, monkeypatch, capsys):
    broken = plugins.Plugin("fake", error="fake_pkg:KIND failed to import (No module named 'fake_pkg')")
    fake_plugins(monkeypatch, policies={"fake": broken}, commands={"fly": broken})
    assert run_cli("run", "--policies", "fake:m", "--scenarios", tiny_yaml, "--store", tmp_path / "s") == 2
    assert "No module named 'fake_pkg'" in capsys.readouterr().err
    assert run_cli("fly", "--any", "flags") == 2  # the broken command still has a name and says why
    assert "fly: the plug-in fake_pkg:KIND failed to import" in capsys.readouterr().err


def test_plugin_commands_and_extensions_register_and_check_their_needs(monkeypatch, capsys):
    calls = []

    def add_arguments(parser):
        parser.add_argument("--speed", type=int, required=True)

    def add_extension_arguments(parser):
        parser.add_argument("--fancy", action="store_true")

    fly = Command("fly", "fly somewhere", add_arguments, lambda args: calls.append(("fly", args.speed)) or 0)
    fancy = CommandExtension("plot", add_extension_arguments, lambda args: args.fancy,
                             lambda args: calls.append(("fancy", args.out)) or 0)  # fmt: skip
    heavy = Command("heavy", "needs a missing extra", add_arguments, lambda args: 0, needs=MISSING_EXTRA)
    fake_plugins(monkeypatch, commands={n: plugins.Plugin(n, c) for n, c in
                                        [("fly", fly), ("plot.fancy", fancy), ("heavy", heavy)]})  # fmt: skip
    with pytest.raises(SystemExit) as help_exit:
        run_cli("--help")
    listing = capsys.readouterr().out
    assert help_exit.value.code == 0 and "fly somewhere" in listing and "needs a missing extra" in listing
    assert run_cli("fly", "--speed", 3) == 0
    assert run_cli("plot", "--fancy", "--out", "figs") == 0
    assert calls == [("fly", 3), ("fancy", "figs")]
    assert run_cli("heavy", "--speed", 1) == 2
    assert "uav-bench heavy needs no_such_module_for_uav_tests (not installed)" in capsys.readouterr().err
    clash = Command("run", "another run", add_arguments, lambda args: 0)
    fake_plugins(monkeypatch, commands={"run": plugins.Plugin("run", clash)})
    assert run_cli("run") == 2
    assert "clashes with a command" in capsys.readouterr().err


def test_run_help_needs_no_plugin_and_no_rl_extra(monkeypatch, capsys):
    fake_plugins(monkeypatch)
    for argv in (["--help"], ["run", "--help"]):
        with pytest.raises(SystemExit) as exit_info:
            run_cli(*argv)
        assert exit_info.value.code == 0
    assert "--policies" in capsys.readouterr().out


def test_a_usage_error_names_uav_bench_once(capsys):
    from uav_penetration_env.benchmark.cli import main

    assert main(["run", "--no-such-flag"]) == 2
    top = capsys.readouterr().err.strip()
    assert top.startswith("uav-bench: error: uav-bench run: unrecognized arguments: --no-such-flag")
    assert top.count("uav-bench:") == 1 and top.endswith("(see uav-bench run --help)")
    assert main(["run", "--policy", "ihpso"]) == 2
    assert "— did you mean '--policies'? (see uav-bench run --help)" in capsys.readouterr().err
    assert main(["run", "--horizon", "x"]) == 2
    sub = capsys.readouterr().err.strip()
    assert (
        sub.startswith("uav-bench: error: uav-bench run: argument --horizon")
        and "(see uav-bench run --help)" in sub
    )


def test_counts_name_their_noun_in_the_right_number():
    from uav_penetration_env.benchmark.commands.run import counted

    assert counted(1, "scenario") == "1 scenario" and counted(3, "scenario") == "3 scenarios"
    assert counted(1, "policy", "policies") == "1 policy" and counted(0, "policy", "policies") == "0 policies"


def test_run_writes_its_report_next_to_its_store_unless_out_says_otherwise(tmp_path, tiny_yaml, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "index.html").write_text("the main job's report")
    store = tmp_path / "elsewhere" / "s.sqlite"
    code = run_cli("run", "--policies", "greedy", "--scenarios", tiny_yaml, "--seeds", 1, "--jobs", 1,
                   "--store", store, "--no-progress")  # fmt: skip
    assert code == 0
    assert (tmp_path / "results" / "index.html").read_text() == "the main job's report"
    assert (store.parent / "index.html").exists()


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads the process table from /proc")
def test_sigterm_mid_run_keeps_finished_episodes_exits_143_and_leaves_no_worker(tmp_path, tiny_yaml):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE.parent), os.environ.get("PYTHONPATH", "")]))
    store = tmp_path / "term.sqlite"
    argv = [sys.executable, "-m", "uav_penetration_env.benchmark.cli", "run", "--scenarios", tiny_yaml,
            "--policies", "pso", "greedy", "--seeds", "12", "--max-evals", "1500", "--jobs", "2",
            "--no-report", "--no-progress", "--store", str(store)]  # fmt: skip
    process = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)

    def children() -> set[int]:
        found = set()
        for stat in Path("/proc").glob("[0-9]*/stat"):
            with contextlib.suppress(OSError):
                fields = stat.read_text().rsplit(")", 1)[1].split()
                if int(fields[1]) == process.pid:
                    found.add(int(stat.parent.name))
        return found

    deadline, stored, workers = time.monotonic() + 180, 0, set()
    while time.monotonic() < deadline and process.poll() is None and stored < 2:
        workers |= children()
        with contextlib.suppress(sqlite3.OperationalError):
            if store.exists():
                with sqlite3.connect(store, timeout=1) as connection:
                    stored = connection.execute("SELECT COUNT(*) FROM episodes").fetchone()[0]
        time.sleep(0.05)
    assert process.poll() is None, "the run finished before it could be terminated"
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 143, err.decode()[-500:]
    assert "terminated (signal 15): " in err.decode() and "rerun the same command to resume" in err.decode()
    assert len(stored_rows(store)) >= 2
    time.sleep(1.0)  # killed workers take a moment to leave the process table
    alive = {}
    for pid in workers:
        with contextlib.suppress(OSError):
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
            if state != "Z":  # a zombie has exited, only its entry waits to be reaped
                alive[pid] = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")[:200]
    assert not alive, f"processes outlived the run: {alive}"


def test_run_reference_is_the_tables_default_unless_named_and_refuses_others():
    assert run_reference(None, ["greedy", "ihpso", "pso"]) == "ihpso"
    assert run_reference(None, ["my-search", "greedy"]) == "ihpso"  # the tables fall back to greedy
    assert run_reference("my-search", ["my-search", "greedy"]) == "my-search"
    with pytest.raises(
        CLIError, match=r"--reference gredy: did you mean 'greedy'\? expected one of --policies"
    ):
        run_reference("gredy", ["my-search", "greedy"])


def test_a_run_without_ihpso_compares_against_greedy_and_the_report_command_agrees(tmp_path, tiny_yaml):
    store = tmp_path / "s.sqlite"
    code = run_cli("run", "--policies", "random", "greedy", "--scenarios", tiny_yaml, "--seeds", 2, "--jobs", 1,
                   "--store", store, "--no-progress")  # fmt: skip
    assert code == 0
    (table,) = [path for path in tmp_path.glob("*.csv") if not path.stem.endswith(("-rl", "-members"))]
    written_by_run = table.read_bytes()
    rows = pd.read_csv(table).set_index("policy")
    # no ihpso: greedy (the floor) is the reference, so random's row holds the paired difference
    assert np.isfinite(rows.loc["random", "delta_mean"]) and rows.loc["random", "n_pairs"] == 2
    assert not np.isfinite(rows.loc["greedy", "delta_mean"])
    assert run_cli("leaderboard", "--store", store, "--out", tmp_path / "again") == 0
    rebuilt = (tmp_path / "again" / table.name).read_bytes()
    assert rebuilt == written_by_run


def test_store_list_and_drop_remove_one_configuration_after_confirmation(
    tmp_path, tiny_yaml, capsys, monkeypatch
):
    store = tmp_path / "s.sqlite"
    assert run_cli("run", "--policies", "greedy,random", "--scenarios", tiny_yaml, "--seeds", 2, "--jobs", 1,
                   "--store", store, "--no-report", "--no-progress") == 0  # fmt: skip
    with ResultsStore(store, create=False) as results:
        before = results.episodes()
        steps_before = results.count("steps")
    random_ids = before.loc[before["policy"] == "random", "episode_id"].tolist()
    capsys.readouterr()
    assert run_cli("store", "list", "--store", store) == 0
    header, *listed = capsys.readouterr().out.splitlines()
    assert header.split()[:2] == ["policy", "configuration"]
    assert [line.split()[0] for line in listed] == ["greedy", "random"]
    assert all(" 2 episodes " in line for line in listed)
    # without a terminal and without --yes nothing is dropped
    monkeypatch.setattr(sys, "stdin", open(os.devnull))
    assert run_cli("store", "drop", "--policy", "random", "--store", store) == 2
    assert "--yes: needed to drop 2 episodes (0 with errors) of random" in capsys.readouterr().err
    assert run_cli("store", "drop", "--policy", "randm", "--store", store) == 2
    assert "did you mean 'random'?" in capsys.readouterr().err
    assert run_cli("store", "drop", "--policy", "random", "--store", store, "--yes") == 0
    with ResultsStore(store, create=False) as results:
        after = results.episodes()
        steps_removed = steps_before - results.count("steps")
        assert set(results.policies()) == set(before.loc[before["policy"] == "greedy", "policy_hash"])
        assert results.steps(random_ids).empty
    assert after["policy"].tolist() == ["greedy", "greedy"]
    assert f"dropped 2 episodes and {steps_removed} steps of random" in capsys.readouterr().out
    assert steps_removed > 2


def test_an_out_folder_of_another_store_is_refused_unless_replaced(tmp_path, tiny_yaml, capsys):
    first, second, out = tmp_path / "a" / "s.sqlite", tmp_path / "b" / "s.sqlite", tmp_path / "out"
    for store in (first, second):
        assert run_cli("run", "--policies", "greedy", "--scenarios", tiny_yaml, "--seeds", 1, "--jobs", 1,
                       "--store", store, "--no-report", "--no-progress") == 0  # fmt: skip
    assert run_cli("leaderboard", "--store", first, "--out", out) == 0
    written = {path.name: path.read_bytes() for path in out.iterdir() if path.suffix in (".md", ".csv")}
    capsys.readouterr()
    for argv in (["leaderboard", "--store", second, "--out", out], ["plot", "--store", second, "--out", out],
                 ["report", "--store", second, "--out", out],
                 ["run", "--policies", "greedy", "--scenarios", tiny_yaml, "--seeds", 1, "--store", second,
                  "--out", out, "--no-progress"]):  # fmt: skip
        assert run_cli(*argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.startswith(
            f"uav-bench: error: --out {out}: holds the tables and report of {first.resolve()}"
        ), err
    assert {
        path.name: path.read_bytes() for path in out.iterdir() if path.suffix in (".md", ".csv")
    } == written
    assert run_cli("leaderboard", "--store", first, "--out", out) == 0  # its own folder: fine
    assert run_cli("leaderboard", "--store", second, "--out", out, "--replace-out") == 0
    assert (out / ".uav-bench-source").read_text().strip() == str(second.resolve())


FAST_REFUSAL = """
import sys
from uav_penetration_env.benchmark.cli import main
status = main(sys.argv[1:])
compiled = sorted(m for m in sys.modules if m == "numba" or m.startswith(("numba.", "uav_penetration_env.kernels",
                  "uav_penetration_env.model", "uav_penetration_env.benchmark.evaluate")))
print(status, len(compiled), compiled[:3])
"""


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--policies", "ihpsoo"], "--policies: unknown policy 'ihpsoo' — did you mean 'ihpso'"),
        (["--policies", "greedy", "nosuch:thing"], "no installed plug-in provides the kind 'nosuch'"),
        (["--policies", "lattice[clearance=5]"], "clearance: got '5', expected an integer number of metres in [10, 1000]"),
        (["--scenarios", "missing.yaml"], "--scenarios: no such scenario file 'missing.yaml'"),
        (["--config", "missing.yaml"], "--config"),
    ],
)
def test_a_mistyped_policy_or_a_missing_file_is_refused_before_the_physics_is_imported(tmp_path, argv, message):
    """The refusal comes before the compiled model's imports (api.md §4.7, fast refusals): measured by
    what the process imported, not by a clock."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE.parent.parent), os.environ.get("PYTHONPATH", "")]))
    done = subprocess.run([sys.executable, "-c", FAST_REFUSAL, "run", *argv, "--store", str(tmp_path / "s.sqlite")],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)  # fmt: skip
    assert done.stdout.strip() == "2 0 []", (done.stdout, done.stderr)
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], lines
    assert not (tmp_path / "s.sqlite").exists()
