"""Behaviour cloning + DAgger (baselines.distill): the fit, the labels, resuming, the sidecar, scoring."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from conftest import RL_EXTRA, tiny_scenario

pytest.importorskip("torch", reason=RL_EXTRA)

from sb3_helpers import baselines_plugins  # noqa: F401 (a fixture)

from baselines.distill import DistillConfig, DistillPolicy, load_distill_policy, run_distill
from baselines.distill.files import RunFolder, load_npz, save_npz
from baselines.distill.network import forward
from uav_penetration_env.benchmark.cli import main
from uav_penetration_env.benchmark.evaluate import evaluate, policy_hash
from uav_penetration_env.benchmark.policies import make_policy
from uav_penetration_env.model import OBSERVATION_SIZE

pytestmark = pytest.mark.usefixtures("baselines_plugins")


class LinearExpert:
    """An expert whose normalised action is a fixed linear map of the observation (clipped)."""

    calls = [0]  # class-level: the episodes deep-copy the expert, the count must survive that

    def __init__(self, seed: int = 2) -> None:
        # Seed 2 at this scale flies the tiny scenario to its goal in 11 steps (no crash).
        rng = np.random.default_rng(seed)
        self.matrix = rng.normal(0.0, 0.01, size=(3, OBSERVATION_SIZE))
        self.high: np.ndarray | None = None

    def config(self):
        return {"kind": "linear-test-expert"}

    def unit(self, observation):
        return np.clip(self.matrix @ np.asarray(observation, dtype=np.float64), -1.0, 1.0)

    def reset(self, model, seed=None):
        self.high = np.asarray(model.limits.action_high, dtype=np.float64)

    def act(self, observation, info):
        LinearExpert.calls[0] += 1
        return self.unit(observation) * self.high


def tiny_config(out, **changes):
    base = dict(
        out=out, expert=LinearExpert(), scenarios=(tiny_scenario(),), rounds=1, epochs=5,
        batch_size=64, hidden=(32, 32), beta0=0.0, seed=3,
    )  # fmt: skip
    return DistillConfig(**{**base, **changes})


@pytest.mark.parametrize("loss", ["mse", "mse-std"])
def test_behaviour_cloning_reproduces_a_linear_expert(tmp_path, loss):
    result = run_distill(tiny_config(tmp_path / "bc", rounds=0, epochs=400, learning_rate=3e-3, loss=loss))
    folder = result.folder
    data = load_npz(folder.round_data(0))
    assert data["expert_flew"].all() and len(data["actions"]) == 11
    predicted = forward(load_npz(folder.policy), data["observations"])
    assert np.max(np.abs(predicted - data["actions"])) < 0.02  # of the range [-1, 1]
    expected = np.array([LinearExpert().unit(o) for o in data["observations"]])
    np.testing.assert_allclose(data["actions"], expected, atol=1e-6)  # the labels are the expert's


def test_dagger_labels_the_states_the_learner_visits(tmp_path):
    result = run_distill(tiny_config(tmp_path / "dagger", rounds=1, epochs=1))
    folder = result.folder
    expert_states = load_npz(folder.round_data(0))["states"]
    round1 = load_npz(folder.round_data(1))
    assert not round1["expert_flew"].any()  # beta0 = 0: the learner flies every step of round 1
    unseen = [s for s in round1["states"] if not np.any(np.all(np.isclose(expert_states, s), axis=1))]
    assert unseen, "round 1 should visit states the expert never did"
    expected = np.array([LinearExpert().unit(o) for o in round1["observations"]])
    np.testing.assert_allclose(round1["actions"], expected, atol=1e-6)
    rows = len(expert_states) + len(round1["states"])
    assert result.rounds[1]["data_rows"] == rows and sum(r["expert_labels"] for r in result.rounds) == rows


def test_the_policy_is_the_round_of_lowest_validation_cost(distilled):
    from baselines.distill.loop import select_round

    costs = distilled.sidecar["validation_costs"]
    assert len(costs) == 2 and costs[distilled.sidecar["selected_round"]] == min(costs)
    rounds = [{"validation": [{"cost": c}]} for c in (5.0, 3.0, 3.0, 4.0)]
    assert select_round(rounds, "best") == 2 and select_round(rounds, "last") == 3


def test_beta_schedule():
    config = DistillConfig(beta0=0.8, decay=0.5)
    assert [config.beta(k) for k in range(4)] == [1.0, 0.4, 0.2, 0.1]


def test_resume_after_an_interrupted_round_gives_the_same_weights(tmp_path, monkeypatch):
    whole = run_distill(tiny_config(tmp_path / "whole", rounds=2))
    LinearExpert.calls[0] = 0
    run_distill(tiny_config(tmp_path / "cut", rounds=0))
    from baselines.distill import loop

    real_fit = loop.fit

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(loop, "fit", interrupted)  # round 1's episodes are flown and saved, its fit cut
    with pytest.raises(KeyboardInterrupt):
        run_distill(tiny_config(tmp_path / "cut", rounds=2))
    assert RunFolder(tmp_path / "cut").finished_rounds() == 1
    monkeypatch.setattr(loop, "fit", real_fit)
    resumed = run_distill(tiny_config(tmp_path / "cut", rounds=2))
    for k in range(3):
        for name, array in load_npz(whole.folder.net(k)).items():
            np.testing.assert_array_equal(load_npz(resumed.folder.net(k))[name], array)
    assert resumed.sidecar["weights_sha256"] == whole.sidecar["weights_sha256"]
    assert resumed.sidecar["selected_round"] == whole.sidecar["selected_round"]
    assert LinearExpert.calls[0] == sum(r["expert_labels"] for r in whole.rounds)  # no label computed twice


def test_a_folder_of_other_settings_is_refused(tmp_path):
    run_distill(tiny_config(tmp_path / "run", rounds=0))
    with pytest.raises(ValueError, match=r"^--epochs: the run folder .* was made with 5, not 7"):
        run_distill(tiny_config(tmp_path / "run", rounds=0, epochs=7))


@pytest.fixture(scope="module")
def distilled(tmp_path_factory):
    return run_distill(tiny_config(tmp_path_factory.mktemp("distill") / "tiny", rounds=1))


def test_the_sidecar_check_refuses_altered_weights(distilled, tmp_path):
    folder = tmp_path / "copy"
    folder.mkdir()
    arrays = load_npz(distilled.folder.policy)
    arrays["W0"] = arrays["W0"] + np.float32(1e-3)
    save_npz(folder / "policy.npz", arrays)
    (folder / "policy.json").write_text(distilled.folder.policy_sidecar.read_text())
    with pytest.raises(ValueError, match=r"SHA-256 .* is not the .* its sidecar"):
        load_distill_policy(folder)
    (folder / "policy.json").unlink()
    with pytest.raises(FileNotFoundError, match=r"policy\.json: no such file"):
        load_distill_policy(folder)


def test_the_policy_is_scored_by_the_evaluator(distilled):
    policy = make_policy(f"distill:{distilled.folder.out}")
    assert isinstance(policy, DistillPolicy)
    df = evaluate({"distill": policy}, [tiny_scenario()], seeds=range(2), progress=False)
    assert df["error"].tolist() == ["", ""]
    assert (df["train_timesteps"] == sum(r["expert_labels"] for r in distilled.rounds)).all()
    # Each round's network is a policy too (behaviour cloning alone is round 0).
    bc = load_distill_policy(distilled.folder.net(0))
    assert bc.sidecar["rounds"] == 0 and bc.sidecar["data_rows"] == distilled.rounds[0]["data_rows"]
    other = 1 - distilled.sidecar["selected_round"]
    assert load_distill_policy(distilled.folder.net(other)).config() != policy.config()


def test_the_store_key_is_the_same_in_another_process(distilled):
    here = policy_hash(load_distill_policy(distilled.folder.out))
    # Another process loads and flies it, and never imports torch (a distilled policy needs no extra).
    code = (
        "import sys; sys.path[:0] = ['tests'];"
        "from conftest import tiny_scenario;"
        "from baselines.distill import load_distill_policy;"
        "from uav_penetration_env.benchmark.evaluate import evaluate, policy_hash;"
        f"p = load_distill_policy({str(distilled.folder.out)!r});"
        "df = evaluate({'d': p}, [tiny_scenario()], seeds=[0], progress=False, n_jobs=1);"
        "print(policy_hash(p), df['error'].tolist() == [''], 'torch' in sys.modules)"
    )
    there = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert there == [here, "True", "False"]
    side = json.loads(distilled.folder.policy_sidecar.read_text())
    assert side["expert"] == {"object": "LinearExpert", "kind": "linear-test-expert"}
    assert side["scenarios"] == [{"name": "tiny", "hash": tiny_scenario().hash}]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--rounds", "-1"], "--rounds: got -1, expected an integer >= 0"),
        (["--beta0", "1.5"], "--beta0: got 1.5, expected a number in [0, 1]"),
        (["--scenarios", "random:10005"], "--scenarios: got 'random:10005', whose seed 10005 belongs to the held-out set"),
        (["--scenarios", "random:29990-30001"], "belongs to the suite uavpen-v1"),
        (["--expert", "lattise"], "--expert: unknown policy 'lattise'"),
        (["--loss", "l1"], "--loss: got 'l1', expected one of mse, mse-std"),
    ],
)
def test_cli_errors_name_the_flag(argv, message, capsys, tmp_path):
    assert main(["distill", "--out", str(tmp_path / "never"), *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "never").exists()


def low_and_high_states(model, state):
    """The start state moved to 10 m above the highest terrain ahead, and to 3 km above it."""
    from uav_penetration_env.kinematics import HEADING

    reach = 2 * model.limits.max_step_length
    distance = np.linspace(0.0, reach, 50)
    heading = float(state[HEADING])
    ground = model.height(state[0] + distance * np.cos(heading), state[1] + distance * np.sin(heading))
    low, high = state.copy(), state.copy()
    low[2] = float(np.max(ground)) + 10.0
    high[2] = float(np.max(ground)) + 3000.0
    return low, high


def test_the_safety_layer_raises_only_the_pitch_and_only_when_needed():
    from baselines.distill.policy import safe_action
    from uav_penetration_env.env import UAVPenetrationEnv

    env = UAVPenetrationEnv(tiny_scenario())
    _, info = env.reset(seed=0)
    model = env.model
    low, high = low_and_high_states(model, np.asarray(info["state"], dtype=np.float64))
    dive = np.array([0.5, 0.0, -model.limits.dpitch_max])
    # Diving 10 m above a ridge: the pitch change is raised, dv and dphi are kept bit for bit.
    guarded, overridden = safe_action(model, low, dive, 100.0, 2.0)
    assert overridden and guarded[2] > dive[2]
    assert guarded[0] == dive[0] and guarded[1] == dive[1]
    # Pitching up harder than the floor needs: untouched.
    climb = np.array([-0.5, 0.1, model.limits.dpitch_max])
    same, overridden = safe_action(model, low, climb, 100.0, 2.0)
    assert not overridden and np.array_equal(same, climb)
    # Far above the terrain, even a dive stays above the clearance: untouched.
    same, overridden = safe_action(model, high, dive, 100.0, 2.0)
    assert not overridden and np.array_equal(same, dive)


def test_the_guarded_policy_is_keyed_apart_and_counts_its_overrides(distilled):
    from baselines.distill import SafeDistillPolicy

    plain = make_policy(f"distill:{distilled.folder.out}")
    safe = make_policy(f"distill-safe:{distilled.folder.out}")
    assert isinstance(safe, SafeDistillPolicy)
    assert policy_hash(safe) != policy_hash(plain)
    assert safe.config()["weights_sha256"] == plain.config()["weights_sha256"]
    df = evaluate({"safe": safe}, [tiny_scenario()], seeds=[0], progress=False)
    assert df["error"].tolist() == [""]
