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
        batch_size=64, hidden=(32, 32), beta0=0.0, seed=3, validation=(),
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


class TurnExpert:
    """An expert that flies the lattice's candidate control for a turn chosen by the goal's side."""

    def config(self):
        return {"kind": "turn-test-expert"}

    def reset(self, model, seed=None):
        self.model = model

    def turn(self, observation):
        from uav_penetration_env.observation import GOAL_BEARING

        # sin(bearing to the goal - heading) > 0: the goal lies to the left; turn half toward it.
        return 0.5 if observation[GOAL_BEARING + 1] > 0 else -0.5

    def act(self, observation, info):
        from baselines.distill.heads import turn_action

        return turn_action(self.model, np.asarray(info["state"], dtype=np.float64), self.turn(observation))


def test_turn_classes_are_the_nearest_lattice_turn():
    from baselines.distill.heads import TURNS, turn_classes

    assert TURNS == (-1.0, -0.5, 0.0, 0.5, 1.0)
    unit = np.array([[0.3, -0.9, 0.0], [-1.0, -0.3, 0.2], [0.0, 0.2, -0.1], [1.0, 0.51, 0.0], [0.0, 1.0, 1.0]])
    assert turn_classes(unit).tolist() == [0, 1, 2, 3, 4]


def test_the_turn_head_flies_the_lattices_candidate_control(tmp_path):
    from baselines.distill.heads import TURNS, head_of, turn_action

    config = tiny_config(tmp_path / "turn", expert=TurnExpert(), head="turn", rounds=1, epochs=60)
    result = run_distill(config)
    arrays = load_npz(result.folder.policy)
    assert head_of(arrays) == "turn" and arrays["W2"].shape[0] == len(TURNS)
    assert arrays["turns"].tolist() == list(TURNS) and result.sidecar["head"] == "turn"
    policy = make_policy(f"distill:{result.folder.out}")
    assert policy.config()["head"] == "turn"
    # On the states it was fitted on, the policy's action is the candidate control of the expert's turn.
    from uav_penetration_env.env import UAVPenetrationEnv

    env = UAVPenetrationEnv(tiny_scenario())
    data = load_npz(result.folder.round_data(1))
    policy.reset(env.model, 0)
    expert = TurnExpert()
    expert.reset(env.model)
    for observation, state, step in zip(data["observations"], data["states"], data["steps"], strict=True):
        action = policy.act(observation, {"state": state, "step": int(step)})
        np.testing.assert_array_equal(action, turn_action(env.model, state, expert.turn(observation)))
    df = evaluate({"turn": policy}, [tiny_scenario()], seeds=[0], progress=False)
    assert df["error"].tolist() == [""]
    # The head is part of the run's key: the folder refuses to continue as an action head.
    with pytest.raises(ValueError, match=r"^--head: the run folder .* was made with 'turn', not None"):
        run_distill(tiny_config(tmp_path / "turn", expert=TurnExpert(), rounds=1, epochs=60))


def test_the_head_flag_is_checked(capsys, tmp_path):
    assert main(["distill", "--out", str(tmp_path / "never"), "--head", "turns"]) == 2
    assert "--head: got 'turns', expected one of action, turn" in capsys.readouterr().err


def constant_network(output):
    """A one-layer network whose output is ``output`` for every observation (zero weights, the bias)."""
    output = np.asarray(output, dtype=np.float32)
    return {
        "obs_mean": np.zeros(OBSERVATION_SIZE, np.float32),
        "obs_scale": np.ones(OBSERVATION_SIZE, np.float32),
        "W0": np.zeros((output.size, OBSERVATION_SIZE), np.float32),
        "b0": output,
    }


def test_the_shield_falls_back_to_greedy_when_the_rollout_fails_or_the_budget_is_spent():
    from baselines.distill.episodes import normalisers
    from baselines.distill.heads import TURNS, turn_action
    from baselines.distill.shield import (
        FAILS_AHEAD,
        HOLDING,
        HOMING,
        KEPT,
        OVER_BUDGET,
        Shield,
        rollout_fails,
        shielded_action,
    )
    from uav_penetration_env.benchmark.policies import greedy_action
    from uav_penetration_env.env import UAVPenetrationEnv

    env = UAVPenetrationEnv(tiny_scenario())
    observation, info = env.reset(seed=0)
    model = env.model
    from_unit = normalisers(model)[1]
    low, _ = low_and_high_states(model, np.asarray(info["state"], dtype=np.float64))
    shield = Shield(horizon=5, budget=2.0)
    diver = constant_network([0.0, 0.0, -1.0])  # the action head: full pitch-down at every step
    obs_low = model.observe(low[None], 0)[0]
    dive = from_unit(np.array([0.0, 0.0, -1.0]))
    assert rollout_fails(model, lambda o, s: dive, obs_low, low, 0, dive, 5)
    action, why = shielded_action(diver, model, from_unit, obs_low, low, 0, shield, step_budget=40.0)
    assert why == FAILS_AHEAD and np.array_equal(action, greedy_action(model, low))
    # A turn network holding its course follows the terrain like the lattice: it is kept.
    straight = {**constant_network([0.0, 0.0, 9.0, 0.0, 0.0]), "turns": np.asarray(TURNS, np.float32)}
    action, why = shielded_action(straight, model, from_unit, observation, info["state"], 0, shield, 40.0)
    assert why == KEPT and np.array_equal(action, turn_action(model, np.asarray(info["state"]), 0.0))
    # Past the step budget the greedy floor flies, whatever the network would.
    action, why = shielded_action(straight, model, from_unit, observation, info["state"], 7, shield, 7.0)
    assert why == OVER_BUDGET and np.array_equal(action, greedy_action(model, np.asarray(info["state"])))
    # During a hold after an override the greedy floor flies too.
    action, why = shielded_action(straight, model, from_unit, observation, info["state"], 3, shield, 40.0, 4)
    assert why == HOLDING and np.array_equal(action, greedy_action(model, np.asarray(info["state"])))
    # Near the goal the greedy floor homes in.
    near = Shield(homing=1e9)
    action, why = shielded_action(straight, model, from_unit, observation, info["state"], 0, near, 40.0)
    assert why == HOMING and np.array_equal(action, greedy_action(model, np.asarray(info["state"])))
    # Homing at a network's own lower clearance is checked by its own rollout: a target under the
    # collision floor (10 m < 30 m) collides, so the floor's 100 m homes instead; a safe one is kept.
    state = np.asarray(info["state"], dtype=np.float64)
    for clearance in (10.0, 60.0):
        rule = greedy_action(model, state, clearance)
        fails = rollout_fails(model, lambda o, s, c=clearance: greedy_action(model, s, c), observation, state, 0, rule, 5)
        action, why = shielded_action(straight, model, from_unit, observation, state, 0, near, 40.0, -1, clearance)
        expected = greedy_action(model, state) if fails else rule
        assert why == HOMING and np.array_equal(action, expected)
        assert fails == (clearance == 10.0)
    with pytest.raises(ValueError, match=r"^shield horizon: got 0, expected an integer >= 1$"):
        Shield(horizon=0)


def test_the_shielded_policy_is_keyed_apart_and_records_why(distilled):
    from baselines.distill.policy import ShieldedDistillPolicy

    plain = make_policy(f"distill:{distilled.folder.out}")
    shielded = make_policy(f"distill-shield:{distilled.folder.out}")
    assert isinstance(shielded, ShieldedDistillPolicy)
    assert policy_hash(shielded) != policy_hash(plain)
    assert shielded.config()["shield"] == {"horizon": 5, "budget": 2.0, "hold": 5, "homing": 4.0, "fallback": "greedy"}
    df = evaluate({"shielded": shielded}, [tiny_scenario()], seeds=[0], progress=False)
    assert df["error"].tolist() == [""]
    from uav_penetration_env.env import UAVPenetrationEnv

    env = UAVPenetrationEnv(tiny_scenario())
    observation, info = env.reset(seed=0)
    shielded.reset(env.model, 0)
    shielded.act(observation, info)
    assert shielded.last_record["shield"] in (0, 1, 2, 3, 4)


def test_ignored_slots_do_not_reach_the_network(tmp_path):
    from uav_penetration_env.observation import SLOTS

    result = run_distill(tiny_config(tmp_path / "blind", rounds=0, ignore=("position", "step_fraction")))
    arrays = load_npz(result.folder.policy)
    observations = load_npz(result.folder.round_data(0))["observations"]
    moved = observations.copy()
    moved[:, SLOTS["position"]] += 3.0
    moved[:, SLOTS["step_fraction"]] = 0.9
    np.testing.assert_array_equal(forward(arrays, moved), forward(arrays, observations))
    moved[:, SLOTS["speed"]] += 0.5  # a slot it sees
    assert not np.array_equal(forward(arrays, moved), forward(arrays, observations))
    assert result.sidecar["ignore"] == ["position", "step_fraction"]
    with pytest.raises(ValueError, match=r"^--ignore: got 'altitude', expected observation slots among position, "):
        run_distill(tiny_config(tmp_path / "never", ignore=("altitude",)))


def test_value_features_are_the_field_one_step_ahead_along_each_turn():
    from baselines.distill.features import VALUE_TURNS, value_features
    from uav_penetration_env.env import UAVPenetrationEnv
    from uav_penetration_env.value_function import value_function

    env = UAVPenetrationEnv(tiny_scenario())
    _, info = env.reset(seed=0)
    model, state = env.model, np.asarray(info["state"], dtype=np.float64)
    vf = value_function(model)
    step = model.limits.speed_max * model.limits.dt
    from uav_penetration_env.kinematics import HEADING

    here = float(vf(state[0], state[1], state[HEADING]))
    expected = [min(here, 50.0) / 10.0]
    for turn in VALUE_TURNS:  # one look-up at a time, the loop the vectorised feature must equal
        psi = state[HEADING] + turn * model.limits.dheading_max
        ahead = float(vf(state[0] + step * np.cos(psi), state[1] + step * np.sin(psi), psi))
        expected.append(min(max(ahead - here, -5.0), 5.0))
    np.testing.assert_allclose(value_features(model, state), expected, rtol=0, atol=1e-12)
    assert 0.0 < here < 50.0  # the tiny scenario's start is on the lattice, short of the crash price


def test_a_network_with_value_features_reads_them_in_training_and_in_flight(tmp_path):
    from baselines.distill.features import input_size, learner_input, value_features
    from uav_penetration_env.env import UAVPenetrationEnv

    config = tiny_config(tmp_path / "value", expert=TurnExpert(), head="turn", features=("value",), rounds=1, epochs=20)
    result = run_distill(config)
    arrays = load_npz(result.folder.policy)
    assert arrays["features"].tolist() == ["value"] and arrays["W0"].shape[1] == input_size(("value",)) == OBSERVATION_SIZE + 6
    assert result.sidecar["features"] == ["value"] and result.sidecar["input_size"] == OBSERVATION_SIZE + 6
    env = UAVPenetrationEnv(tiny_scenario())
    data = load_npz(result.folder.round_data(1))
    # The saved inputs are the observation followed by the features of the exact state labelled.
    for row, state in zip(data["observations"], data["states"], strict=True):
        np.testing.assert_array_equal(row[OBSERVATION_SIZE:], value_features(env.model, state).astype(np.float32))
    policy = make_policy(f"distill:{result.folder.out}")
    assert policy.config()["features"] == ["value"]
    policy.reset(env.model, 0)
    observation, info = env.reset(seed=0)
    from baselines.distill.heads import network_action

    action = policy.act(observation, info)
    np.testing.assert_array_equal(action, network_action(arrays, env.model, observation, info["state"], None))
    assert learner_input(("value",), env.model, observation, info["state"]).shape == (OBSERVATION_SIZE + 6,)
    df = evaluate({"value": policy}, [tiny_scenario()], seeds=[0], progress=False)
    assert df["error"].tolist() == [""]
    with pytest.raises(ValueError, match=r"^--features: the run folder .* was made with \['value'\], not None"):
        run_distill(tiny_config(tmp_path / "value", expert=TurnExpert(), head="turn", rounds=1, epochs=20))
    with pytest.raises(ValueError, match=r"^--features: got 'values', expected feature sets among value"):
        run_distill(tiny_config(tmp_path / "never", features=("values",)))


def test_a_turn_network_flies_its_lattice_experts_clearance(tmp_path):
    from baselines.distill.heads import expert_clearance, turn_action, turn_clearance

    expert = make_policy("lattice-c40")
    assert expert.guidance.clearance_m == 40.0 and expert_clearance(expert) == 40.0
    assert expert_clearance(make_policy("lattice")) == 100.0 == expert_clearance(TurnExpert())
    arrays = {"turns": np.zeros(5), "clearance_m": np.asarray(40.0)}
    assert turn_clearance(arrays) == 40.0 and turn_clearance({"turns": np.zeros(5)}) == 100.0
    from uav_penetration_env.env import UAVPenetrationEnv

    env = UAVPenetrationEnv(tiny_scenario())
    _, info = env.reset(seed=0)
    low, high = (turn_action(env.model, info["state"], 0.0, c)[2] for c in (40.0, 100.0))
    assert low <= high  # a lower clearance never pitches up more


def test_a_turn_value_network_with_no_opinion_of_its_own_flies_the_value_greedy_rule():
    from baselines.distill.features import input_size, value_features, value_prior
    from baselines.distill.heads import TURNS, head_of, network_action
    from uav_penetration_env.env import UAVPenetrationEnv

    width = input_size(("value",))
    arrays = {
        "obs_mean": np.zeros(width, np.float32),
        "obs_scale": np.ones(width, np.float32),
        "W0": np.zeros((len(TURNS), width), np.float32),  # the MLP says nothing: only the prior scores
        "b0": np.zeros(len(TURNS), np.float32),
        "turns": np.asarray(TURNS, np.float32),
        "features": np.asarray(["value"]),
        "prior_log_weight": np.asarray(np.log(10.0), np.float32),
    }
    assert head_of(arrays) == "turn-value"
    env = UAVPenetrationEnv(tiny_scenario())
    rule = make_policy("value-greedy")
    observation, info = env.reset(seed=0)
    rule.reset(env.model, 0)
    done = False
    while not done:
        state = np.asarray(info["state"], dtype=np.float64)
        row = np.concatenate([observation, value_features(env.model, state)]).astype(np.float32)
        np.testing.assert_array_equal(value_prior(("value",), row)[0], -row[OBSERVATION_SIZE + 1 :].astype(np.float64))
        action = network_action(arrays, env.model, observation, state, None)
        np.testing.assert_array_equal(action, rule.act(observation, info))
        observation, _, terminated, truncated, info = env.step(action)
        done = terminated or truncated
    assert info["reached_goal"]


def test_the_turn_value_head_learns_its_prior_weight_and_needs_the_value_inputs(tmp_path):
    config = tiny_config(tmp_path / "tv", expert=TurnExpert(), head="turn-value", features=("value",), rounds=1, epochs=20)
    result = run_distill(config)
    arrays = load_npz(result.folder.policy)
    assert arrays["prior_log_weight"].shape == () and np.isfinite(arrays["prior_log_weight"])
    assert float(arrays["prior_log_weight"]) != pytest.approx(np.log(10.0), abs=1e-6)  # Adam moved it
    assert make_policy(f"distill:{result.folder.out}").config()["head"] == "turn-value"
    with pytest.raises(ValueError, match=r"^--head: got 'turn-value', which reads the value inputs; add --features value"):
        run_distill(tiny_config(tmp_path / "never", head="turn-value"))


@pytest.mark.parametrize("run", ["c40-value-s1", "c40-value64-s0"])
def test_the_published_distilled_planners_load_and_fly(run):
    from pathlib import Path

    from uav_penetration_env.env import UAVPenetrationEnv

    folder = Path(__file__).resolve().parents[2] / "leaderboards" / "distill" / run
    policy = make_policy(f"distill-shield:{folder}")  # the sidecar's SHA-256 check passes
    config = policy.config()
    assert config["features"] == ["value"] and config["head"] == "turn"
    assert config["shield"]["homing_clearance_m"] == 40.0
    env = UAVPenetrationEnv(tiny_scenario())  # the benchmark profile it was trained under
    observation, info = env.reset(seed=0)
    policy.reset(env.model, 0)
    action = policy.act(observation, info)
    assert np.all(np.isfinite(action)) and policy.last_record["shield"] in (0, 1, 2, 3, 4)
