"""Training formulations (docs/rl.md §6): value shaping telescopes and leaves J alone; the turn action
is the lattice's candidate control, in training and in the evaluator."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import RL_EXTRA, run_into_store, tiny_scenario
from sb3_helpers import baselines_plugins  # noqa: F401 (a fixture)

from baselines.formulation import (
    LOOKAHEAD_STEPS,
    OBSERVATION_VALUES,
    TURNS,
    Formulation,
    formulation_for,
    learner_observation,
    turn_control,
    value_potential,
)
from baselines.formulation_env import TurnAction, ValueShaping
from uav_penetration_env.env import UAVPenetrationEnv
from uav_penetration_env.model import OBSERVATION_SIZE
from uav_penetration_env.value_function import (
    LATTICE_GUIDANCE,
    LatticeGuidance,
    candidate_control,
    value_function,
)

# A fixed zig-zag of turns: not the optimum, so the potential changes along the way.
TURN_SEQUENCE = (4, 4, 2, 0, 1, 2, 3, 2, 2, 0)


def _fly(env, seed, chooser):
    """Step ``env`` from reset(seed) until the episode ends; one (reward, info) per step and the first info."""
    _, first = env.reset(seed=seed)
    rows, k = [], 0
    while True:
        _, reward, terminated, truncated, info = env.step(chooser(k))
        rows.append((reward, terminated, info))
        k += 1
        if terminated or truncated:
            return first, rows


def _turn_env(clearance_m=40.0):
    return TurnAction(
        UAVPenetrationEnv(scenario=tiny_scenario()), Formulation(action="turn", clearance_m=clearance_m)
    )


@pytest.mark.parametrize("gamma", [1.0, 0.9])
def test_value_shaping_telescopes_to_the_potentials(gamma):
    env = ValueShaping(_turn_env(), gamma)
    first, rows = _fly(env, 0, lambda k: TURN_SEQUENCE[k % len(TURN_SEQUENCE)])
    model = env.unwrapped.model
    # Phi by hand from V at each exact state: -min(V, 50), zero after the terminating step.
    states = [first["state"], *(info["state"] for _, _, info in rows)]
    phi = [-min(float(value_function(model)(s[0], s[1], s[4])), 50.0) for s in states]
    terminated = rows[-1][1]
    if terminated:
        phi[-1] = 0.0
    discounted = sum(gamma**k * info["shaping"] for k, (_, _, info) in enumerate(rows))
    expected = gamma ** len(rows) * phi[-1] - phi[0]
    assert discounted == pytest.approx(expected, rel=1e-9, abs=1e-9)
    for k, (reward, _, info) in enumerate(rows):
        assert info["shaping"] == pytest.approx(gamma * phi[k + 1] - phi[k], rel=1e-12, abs=1e-12)
        assert reward == info["reward_env"] + info["shaping"]
    if gamma == 1.0 and terminated:
        # Phi(s_T) = 0: the whole shaping of an episode is V(s0) (capped), whatever was flown.
        assert sum(info["shaping"] for _, _, info in rows) == pytest.approx(-phi[0], rel=1e-9)


def test_value_shaping_leaves_the_env_reward_and_j_unchanged():
    shaped = ValueShaping(_turn_env(), 0.99)
    plain = _turn_env()
    chooser = lambda k: TURN_SEQUENCE[k % len(TURN_SEQUENCE)]  # noqa: E731
    _, with_shaping = _fly(shaped, 3, chooser)
    _, without = _fly(plain, 3, chooser)
    assert len(with_shaping) == len(without)
    for (_, _, a), (reward, _, b) in zip(with_shaping, without, strict=True):
        assert a["J"] == b["J"] and a["penalty"] == b["penalty"]
        assert a["reward_env"] == reward
        np.testing.assert_array_equal(a["state"], b["state"])


def test_the_potential_is_capped_and_finite():
    env = UAVPenetrationEnv(scenario=tiny_scenario())
    _, info = env.reset(seed=0)
    far = np.array([[-1e6, -1e6, 500.0, 200.0, 0.0, 0.0], info["state"]])
    phi = value_potential(env.model, far)
    vf = value_function(env.model)
    # Off the map V is the field's fallback (no finite lattice corner); Phi is -V capped at 50 J.
    assert phi[0] == -min(vf.missing, 50.0)
    assert phi[1] == -min(float(vf(far[1, 0], far[1, 1], far[1, 4])), 50.0)
    assert np.all(np.isfinite(phi)) and np.all((-50.0 <= phi) & (phi <= 0.0))


@pytest.mark.parametrize("index", range(len(TURNS)))
def test_a_discrete_turn_is_the_candidate_control(index):
    wrapped = _turn_env(clearance_m=40.0)
    raw = UAVPenetrationEnv(scenario=tiny_scenario())
    _, info = wrapped.reset(seed=1)
    _, raw_info = raw.reset(seed=1)
    for _ in range(3):
        control = candidate_control(
            raw.model, raw_info["state"], TURNS[index], LatticeGuidance(clearance_m=40.0)
        )
        _, _, _, _, info = wrapped.step(index)
        _, _, _, _, raw_info = raw.step(control)
        np.testing.assert_array_equal(info["state"], raw_info["state"])
        assert info["J"] == raw_info["J"]


def test_a_box_turn_is_the_candidate_control_of_that_fraction():
    env = UAVPenetrationEnv(scenario=tiny_scenario())
    _, info = env.reset(seed=0)
    box = Formulation(action="turn", turn_space="box", clearance_m=60.0)
    for value in (-1.0, 0.3, 2.0):
        expected = candidate_control(
            env.model, info["state"], float(np.clip(value, -1, 1)), LatticeGuidance(clearance_m=60.0)
        )
        np.testing.assert_array_equal(
            turn_control(env.model, info["state"], box, np.array([value])), expected
        )


def test_the_value_inputs_follow_the_observation():
    from baselines.distill.features import value_features

    env = UAVPenetrationEnv(scenario=tiny_scenario())
    obs, info = env.reset(seed=0)
    inputs = learner_observation(Formulation(features="value"), env.model, obs, info["state"])
    assert inputs.shape == (73,)
    np.testing.assert_array_equal(inputs[:67], obs)
    np.testing.assert_allclose(inputs[67:], value_features(env.model, info["state"]).astype(np.float32))


def test_the_light_constants_are_the_physics_ones():
    assert TURNS == tuple(float(t) for t in LATTICE_GUIDANCE.turns)
    assert LOOKAHEAD_STEPS == LATTICE_GUIDANCE.lookahead_steps
    assert OBSERVATION_VALUES == OBSERVATION_SIZE


def test_a_formulation_has_its_own_default_model_file():
    from baselines.plan import default_model_path

    assert formulation_for("ppo").tag == ""
    assert formulation_for("ppo", action="turn", features="value").tag == "turn-value"
    assert formulation_for("ppo", shaping="value", action="turn", clearance_m=100.0).tag == "shaped-turn-c100"
    tag = formulation_for("ppo", action="turn").tag
    assert default_model_path("ppo", "UAVPenetration-v0", "paper", 0, tag).name == "ppo-paper-turn-s0.zip"


def test_formulations_are_checked_naming_the_field():
    assert formulation_for("ppo", action="turn").turn_space == "discrete"
    assert formulation_for("sac", action="turn").turn_space == "box"
    with pytest.raises(ValueError, match=r"^shaping: got 'potential'"):
        formulation_for("ppo", shaping="potential")
    with pytest.raises(ValueError, match=r"^clearance_m: got -5"):
        formulation_for("ppo", action="turn", clearance_m=-5.0)
    with pytest.raises(ValueError, match=r"^formulation.turns"):
        Formulation.from_json({"action": "turn", "turns": [-1, 0, 1]})
    with pytest.raises(ValueError, match=r"^formulation.lookahead_steps: got 3"):
        Formulation.from_json({"action": "turn", "lookahead_steps": 3})
    assert Formulation.from_json(Formulation(action="turn").to_json()) == Formulation(action="turn")
    assert Formulation.from_json(None).is_default  # a sidecar written before formulations


# --- with SB3: the batched training wrapper, training and the evaluator -------------------------------


@pytest.fixture(scope="module")
def sb3():
    return pytest.importorskip("stable_baselines3", reason=RL_EXTRA)


def test_the_batched_wrapper_shapes_as_the_single_env_wrapper(sb3):
    from baselines.vec_env import FormulationVecEnv, UAVPenetrationSB3VecEnv

    formulation = Formulation(shaping="value", action="turn", features="value")
    venv = FormulationVecEnv(UAVPenetrationSB3VecEnv(num_envs=1, scenario=tiny_scenario()), formulation, 0.97)
    single = ValueShaping(TurnAction(UAVPenetrationEnv(scenario=tiny_scenario()), formulation), 0.97)
    venv.seed(5)
    obs = venv.reset()
    single_obs, _ = single.reset(seed=5)
    np.testing.assert_array_equal(obs[0], single_obs)
    for k in range(200):
        action = TURN_SEQUENCE[k % len(TURN_SEQUENCE)]
        obs, rewards, dones, infos = venv.step(np.array([action]))
        single_obs, _, _, _, info = single.step(action)
        assert infos[0]["J"] == info["J"] and infos[0]["shaping"] == pytest.approx(info["shaping"], rel=1e-12)
        # The adapter hands SB3 float32 rewards; F is added in float64 to that, then rounded once.
        assert rewards[0] == np.float32(np.float64(np.float32(info["reward_env"])) + info["shaping"])
        if dones[0]:
            np.testing.assert_array_equal(infos[0]["terminal_observation"], single_obs)
            break
        np.testing.assert_array_equal(obs[0], single_obs)
    assert dones[0]
    venv.close()


@pytest.fixture(scope="module")
def trained_turn(sb3, tmp_path_factory):
    """A PPO model trained for a few hundred steps with all three options."""
    from sb3_helpers import tiny_run

    from baselines import train_agent

    root = tmp_path_factory.mktemp("formulation")
    return train_agent(
        "ppo",
        out=root / "ppo-turn.zip",
        **tiny_run(shaping="value", action="turn", features="value", checkpoint_freq=0),
    )


def test_a_turn_model_is_scored_by_the_evaluator_with_the_same_mapping(trained_turn):
    from baselines import load_policy
    from uav_penetration_env.benchmark.evaluate import evaluate

    sidecar = json.loads(trained_turn.files.sidecar.read_text())
    assert sidecar["formulation"]["action"] == "turn" and sidecar["formulation"]["gamma"] == 0.99
    assert sidecar["observation_space"]["shape"] == [73]
    policy = load_policy(trained_turn.files.model)
    assert policy.config()["formulation"]["features"] == "value"
    # The policy's physical action is the candidate control of the network's own turn.
    env = UAVPenetrationEnv(scenario=tiny_scenario())
    obs, info = env.reset(seed=0)
    from uav_penetration_env import value_function as fields

    assert env.model not in fields._memo
    policy.reset(env.model, 0)
    # The value inputs' field is built in reset, not in the first act() (whose time is decision time).
    assert (0, fields.LATTICE_DEFAULTS) in fields._memo[env.model]
    agent, normalizer = policy._load()
    inputs = normalizer.normalize_obs(
        learner_observation(policy.formulation, env.model, obs, info["state"])[None]
    )
    index, _ = agent.predict(inputs, deterministic=True)
    expected = candidate_control(
        env.model, info["state"], TURNS[int(index[0])], LatticeGuidance(clearance_m=40.0)
    )
    np.testing.assert_array_equal(policy.act(obs, info), expected)
    df = evaluate({"turn": policy}, [tiny_scenario()], seeds=range(2), progress=False, n_jobs=1)
    assert df["error"].tolist() == ["", ""]


def test_a_box_turn_model_trains_and_is_scored(sb3, tmp_path):
    from sb3_helpers import tiny_run

    from baselines import load_policy, train_agent
    from uav_penetration_env.benchmark.evaluate import evaluate

    result = train_agent(
        "td3", out=tmp_path / "td3-turn.zip",
        **tiny_run(action="turn", total_timesteps=96, hyperparams={"learning_starts": 64, "buffer_size": 1000}, checkpoint_freq=0, eval_freq=0),
    )  # fmt: skip
    assert result.sidecar["formulation"]["turn_space"] == "box"
    policy = load_policy(result.files.model)
    env = UAVPenetrationEnv(scenario=tiny_scenario())
    obs, info = env.reset(seed=0)
    policy.reset(env.model, 0)
    agent, normalizer = policy._load()
    inputs = obs[None] if normalizer is None else normalizer.normalize_obs(obs[None])
    turn, _ = agent.predict(inputs, deterministic=True)
    expected = candidate_control(
        env.model, info["state"], float(np.clip(turn[0, 0], -1, 1)), LatticeGuidance(clearance_m=40.0)
    )
    np.testing.assert_array_equal(policy.act(obs, info), expected)
    df = evaluate({"td3": policy}, [tiny_scenario()], seeds=[0], progress=False, n_jobs=1)
    assert df["error"].tolist() == [""]


def test_todays_formulation_writes_the_sidecar_and_key_it_always_did(sb3, tmp_path):
    from sb3_helpers import tiny_run

    from baselines import load_policy, train_agent

    result = train_agent(
        "ppo", out=tmp_path / "ppo.zip", **tiny_run(total_timesteps=64, eval_freq=0, checkpoint_freq=0)
    )
    assert "formulation" not in result.sidecar and result.sidecar["observation_space"]["shape"] == [67]
    assert "formulation" not in load_policy(result.files.model).config()


def test_the_random_id_is_refused_with_a_formulation(sb3, tmp_path):
    from baselines.plan import TrainConfig, prepare_training

    with pytest.raises(ValueError, match=r"^env_id: UAVPenetrationRandom-v0 flies a pool"):
        prepare_training(
            TrainConfig(env_id="UAVPenetrationRandom-v0", shaping="value", out=tmp_path / "x.zip")
        )


@pytest.mark.slow
@pytest.mark.usefixtures("baselines_plugins")
def test_the_cli_trains_a_turn_model_and_workers_fly_it_as_in_process(sb3, tmp_path):
    """`uav-bench train` with every option, then `uav-bench run` in two worker processes: the same J."""
    from baselines import load_policy
    from uav_penetration_env.benchmark import cli
    from uav_penetration_env.benchmark.evaluate import evaluate
    from uav_penetration_env.benchmark.store import ResultsStore

    scenario = tiny_scenario().to_yaml(tmp_path / "tiny.yaml")
    model = tmp_path / "ppo-turn.zip"
    train = [
        "train",
        "--scenario",
        str(scenario),
        "--timesteps",
        "4096",
        "--n-envs",
        "4",
        "--out",
        str(model),
    ]
    train += [
        "--action",
        "turn",
        "--features",
        "value",
        "--shaping",
        "value",
        "--eval-freq",
        "2048",
        "--no-progress",
    ]
    assert cli.main(train) == 0
    store = tmp_path / "rl.sqlite"
    assert run_into_store(store, [f"sb3:{model}"], scenario, 2, "--jobs", 2) == 0
    with ResultsStore(store) as results:
        rows = results.episodes().sort_values("seed")
    in_process = evaluate({"turn": load_policy(model)}, [tiny_scenario()], range(2), progress=False, n_jobs=1)
    np.testing.assert_array_equal(rows["total_J"], in_process.sort_values("seed")["total_J"])
