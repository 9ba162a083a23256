"""rl-baselines3-zoo interop: the shipped hyper-parameter files, the action wrapper, models without a sidecar."""

from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest
from conftest import RL_EXTRA, tiny_scenario

pytest.importorskip("stable_baselines3", reason=RL_EXTRA)

from sb3_helpers import baselines_plugins  # noqa: F401 (a fixture)
from stable_baselines3.common.noise import ActionNoise

from baselines import load_policy
from baselines.hyperparameters import algorithm_kwargs, normalize_kwargs, resolve_hyperparams
from baselines.plan import TrainConfig
from baselines.policy import NoSidecarWarning
from baselines.policy_params import SB3Params
from baselines.zoo import ZOO_HYPERPARAMS_DIR, NormalisedActions
from uav_penetration_env import ENV_IDS
from uav_penetration_env.benchmark.evaluate import evaluate, policy_hash
from uav_penetration_env.benchmark.policy_names import parse_policy
from uav_penetration_env.env import UAVPenetrationEnv

pytestmark = pytest.mark.usefixtures("baselines_plugins")


@pytest.fixture(autouse=True)
def _gymnasium_time_limit_restored():
    """Put gymnasium's own TimeLimit back after each test: importing rl_zoo3 replaces it process-wide.

    ``rl_zoo3.gym_patches`` assigns its ``PatchedTimeLimit`` (a step that reports no truncation when
    the episode also terminates) to ``gymnasium.wrappers``, ``gymnasium.wrappers.common`` and
    ``gymnasium.envs.registration``; left in place, every later ``gym.make`` in the test process
    would wrap with it and the vector-env equality tests would compare two different wrappers.
    """
    import gymnasium.envs.registration as registration
    import gymnasium.wrappers as wrappers
    import gymnasium.wrappers.common as common

    missing = object()
    saved = [(module, getattr(module, "TimeLimit", missing)) for module in (wrappers, common, registration)]
    yield
    for module, original in saved:
        if original is missing:
            module.__dict__.pop("TimeLimit", None)  # the zoo added it (gymnasium.envs.registration has none)
        else:
            module.TimeLimit = original


@pytest.fixture(autouse=True)
def _models_made_here_are_trusted(monkeypatch):
    """The models these tests score are the ones they trained: opt in to loading them (docs/rl.md §5.2)."""
    from baselines.foreign import TRUST_VARIABLE

    monkeypatch.setenv(TRUST_VARIABLE, "1")


REPO = Path(__file__).resolve().parents[2]


def zoo_reading(algo: str, env_id: str, log_folder: Path):
    """What rl_zoo3 makes of the shipped file for ``env_id``: its own reading code, no training."""
    exp_manager = pytest.importorskip("rl_zoo3.exp_manager", reason="rl_zoo3 (the zoo extra)")
    manager = exp_manager.ExperimentManager(
        argparse.Namespace(),
        algo,
        env_id,
        str(log_folder),
        config=str(ZOO_HYPERPARAMS_DIR / f"{algo}.yml"),
        verbose=0,
    )
    hyperparams, saved = manager.read_hyperparameters()
    processed, env_wrapper, _, vec_env_wrapper = manager._preprocess_hyperparams(hyperparams)
    # The exploration noise is built from the training env's action space, here the wrapped box.
    box = SimpleNamespace(action_space=gym.spaces.Box(-1.0, 1.0, (3,), np.float32))
    processed = manager._preprocess_action_noise(processed, saved, box)
    return manager, processed, env_wrapper, vec_env_wrapper


def same_value(got, expected) -> bool:
    """A zoo value equals the project's: schedules by their value, noise objects by their mean and std."""
    if isinstance(expected, ActionNoise):
        return type(got) is type(expected) and all(
            np.array_equal(getattr(got, name), getattr(expected, name)) for name in ("_mu", "_sigma")
        )
    if callable(got) and not isinstance(expected, type) and not callable(expected):
        return got(1.0) == expected and got(0.0) == expected  # a constant schedule of the progress
    return got == expected


@pytest.mark.parametrize("algo", ["ppo", "sac", "td3"])
def test_the_zoo_reads_the_shipped_file_as_the_projects_hyperparameters(algo, tmp_path):
    params, _ = resolve_hyperparams(algo)
    expected = algorithm_kwargs(params, action_dim=3)
    defaults = TrainConfig.of(algo=algo)
    for env_id in ENV_IDS:
        manager, processed, env_wrapper, vec_env_wrapper = zoo_reading(algo, env_id, tmp_path)
        assert processed.pop("policy") == params["policy"]
        assert set(processed) == set(expected), env_id
        for key, value in expected.items():
            # The zoo turns constant learning rates and clip ranges into schedules of the progress.
            assert same_value(processed[key], value), (env_id, key, processed[key], value)
        # VecNormalize: the project's keywords; the zoo adds gamma, which only reward normalisation reads.
        assert manager.normalize is True
        zoo_normalize = dict(manager.normalize_kwargs)
        assert zoo_normalize.pop("gamma") == params["gamma"] and not zoo_normalize["norm_reward"]
        assert zoo_normalize == normalize_kwargs(params)
        assert (manager.n_envs, manager.n_timesteps) == (defaults.n_envs, defaults.total_timesteps)
        assert vec_env_wrapper is None
        wrapped = env_wrapper(UAVPenetrationEnv(scenario=tiny_scenario()))
        assert isinstance(wrapped, NormalisedActions)


def test_normalised_actions_map_as_the_training_adapter(tiny):
    from baselines.vec_env import UAVPenetrationSB3VecEnv

    env = NormalisedActions(UAVPenetrationEnv(scenario=tiny))
    adapter = UAVPenetrationSB3VecEnv(num_envs=1, scenario=tiny)
    assert env.action_space == adapter.action_space == gym.spaces.Box(-1.0, 1.0, (3,), np.float32)
    # Inside, on and outside [-1, 1]: the wrapper clips and rescales exactly as the adapter does.
    actions = np.random.default_rng(0).uniform(-1.5, 1.5, size=(50, 3)).astype(np.float32)
    actions[:3] = [[-1, -1, -1], [1, 1, 1], [0, 0, 0]]
    for action in actions:
        np.testing.assert_array_equal(env.action(action), adapter.to_physical(action[None])[0])
    high = env.unwrapped.action_space.high
    np.testing.assert_array_equal(env.action(np.ones(3)), high)
    np.testing.assert_array_equal(env.action(np.full(3, 7.0)), high)
    adapter.close()
    with pytest.raises(TypeError, match="NormalisedActions: expected a Box action space"):
        NormalisedActions(gym.make("CartPole-v1"))


# --- models without a sidecar ---------------------------------------------------------------------


def save_foreign_ppo(
    folder: Path, env_id: str = "UAVPenetration-v0", wrap: bool = True, steps: int = 64
) -> Path:
    """A PPO model saved by SB3 itself in rl_zoo3's layout: ``ENV_1/ENV.zip`` and ``ENV_1/ENV/vecnormalize.pkl``."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    def make() -> gym.Env:
        env = UAVPenetrationEnv(scenario=tiny_scenario())
        return NormalisedActions(env) if wrap else env

    venv = VecNormalize(DummyVecEnv([make]), norm_obs=True, norm_reward=False, clip_obs=10.0)
    model = PPO("MlpPolicy", venv, n_steps=32, batch_size=32, n_epochs=1, seed=0, device="cpu")
    if steps:
        model.learn(steps)
    run = folder / f"{env_id}_1"
    (run / env_id).mkdir(parents=True)
    model.save(run / f"{env_id}.zip")
    venv.save(run / env_id / "vecnormalize.pkl")
    venv.close()
    return run / f"{env_id}.zip"


@pytest.fixture(scope="module")
def foreign_ppo(tmp_path_factory) -> Path:
    return save_foreign_ppo(tmp_path_factory.mktemp("zoo"))


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_model_without_a_sidecar_is_scored_with_a_warning(foreign_ppo):
    statistics = foreign_ppo.parent / "UAVPenetration-v0" / "vecnormalize.pkl"
    with pytest.warns(
        NoSidecarWarning, match=r"no sidecar UAVPenetration-v0\.json; scored as a ppo model"
    ) as caught:
        policy = load_policy(foreign_ppo)
    (message,) = [str(w.message) for w in caught if w.category is NoSidecarWarning]
    assert "\n" not in message and "rl_zoo3 run on UAVPenetration-v0" in message
    assert str(statistics) in message and "physics profile" in message and "end of training" not in message
    assert policy.algorithm == "ppo" and policy.files.vecnormalize == statistics
    # The store key: the hashes of the two files, the same for every load.
    config = policy.config()
    assert (config["model_sha256"], config["vecnormalize_sha256"]) == (
        sha256(foreign_ppo),
        sha256(statistics),
    )
    assert config["sidecar_sha256"] is None
    with pytest.warns(NoSidecarWarning):
        assert policy_hash(load_policy(foreign_ppo)) == policy_hash(policy)
    assert policy.metadata == {"train_timesteps": 64}  # PPO's two rollouts of 32 steps
    df = evaluate({"zoo": policy}, [tiny_scenario()], seeds=range(2), progress=False)
    assert df["error"].tolist() == ["", ""]
    assert (df["train_timesteps"] == 64).all()


def test_the_statistics_option_names_the_file_or_none(foreign_ppo, tmp_path):
    statistics = foreign_ppo.parent / "UAVPenetration-v0" / "vecnormalize.pkl"
    # best_model.zip (the zoo's best evaluation) finds the statistics of its run folder too.
    best = foreign_ppo.with_name("best_model.zip")
    best.write_bytes(foreign_ppo.read_bytes())
    with pytest.warns(NoSidecarWarning, match=r"rl_zoo3 run on UAVPenetration-v0 .* \(the zoo's statistics at the end of training, those of UAVPenetration-v0\.zip\)"):  # fmt: skip
        assert load_policy(best).files.vecnormalize == statistics
    elsewhere = tmp_path / "agent.zip"
    elsewhere.write_bytes(foreign_ppo.read_bytes())
    with pytest.raises(FileNotFoundError, match=r"agent\.zip: no sidecar agent\.json and no observation statistics at .*agent\.vecnormalize\.pkl; give them as sb3:.*\?vecnormalize=PATH\.pkl"):  # fmt: skip
        load_policy(elsewhere)
    with pytest.warns(NoSidecarWarning, match="an unknown env with observation statistics"):
        named = load_policy(elsewhere, vecnormalize=str(statistics))
    with pytest.warns(NoSidecarWarning, match="an unknown env with raw observations"):
        raw = load_policy(elsewhere, vecnormalize="none")
    assert named.config()["vecnormalize_sha256"] == sha256(statistics)
    assert raw.config()["vecnormalize_sha256"] is None and policy_hash(raw) != policy_hash(named)
    # The published form sb3:PATH?vecnormalize=VALUE is the name sb3[model=PATH,vecnormalize=VALUE].
    published = parse_policy(f"sb3:{elsewhere}?vecnormalize=none")
    assert published == parse_policy(f"sb3[model={elsewhere},vecnormalize=none]")
    assert published.params == SB3Params(str(elsewhere), "none") and published.label == "sb3:agent"
    with pytest.raises(ValueError, match=r"agent\.zip: the option after '\?' must be vecnormalize=PATH\.pkl or vecnormalize=none, got 'stats=x'"):  # fmt: skip
        parse_policy(f"sb3:{elsewhere}?stats=x")
    with pytest.raises(FileNotFoundError, match=r"nope\.pkl: no such observation statistics file"):
        load_policy(elsewhere, vecnormalize=str(tmp_path / "nope.pkl"))
    (tmp_path / "agent.json").write_text("{}")  # a sidecar names its own statistics
    with pytest.raises(
        ValueError, match=r"agent\.zip: vecnormalize= is for models without a sidecar; .*agent\.json names"
    ):
        load_policy(elsewhere, vecnormalize="none")


def test_a_model_of_other_spaces_is_refused_in_one_line(tmp_path):
    from stable_baselines3 import PPO

    physical = save_foreign_ppo(tmp_path / "physical", wrap=False, steps=0)
    with pytest.raises(
        ValueError, match=r"does not fit this env: it was trained with action space Box\(\[-"
    ) as error:
        load_policy(physical, vecnormalize="none")
    assert "\n" not in str(error.value) and "observation space" not in str(error.value)
    other = tmp_path / "pendulum.zip"
    PPO("MlpPolicy", gym.make("Pendulum-v1"), n_steps=32, batch_size=32, device="cpu").save(other)
    with pytest.raises(ValueError, match=r"observation space Box\(.*\(3,\), float32\) \(the env's is Box\(-10\.0, 10\.0, \(67,\), float32\)\); action space") as error:  # fmt: skip
        load_policy(other, vecnormalize="none")
    assert "\n" not in str(error.value)
    not_a_model = tmp_path / "junk.zip"
    not_a_model.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match=r"junk\.zip: not a Stable-Baselines3 model"):
        load_policy(not_a_model, vecnormalize="none")


@pytest.mark.slow
def test_rl_zoo3_trains_on_the_shipped_file_and_uav_bench_scores_the_model(tmp_path):
    """``python -m rl_zoo3.train`` with the shipped file, then ``uav-bench run --policies sb3:...``."""
    pytest.importorskip("rl_zoo3", reason="rl_zoo3 (the zoo extra)")
    from uav_penetration_env.benchmark import cli
    from uav_penetration_env.benchmark.store import ResultsStore

    scenario = tiny_scenario().to_yaml(tmp_path / "tiny.yaml")
    command = [
        sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", "UAVPenetration-v0",
        "--gym-packages", "uav_penetration_env", "--conf-file", str(ZOO_HYPERPARAMS_DIR / "ppo.yml"),
        "-n", "256", "--seed", "0", "-f", str(tmp_path / "logs"), "--eval-freq", "128", "--eval-episodes", "2",
        "--num-threads", "1",
        "--hyperparams", "n_envs:2", "n_steps:64", "batch_size:64", "n_epochs:2",
        "--env-kwargs", f"scenario:{str(scenario)!r}",
    ]  # fmt: skip
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run(command, cwd=tmp_path, env=environment, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    run = tmp_path / "logs" / "ppo" / "UAVPenetration-v0_1"
    model = run / "UAVPenetration-v0.zip"
    assert model.is_file() and (run / "UAVPenetration-v0" / "vecnormalize.pkl").is_file()
    assert "Eval num_timesteps=256" in done.stdout  # the zoo evaluated on the same wrapped env
    store = tmp_path / "zoo.sqlite"
    argv = ["run", "--policies", f"sb3:{model}", "greedy", "--scenarios", str(scenario), "--seeds", "2",
            "--store", str(store), "--no-report", "--no-progress", "--jobs", "1"]  # fmt: skip
    with pytest.warns(NoSidecarWarning, match="rl_zoo3 run on UAVPenetration-v0"):
        assert cli.main(argv) == 0
    with ResultsStore(store) as results:
        rows = results.episodes()
    agent = rows[rows["policy"] == "sb3:UAVPenetration-v0"]
    assert len(agent) == 2 and (agent["error"] == "").all()
    assert (agent["train_timesteps"] == 256).all()


@pytest.mark.parametrize("name", ["PPO", "A2C", "SAC", "TD3", "DDPG"])
def test_the_algorithm_is_read_from_the_zip(name, tmp_path):
    import stable_baselines3

    from baselines.foreign import read_model_header

    cls = getattr(stable_baselines3, name)
    off_policy = {"buffer_size": 100, "learning_starts": 10} if name in ("SAC", "TD3", "DDPG") else {}
    env = NormalisedActions(UAVPenetrationEnv(scenario=tiny_scenario()))
    cls("MlpPolicy", env, device="cpu", **off_policy).save(tmp_path / "model.zip")
    header = read_model_header(tmp_path / "model.zip")
    assert header.algorithm == name.lower() and header.num_timesteps == 0
    assert header.action_space == env.action_space and header.observation_space == env.observation_space
