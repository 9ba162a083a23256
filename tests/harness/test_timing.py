"""Planners timed side by side (api.md §4.12): cold setups, interleaved decisions, ratios with intervals."""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_scenario

from uav_penetration_env import cache
from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.policies import GreedyPolicy, LatticePolicy
from uav_penetration_env.benchmark.seeding import episode_seeds
from uav_penetration_env.benchmark.timing import ColdCache, summarise, time_map
from uav_penetration_env.env import UAVPenetrationEnv


@pytest.fixture(scope="module")
def tiny():
    return tiny_scenario(time={"max_steps": 12})


def test_the_driver_flies_its_own_episode_and_every_planner_decides_on_each_state_in_rotation(tiny):
    setups, steps = time_map({"greedy": GreedyPolicy(), "lattice": LatticePolicy()}, tiny, seed=3)
    assert list(setups["policy"]) == ["greedy", "lattice"] and (setups[["setup_cpu", "setup_wall"]] >= 0).all().all()
    k = steps["step"].max() + 1
    assert len(steps) == 2 * k and (steps.groupby("step")["policy"].nunique() == 2).all()
    firsts = steps[steps["order"] == 0].sort_values("step")["policy"].tolist()
    assert firsts == ["greedy", "lattice"] * (k // 2) + ["greedy"] * (k % 2)  # the order rotates each step
    # The episode is the driver's: as long as greedy flown alone from the same seed.
    env = UAVPenetrationEnv(tiny)
    env_seed, policy_seed = episode_seeds(3, tiny.hash)
    observation, info = env.reset(seed=env_seed)
    greedy = GreedyPolicy()
    greedy.reset(env.model, policy_seed)
    alone, done = 0, False
    while not done:
        observation, _, terminated, truncated, info = env.step(greedy.act(observation, info))
        done, alone = terminated or truncated, alone + 1
    assert k == alone


def test_a_cold_setup_builds_the_value_function_even_when_the_cache_holds_it(tiny, tmp_path, monkeypatch):
    from uav_penetration_env.value_function import value_function

    monkeypatch.setenv(cache.ENV_VAR, str(tmp_path))
    value_function(UAVPenetrationEnv(tiny).model)  # now on disk and in memory
    assert value_function(UAVPenetrationEnv(tiny).model).build_seconds == 0.0  # loaded, not built
    with ColdCache():
        assert os.environ[cache.ENV_VAR] != str(tmp_path)
        assert value_function(UAVPenetrationEnv(tiny).model).build_seconds > 0.0  # built again
    assert os.environ[cache.ENV_VAR] == str(tmp_path)


def test_ratios_by_hand_over_maps():
    # Two maps. Planner a: setup 1 s, 10 steps of 0.01 s; b (the reference): setup 0, 10 steps of 0.1 s.
    setups = pd.DataFrame({"map": ["m1", "m1", "m2", "m2"], "policy": ["a", "b", "a", "b"],
                           "setup_cpu": [1.0, 0.0, 1.0, 0.0], "setup_wall": [1.0, 0.0, 1.0, 0.0]})  # fmt: skip
    steps = pd.DataFrame([{"map": m, "policy": p, "step": k, "order": 0, "cpu": c, "wall": c}
                          for m in ("m1", "m2") for p, c in (("a", 0.01), ("b", 0.1)) for k in range(10)])  # fmt: skip
    table = summarise(setups, steps, "b", n_resamples=200).set_index("policy")
    assert table.loc["a", "step_ratio"] == pytest.approx(0.1) and table.loc["b", "step_ratio"] == pytest.approx(1.0)
    # Per map: a costs 1 + 10 × 0.01 = 1.1 s, b 10 × 0.1 = 1.0 s: a is the costlier per new map.
    assert table.loc["a", "map_cpu"] == pytest.approx(1.1) and table.loc["a", "map_ratio"] == pytest.approx(1.1)
    assert table.loc["a", "step_ratio_low"] <= 0.1 + 1e-12 <= table.loc["a", "step_ratio_high"] + 2e-12
    assert table.loc["a", "steps"] == 20 and table.loc["a", "maps"] == 2


def test_the_command_prints_the_ratios_and_writes_every_measurement(tmp_path, capsys, tiny):
    scenario = tiny.to_yaml(tmp_path / "tiny.yaml")
    out = tmp_path / "out"
    argv = ["timing", "--policies", "greedy", "random", "--scenarios", str(scenario), "--seeds", "2", "--max-steps", "3",
            "--out", str(out)]  # fmt: skip
    assert cli.main(argv) == 0
    printed = capsys.readouterr().out
    assert "step CPU / random" in printed and "| greedy " in printed
    summary = pd.read_csv(out / "timing.csv")
    steps = pd.read_csv(out / "timing-steps.csv")
    assert set(summary["policy"]) == {"greedy", "random"} and (summary["maps"] == 2).all()
    assert len(steps) == 2 * 2 * 3 and np.isfinite(steps["cpu"]).all()
    assert cli.main(["timing", "--policies", "greedy", "random", "--reference", "lattice"]) == 2
    assert "--reference: got 'lattice'" in capsys.readouterr().err
