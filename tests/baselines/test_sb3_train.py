"""train_agent and `uav-bench train`: files, sidecar, determinism, clear errors."""

from __future__ import annotations

import csv
import json

import pytest
from conftest import RL_EXTRA, tiny_scenario

pytest.importorskip("stable_baselines3", reason=RL_EXTRA)

from sb3_helpers import TINY_PPO, baselines_plugins, tiny_run, trained_tiny_ppo  # noqa: F401 (a fixture)

from baselines import load_policy, train_agent
from baselines.hyperparameters import algorithm_kwargs, resolve_hyperparams
from baselines.run import EVALUATION_COLUMNS
from uav_penetration_env.benchmark.cli import main
from uav_penetration_env.benchmark.evaluate import evaluate

# Discovery of the sb3 kind and the train command answers from baselines.plugin (sb3_helpers).
pytestmark = pytest.mark.usefixtures("baselines_plugins")


@pytest.fixture(scope="session")
def tiny_ppo(tmp_path_factory):
    return trained_tiny_ppo(tmp_path_factory.mktemp("sb3"))


def test_training_writes_model_and_sidecars(tiny_ppo):
    files = tiny_ppo.files
    for path in (files.model, files.sidecar, files.vecnormalize, files.evaluations):
        assert path.is_file(), path
    assert (
        files.sidecar.name == "ppo-tiny-s0.json" and files.vecnormalize.name == "ppo-tiny-s0.vecnormalize.pkl"
    )
    checkpoints = sorted(p.name for p in files.checkpoints.iterdir())
    assert "ppo-tiny-s0-128steps.zip" in checkpoints and "ppo-tiny-s0-128steps.json" in checkpoints

    sidecar = json.loads(files.sidecar.read_text())
    assert sidecar == tiny_ppo.sidecar
    assert sidecar["algorithm"] == "ppo" and sidecar["env_id"] == "UAVPenetration-v0"
    assert sidecar["profile"] == "benchmark" and sidecar["env_kwargs"]["profile"] == "benchmark"
    assert sidecar["scenario"] == {"name": "tiny", "hash": tiny_scenario().hash}
    assert sidecar["env_kwargs"]["scenario"]["name"] == "tiny"  # the full scenario, to rebuild the env
    assert sidecar["observation_space"]["shape"] == [67]
    assert sidecar["action_space"]["shape"] == [3]
    assert sidecar["action_space"]["high"] == pytest.approx([2.0, 0.2617994, 0.2617994])
    assert sidecar["hyperparameters"]["n_steps"] == TINY_PPO["n_steps"]
    assert "rl-baselines3-zoo" in sidecar["hyperparameters"]["provenance"]
    assert sidecar["hyperparameters"]["normalize"]["norm_obs"] is True
    assert sidecar["vecnormalize"] == files.vecnormalize.name
    assert sidecar["total_timesteps"] == 256 and sidecar["timesteps_done"] == 256
    assert sidecar["seed"] == 0 and sidecar["n_envs"] == 2 and len(set(sidecar["train_env_seeds"])) == 2
    assert sidecar["wall_seconds"] > 0 and sidecar["torch_threads"] == 1
    assert sidecar["versions"]["stable-baselines3"] != "not installed" and sidecar["commit"]
    assert sidecar["interrupted"] is False

    with files.evaluations.open() as handle:
        rows = list(csv.DictReader(handle))
    assert tuple(rows[0]) == EVALUATION_COLUMNS
    assert [int(r["timesteps"]) for r in rows] == [128, 256]
    for row in rows:
        assert float(row["mean_cost"]) == pytest.approx(-float(row["mean_return"]))
        assert float(row["mean_cost"]) == pytest.approx(float(row["mean_J"]) + float(row["mean_penalty"]))
    assert sidecar["final_evaluation"]["mean_return"] == pytest.approx(float(rows[-1]["mean_return"]))


def test_final_evaluation_is_the_saved_model(tiny_ppo):
    # The harness flies the saved model; its score on the evaluation seed equals the training's.
    from uav_penetration_env.env import UAVPenetrationEnv

    policy = load_policy(tiny_ppo.files.model)
    env = UAVPenetrationEnv(tiny_scenario())
    observation, info = env.reset(seed=tiny_ppo.sidecar["eval_seeds"][0])
    policy.reset(env.model, None)
    total, done = 0.0, False
    while not done:
        observation, reward, terminated, truncated, info = env.step(policy.act(observation, info))
        total += reward
        done = terminated or truncated
    assert total == pytest.approx(tiny_ppo.evaluations[-1]["mean_return"], rel=1e-6)


def test_same_seed_gives_the_same_first_evaluation(tiny_ppo, tmp_path, monkeypatch):
    # SB3 puts its default log folder (an empty one per learn() call) here; training must not.
    monkeypatch.setenv("SB3_LOGDIR", str(tmp_path / "sb3-log"))
    # The scenario as a mapping this time (the fixture passed a Scenario): the same env either way.
    again = train_agent(
        "ppo",
        out=tmp_path / "again.zip",
        **tiny_run(total_timesteps=128, checkpoint_freq=0, scenario=tiny_scenario().to_dict()),
    )
    assert again.sidecar["scenario"] == tiny_ppo.sidecar["scenario"]
    assert not (tmp_path / "sb3-log").exists()
    first, repeat = tiny_ppo.evaluations[0], again.evaluations[0]
    assert repeat["timesteps"] == first["timesteps"] == 128
    for key in EVALUATION_COLUMNS:
        if key != "wall_seconds":
            assert repeat[key] == first[key], key


def test_interrupted_training_saves_the_model(tmp_path, monkeypatch):
    import baselines.run

    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt  # as Ctrl-C during the first evaluation would

    monkeypatch.setattr(baselines.run, "evaluate_agent", interrupt)
    tiny_scenario().to_yaml(tmp_path / "tiny.yaml")
    with pytest.raises(KeyboardInterrupt):
        train_agent("ppo", out=tmp_path / "cut.zip", **tiny_run(scenario=str(tmp_path / "tiny.yaml")))
    sidecar = json.loads((tmp_path / "cut.json").read_text())
    assert sidecar["interrupted"] is True and sidecar["timesteps_done"] == 128
    assert load_policy(tmp_path / "cut.zip").metadata["train_timesteps"] == 128


def test_unknown_algorithm_lists_the_known_ones(tmp_path):
    with pytest.raises(
        ValueError, match=r"unknown algorithm 'ppp' — did you mean 'ppo'.*known: a2c, ddpg, ppo, sac, td3"
    ):
        train_agent("ppp", out=tmp_path / "x.zip", **tiny_run())
    assert not list(tmp_path.iterdir())  # nothing written


def test_bad_inputs_fail_before_training(tmp_path):
    out = tmp_path / "x.zip"
    with pytest.raises(ValueError, match="unknown key 'n_step' for PPO — did you mean 'n_steps'"):
        train_agent("ppo", out=out, **tiny_run(hyperparams={"n_step": 64}))
    with pytest.raises(ValueError, match="'seed' is set by train_agent"):
        train_agent("ppo", out=out, **tiny_run(hyperparams={"seed": 3}))
    with pytest.raises(ValueError, match="draws procedural scenarios"):
        train_agent("ppo", env_id="UAVPenetrationRandom-v0", out=out, **tiny_run())
    with pytest.raises(ValueError, match="only UAVPenetrationRandom-v0 takes a difficulty"):
        train_agent("ppo", out=out, difficulty=0.3, **tiny_run())
    with pytest.raises(ValueError, match="unknown id 'UAVPenetraton-v0' — did you mean 'UAVPenetration-v0'"):
        train_agent("ppo", env_id="UAVPenetraton-v0", out=out, **tiny_run())
    with pytest.raises(ValueError, match="n_envs: got 0"):
        train_agent("ppo", out=out, **tiny_run(n_envs=0))
    with pytest.raises(ValueError, match=r"radars\[0\]"):  # ScenarioError names the field
        train_agent(
            "ppo", out=out, **tiny_run(scenario={**tiny_scenario().to_dict(), "radars": [{"x_km": 1}]})
        )


@pytest.mark.parametrize("algo", ["ppo", "sac", "td3"])
def test_tuned_files_have_provenance_and_build(algo):
    params, source = resolve_hyperparams(algo)
    assert source == f"baselines/hyperparams/{algo}.yaml"
    assert len(params["provenance"]) > 200 and "Adapted" in params["provenance"]
    assert params["normalize"] == {"norm_obs": True, "norm_reward": False, "clip_obs": 10.0}
    assert params["policy_kwargs"]["net_arch"]
    kwargs = algorithm_kwargs(params, action_dim=3)
    assert "provenance" not in kwargs and "normalize" not in kwargs
    if algo == "td3":
        assert type(kwargs["action_noise"]).__name__ == "NormalActionNoise"


def test_untuned_algorithm_uses_sb3_defaults_with_a_warning():
    with pytest.warns(UserWarning, match="no tuned hyper-parameters for 'a2c'"):
        params, source = resolve_hyperparams("A2C", {"n_steps": 8})
    assert params["n_steps"] == 8 and "A2C defaults" in source


def test_cli_train(tmp_path, capsys):
    tiny_scenario().to_yaml(tmp_path / "tiny.yaml")
    (tmp_path / "hp.yaml").write_text("n_steps: 64\nbatch_size: 64\nn_epochs: 2\n")
    out = tmp_path / "models" / "cli.zip"
    argv = ["train", "--scenario", str(tmp_path / "tiny.yaml"), "--timesteps", "128", "--n-envs", "2",
            "--out", str(out), "--eval-freq", "128", "--eval-episodes", "2", "--checkpoint-freq", "0",
            "--hyperparams", str(tmp_path / "hp.yaml"), "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert f"model: {out}" in printed and "final evaluation (2 episodes, 128 steps)" in printed
    assert out.is_file() and out.with_suffix(".json").is_file()
    df = evaluate({"cli": load_policy(out)}, [tiny_scenario()], seeds=[0], progress=False)
    assert df["error"].tolist() == [""]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--algo", "ppp"], "unknown algorithm 'ppp' — did you mean 'ppo'"),
        (["--scenario", "papr"], "--scenario: unknown scenario 'papr' — did you mean 'paper'"),
        (["--scenario", "random:1-3"], "expected one scenario"),
        (["--difficulty", "0.3"], "--difficulty: applies to --env-id UAVPenetrationRandom-v0"),
        (["--hyperparams", "no-such-file.yaml"], "cannot read no-such-file.yaml"),
    ],
)
def test_cli_train_errors_exit_2(argv, message, capsys):
    assert main(["train", *argv, "--no-progress"]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.parametrize("algo", ["ppo", "sac", "td3"])
def test_each_tuned_algorithm_trains_and_is_scored(algo, tmp_path):
    short = {"ppo": {"n_steps": 128}, "sac": {"learning_starts": 500}, "td3": {"learning_starts": 500}}[algo]
    result = train_agent(
        algo, out=tmp_path / f"{algo}.zip",
        **tiny_run(total_timesteps=3000, n_envs=4, hyperparams=short, eval_freq=1000, checkpoint_freq=0),
    )  # fmt: skip
    assert result.sidecar["timesteps_done"] >= 3000 and len(result.evaluations) >= 3
    df = evaluate({algo: load_policy(result.files.model)}, [tiny_scenario()], seeds=range(3), progress=False)
    assert df["error"].tolist() == ["", "", ""]
    assert (df["train_timesteps"] == result.sidecar["timesteps_done"]).all()


@pytest.mark.slow
def test_random_id_training_describes_its_scenarios(tmp_path):
    result = train_agent(
        "ppo", env_id="UAVPenetrationRandom-v0", out=tmp_path / "random.zip", total_timesteps=256,
        n_envs=2, difficulty=0.2, env_kwargs={"pool_size": 2}, hyperparams=TINY_PPO,
        eval_freq=256, eval_episodes=2, checkpoint_freq=0,
    )  # fmt: skip
    scenario = result.sidecar["scenario"]
    assert scenario["difficulty"] == 0.2 and scenario["pool_size"] == 2 and scenario["pool_seed"] is not None
    assert "procedural scenarios" in scenario["description"]
    assert result.sidecar["env_kwargs"] == {"difficulty": 0.2, "pool_size": 2}
