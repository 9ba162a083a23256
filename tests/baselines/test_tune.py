"""`uav-bench tune`: Optuna studies that resume, prune, and write hyper-parameters train can load."""

from __future__ import annotations

import csv

import pytest
import yaml
from conftest import RL_EXTRA

pytest.importorskip("stable_baselines3", reason=RL_EXTRA)
pytest.importorskip("optuna", reason=RL_EXTRA)

import optuna
from sb3_helpers import baselines_plugins  # noqa: F401 (a fixture)

import baselines.run
from baselines.hyperparameters import resolve_hyperparams
from baselines.tune import (
    SAMPLERS,
    StudyBusy,
    TuneConfig,
    open_study,
    prepare_tuning,
    run_study,
    study_lock,
)
from uav_penetration_env.benchmark.cli import main

# Rollouts of 64 steps x 2 envs, one epoch: a trial of 256 steps is a second or two on the paper scenario.
TINY_FIXED = {
    "n_steps": 64,
    "batch_size": 64,
    "n_epochs": 1,
    "policy_kwargs": {"net_arch": {"pi": [16], "vf": [16]}},
}


def tiny(tmp_path, **changes):
    settings = {
        "algo": "ppo", "regime": "paper", "trials": 2, "timesteps": 256, "eval_every": 128, "n_envs": 2,
        "out": tmp_path / "study", "fixed": TINY_FIXED, "progress": False,
    }  # fmt: skip
    return TuneConfig(**{**settings, **changes})


def states(result_or_plan):
    plan = result_or_plan
    study = optuna.load_study(study_name=plan.study_name, storage=plan.files.storage)
    return [t.state.name for t in study.get_trials()], study


@pytest.fixture(scope="module")
def two_trials(tmp_path_factory):
    """A study of two finished trials (shared by the read-only tests)."""
    config = tiny(tmp_path_factory.mktemp("tune"))
    return config, run_study(config)


def test_a_study_writes_the_best_yaml_and_the_summaries(two_trials):
    _, result = two_trials
    files = result.files
    assert (result.complete, result.pruned, result.failed) == (2, 0, 0)
    assert files.database.is_file() and files.best_yaml.is_file()
    text = files.best_yaml.read_text()
    data = yaml.safe_load(text)
    provenance = data["provenance"]
    assert provenance["study"] == "ppo-paper" and provenance["storage"] == files.storage
    assert provenance["trials_complete"] == 2 and provenance["trials_pruned"] == 0
    assert provenance["budget_steps_per_trial"] == 256 and provenance["best_trial"] == result.best_trial
    assert provenance["best_value"] == pytest.approx(result.best_value)
    assert provenance["versions"]["optuna"] == optuna.__version__ and provenance["date"]
    assert provenance["fixed"]["n_steps"] == 64
    # The file holds the trial's effective hyper-parameters: sampled keys, fixed keys, the untuned rest.
    assert data["n_steps"] == 64 and data["policy_kwargs"]["net_arch"] == {"pi": [16], "vf": [16]}
    assert data["vf_coef"] == 0.5  # not in the search space: from baselines/hyperparams/ppo.yaml
    assert 0.97 <= data["gamma"] <= 0.9999 and data["clip_range"] in (0.1, 0.2, 0.3, 0.4)
    assert {k: v for k, v in data.items() if k != "provenance"} == result.best_hyperparams

    with files.trials_csv.open() as handle:
        rows = list(csv.DictReader(handle))
    assert [r["number"] for r in rows] == ["0", "1"] and {r["state"] for r in rows} == {"COMPLETE"}
    assert min(float(r["value"]) for r in rows) == pytest.approx(result.best_value)
    assert all(float(r["duration_s"]) > 0 and r["last_step"] == "256" for r in rows)
    assert "param_learning_rate" in rows[0] and "param_one_minus_gamma" in rows[0]
    summary = files.summary_md.read_text()
    assert "2 complete, 0 pruned" in summary and f"best: trial {result.best_trial}" in summary
    assert summary.count("| COMPLETE |") == 2


def test_the_best_yaml_loads_in_train(two_trials, tmp_path, capsys, baselines_plugins):  # noqa: F811
    _, result = two_trials
    params, source = resolve_hyperparams("ppo", result.files.best_yaml)
    assert source.endswith(str(result.files.best_yaml))
    assert {k: v for k, v in params.items() if k != "provenance"} == result.best_hyperparams
    out = tmp_path / "tuned.zip"
    argv = ["train", "--hyperparams", str(result.files.best_yaml), "--timesteps", "128", "--n-envs", "2",
            "--eval-freq", "0", "--checkpoint-freq", "0", "--out", str(out), "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    assert out.is_file()


def test_a_rerun_continues_to_the_number_of_trials_asked(two_trials):
    config, _ = two_trials
    again = run_study(config)  # already 2: nothing runs
    assert again.complete == 2
    more = run_study(TuneConfig(**{**config.__dict__, "trials": 3}))
    names, _ = states(prepare_tuning(config))
    assert names == ["COMPLETE"] * 3 and more.complete == 3


def test_each_trial_is_collected_before_the_next_starts(tmp_path, monkeypatch):
    """A trial's model, envs and replay buffer are cycles the collector must free between trials."""
    import gc
    import weakref

    from stable_baselines3 import PPO

    import baselines.tuning.study

    gc.collect()
    # Models that earlier tests keep alive (module fixtures) are not this study's: count only new ones.
    earlier = weakref.WeakSet(o for o in gc.get_objects() if type(o) is PPO)
    alive_at_collection, original = [], gc.collect

    def collect(*args):
        result = original(*args)
        alive_at_collection.append(sum(1 for o in gc.get_objects() if type(o) is PPO and o not in earlier))
        return result

    monkeypatch.setattr(baselines.tuning.study.gc, "collect", collect)
    run_study(tiny(tmp_path, trials=2))
    assert alive_at_collection == [0, 0]  # one collection per trial, after which no trial model survives


def test_an_interrupted_trial_is_failed_and_its_parameters_run_again(tmp_path, monkeypatch):
    config = tiny(tmp_path, trials=2)
    run_study(tiny(tmp_path, trials=1))
    calls = []
    real = baselines.run.evaluate_agent

    def interrupt(*args, **kwargs):
        calls.append(1)
        raise KeyboardInterrupt  # Ctrl-C during the second trial's first evaluation

    monkeypatch.setattr(baselines.run, "evaluate_agent", interrupt)
    with pytest.raises(KeyboardInterrupt):
        run_study(config)
    plan = prepare_tuning(config)
    names, study = states(plan)
    assert names == ["COMPLETE", "FAIL"] and calls == [1]
    cut = study.trials[1]
    assert cut.user_attrs["interrupted"] is True
    # The files were rewritten on the way out and the lock released.
    assert "1 failed/interrupted" in plan.files.summary_md.read_text()

    monkeypatch.setattr(baselines.run, "evaluate_agent", real)
    result = run_study(config)
    names, study = states(plan)
    assert names == ["COMPLETE", "FAIL", "COMPLETE"] and result.complete == 2 and result.failed == 1
    retry = study.trials[2]
    assert retry.user_attrs["retry_of"] == 1 and retry.params == cut.params


def test_a_trial_left_running_by_a_killed_process_is_failed_on_resume(tmp_path):
    config = tiny(tmp_path, trials=1)
    plan = prepare_tuning(config)
    study = open_study(plan)
    study.ask()  # a trial that started and was never told: what kill -9 leaves behind
    result = run_study(config)
    names, _ = states(plan)
    assert names == ["FAIL", "COMPLETE"] and result.complete == 1


def test_a_trial_worse_than_the_median_is_pruned(tmp_path):
    # Five finished trials that scored 0 (a cost no agent reaches: every step costs J > 0) at step 128:
    # the new trial's first report, also at step 128, is above their median, so it is pruned there.
    config = tiny(tmp_path, trials=6, timesteps=512, pruner_warmup_steps=0, startup_trials=10)
    plan = prepare_tuning(config)
    study = open_study(plan)
    for _ in range(5):
        study.add_trial(
            optuna.trial.create_trial(
                value=0.0, intermediate_values={128: 0.0}, state=optuna.trial.TrialState.COMPLETE
            )
        )
    result = run_study(config)
    names, study = states(plan)
    assert names == ["COMPLETE"] * 5 + ["PRUNED"] and result.pruned == 1
    pruned = study.trials[5]
    assert pruned.user_attrs["pruned_at"] == 128 and list(pruned.intermediate_values) == [128]
    assert pruned.intermediate_values[128] > 0
    # Without records of their hyper-parameters the synthetic trials are never the "best" trial.
    assert result.best_trial is None and not plan.files.best_yaml.exists()


def test_a_study_refuses_other_settings_and_a_second_process(tmp_path):
    config = tiny(tmp_path, trials=1)
    open_study(prepare_tuning(config))
    with pytest.raises(
        ValueError, match=r"timesteps: study 'ppo-paper' .* created with timesteps=256, got 512"
    ):
        run_study(tiny(tmp_path, trials=1, timesteps=512))
    plan = prepare_tuning(config)
    with study_lock(plan.files.lock), pytest.raises(StudyBusy, match="in use by another `uav-bench tune`"):
        run_study(config)


@pytest.mark.parametrize("algo", ["ppo", "sac", "td3"])
def test_every_sampled_point_is_a_valid_hyper_parameter_set(algo):
    # 30 random points of each space resolve and validate as train --hyperparams would read them.
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=1))
    for _ in range(30):
        trial = study.ask()
        overrides = SAMPLERS[algo](trial)
        params, _ = resolve_hyperparams(algo, overrides)
        if algo != "ppo":
            assert params["gradient_steps"] % params["train_freq"] == 0
            assert params["buffer_size"] == 300_000  # not tuned
        study.tell(trial, 0.0)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"algo": "ppp"}, "algo: got 'ppp' — did you mean 'ppo'"),
        ({"algo": "a2c"}, "expected one of ppo, sac, td3"),
        ({"regime": "paperr"}, "regime: got 'paperr' — did you mean 'paper'"),
        ({"trials": 0}, "trials: got 0, expected an integer >= 1"),
        ({"eval_episodes": 51}, "eval_episodes: got 51, expected at most 50"),
        ({"storage": "postgresql://x/y"}, "storage: got 'postgresql://x/y', expected sqlite:///PATH"),
        ({"fixed": {"n_step": 8}}, "unknown key 'n_step' for PPO — did you mean 'n_steps'"),
    ],
)
def test_bad_settings_fail_before_anything_runs(tmp_path, changes, message):
    with pytest.raises(ValueError, match=message):
        prepare_tuning(tiny(tmp_path, **changes))
    assert not (tmp_path / "study").exists()


def test_defaults_state_the_budget_and_the_validation_seeds(tmp_path):
    paper = prepare_tuning(TuneConfig(algo="ppo", out=tmp_path))
    assert paper.trials == 30 and paper.timesteps == 150_000 and paper.eval_seeds == (40000,)
    assert paper.eval_every == 30_000 and paper.pruner_warmup_steps == 50_000 and paper.startup_trials == 10
    random = prepare_tuning(TuneConfig(algo="sac", regime="random", out=tmp_path))
    assert random.trials == 15 and random.timesteps == 50_000
    assert random.eval_seeds == tuple(range(40000, 40050))
    assert random.env == {"env_id": "UAVPenetrationRandom-v0", "difficulty": 0.5}
    assert random.files.storage == f"sqlite:///{tmp_path}/study.sqlite"


def test_cli_tune_runs_and_is_resumable(tmp_path, capsys, baselines_plugins, monkeypatch):  # noqa: F811
    out = tmp_path / "cli"
    argv = ["tune", "--algo", "ppo", "--trials", "1", "--timesteps", "64", "--eval-every", "64",
            "--n-envs", "1", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "1 complete, 0 pruned" in printed and f"hyper-parameters: {out}/ppo-paper.yaml" in printed
    assert (out / "ppo-paper.yaml").is_file() and (out / "study.sqlite").is_file()

    import baselines.tune

    def interrupted(plan):
        raise KeyboardInterrupt

    monkeypatch.setattr(baselines.tune, "run_study", interrupted)
    assert main(argv) == 130
    assert "rerun the same command to continue" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--algo", "sca"], "--algo: got 'sca' — did you mean 'sac'"),
        (["--eval-episodes", "60", "--regime", "random"], "--eval-episodes: got 60, expected at most 50"),
        (["--storage", "sqlite:///"], "--storage: got 'sqlite:///', expected sqlite:///PATH"),
    ],
)
def test_cli_tune_errors_exit_2(argv, message, tmp_path, capsys, baselines_plugins):  # noqa: F811
    assert main(["tune", "--out", str(tmp_path / "x"), *argv]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_the_paper_start_is_fixed_so_one_evaluation_episode_suffices():
    # Two reset seeds, the same actions: the same observations and costs, step for step. A
    # deterministic policy therefore flies one episode whatever the evaluation seed (docs/rl.md §1.1).
    import gymnasium as gym
    import numpy as np

    import uav_penetration_env  # noqa: F401 (registers the ids)

    tracks = []
    for seed in (40000, 12345):
        env = gym.make("UAVPenetration-v0")
        observation, _ = env.reset(seed=seed)
        rows, actions = [observation], np.random.default_rng(0).uniform(-1, 1, size=(40, 3))
        for action in actions * env.action_space.high:
            observation, reward, terminated, truncated, _ = env.step(action.astype(np.float32))
            rows.append(np.append(observation, reward))
            if terminated or truncated:
                break
        tracks.append(rows)
    assert len(tracks[0]) == len(tracks[1]) > 1
    for first, second in zip(*tracks, strict=True):
        np.testing.assert_array_equal(first, second)


def test_random_id_training_seeds_lie_in_the_pool_range():
    from baselines.run import train_env_seeds

    plain, pool = train_env_seeds(3, 8), train_env_seeds(3, 8, pool=True)
    assert all(p == 2**32 + s for p, s in zip(pool, plain, strict=True))
    assert min(pool) >= 2**32  # never a held-out (10000-), suite (30000-) or validation (40000-) seed
