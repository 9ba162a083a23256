"""Suite leaderboards: one table over several scenarios, paired by (scenario, seed) blocks."""

from __future__ import annotations

import numpy as np
import pandas as pd
from conftest import tiny_scenario

from uav_penetration_env.benchmark.evaluate import evaluate
from uav_penetration_env.benchmark.figures import write_figures
from uav_penetration_env.benchmark.leaderboard import leaderboard_table, suite_group, write_leaderboards
from uav_penetration_env.benchmark.policies import GreedyPolicy, RandomPolicy


def test_suite_blocks_are_scenario_seed_pairs():
    episodes = pd.DataFrame(
        {
            "policy": ["a", "b"] * 4,
            "policy_hash": ["ha", "hb"] * 4,
            "scenario": ["s1"] * 4 + ["s2"] * 4,
            "scenario_hash": ["h1"] * 4 + ["h2"] * 4,
            "seed": [0, 0, 1, 1, 0, 0, 1, 1],
            "outcome": ["success"] * 8,
            "error": [""] * 8,
            "total_cost": [1.0, 2.0, 1.5, 2.5, 3.0, 2.0, 4.0, 5.0],
        }
    )
    group = suite_group(episodes, "held-out")
    assert group.scenarios == ("s1", "s2") and group.stem == "held-out"
    # (h1, 0) -> 0, (h1, 1) -> 1, (h2, 0) -> 2, (h2, 1) -> 3: four complete blocks of two policies.
    assert group.episodes["seed"].tolist() == [0, 0, 1, 1, 2, 2, 3, 3]
    assert group.episodes["episode_seed"].tolist() == [0, 0, 1, 1, 0, 0, 1, 1]
    table = leaderboard_table(group.episodes, reference="a", n_resamples=200).set_index("policy")
    assert table.loc["a", "total_cost_mean"] == np.mean([1.0, 1.5, 3.0, 4.0])
    # a wins blocks 0, 1 and 3, b wins block 2: average ranks 1.25 and 1.75.
    assert table.loc["a", "friedman_rank"] == 1.25 and table.loc["b", "friedman_rank"] == 1.75


def test_suite_leaderboard_and_figures_from_a_store(tmp_path):
    scenarios = [
        tiny_scenario(name="tiny-a", time={"max_steps": 12}),
        tiny_scenario(name="tiny-b", terrain={"seed": 5}, time={"max_steps": 12}),
    ]
    store = tmp_path / "suite.sqlite"
    evaluate(
        {"greedy": GreedyPolicy(), "random": RandomPolicy()}, scenarios, range(2), store=store, progress=False
    )
    written = write_leaderboards(store, tmp_path, reference="greedy", suite="tiny-suite", n_resamples=200)
    assert [p.name for p in written] == ["tiny-suite.md", "tiny-suite.csv"]
    text = written[0].read_text()
    assert (
        "Suite: tiny-suite (2 scenarios: tiny-a, tiny-b" in text
        and "Blocks: 4 (scenario, seed) pairs" in text
    )
    table = pd.read_csv(written[1])
    assert set(table["policy"]) == {"greedy", "random"} and (table["episodes"] == 4).all()
    figures = write_figures(store, tmp_path, formats=("png",), suite="tiny-suite")
    assert [p.name for p in figures] == [
        "tiny-suite-j-per-point.png", "tiny-suite-cost-box.png", "tiny-suite-performance-profile.png", "tiny-suite-convergence.png",
        "tiny-suite-compute-axis.png", "tiny-suite-rl-profile.png",
    ]  # fmt: skip


def test_significance_direction_follows_the_median_not_a_crash_skewed_mean():
    """One crash of the reference makes the mean difference negative while the policy is costlier on 19 of 20 seeds."""
    from uav_penetration_env.benchmark.leaderboard import statistics_paragraph

    seeds = list(range(20))
    ref = [10.0] * 19 + [200.0]
    other = [11.0] * 20
    episodes = pd.DataFrame(
        {
            "policy": ["ref"] * 20 + ["b"] * 20,
            "policy_hash": ["hr"] * 20 + ["hb"] * 20,
            "scenario": "s",
            "scenario_hash": "h",
            "seed": seeds + seeds,
            "outcome": ["success"] * 19 + ["collided"] + ["success"] * 20,
            "error": "",
            "total_cost": ref + other,
        }
    )
    table = leaderboard_table(episodes, reference="ref", n_resamples=200)
    row = table.set_index("policy").loc["b"]
    assert row["delta_mean"] < 0 < row["median_difference"]
    assert row["pvalue_holm"] < 0.05
    text = statistics_paragraph(table)
    assert "Significantly costlier than `ref`: `b`" in text and "cheaper" not in text
