"""The single env's one compiled call gives exactly what the model's public methods give.

The reference below flies the same episodes through ``model.step``, ``model.observe``,
``model.reset_result`` and :func:`batched_info` (the vector env's calls), so the single env's
hot path and the vector env's path are held to the same numbers and the same info.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import tiny_scenario

from uav_penetration_env import PenetrationModel
from uav_penetration_env.env import (
    UAVPenetrationEnv,
    UAVPenetrationRandomEnv,
    batched_info,
    unbatch,
    validate_action,
)
from uav_penetration_env.mpc import Terminal
from uav_penetration_env.terminal import terminal_cost


class ThroughPublicMethods:
    """An env's step and state description rebuilt from the model's public batched methods."""

    def _step_compiled(self, action):
        control = validate_action(action, self.model.limits.action_high)
        result = self.model.step(self.state[None], control[None], self.step_index)
        self.state = result.state[0].copy()
        observation = self.model.observe(result.state, result.step_index, result)[0]
        info = unbatch(batched_info(result), 0)
        reward = float(result.reward[0])
        return observation, reward, bool(result.terminated[0]), bool(result.truncated[0]), info

    def _describe_state(self):
        result = self.model.reset_result(self.state[None], step_index=self.step_index)
        observation = self.model.observe(result.state, result.step_index, result)[0]
        return observation, unbatch(batched_info(result), 0)


class GenericEnv(ThroughPublicMethods, UAVPenetrationEnv):
    pass


class GenericRandomEnv(ThroughPublicMethods, UAVPenetrationRandomEnv):
    pass


def assert_same_output(fast, slow):
    """Observations and infos equal value for value, with the same Python types."""
    assert fast[0].dtype == slow[0].dtype == np.float32
    np.testing.assert_array_equal(fast[0], slow[0])
    fast_info, slow_info = fast[-1], slow[-1]
    assert list(fast_info) == list(slow_info)  # same keys, same order
    for key, value in slow_info.items():
        assert type(fast_info[key]) is type(value), key
        np.testing.assert_array_equal(fast_info[key], value, err_msg=key)
    for fast_item, slow_item in zip(fast[1:-1], slow[1:-1], strict=True):  # reward, terminated, truncated
        assert type(fast_item) is type(slow_item)
        assert fast_item == slow_item


@pytest.mark.parametrize(
    "changes",
    [
        {},
        {"start": {"jitter": {"xy_km": 1.0, "heading_deg": 5.0}}},
        {"radar_model": {"fusion": "or"}},
        {"radar_model": {"detection": "ratio", "masking": "hard"}},
        {"time": {"max_steps": 9}},  # episodes truncate
    ],
    ids=["default", "jitter", "or-fusion", "ratio-hard", "truncation"],
)
def test_hot_path_equals_the_generic_path_over_episodes(changes):
    scenario = tiny_scenario(**changes)
    fast, slow = UAVPenetrationEnv(scenario), GenericEnv(scenario)
    rng = np.random.default_rng(3)
    high = fast.action_space.high.astype(np.float64)
    ends = 0
    assert_same_output(fast.reset(seed=5), slow.reset(seed=5))
    for step in range(120):
        # float32 and float64 arrays, lists; some actions outside the box (clipped)
        action = rng.uniform(-1.5, 1.5, size=3) * high * [1.0, 0.5, 0.2]
        action = [action.astype(np.float32), action, action.tolist()][step % 3]
        fast_out, slow_out = fast.step(action), slow.step(action)
        assert_same_output(fast_out, slow_out)
        if fast_out[2] or fast_out[3]:
            ends += 1
            assert_same_output(fast.reset(), slow.reset())
    assert ends >= 2  # the episodes ended (a crash or the time limit), so resets were compared too
    state = fast.state + np.array([500.0, -300.0, 40.0, 1.0, 0.1, 0.02])
    assert_same_output(fast.set_state(state, 3), slow.set_state(state, 3))
    assert_same_output(fast.step([0.0, 0.1, 0.0]), slow.step([0.0, 0.1, 0.0]))


def test_hot_path_equals_the_generic_path_on_the_random_id():
    fast, slow = UAVPenetrationRandomEnv(0.5), GenericRandomEnv(0.5)
    assert_same_output(fast.reset(seed=11), slow.reset(seed=11))
    for _ in range(20):
        out = fast.step([1.0, 0.05, 0.0])
        assert_same_output(out, slow.step([1.0, 0.05, 0.0]))
        assert out[-1]["radar_threat_per_radar"].shape == (8,)


@pytest.mark.parametrize(
    "action, message",
    [
        ([0.0, np.nan, 0.0], "expected finite values"),
        ([0.0, 0.0, np.inf], "expected finite values"),
        ([0.0, 0.0], "expected (3,)"),
        (np.zeros((1, 3)), "expected (3,)"),
        (0.5, "expected (3,)"),
        ("fast", "expected a float array"),
    ],
)
def test_hot_path_rejects_bad_actions_as_the_generic_path_does(action, message):
    for env in (UAVPenetrationEnv(tiny_scenario()), GenericEnv(tiny_scenario())):
        env.reset(seed=0)
        with pytest.raises(ValueError, match=f"^action: .*{message.replace('(', '[(]').replace(')', '[)]')}"):
            env.step(action)
        assert env.step_index == 0  # nothing moved


def test_the_env_does_not_consult_a_model_subclass_override():
    # model.md §7a: the compiled call is the env's only path; an override changes the
    # subclass's own methods, not what the env flies.
    class Shifted(PenetrationModel):
        def step(self, states, controls, step_index, scenario_index=None):
            result = super().step(states, controls, step_index, scenario_index)
            result.J[:] += 1.0
            return result

    env = UAVPenetrationEnv(tiny_scenario())
    env._models[env.scenario.hash] = Shifted(env.model.built)
    env.reset(seed=0)
    reference = UAVPenetrationEnv(tiny_scenario())
    reference.reset(seed=0)
    info = env.step([0.0, 0.0, 0.0])[-1]
    assert info["J"] == reference.step([0.0, 0.0, 0.0])[-1]["J"]
    state = env.state[None]
    shifted = env.model.step(state, np.zeros((1, 3)), 1).J[0]
    assert shifted == PenetrationModel(tiny_scenario()).step(state, np.zeros((1, 3)), 1).J[0] + 1.0


def test_rollout_function_equals_rollout_cost_and_checks_its_arguments():
    model = PenetrationModel(tiny_scenario())
    state = model.initial_state()
    controls = np.random.default_rng(0).uniform(-1, 1, size=(40, 4, 3)) * model.limits.action_high
    distance = terminal_cost(model, Terminal("distance", 0.06))
    costs = model.rollout_function(state, step=2, discount=0.9, terminal_cost=distance)
    expected = model.rollout_cost(state, controls, step=2, discount=0.9, terminal_cost=distance)
    np.testing.assert_array_equal(costs(controls), expected)
    state[0] += 1000.0  # the window was copied when bound
    np.testing.assert_array_equal(costs(controls), expected)
    with pytest.raises(ValueError, match=r"^controls: got a non-finite entry"):
        costs(np.full((2, 4, 3), np.nan))
    with pytest.raises(ValueError, match=r"^controls: got shape"):
        costs(np.zeros((2, 0, 3)))
    with pytest.raises(ValueError, match=r"^discount: got 0\.0"):
        model.rollout_function(state, step=0, discount=0.0)
    with pytest.raises(TypeError, match=r"^step: got 1\.5"):
        model.rollout_function(state, step=1.5)


def test_rollout_function_of_a_subclass_calls_its_own_rollout_cost():
    class Doubled(PenetrationModel):
        def rollout_cost(self, state, controls, **kwargs):
            return 2.0 * super().rollout_cost(state, controls, **kwargs)

    model = Doubled(tiny_scenario())
    state = model.initial_state()
    controls = np.zeros((3, 2, 3))
    plain = PenetrationModel(tiny_scenario()).rollout_cost(state, controls, step=0)
    np.testing.assert_array_equal(model.rollout_function(state, step=0)(controls), 2.0 * plain)
