"""The agent-warm-started MPC hybrid (``ihpso+sb3:PATH.zip``): its plan, determinism and store rows."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import RL_EXTRA, tiny_scenario

pytest.importorskip("stable_baselines3", reason=RL_EXTRA)

from sb3_helpers import baselines_plugins, trained_tiny_ppo  # noqa: F401 (a fixture)

from baselines import load_policy
from baselines.hybrid import AgentWarmStartedMPC, agent_rollout
from uav_penetration_env.benchmark.evaluate import evaluate, policy_hash
from uav_penetration_env.benchmark.policies import make_policy, policy_label
from uav_penetration_env.benchmark.store import ResultsStore
from uav_penetration_env.env import UAVPenetrationEnv

pytestmark = pytest.mark.usefixtures("baselines_plugins")


@pytest.fixture(scope="session")
def tiny_ppo(tmp_path_factory):
    return trained_tiny_ppo(tmp_path_factory.mktemp("sb3-hybrid"))


def rollout_by_env(agent, scenario, seed, horizon):
    """The agent's first H actions, flown in a real env: the plan the hybrid should predict."""
    env = UAVPenetrationEnv(scenario)
    observation, info = env.reset(seed=seed)
    agent.reset(env.model, None)
    actions = []
    for _ in range(horizon):
        action = agent.act(observation, info)
        actions.append(action)
        observation, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    plan = np.zeros((horizon, 3))
    plan[: len(actions)] = actions
    return plan, env


def test_agent_rollout_through_the_model_equals_the_agent_flying_the_env(tiny_ppo):
    scenario = tiny_scenario(time={"max_steps": 20})
    agent = load_policy(tiny_ppo.files.model)
    expected, _ = rollout_by_env(agent, scenario, seed=3, horizon=4)
    env = UAVPenetrationEnv(scenario)
    observation, info = env.reset(seed=3)
    agent.reset(env.model, None)
    plan = agent_rollout(agent, env.model, info["state"], info["step"], observation, horizon=4)
    np.testing.assert_array_equal(plan, expected)


def test_with_no_budget_beyond_x0_the_first_plan_is_the_agents_rollout(tiny_ppo):
    # max_evals=1: the optimiser evaluates only row 0 of its first batch, which is x0 (optimizers.md D1).
    scenario = tiny_scenario(time={"max_steps": 20})
    hybrid = make_policy(f"ihpso+sb3:{tiny_ppo.files.model}", horizon=4, max_evals=1)
    assert isinstance(hybrid, AgentWarmStartedMPC)
    expected, _ = rollout_by_env(load_policy(tiny_ppo.files.model), scenario, seed=3, horizon=4)
    env = UAVPenetrationEnv(scenario)
    observation, info = env.reset(seed=3)
    hybrid.reset(env.model, 0)
    action = hybrid.act(observation, info)
    np.testing.assert_array_equal(action, expected[0])
    assert hybrid.last_record["nfev"] == 1
    assert hybrid.last_record["plan_cost"] == hybrid.last_record["agent_plan_cost"]
    np.testing.assert_array_equal(hybrid.last_record["agent_plan"], expected)


def test_with_a_budget_the_plan_is_never_worse_than_the_agents(tiny_ppo):
    scenario = tiny_scenario(time={"max_steps": 20})
    hybrid = make_policy(f"ihpso+sb3:{tiny_ppo.files.model}", horizon=3, max_evals=300)
    env = UAVPenetrationEnv(scenario)
    observation, info = env.reset(seed=1)
    hybrid.reset(env.model, 0)
    for _ in range(3):
        action = hybrid.act(observation, info)
        assert hybrid.last_record["plan_cost"] <= hybrid.last_record["agent_plan_cost"]
        observation, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break


def test_hybrid_is_named_keyed_and_stored_like_any_policy(tiny_ppo, tmp_path):
    spec = f"ihpso+sb3:{tiny_ppo.files.model}"
    assert policy_label(spec) == "ihpso+sb3:ppo-tiny-s0"
    hybrid = make_policy(spec, horizon=3, max_evals=60)
    plain = make_policy("ihpso", horizon=3, max_evals=60)
    agent = load_policy(tiny_ppo.files.model)
    config = hybrid.config()
    assert config["kind"] == "mpc+agent" and config["agent"] == agent.config()
    assert policy_hash(hybrid) not in (policy_hash(plain), policy_hash(agent))
    store = tmp_path / "hybrid.sqlite"
    scenario = tiny_scenario(time={"max_steps": 12})
    first = evaluate({policy_label(spec): hybrid}, [scenario], range(2), store=store, progress=False)
    again = evaluate(
        {"again": make_policy(spec, horizon=3, max_evals=60)}, [scenario], range(2), progress=False
    )
    assert first["error"].tolist() == ["", ""]
    # Deterministic given the seed: a fresh policy from the same name flies the same episodes.
    np.testing.assert_array_equal(
        first.sort_values("seed")["total_cost"].to_numpy(), again.sort_values("seed")["total_cost"].to_numpy()
    )
    with ResultsStore(store) as results:
        rows = results.episodes()
        steps = results.steps(rows["episode_id"].tolist())
    assert rows["policy"].tolist() == ["ihpso+sb3:ppo-tiny-s0"] * 2
    assert (rows["horizon"] == 3).all() and (rows["max_evals"] == 60).all()
    assert (rows["train_timesteps"] == 256).all()  # the agent's training budget travels with the hybrid
    assert (steps["nfev"] > 0).all() and steps["planning_seconds"].notna().all()


def test_a_hybrid_needs_a_planner_before_the_plus(tiny_ppo):
    with pytest.raises(KeyError, match="MPC planner"):
        make_policy(f"greedy+sb3:{tiny_ppo.files.model}")
    with pytest.raises(KeyError, match="unknown policy 'ihspo'"):
        make_policy(f"ihspo+sb3:{tiny_ppo.files.model}")
