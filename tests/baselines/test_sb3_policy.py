"""load_policy: a trained model as a harness Policy, scored by the one evaluator; clear errors."""

from __future__ import annotations

import json
import pickle
import shutil

import numpy as np
import pytest
from conftest import RL_EXTRA, run_into_store, tiny_scenario

pytest.importorskip("stable_baselines3", reason=RL_EXTRA)

from sb3_helpers import baselines_plugins, trained_tiny_ppo  # noqa: F401 (a fixture)

from baselines import SB3Policy, load_policy
from baselines.artifacts import ModelFiles
from uav_penetration_env.benchmark.evaluate import evaluate, policy_hash
from uav_penetration_env.benchmark.policies import Policy, make_policy
from uav_penetration_env.env import UAVPenetrationEnv

# Discovery of the sb3 kind and the train command answers from baselines.plugin (sb3_helpers).
pytestmark = pytest.mark.usefixtures("baselines_plugins")


@pytest.fixture(scope="session")
def tiny_ppo(tmp_path_factory):
    return trained_tiny_ppo(tmp_path_factory.mktemp("sb3"))


def copy_model(files: ModelFiles, folder, name="copy"):
    """Copy a model's .zip, .json and .vecnormalize.pkl under a new name; returns the new files."""
    folder.mkdir(parents=True, exist_ok=True)
    new = ModelFiles.of(folder / f"{name}.zip")
    for source, target in (
        (files.model, new.model),
        (files.sidecar, new.sidecar),
        (files.vecnormalize, new.vecnormalize),
    ):
        shutil.copyfile(source, target)
    return new


def edit_sidecar(files: ModelFiles, **changes):
    data = json.loads(files.sidecar.read_text())
    for key, value in changes.items():
        data[key] = value
    files.sidecar.write_text(json.dumps(data))


def test_policy_is_scored_by_the_evaluator(tiny_ppo):
    policy = load_policy(tiny_ppo.files.model)
    assert isinstance(policy, SB3Policy) and isinstance(policy, Policy)
    df = evaluate({"ppo": policy}, [tiny_scenario()], seeds=range(2), progress=False)
    assert df["error"].tolist() == ["", ""]
    assert set(df["outcome"]) <= {"success", "collided", "out_of_area", "truncated"}
    assert (df["train_timesteps"] == 256).all()
    assert df["train_seconds"].tolist() == pytest.approx([tiny_ppo.sidecar["wall_seconds"]] * 2)


def test_sb3_name_runs_in_worker_processes(tiny_ppo):
    in_process = evaluate(
        {"ppo": load_policy(tiny_ppo.files.model)}, [tiny_scenario()], range(2), progress=False
    )
    workers = evaluate(
        {"ppo": make_policy(f"sb3:{tiny_ppo.files.model}")},
        [tiny_scenario()],
        range(2),
        n_jobs=2,
        progress=False,
    )
    assert workers["error"].tolist() == ["", ""]
    np.testing.assert_array_equal(
        workers.sort_values("seed")["total_J"], in_process.sort_values("seed")["total_J"]
    )


def test_policy_pickles_without_the_torch_model(tiny_ppo):
    policy = load_policy(tiny_ppo.files.model)
    env = UAVPenetrationEnv(tiny_scenario())
    observation, info = env.reset(seed=0)
    policy.reset(env.model, None)
    action = policy.act(observation, info)
    assert action.shape == (3,) and action.dtype == np.float64
    assert np.all(np.abs(action) <= env.action_space.high + 1e-7)
    data = pickle.dumps(policy)
    # No tensors (torch._utils rebuilds them) or modules: workers load the model themselves.
    assert b"torch._utils" not in data and b"torch.nn" not in data and len(data) < 50_000
    clone = pickle.loads(data)
    clone.reset(env.model, None)
    np.testing.assert_array_equal(clone.act(observation, info), action)


def test_config_keys_on_file_contents_not_paths(tiny_ppo, tmp_path):
    policy = load_policy(tiny_ppo.files.model)
    config = policy.config()
    assert config["kind"] == "sb3" and config["algorithm"] == "ppo"
    assert len(config["model_sha256"]) == 64 and config["vecnormalize_sha256"] and config["sidecar_sha256"]
    moved = load_policy(copy_model(tiny_ppo.files, tmp_path / "moved", "renamed").model)
    assert policy_hash(moved) == policy_hash(policy)  # a moved file keeps its store key
    checkpoint = load_policy(tiny_ppo.files.checkpoints / "ppo-tiny-s0-128steps.zip")
    assert policy_hash(checkpoint) != policy_hash(policy)  # other weights: a new key
    assert checkpoint.metadata["train_timesteps"] == 128 and checkpoint.metadata["train_seconds"] > 0


def test_missing_files_name_the_path(tiny_ppo, tmp_path):
    with pytest.raises(FileNotFoundError, match=r"nope\.zip: no such SB3 model file"):
        load_policy(tmp_path / "nope.zip")
    copied = copy_model(tiny_ppo.files, tmp_path)
    copied.sidecar.unlink()
    copied.vecnormalize.unlink()  # without a sidecar the statistics are looked for (test_zoo.py)
    with pytest.raises(
        FileNotFoundError, match=r"copy\.zip: no sidecar copy\.json and no observation statistics"
    ):
        load_policy(copied.model)
    copied = copy_model(tiny_ppo.files, tmp_path)
    copied.vecnormalize.unlink()
    with pytest.raises(FileNotFoundError, match=r"copy\.vecnormalize\.pkl: missing observation statistics"):
        load_policy(copied.model)


def test_corrupt_sidecar_names_the_path(tiny_ppo, tmp_path):
    copied = copy_model(tiny_ppo.files, tmp_path)
    copied.sidecar.write_text("{not json")
    with pytest.raises(ValueError, match=r"copy\.json: corrupt sidecar, expected JSON"):
        load_policy(copied.model)
    copied.sidecar.write_text(json.dumps({"format": 1, "algorithm": "ppo"}))
    with pytest.raises(ValueError, match=r"copy\.json: corrupt sidecar, missing key\(s\) env_id"):
        load_policy(copied.model)


@pytest.mark.parametrize(
    ("key", "value", "expected"),
    [("observation_space", None, "expected dict"), ("timesteps_done", "many", "expected int"),
     ("format", True, "expected int"), ("observation_space", {"shape": "67"}, "expected a list of integers")],
)  # fmt: skip
def test_a_sidecar_field_of_the_wrong_type_is_refused_naming_it(tiny_ppo, tmp_path, key, value, expected):
    copied = copy_model(tiny_ppo.files, tmp_path)
    sidecar = json.loads(copied.sidecar.read_text())
    sidecar[key] = value
    copied.sidecar.write_text(json.dumps(sidecar))
    with pytest.raises(ValueError, match=rf"copy\.json: corrupt sidecar, {key}(\.shape)?: got .*{expected}"):
        load_policy(copied.model)


def test_model_and_sidecar_must_belong_together(tiny_ppo, tmp_path):
    copied = copy_model(tiny_ppo.files, tmp_path)
    shutil.copyfile(tiny_ppo.files.checkpoints / "ppo-tiny-s0-128steps.zip", copied.model)
    with pytest.raises(ValueError, match=r"is not the model its sidecar .* describes"):
        load_policy(copied.model)


def test_other_observation_shape_is_refused(tiny_ppo, tmp_path):
    copied = copy_model(tiny_ppo.files, tmp_path)
    edit_sidecar(copied, observation_space={"shape": [60], "low": -10.0, "high": 10.0})
    with pytest.raises(
        ValueError,
        match=r"copy\.json: the model was trained on observations of shape \(60,\), this env's are \(67,\)",
    ):
        load_policy(copied.model)


def test_other_profile_or_action_box_is_refused(tiny_ppo):
    policy = load_policy(tiny_ppo.files.model)
    paper = UAVPenetrationEnv(tiny_scenario(), profile="paper").model
    with pytest.raises(
        ValueError, match="says profile 'benchmark' \\(the env's scenario 'tiny' uses 'paper'\\)"
    ):
        policy.reset(paper, None)
    faster = UAVPenetrationEnv(tiny_scenario(uav={"dv_max_m_s": 3})).model
    with pytest.raises(ValueError, match=r"action bounds high=\[2\.0, .*\(the env's are high=\[3\.0"):
        policy.reset(faster, None)
    df = evaluate({"ppo": policy}, [tiny_scenario(profile="paper")], seeds=[0], progress=False)
    assert "profile 'benchmark'" in df["error"][0]  # the evaluator records it as an error row


def test_another_scenario_is_allowed(tiny_ppo):
    # Generalisation: same airframe and profile, other map features.
    other = tiny_scenario(goal={"x_km": 24, "y_km": 26}, terrain={"seed": 11})
    df = evaluate({"ppo": load_policy(tiny_ppo.files.model)}, [other], seeds=[0], progress=False)
    assert df["error"].tolist() == [""]


def test_act_before_reset_is_an_error(tiny_ppo):
    with pytest.raises(RuntimeError, match="before reset"):
        load_policy(tiny_ppo.files.model).act(np.zeros(67, dtype=np.float32), {})


def test_cli_run_names_an_agent_by_its_file_stem(tiny_ppo, tmp_path):
    from uav_penetration_env.benchmark.store import ResultsStore

    scenario = tiny_scenario().to_yaml(tmp_path / "tiny.yaml")
    store = tmp_path / "rl.sqlite"
    spec = f"sb3:{tiny_ppo.files.model}"
    assert run_into_store(store, [spec, "greedy"], scenario, 2, "--jobs", 1) == 0
    with ResultsStore(store) as results:
        rows = results.episodes()
    assert set(rows["policy"]) == {f"sb3:{tiny_ppo.files.model.stem}", "greedy"}
    assert rows.loc[rows["policy"] != "greedy", "train_timesteps"].notna().all()


# --- every file an agent needs is verified by its SHA-256 ----------------------------------------


def test_the_sidecar_records_the_hash_of_every_file_the_agent_needs(tiny_ppo):
    from baselines.artifacts import hyperparameters_sha256, sha256_file

    sidecar, files = tiny_ppo.sidecar, tiny_ppo.files
    assert sidecar["model_sha256"] == sha256_file(files.model)
    assert sidecar["vecnormalize_sha256"] == sha256_file(files.vecnormalize)
    assert sidecar["hyperparameters_sha256"] == hyperparameters_sha256(sidecar["hyperparameters"])


def test_swapped_observation_statistics_are_refused_naming_the_file(tiny_ppo, tmp_path):
    copied = copy_model(tiny_ppo.files, tmp_path)
    other = tiny_ppo.files.checkpoints / "ppo-tiny-s0-128steps.vecnormalize.pkl"
    assert other.read_bytes() != copied.vecnormalize.read_bytes()  # another run's statistics
    shutil.copyfile(other, copied.vecnormalize)
    with pytest.raises(
        ValueError, match=r"copy\.vecnormalize\.pkl: not the observation statistics its sidecar"
    ):
        load_policy(copied.model)


def test_edited_hyperparameters_are_refused(tiny_ppo, tmp_path):
    copied = copy_model(tiny_ppo.files, tmp_path)
    hyperparameters = dict(tiny_ppo.sidecar["hyperparameters"], learning_rate=0.5)
    edit_sidecar(copied, hyperparameters=hyperparameters)
    with pytest.raises(ValueError, match=r"copy\.json: its hyperparameters are not those it was sealed with"):
        load_policy(copied.model)


def test_an_unsealed_sidecar_loads_with_a_warning_and_can_be_sealed(tiny_ppo, tmp_path, recwarn):
    import warnings

    from baselines.artifacts import UnverifiedArtifactWarning, seal_sidecar

    copied = copy_model(tiny_ppo.files, tmp_path)
    legacy = json.loads(copied.sidecar.read_text())
    del legacy["vecnormalize_sha256"], legacy["hyperparameters_sha256"]
    copied.sidecar.write_text(json.dumps(legacy))
    with pytest.warns(UnverifiedArtifactWarning, match=r"copy\.vecnormalize\.pkl, hyperparameters"):
        unsealed = load_policy(copied.model)
    assert unsealed.vecnormalize_sha256 == tiny_ppo.sidecar["vecnormalize_sha256"]
    sealed = seal_sidecar(copied.model)
    assert sealed["vecnormalize_sha256"] == tiny_ppo.sidecar["vecnormalize_sha256"]
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnverifiedArtifactWarning)
        load_policy(copied.model)  # sealed: verified, no warning
    shutil.copyfile(tiny_ppo.files.checkpoints / "ppo-tiny-s0-128steps.vecnormalize.pkl", copied.vecnormalize)
    with pytest.raises(ValueError, match="not the observation statistics"):
        load_policy(copied.model)
