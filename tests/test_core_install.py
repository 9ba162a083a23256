"""The core install (no extra) serves ``gym.make`` and the optimisers; the harness says which extra it needs.

pyproject.toml's ``dependencies`` are what the env needs (numpy, scipy, numba, gymnasium, PyYAML,
platformdirs, cmaes); pandas, pyarrow, matplotlib, joblib, plotly and rich are the ``harness``
extra. A child process hides the extras' modules (an import of any of them fails, as in a venv
without them) and uses the env, the vector env and an MPC planner, then asks ``uav-bench run``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

from uav_penetration_env.benchmark.commands.common import HARNESS

# The start of each child script: every import of a module named in argv[1] (comma-separated) fails,
# as in a venv without them.
HIDE_EXTRAS = textwrap.dedent(
    """
    import importlib.abc, sys
    HIDDEN = set(sys.argv[1].split(","))

    class Hide(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in HIDDEN:
                raise ModuleNotFoundError(f"No module named {name!r}")
            return None

    sys.meta_path.insert(0, Hide())
    import gymnasium as gym
    import numpy as np
    """
)

CHILD = HIDE_EXTRAS + textwrap.dedent(
    """
    import uav_penetration_env  # registers the ids
    from optimizers import get_optimizer
    from uav_penetration_env.benchmark.policies import MPCPolicy
    from uav_penetration_env.mpc import MPCSettings

    env = gym.make("UAVPenetration-v0")
    observation, _ = env.reset(seed=0)
    observation, reward, terminated, truncated, info = env.step(np.zeros(3, dtype=np.float32))
    assert np.isfinite(reward) and not terminated, (reward, info)
    vector = gym.make_vec("UAVPenetration-v0", num_envs=2, vectorization_mode="vector_entry_point")
    vector.reset(seed=0)
    vector.step(np.zeros((2, 3), dtype=np.float32))
    optimizer = get_optimizer("ihpso", swarm_size=10, n_groups=2)
    policy = MPCPolicy(optimizer, settings=MPCSettings(horizon=2, max_evals=40))
    policy.reset(env.unwrapped.model, seed=0)
    action = policy.act(observation, info)
    assert np.shape(action) == (3,), action
    loaded = sorted(name for name in HIDDEN if name in sys.modules)
    assert not loaded, loaded
    from uav_penetration_env.benchmark.cli import main
    sys.exit(main(["run", "--policies", "greedy", "--seeds", "0"]))
    """
)


def run_hiding(script: str, hidden: str, folder) -> subprocess.CompletedProcess:
    """Run ``script`` in a child Python in ``folder`` with the modules ``hidden`` names hidden."""
    return subprocess.run(
        [sys.executable, "-c", script, hidden],
        cwd=folder,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)},
        capture_output=True,
        text=True,
        timeout=600,
    )


def test_the_env_and_planners_run_without_the_harness_extra(tmp_path):
    hidden = ",".join(module for module in HARNESS.modules)
    result = run_hiding(CHILD, hidden, tmp_path)
    assert result.returncode == 2, result.stderr[-3000:]
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr[-3000:]
    assert lines[0].startswith("uav-bench: error: uav-bench run needs pandas"), lines[0]
    assert "pip install -e '.[harness]'" in lines[0]
    assert not (tmp_path / "results").exists()  # nothing written


def test_the_harness_extra_lists_what_the_commands_check():
    from pathlib import Path

    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    pyproject = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())
    project = pyproject["project"]

    def names(requirements: list[str]) -> set[str]:
        return {requirement.split(">")[0].split("=")[0].strip().lower() for requirement in requirements}

    core, extra = names(project["dependencies"]), names(project["optional-dependencies"]["harness"])
    assert not core & {"pandas", "pyarrow", "matplotlib", "plotly", "rich", "joblib"}, core
    assert set(HARNESS.modules) <= extra, (HARNESS.modules, extra)
    assert "uav-penetration[harness]" in project["optional-dependencies"]["dev"]


EVERY_ID = HIDE_EXTRAS + textwrap.dedent(
    """
    from uav_penetration_env import ENV_IDS
    from uav_penetration_env.scenario import ScenarioError

    for env_id in ENV_IDS:
        try:
            env = gym.make(env_id)
            env.reset(seed=0)
            env.step(np.zeros(3, dtype=np.float32))
            print(env_id, "built")
        except ScenarioError as error:
            print(env_id, "refused:", str(error).replace(chr(10), "|"))
    loaded = sorted(name for name in HIDDEN if name in sys.modules)
    assert not loaded, loaded
    """
)


def test_every_env_id_builds_or_names_what_to_install_in_a_core_install(tmp_path):
    """Every registered id is made, reset and stepped with the harness extra (matplotlib too) hidden.

    The DEM id's raster is matplotlib's sample file ``topobathy.npz`` (model.md §2.5): without
    matplotlib it is refused with one line naming what to install, never an ImportError traceback.
    """
    from uav_penetration_env import ENV_IDS

    hidden = ",".join(HARNESS.modules)
    result = run_hiding(EVERY_ID, hidden, tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    said = dict(line.split(" ", 1) for line in result.stdout.strip().splitlines())
    assert sorted(said) == sorted(ENV_IDS)
    for env_id, outcome in said.items():
        if env_id == "UAVPenetrationDEM-v0":
            assert outcome.startswith("refused: terrain.natural.file: got 'topobathy.npz'"), outcome
            assert "matplotlib is not installed" in outcome and "pip install matplotlib" in outcome, outcome
            assert "|" not in outcome  # one line
        else:
            assert outcome == "built", (env_id, outcome)
