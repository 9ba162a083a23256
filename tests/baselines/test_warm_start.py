"""PPO warm-started from a distilled turn network (docs/rl.md §6.5): the actor starts as the network,
the critic learns alone first, and every mismatch is refused before training."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import RL_EXTRA, tiny_scenario
from sb3_helpers import baselines_plugins  # noqa: F401 (a fixture)

from baselines.distill.network import outputs
from baselines.warm_start import folded_layers

PUBLISHED = Path(__file__).resolve().parents[2] / "leaderboards" / "distill" / "c40-value-s1"


def _forward(layers, x):
    for i, (w, b) in enumerate(layers):
        x = x @ w.T + b
        if i < len(layers) - 1:
            x = np.tanh(x)
    return x


def test_folding_the_input_scaling_keeps_the_networks_outputs():
    rng = np.random.default_rng(3)
    arrays = {
        "W0": rng.normal(size=(5, 4)).astype(np.float32), "b0": rng.normal(size=5).astype(np.float32),
        "W1": rng.normal(size=(3, 5)).astype(np.float32), "b1": rng.normal(size=3).astype(np.float32),
        "obs_mean": np.array([1.0, -2.0, 0.0, 0.5], np.float32),
        "obs_scale": np.array([2.0, 0.25, np.inf, 1.0], np.float32),  # slot 2 blinded
    }  # fmt: skip
    x = rng.normal(size=(7, 4)) * 10
    layers = folded_layers(arrays)
    np.testing.assert_allclose(_forward(layers, x), outputs(arrays, x), rtol=1e-12, atol=1e-12)
    assert np.all(layers[0][0][:, 2] == 0.0)  # the blinded slot reaches nothing


@pytest.fixture(scope="module")
def sb3():
    return pytest.importorskip("stable_baselines3", reason=RL_EXTRA)


def _warm_run(tmp_path, **changes):
    from sb3_helpers import tiny_run

    from baselines import train_agent

    fields = tiny_run(
        action="turn", features="value", init_from=PUBLISHED, total_timesteps=128, eval_freq=0,
        checkpoint_freq=0, critic_warmup_steps=10**6,
    )  # fmt: skip
    return train_agent("ppo", out=tmp_path / "warm.zip", **{**fields, **changes})


def _actor_and_critic(model):
    policy = model.policy
    actor = [p.detach().numpy().copy() for p in [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()]]
    critic = [p.detach().numpy().copy() for p in [*policy.mlp_extractor.value_net.parameters(), *policy.value_net.parameters()]]
    return actor, critic


def test_the_warm_started_actor_is_the_network_and_stays_it_during_the_warmup(sb3, tmp_path):
    import torch

    from baselines import load_policy
    from baselines.distill.features import learner_input
    from baselines.distill.heads import turn_logits
    from baselines.distill.policy import load_distill_policy
    from uav_penetration_env.benchmark.evaluate import evaluate
    from uav_penetration_env.env import UAVPenetrationEnv

    result = _warm_run(tmp_path)
    network = load_distill_policy(PUBLISHED)
    # Frozen: the actor is still exactly the folded network (float32), the critic has learned.
    actor, _ = _actor_and_critic(result.model)
    expected = [a for w, b in folded_layers(network.arrays) for a in (w, b)]
    for got, want in zip(actor, expected, strict=True):
        np.testing.assert_array_equal(got, want.astype(np.float32))
    # Its turn probabilities are the network's softmax on the learner's inputs.
    env = UAVPenetrationEnv(scenario=tiny_scenario())
    obs, info = env.reset(seed=0)
    rows = []
    for _ in range(5):
        rows.append(learner_input(("value",), env.model, obs, info["state"]))
        obs, _, terminated, truncated, info = env.step(env.action_space.sample() * 0.0)
        if terminated or truncated:
            break
    x = np.array(rows)
    with torch.no_grad():
        probs = result.model.policy.get_distribution(torch.as_tensor(x)).distribution.probs.numpy()
    logits = turn_logits(network.arrays, x)
    want = np.exp(logits - logits.max(1, keepdims=True))
    np.testing.assert_allclose(probs, want / want.sum(1, keepdims=True), atol=1e-4)
    # The sidecar says where the actor came from; the evaluator flies it without normalisation.
    warm = result.sidecar["warm_start"]
    assert warm["weights_sha256"] == network.sidecar["weights_sha256"] and warm["hidden"] == [256, 256]
    assert result.sidecar["vecnormalize"] is None
    df = evaluate({"warm": load_policy(result.files.model)}, [tiny_scenario()], seeds=[0], progress=False, n_jobs=1)
    assert df["error"].tolist() == [""]


def test_after_the_warmup_the_actor_learns_too(sb3, tmp_path):
    frozen = _actor_and_critic(_warm_run(tmp_path / "a").model)
    free = _actor_and_critic(_warm_run(tmp_path / "b", critic_warmup_steps=0).model)
    assert any(not np.array_equal(a, b) for a, b in zip(frozen[0], free[0], strict=True))
    # Same seed, same data up to the first update: the critic learns in both.
    assert all(a.shape == b.shape for a, b in zip(frozen[1], free[1], strict=True))


def test_the_default_file_is_named_after_the_warm_start(sb3, tmp_path, monkeypatch):
    from baselines.plan import TrainConfig, prepare_training

    monkeypatch.chdir(tmp_path)
    plan = prepare_training(
        TrainConfig(scenario="paper", action="turn", features="value", init_from=PUBLISHED)
    )
    assert plan.files.model.name == "ppo-paper-turn-value-warm-s0.zip"
    assert plan.hyperparams["learning_rate"] == 1.0e-4 and plan.hyperparams["normalize"] is False


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"algo": "sac"}, r"^init_from: got algorithm 'sac', expected ppo"),
        ({"action": "physical"}, r"^action: got 'physical', expected 'turn' with init_from"),
        ({"features": "none"}, r"^features: got 'none', expected 'value' \(the inputs"),
        ({"clearance_m": 100.0}, r"^clearance_m: got 100, expected 40"),
        ({"hyperparams": {"policy_kwargs": {"net_arch": {"pi": [64, 64], "vf": [64, 64]}}}},
         r"^hyperparams.policy_kwargs.net_arch.pi: got \[64, 64\], expected \[256, 256\]"),
        ({"hyperparams": {"normalize": True}}, r"^hyperparams.normalize: got observation normalisation"),
        ({"init_from": None, "critic_warmup_steps": 10}, r"^critic_warmup_steps: given without init_from"),
        ({"critic_warmup_steps": -1}, r"^critic_warmup_steps: got -1, expected an integer >= 0"),
    ],
)  # fmt: skip
def test_a_warm_start_that_cannot_hold_is_refused_naming_the_field(sb3, tmp_path, changes, message):
    from baselines.plan import TrainConfig, prepare_training

    fields = {"scenario": "paper", "action": "turn", "features": "value", "init_from": PUBLISHED,
              "out": tmp_path / "x.zip", **changes}  # fmt: skip
    with pytest.raises(ValueError, match=message):
        prepare_training(TrainConfig(**fields))


@pytest.mark.usefixtures("baselines_plugins")
def test_the_cli_flag_is_checked(sb3, capsys, tmp_path):
    from uav_penetration_env.benchmark import cli

    code = cli.main(["train", "--scenario", "paper", "--init-from", str(PUBLISHED), "--out", str(tmp_path / "x.zip")])
    assert code == 2
    err = capsys.readouterr().err
    assert "action: got 'physical', expected 'turn' with init_from" in err and err.count("\n") == 1
