"""baselines as a harness plug-in: its entry points, and the harness without the rl extra."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from sb3_helpers import baselines_plugins  # noqa: F401 (a fixture)

from baselines import plugin
from baselines.policy_params import DistillParams, SB3Params
from uav_penetration_env.benchmark.commands.common import Command, CommandExtension
from uav_penetration_env.benchmark.plugins import COMMAND_GROUP, POLICY_GROUP, PolicyKind
from uav_penetration_env.benchmark.policy_names import parse_policy

ROOT = Path(__file__).resolve().parents[2]


def test_pyproject_declares_the_plugins_of_baselines():
    tomllib = pytest.importorskip("tomllib")
    entry_points = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    assert entry_points[POLICY_GROUP] == {
        "sb3": "baselines.plugin:SB3_POLICY_KIND",
        "distill": "baselines.plugin:DISTILL_POLICY_KIND",
    }
    assert entry_points[COMMAND_GROUP] == {
        "train": "baselines.plugin:TRAIN_COMMAND",
        "distill": "baselines.plugin:DISTILL_COMMAND",
        "tune": "baselines.plugin:TUNE_COMMAND",
        "plot.models": "baselines.plugin:LEARNING_CURVES",
    }
    assert isinstance(plugin.SB3_POLICY_KIND, PolicyKind) and plugin.SB3_POLICY_KIND.name == "sb3"
    assert isinstance(plugin.TRAIN_COMMAND, Command) and plugin.TRAIN_COMMAND.name == "train"
    assert isinstance(plugin.TUNE_COMMAND, Command) and plugin.TUNE_COMMAND.name == "tune"
    assert "optuna" in plugin.TUNE_COMMAND.needs.modules
    assert isinstance(plugin.LEARNING_CURVES, CommandExtension) and plugin.LEARNING_CURVES.command == "plot"
    assert plugin.SB3_POLICY_KIND.label(SB3Params("models/ppo-paper-s0.zip")) == "sb3:ppo-paper-s0"
    assert isinstance(plugin.DISTILL_POLICY_KIND, PolicyKind) and plugin.DISTILL_POLICY_KIND.name == "distill"
    assert plugin.DISTILL_POLICY_KIND.label(DistillParams("results/distill/lattice-s0")) == "distill:lattice-s0"
    assert isinstance(plugin.DISTILL_COMMAND, Command) and plugin.DISTILL_COMMAND.name == "distill"
    assert plugin.DISTILL_POLICY_KIND.needs.modules == ()  # flown with NumPy: no extra needed
    assert plugin.DISTILL_POLICY_KIND.label(DistillParams("results/distill/lattice-s0", "safe")) == (
        "distill-safe:lattice-s0"
    )
    assert plugin.DISTILL_POLICY_KIND.label(DistillParams("results/distill/turn-s0", "shield")) == (
        "distill-shield:turn-s0"
    )


# The published names of baselines' kinds (leaderboards v2, v3, protocol v4), their bracket forms and labels.
PUBLISHED = [
    ("distill-shield:oos-c40-value-s0", "distill[run=oos-c40-value-s0,guard=shield]",
     "distill-shield:oos-c40-value-s0", DistillParams("oos-c40-value-s0", "shield")),
    ("distill-safe:runs/c40-s0", "distill[run=runs/c40-s0,guard=safe]", "distill-safe:c40-s0",
     DistillParams("runs/c40-s0", "safe")),
    ("distill:runs/c40-value-s1", "distill[run=runs/c40-value-s1]", "distill:c40-value-s1",
     DistillParams("runs/c40-value-s1")),
    ("sb3:models/ppo-paper-s0.zip", "sb3[model=models/ppo-paper-s0.zip]", "sb3:ppo-paper-s0",
     SB3Params("models/ppo-paper-s0.zip")),
    ("sb3:logs/ENV_1/ENV.zip?vecnormalize=logs/ENV_1/ENV/vecnormalize.pkl",
     "sb3[model=logs/ENV_1/ENV.zip,vecnormalize=logs/ENV_1/ENV/vecnormalize.pkl]", "sb3:ENV",
     SB3Params("logs/ENV_1/ENV.zip", "logs/ENV_1/ENV/vecnormalize.pkl")),
    ("sb3:m/a,b.zip?vecnormalize=none", 'sb3[model="m/a,b.zip",vecnormalize=none]', "sb3:a,b",
     SB3Params("m/a,b.zip", "none")),
]  # fmt: skip


@pytest.mark.usefixtures("baselines_plugins")
@pytest.mark.parametrize("published, bracket, label, params", PUBLISHED)
def test_published_names_of_the_plugin_kinds_read_as_their_bracket_forms(published, bracket, label, params):
    spec = parse_policy(published)
    assert (spec.params, spec.label, spec.canonical()) == (params, label, bracket)
    assert parse_policy(bracket) == spec
    if spec.kind == "sb3":  # an agent warm-starts a planner; a distilled network does not
        hybrid = parse_policy(f"ihpso+{published}")
        assert hybrid.label == f"ihpso+{label}" and hybrid.canonical() == f"ihpso+{bracket}"
        assert parse_policy(f"ihpso[terminal=none]+{bracket}").label == f"ihpso-eq37+{label}"


@pytest.mark.usefixtures("baselines_plugins")
def test_a_bad_plugin_parameter_is_one_line():
    with pytest.raises(ValueError, match=r"guard: got 'maybe', expected one of none, safe, shield$"):
        parse_policy("distill[run=d,guard=maybe]")
    with pytest.raises(ValueError, match=r"the kind 'sb3' needs the parameter 'model' \(the path of an SB3 \.zip\)"):
        parse_policy("sb3[vecnormalize=none]")
    with pytest.raises(KeyError, match=r"the plug-in kind 'distill' cannot warm-start a planner"):
        parse_policy("ihpso+distill-shield:d")


# A fresh interpreter in which torch and stable_baselines3 cannot be imported (as without the rl
# extra), with plug-in discovery answering from baselines.plugin, as an installed checkout does.
WITHOUT_RL = textwrap.dedent(
    """
    import importlib.abc, sys

    class NoRL(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.partition(".")[0] in ("torch", "stable_baselines3", "optuna"):
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)
            return None

    sys.meta_path.insert(0, NoRL())
    from uav_penetration_env.benchmark import plugins
    import baselines.plugin as rl

    found = {
        plugins.POLICY_GROUP: {"sb3": plugins.Plugin("sb3", rl.SB3_POLICY_KIND),
                               "distill": plugins.Plugin("distill", rl.DISTILL_POLICY_KIND)},
        plugins.COMMAND_GROUP: {"train": plugins.Plugin("train", rl.TRAIN_COMMAND),
                                "distill": plugins.Plugin("distill", rl.DISTILL_COMMAND),
                                "tune": plugins.Plugin("tune", rl.TUNE_COMMAND),
                                "plot.models": plugins.Plugin("plot.models", rl.LEARNING_CURVES)},
    }
    plugins.discover = lambda group: found[group]
    from uav_penetration_env.benchmark.cli import main

    try:
        code = main(sys.argv[1:])
    except SystemExit as exit:
        code = exit.code
    assert not {"torch", "stable_baselines3", "optuna"} & set(sys.modules)
    sys.exit(code)
    """
)


def uav_bench_without_rl(*argv, cwd):
    return subprocess.run(
        [sys.executable, "-c", WITHOUT_RL, *map(str, argv)],
        cwd=cwd,
        env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg"},
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_without_the_rl_extra_help_works_and_sb3_and_train_are_refused_in_one_line(tmp_path):
    for argv in (["--help"], ["run", "--help"]):
        shown = uav_bench_without_rl(*argv, cwd=tmp_path)
        assert shown.returncode == 0, shown.stderr
        assert "train" in shown.stdout or "--policies" in shown.stdout
    store = tmp_path / "never.sqlite"
    refused = uav_bench_without_rl(
        "run", "--policies", "greedy", "sb3:models/ppo.zip", "--seeds", 1, "--store", store, cwd=tmp_path
    )
    assert refused.returncode == 2 and not store.exists()
    assert refused.stderr.count("\n") == 1
    assert refused.stderr.startswith("uav-bench: error: --policies: policy 'sb3:models/ppo.zip' needs ")
    assert "pip install 'uav-penetration[rl]'" in refused.stderr
    assert "pip install torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu && pip install -e '.[rl]'" in refused.stderr  # not several GB of CUDA
    train = uav_bench_without_rl("train", "--algo", "ppo", "--timesteps", 10, cwd=tmp_path)
    assert train.returncode == 2 and train.stderr.count("\n") == 1
    assert "uav-bench train needs stable_baselines3, torch (not installed)" in train.stderr
    tune = uav_bench_without_rl("tune", "--algo", "ppo", "--trials", 1, cwd=tmp_path)
    assert tune.returncode == 2 and tune.stderr.count("\n") == 1
    assert "uav-bench tune needs stable_baselines3, torch, optuna (not installed)" in tune.stderr
    distill = uav_bench_without_rl("distill", "--out", tmp_path / "results" / "d", cwd=tmp_path)
    assert distill.returncode == 2 and distill.stderr.count("\n") == 1
    assert "uav-bench distill needs stable_baselines3, torch (not installed)" in distill.stderr
    assert not (tmp_path / "results").exists()


def test_without_the_rl_extra_a_hybrid_is_refused_in_one_line(tmp_path):
    store = tmp_path / "never.sqlite"
    refused = uav_bench_without_rl(
        "run", "--policies", "ihpso+sb3:models/ppo.zip", "--seeds", 1, "--store", store, cwd=tmp_path
    )
    assert refused.returncode == 2 and not store.exists()
    assert refused.stderr.count("\n") == 1
    assert refused.stderr.startswith("uav-bench: error: --policies: policy 'ihpso+sb3:models/ppo.zip' needs ")
    assert "pip install 'uav-penetration[rl]'" in refused.stderr
