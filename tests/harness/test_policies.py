"""MPCPolicy, the floors and the policy-name resolver."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from conftest import tiny_scenario

from optimizers import OptimizeResult, get_optimizer
from uav_penetration_env import PenetrationModel
from uav_penetration_env.benchmark.policies import (
    MPC_DEFAULTS,
    GreedyPolicy,
    LatticePolicy,
    MPCPolicy,
    MPCSettings,
    RandomPolicy,
    make_policy,
    policy_names,
)
from uav_penetration_env.env import UAVPenetrationEnv
from uav_penetration_env.mpc import Terminal
from uav_penetration_env.terminal import terminal_cost


def one_evaluation(x, value: float, message: str) -> OptimizeResult:
    """The result of a run that evaluated one plan ``x`` once, at ``value``."""
    return OptimizeResult(
        x=x, fun=value, nfev=1, nit=0, history=np.array([value]), history_nfev=np.array([1]), message=message
    )


@dataclass
class SpyOptimizer:
    """Records what minimize receives and returns a fixed plan (or no finite plan)."""

    plan_value: float = 0.1
    finite: bool = True

    def __post_init__(self) -> None:
        self.calls: list[dict] = []

    def minimize(self, fun, bounds, *, rng=None, max_evals=10_000, x0=None):
        lo, hi = bounds.lb, bounds.ub
        plan = np.clip(np.full(lo.shape, self.plan_value) * np.arange(1, lo.size + 1), lo, hi)
        cost = fun(plan[None])[0]
        self.calls.append(
            {
                "x0": None if x0 is None else np.array(x0),
                "bounds": (lo.copy(), hi.copy()),
                "max_evals": max_evals,
            }
        )
        return one_evaluation(plan, cost if self.finite else math.inf, "spy")


@dataclass
class NoWarmStart:
    """A plug-in optimiser whose minimize has no x0 parameter."""

    def minimize(self, fun, bounds, *, rng=None, max_evals=10_000):
        x = np.zeros_like(bounds.lb)
        return one_evaluation(x, float(fun(x[None])[0]), "zero")


@pytest.fixture(scope="module")
def env():
    return UAVPenetrationEnv(tiny_scenario())


def test_mpc_plans_on_the_box_and_warm_starts_from_the_shifted_plan(env):
    spy = SpyOptimizer()
    policy = MPCPolicy(spy, MPCSettings(horizon=3, max_evals=77))
    obs, info = env.reset(seed=0)
    policy.reset(env.model, 0)
    first = policy.act(obs, info)
    lo, hi = spy.calls[0]["bounds"]
    np.testing.assert_array_equal(hi, np.tile(env.model.limits.action_high, 3))
    np.testing.assert_array_equal(lo, -hi)
    assert spy.calls[0]["x0"] is None and spy.calls[0]["max_evals"] == 77
    plan = np.clip(0.1 * np.arange(1, 10), lo, hi).reshape(3, 3)
    np.testing.assert_array_equal(first, plan[0])
    obs, _, _, _, info = env.step(first)
    policy.act(obs, info)
    expected_x0 = np.vstack([plan[1:], np.zeros((1, 3))]).reshape(-1)
    np.testing.assert_array_equal(spy.calls[1]["x0"], expected_x0)
    record = policy.last_record
    # The harness times the whole act() (planning_seconds, api.md §4.12); the planner records its objective's share.
    assert record["nfev"] == 1 and record["objective_seconds"] > 0 and "planning_seconds" not in record


def test_mpc_applies_zeros_without_a_finite_plan(env):
    policy = MPCPolicy(SpyOptimizer(finite=False), MPCSettings(horizon=2))
    obs, info = env.reset(seed=0)
    policy.reset(env.model, 0)
    np.testing.assert_array_equal(policy.act(obs, info), np.zeros(3))
    obs, _, _, _, info = env.step(np.zeros(3))
    policy.act(obs, info)
    assert policy.optimizer.calls[1]["x0"] is None  # no plan to warm-start from


def test_optimizer_without_x0_is_never_given_one(env):
    policy = MPCPolicy(NoWarmStart(), MPCSettings(horizon=2))
    obs, info = env.reset(seed=0)
    policy.reset(env.model, 0)
    for _ in range(2):
        action = policy.act(obs, info)
        obs, _, _, _, info = env.step(action)
    np.testing.assert_array_equal(action, np.zeros(3))


def test_mpc_objective_is_the_model_rollout_cost(env):
    """The cost the optimiser sees for a plan is rollout_cost with the policy's settings."""
    seen = []

    @dataclass
    class Probe:
        def minimize(self, fun, bounds, *, rng=None, max_evals=10_000, x0=None):
            plans = np.random.default_rng(0).uniform(bounds.lb, bounds.ub, size=(7, bounds.lb.size))
            seen.append((plans, fun(plans)))
            return OptimizeResult(
                x=plans[0],
                fun=float(seen[-1][1][0]),
                nfev=7,
                nit=0,
                history=np.zeros(1),
                history_nfev=np.ones(1, int),
                message="",
            )

    policy = MPCPolicy(Probe(), MPCSettings(horizon=4, discount=0.9, terminal=Terminal("distance", 0.2)))
    obs, info = env.reset(seed=0)
    policy.reset(env.model, 0)
    policy.act(obs, info)
    plans, costs = seen[0]
    expected = env.model.rollout_cost(
        info["state"],
        plans.reshape(7, 4, 3),
        step=0,
        discount=0.9,
        terminal_cost=terminal_cost(env.model, Terminal("distance", 0.2)),
    )
    np.testing.assert_array_equal(costs, expected)


def test_mpc_is_reproducible_for_a_seed(env):
    def actions(seed):
        policy = MPCPolicy(get_optimizer("pso"), MPCSettings(max_evals=300))
        obs, info = env.reset(seed=0)
        policy.reset(env.model, seed)
        out = []
        for _ in range(3):
            action = policy.act(obs, info)
            out.append(action)
            obs, _, _, _, info = env.step(action)
        return np.array(out)

    np.testing.assert_array_equal(actions(1), actions(1))
    assert not np.array_equal(actions(1), actions(2))


def test_mpc_validates_its_settings():
    with pytest.raises(ValueError, match=r"^horizon: got 0, expected an integer >= 1$"):
        MPCSettings(horizon=0)
    with pytest.raises(ValueError, match=r"^discount: got 1\.5, expected a number in \(0, 1\]$"):
        MPCSettings(discount=1.5)
    with pytest.raises(ValueError, match=r"^max_evals: got 0, expected an integer >= 1$"):
        make_policy("pso", max_evals=0)
    with pytest.raises(ValueError, match=r"^max_evals: got 2\.0, expected an integer >= 1$"):
        MPCSettings(max_evals=2.0)  # an integer setting refuses a float, as it always has
    with pytest.raises(ValueError, match="horizon: got True"):
        MPCSettings(horizon=True)  # a bool is no number
    with pytest.raises(ValueError, match=r"^terminal_cost: got -1\.0, expected None or a finite number >= 0$"):
        Terminal("distance", -1.0)
    with pytest.raises(ValueError, match=r"^terminal_cost: got -1\.0, expected None or a finite number >= 0$"):
        make_policy("pso", terminal="distance", terminal_cost=-1.0)
    with pytest.raises(ValueError, match=r"^terminal_cost: got True, expected None or a finite number >= 0$"):
        Terminal("distance", True)  # a bool is no c_T
    with pytest.raises(ValueError, match=r"^terminal: got 'distance', expected a Terminal\(form, scale\)$"):
        MPCSettings(terminal="distance")  # the field holds the one object, never its parts
    with pytest.raises(TypeError, match="minimize"):
        MPCPolicy(object())
    with pytest.raises(TypeError, match="settings: got 5, expected an MPCSettings"):
        MPCPolicy(get_optimizer("pso"), 5)
    with pytest.raises(TypeError, match="horizont"):
        make_policy("pso", horizont=3)  # a change that names no setting
    # A c_T with a form that has none is refused where a planner is built, not in the request.
    request = MPCSettings(terminal=Terminal("value", 0.25))
    with pytest.raises(ValueError, match=r"terminal_cost: got 0\.25 with the 'value' terminal form"):
        MPCPolicy(get_optimizer("pso"), request)
    assert make_policy("pso-ctg-distance", request).settings == MPCSettings(terminal=Terminal("distance", 0.25))


def test_make_policy_names():
    assert isinstance(make_policy("greedy"), GreedyPolicy)
    assert isinstance(make_policy("random"), RandomPolicy)
    ihpso = make_policy("ihpso", horizon=4, max_evals=123)
    assert (
        isinstance(ihpso, MPCPolicy)
        and ihpso.settings.terminal == MPC_DEFAULTS.terminal == Terminal("value", None)
        and ihpso.horizon == 4
        and ihpso.max_evals == 123
    )
    literal = make_policy("ihpso-eq37")
    assert literal.settings.terminal == Terminal("none") and type(literal.optimizer) is type(ihpso.optimizer)
    assert ihpso.config() != literal.config()
    # A suffix fixes the terminal form (model.md §7e); c_T still comes from the arguments.
    forms = {f: make_policy(f"hpso-ctg-{f}", terminal_cost=0.3) for f in ("distance", "dubins", "value")}
    assert {f: (p.settings.terminal.form, p.settings.terminal.scale, p.name) for f, p in forms.items()} == {
        "distance": ("distance", 0.3, "hpso-ctg-distance"),
        "dubins": ("dubins", 0.3, "hpso-ctg-dubins"),
        "value": ("value", None, "hpso-ctg-value"),  # the value form has no c_T
    }
    assert len({str(p.config()) for p in forms.values()}) == 3
    # A c_T given with the value form (the default) is refused, never silently ignored.
    with pytest.raises(ValueError, match=r"terminal_cost: got 0\.25 with the 'value' terminal form"):
        make_policy("hpso", terminal="value", terminal_cost=0.25)
    # The value form's configuration names the lattice, so a changed V is a new store key.
    assert forms["value"].config()["value_algorithm"] >= 1 and "lattice" in forms["value"].config()
    assert "lattice" not in forms["distance"].config()
    assert isinstance(make_policy("lattice"), LatticePolicy)
    # lattice-cN: the lattice planner at another clearance, keyed apart; N checked.
    low = make_policy("lattice-c40")
    assert isinstance(low, LatticePolicy) and low.guidance.clearance_m == 40.0
    assert low.config()["guidance"]["clearance_m"] == 40.0 and low.config() != make_policy("lattice").config()
    for bad in ("lattice-c5", "lattice-c", "lattice-c4.5", "lattice-c2000"):
        with pytest.raises(ValueError, match=r"clearance: got '.*', expected an integer number of metres in \[10, 1000\]"):
            make_policy(bad)
    assert make_policy("value-greedy-c40").guidance.clearance_m == 40.0
    assert make_policy("value-greedy").config()["kind"] == "value-greedy"
    expected = {"ihpso", "ihpso-eq37", "greedy", "random", "lattice", "cem-eq37", "cem-ctg-value"}
    assert expected <= set(policy_names())
    with pytest.raises(KeyError, match="did you mean 'ihpso'"):
        make_policy("ihspo")


def test_greedy_turns_at_the_maximum_rate_and_holds_100_m_over_terrain():
    model = PenetrationModel(
        tiny_scenario(terrain={"natural": {"method": "flat", "height_m": 50}, "mountains": []})
    )
    policy = GreedyPolicy()
    policy.reset(model)
    # Heading east while the goal is north-east at 45 degrees: turn left by the full 15 degrees.
    state = np.array([0.0, 0.0, 150.0, 8.0, 0.0, 0.0])
    action = policy.act(None, {"state": state})
    assert action[0] == pytest.approx(2.0)  # toward v_max = 10 m/s at the 2 m/s step limit
    assert action[1] == pytest.approx(math.radians(15))
    assert action[2] == pytest.approx(0.0, abs=1e-12)  # already 100 m above flat 50 m terrain
    # 1000 m too low: the needed climb asin(1000 / 3000) = 19.5 deg exceeds the 15 deg pitch change.
    low = state.copy()
    low[2] = -850.0
    assert policy.act(None, {"state": low})[2] == pytest.approx(math.radians(15))
    # 300 m too low: exactly the pitch asin(300 / 3000) that reaches the target in one step.
    low[2] = -150.0
    assert policy.act(None, {"state": low})[2] == pytest.approx(math.asin(0.1))
    # Slightly high: the pitch that descends to the target in one step, asin(dz / (v dt)).
    high = state.copy()
    high[2] = 250.0
    expected = math.asin(-100.0 / (10.0 * 300.0))
    assert policy.act(None, {"state": high})[2] == pytest.approx(expected)


def test_random_policy_is_uniform_in_the_box_and_seeded():
    model = PenetrationModel(tiny_scenario())
    a, b = RandomPolicy(), RandomPolicy()
    a.reset(model, 3)
    b.reset(model, 3)
    draws = np.array([a.act(None, {}) for _ in range(2000)])
    np.testing.assert_array_equal(draws[0], b.act(None, {}))
    high = model.limits.action_high
    assert np.all(np.abs(draws) <= high)
    assert np.all(draws.max(axis=0) > 0.95 * high) and np.all(draws.min(axis=0) < -0.95 * high)


def test_mpc_defaults_live_in_one_place():
    from uav_penetration_env.benchmark.commands.run_settings import RunSettings
    from uav_penetration_env.benchmark.policies import MPC_DEFAULTS
    from uav_penetration_env.mpc import SETTING_FIELDS
    from uav_penetration_env.settings_fields import config_keys

    # Paper §5: H = 5, 10 000 evaluations per step, gamma = 1; the terminal form (model.md §7e).
    assert (MPC_DEFAULTS.horizon, MPC_DEFAULTS.max_evals, MPC_DEFAULTS.discount) == (5, 10_000, 1.0)
    built = make_policy("pso")
    plain = MPCPolicy(get_optimizer("pso"))
    keys = ("horizon", "discount", "max_evals", "terminal", "terminal_cost")
    for policy in (built, plain):
        assert policy.settings is MPC_DEFAULTS
        assert (policy.horizon, policy.max_evals) == (MPC_DEFAULTS.horizon, MPC_DEFAULTS.max_evals)
    assert SETTING_FIELDS == keys and not set(keys) & set(config_keys(RunSettings))  # the CLI reads the dataclass
    with pytest.raises(ValueError, match="terminal: got 'euclid'"):
        MPCPolicy(get_optimizer("pso"), MPCSettings(terminal=Terminal("euclid")))


def test_trace_summary_of_a_hand_made_trace():
    from uav_penetration_env.benchmark.policies import trace_summary

    ihpso = {"switch_iterations": (3, 9), "reverse_switch_iterations": (7,), "stopped_by": "termination"}
    assert trace_summary(ihpso, 4200, 10_000) == {
        "stopped_early": True,
        "switches": 2,
        "reverse_switches": 1,
        "extinctions": None,
    }
    ps2o = {"extinctions": ((4, (1,)), (8, (0, 2)))}
    assert trace_summary(ps2o, 10_000, 10_000) == {
        "stopped_early": False,
        "switches": None,
        "reverse_switches": None,
        "extinctions": 2,
    }
    assert trace_summary(None, 10, 10)["switches"] is None  # an optimiser without a trace


def test_mpc_records_the_trace_summary_and_shares_its_objective(tiny):
    from uav_penetration_env.benchmark.policies import make_policy, mpc_objective
    from uav_penetration_env.env import UAVPenetrationEnv

    env = UAVPenetrationEnv(tiny)
    observation, info = env.reset(seed=3)
    policy = make_policy("ihpso", max_evals=300)
    policy.reset(env.unwrapped.model, 0)
    policy.act(observation, info)
    record = policy.last_record
    assert record["stopped_early"] == (record["nfev"] < 300)
    assert isinstance(record["switches"], int) and isinstance(record["reverse_switches"], int)
    assert record["extinctions"] is None
    # The objective MPCPolicy plans on is mpc_objective's: the same cost for the same sequences.
    cost = mpc_objective(env.unwrapped.model, info["state"], info["step"], policy.settings)
    plans = np.random.default_rng(0).uniform(cost.bounds.lb, cost.bounds.ub, size=(4, 3 * policy.horizon))
    expected = env.unwrapped.model.rollout_cost(
        info["state"],
        plans.reshape(4, policy.horizon, 3),
        step=info["step"],
        terminal_cost=terminal_cost(env.unwrapped.model, policy.settings.terminal),
    )
    np.testing.assert_array_equal(cost(plans), expected)


def test_value_greedy_flies_the_turn_toward_the_lowest_value_one_step_ahead():
    from uav_penetration_env.value_function import LATTICE_GUIDANCE, value_function

    env = UAVPenetrationEnv(tiny_scenario())
    policy = make_policy("value-greedy-c60")
    observation, info = env.reset(seed=0)
    policy.reset(env.model, 0)
    vf = value_function(env.model)
    limits = env.model.limits
    done, steps = False, 0
    while not done:
        state = np.asarray(info["state"], dtype=np.float64)
        ahead = []
        for turn in LATTICE_GUIDANCE.turns:  # the loop the rule must agree with: one point per turn
            psi = state[4] + turn * limits.dheading_max
            step = limits.speed_max * limits.dt
            ahead.append(float(vf(state[0] + step * math.cos(psi), state[1] + step * math.sin(psi), psi)))
        action = policy.act(observation, info)
        best = LATTICE_GUIDANCE.turns[int(np.argmin(ahead))]
        assert action[1] == pytest.approx(best * limits.dheading_max, abs=1e-12)
        assert action[0] == pytest.approx(min(limits.dv_max, limits.speed_max - state[3]))  # toward v_max
        observation, _, terminated, truncated, info = env.step(action)
        done, steps = terminated or truncated, steps + 1
    assert info["reached_goal"] and steps > 3
