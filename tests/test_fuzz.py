"""Fuzzing the entry points a user types into: scenario dicts and ``gym.make`` keyword arguments.

Each generated case must end in a result or in the one documented error (``ScenarioError`` for a
scenario, ``TypeError``/``ValueError``/``ScenarioError`` for the env's arguments) whose message
is one line: never another exception, a traceback from deep inside, or a hang. The default suite
runs a deterministic sample of a few hundred cases; ``-m slow`` runs 10 000.
(The ``uav-bench`` command line has its own property tests in tests/test_argument_domains.py.)
"""

from __future__ import annotations

import copy
import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from conftest import TINY_SCENARIO
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import uav_penetration_env  # noqa: F401  (registers the ids)
from uav_penetration_env.build import build_scenario
from uav_penetration_env.scenario import Scenario, ScenarioError

DEFAULT = settings(max_examples=300, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
SLOW = settings(max_examples=int(__import__("os").environ.get("FUZZ_EXAMPLES", 10_000)), deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))

JUNK = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([5e-324, 1e308, -1e308, 1e6, -1e6, 0.0, -0.0, 1e-9]),
    st.text(max_size=30),
    st.sampled_from(["x" * 5000, "a\x00b", "gaussian_field", "dem", "paper", "", "~/nowhere.npz"]),
    st.lists(st.one_of(st.integers(-10, 10), st.floats(-1e3, 1e3), st.text(max_size=3)), max_size=4),
    st.dictionaries(st.text(max_size=5), st.integers(-3, 3), max_size=3),
    st.complex_numbers(max_magnitude=10),
)


def leaf_paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    """Every path into the nested dict/list ``node``, containers included."""
    paths = [prefix] if prefix else []
    if isinstance(node, dict):
        for key, value in node.items():
            paths += leaf_paths(value, (*prefix, key))
    elif isinstance(node, list):
        for i, value in enumerate(node):
            paths += leaf_paths(value, (*prefix, i))
    return paths


PATHS = leaf_paths(TINY_SCENARIO)


def replaced(data: dict, path: tuple, value: Any) -> dict:
    out = copy.deepcopy(data)
    node = out
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return out


@st.composite
def broken_scenarios(draw) -> dict:
    """The tiny scenario with one to three fields replaced by junk, and sometimes an unknown key added."""
    data = copy.deepcopy(TINY_SCENARIO)
    for _ in range(draw(st.integers(1, 3))):
        paths = leaf_paths(data)
        path = draw(st.sampled_from(paths or PATHS))
        try:
            data = replaced(data, path, draw(JUNK))
        except (KeyError, IndexError, TypeError):  # an earlier replacement removed the path
            continue
    if draw(st.booleans()):
        section = draw(st.sampled_from([None, "map", "time", "terrain", "start"]))
        target = data if section is None or not isinstance(data.get(section), dict) else data[section]
        target[draw(st.text(min_size=1, max_size=8))] = draw(JUNK)
    return data


def small_enough_to_build(scenario: Scenario) -> bool:
    """Builds of at most ~40 000 grid nodes (the fuzz checks errors, not the speed of large builds)."""
    width = (scenario.map.x_km[1] - scenario.map.x_km[0]) * 1000 / scenario.map.grid_m
    height = (scenario.map.y_km[1] - scenario.map.y_km[0]) * 1000 / scenario.map.grid_m
    return math.isfinite(width * height) and width * height <= 40_000


def check_scenario_dict(data: dict) -> None:
    try:
        scenario = Scenario.from_dict(data)
        if small_enough_to_build(scenario):
            build_scenario(scenario)
    except ScenarioError as error:
        message = str(error)
        assert "\n" not in message, message[:500]
        assert message, "an empty ScenarioError"


@DEFAULT
@given(broken_scenarios())
def test_a_broken_scenario_dict_is_a_scenario_error_or_a_scenario(data):
    check_scenario_dict(data)


@pytest.mark.slow
@SLOW
@given(broken_scenarios())
def test_ten_thousand_broken_scenario_dicts(data):
    check_scenario_dict(data)


ENV_KWARGS = {
    "UAVPenetration-v0": ["scenario", "profile", "render_mode", "threads", "max_episode_steps"],
    "UAVPenetrationRandom-v0": ["difficulty", "pool_size", "pool_seed", "profile", "render_mode", "threads"],
}
GOOD = {
    "scenario": st.sampled_from([None, "paper", TINY_SCENARIO]),
    "profile": st.sampled_from(["benchmark", "paper", None]),
    "render_mode": st.sampled_from([None, "rgb_array"]),
    "threads": st.sampled_from([None, 1, 2]),
    "max_episode_steps": st.sampled_from([None, 5]),
    "difficulty": st.sampled_from([0.0, 0.5, 1.0]),
    "pool_size": st.sampled_from([1, 4]),
    "pool_seed": st.sampled_from([None, 0, 7]),
}


@st.composite
def env_arguments(draw) -> tuple[str, dict]:
    """An env id and keyword arguments: each known one good or junk, sometimes an unknown name."""
    env_id = draw(st.sampled_from(sorted(ENV_KWARGS)))
    kwargs = {}
    for name in draw(st.lists(st.sampled_from(ENV_KWARGS[env_id]), unique=True, max_size=3)):
        # gymnasium's make reads render_mode itself (str methods) before the env sees it
        junk = st.text(max_size=12) if name == "render_mode" else JUNK
        kwargs[name] = draw(st.one_of(GOOD[name], junk) if draw(st.booleans()) else GOOD[name])
    if draw(st.integers(0, 9)) == 0:
        kwargs[draw(st.text(min_size=1, max_size=6).filter(str.isidentifier))] = draw(JUNK)
    return env_id, kwargs


@pytest.mark.filterwarnings("ignore:.*render_mode.*:UserWarning")  # gymnasium's own warning for a junk mode
@settings(max_examples=120, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(env_arguments())
def test_gym_make_with_fuzzed_keywords_works_or_refuses_in_one_line(case):
    check_env_arguments(case)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:.*render_mode.*:UserWarning")
@SLOW
@given(env_arguments())
def test_ten_thousand_fuzzed_gym_make_calls(case):
    check_env_arguments(case)


def check_env_arguments(case: tuple[str, dict]) -> None:
    env_id, kwargs = case
    try:
        env = gym.make(env_id, disable_env_checker=True, **kwargs)
    except (TypeError, ValueError, ScenarioError) as error:  # ScenarioError is a ValueError
        assert "\n" not in str(error), str(error)[:500]
        return
    try:
        env.reset(seed=0)  # a procedural scenario is generated here (the paper profile refuses it)
        _, reward, *_ = env.step(np.zeros(3, dtype=np.float32))
        assert np.isfinite(reward)
    except ScenarioError as error:
        assert "\n" not in str(error), str(error)[:500]
    finally:
        env.close()
