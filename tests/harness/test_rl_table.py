"""The RL table and the compute points: agents pooled over training seeds, hand-computed values."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from uav_penetration_env.benchmark.leaderboard import (
    compute_points,
    rl_markdown,
    rl_table,
    write_leaderboards,
)
from uav_penetration_env.benchmark.leaderboard.rl import methods, rl_group_label, run_scores
from uav_penetration_env.benchmark.store import ResultsStore
from uav_penetration_env.benchmark.summary import print_summary

# Per policy: the total costs of seeds 0 and 1 on one scenario, and the seconds per action.
COSTS = {
    "sb3:ppo-paper-s0": ([20.0, 20.0], 1e-4),
    "sb3:ppo-paper-s1": ([22.0, 24.0], 1e-4),
    "sb3:ppo-paper-s2": ([18.0, 18.0], 1e-4),
    "sb3:ppo-paper-s3": ([30.0, 30.0], 3e-4),
    "greedy": ([21.0, 21.0], 5e-5),
    "ihpso": ([15.0, 25.0], 0.2),  # mean 20: not the best paper planner
    "hpso": ([19.0, 19.0], 0.3),  # mean 19: the best
    "cmaes": ([10.0, 10.0], 0.5),  # cheaper, but no paper planner
}


def episode_rows(costs=COSTS, scenario="s", scenario_hash="h") -> list[dict]:
    rows = []
    for index, (policy, (values, seconds)) in enumerate(costs.items()):
        for seed, cost in enumerate(values):
            trained = policy.startswith("sb3:")
            rows.append(
                {
                    "policy": policy, "policy_hash": f"{index:016d}", "scenario": scenario,
                    "scenario_hash": scenario_hash, "seed": seed, "outcome": "success", "total_J": cost,
                    "total_penalty": 0.0, "total_cost": cost, "planning_seconds": seconds, "steps": 10,
                    "train_timesteps": 1000 * (index + 1) if trained else None,
                    "train_seconds": 10.0 * (index + 1) if trained else None, "error": "",
                }
            )  # fmt: skip
    return rows


def test_agents_are_grouped_by_label_without_the_training_seed():
    assert rl_group_label("sb3:ppo-paper-s12") == "sb3:ppo-paper"
    assert rl_group_label("ihpso+sb3:ppo-paper-s0") == "ihpso+sb3:ppo-paper"
    assert rl_group_label("sb3:ppo-final") == "sb3:ppo-final"  # no seed suffix: a group of one
    found = {m.label: m for m in methods(pd.DataFrame(episode_rows()))}
    assert found["sb3:ppo-paper"].members == tuple(f"sb3:ppo-paper-s{i}" for i in range(4))
    assert found["sb3:ppo-paper"].grouped and not found["greedy"].grouped


def test_run_scores_are_training_seed_means_for_groups_and_episode_seeds_otherwise():
    frame = pd.DataFrame(episode_rows())
    found = {m.label: m for m in methods(frame)}
    from uav_penetration_env.benchmark.leaderboard import prepare_episodes

    frame = prepare_episodes(frame)
    group = run_scores(frame, found["sb3:ppo-paper"])
    assert group["h"].tolist() == [20.0, 23.0, 18.0, 30.0]  # each training seed's mean over its episodes
    assert run_scores(frame, found["ihpso"])["h"].tolist() == [15.0, 25.0]  # one run per episode seed


def test_rl_table_by_hand():
    table = rl_table(pd.DataFrame(episode_rows()), n_resamples=400)
    assert table["group"].tolist() == ["sb3:ppo-paper", "greedy", "hpso"]
    assert table["kind"].tolist() == ["RL group", "reference", "reference"]
    assert table.attrs["best_planner"] == "hpso"  # cmaes is cheaper but no swarm planner of the paper
    group = table.iloc[0]
    assert (group["runs"], group["tasks"], group["episodes"]) == (4, 1, 8)
    # Runs 20, 23, 18, 30: IQM = mean(20, 23) = 21.5 (one of four trimmed at each end); mean 22.75.
    assert group["iqm"] == pytest.approx(21.5) and group["mean"] == pytest.approx(22.75)
    assert group["iqm_ci_low"] <= 21.5 <= group["iqm_ci_high"]
    # Against greedy (21, 21): 20 and 18 are cheaper, 2 x 2 of 8 pairs -> 0.5; against hpso (19, 19):
    # only 18 is cheaper -> 2 of 8 pairs = 0.25.
    assert group["poi_greedy"] == pytest.approx(0.5) and group["poi_planner"] == pytest.approx(0.25)
    assert group["poi_greedy_ci_low"] <= 0.5 <= group["poi_greedy_ci_high"]
    # Paired difference to greedy (21): mean of the runs 22.75 - 21 = 1.75; with one scenario the
    # interval resamples the four training seeds: the mean of four draws from {20, 23, 18, 30}, minus 21.
    assert group["delta_greedy"] == pytest.approx(1.75)
    assert 18.0 - 21.0 <= group["delta_greedy_ci_low"] < 1.75 < group["delta_greedy_ci_high"] <= 30.0 - 21.0
    assert group["decision_seconds"] == pytest.approx(1.5e-4)  # mean over the group's 8 episodes
    assert group["train_timesteps"] == pytest.approx(2500.0)  # members trained 1000..4000 steps
    greedy, hpso = table.iloc[1], table.iloc[2]
    assert np.isnan(greedy["poi_greedy"]) and greedy["poi_planner"] == 0.0 and hpso["poi_greedy"] == 1.0
    assert (greedy["iqm"], greedy["iqm_ci_low"], greedy["iqm_ci_high"]) == (21.0, 21.0, 21.0)
    text = rl_markdown(table)
    assert text.startswith("## RL agents over training seeds")
    assert "the variation that counts is across training seeds" in text
    assert "P(< hpso) [95% CI]" in text and "| hpso (reference) " in text
    assert "Δ vs greedy [95% CI]" in text and "1.75 [" in text


def test_a_suite_stratifies_by_scenario():
    a = episode_rows(scenario="a", scenario_hash="ha")
    b = episode_rows({k: ([v + 10.0 for v in values], s) for k, (values, s) in COSTS.items()}, "b", "hb")
    from uav_penetration_env.benchmark.leaderboard import suite_group

    group = suite_group(pd.DataFrame(a + b), "suite")
    table = rl_table(group.episodes, n_resamples=300)
    row = table.iloc[0]
    assert (row["runs"], row["tasks"], row["episodes"]) == (4, 2, 16)
    assert row["mean"] == pytest.approx(22.75 + 5.0)  # tasks weigh alike: (22.75 + 32.75) / 2
    # Per scenario the pairs are the same as in one scenario, so the average over tasks is too.
    assert row["poi_greedy"] == pytest.approx(0.5) and row["poi_planner"] == pytest.approx(0.25)
    assert row["delta_greedy"] == pytest.approx(1.75)  # both scenarios shifted alike: the same difference
    hpso = table[table["group"] == "hpso"].iloc[0]
    assert hpso["delta_greedy"] == pytest.approx(-2.0)  # 19 vs 21 and 29 vs 31, every resample alike
    assert (hpso["delta_greedy_ci_low"], hpso["delta_greedy_ci_high"]) == (pytest.approx(-2.0), pytest.approx(-2.0))


def test_no_agents_no_table():
    rows = [r for r in episode_rows() if not r["policy"].startswith("sb3:")]
    table = rl_table(pd.DataFrame(rows), n_resamples=100)
    assert table.empty and rl_markdown(table) == ""


def test_compute_points_pool_agents_and_give_intervals():
    points = compute_points(pd.DataFrame(episode_rows()), n_resamples=300).set_index("method")
    assert set(points.index) == {"sb3:ppo-paper", "greedy", "ihpso", "hpso", "cmaes"}
    agents = points.loc["sb3:ppo-paper"]
    assert agents["runs"] == 4 and agents["family"] == "RL agents"
    assert agents["decision_seconds"] == pytest.approx(1.5e-4)  # mean over the 4 training seeds
    assert agents["decision_seconds_ci_low"] == pytest.approx(1e-4)  # every resample draws 1e-4 or 3e-4
    assert agents["total_cost"] == pytest.approx(22.75)
    assert points.loc["hpso", "decision_seconds"] == pytest.approx(0.3)
    assert np.isnan(points.loc["greedy", "train_timesteps"]) and agents["train_seconds"] == pytest.approx(
        25.0
    )


def test_write_leaderboards_adds_the_rl_section_and_csv(tmp_path, capsys):
    store = tmp_path / "rl.sqlite"
    with ResultsStore(store) as results:
        for row in episode_rows():
            results.write_episode(row, [])
    written = write_leaderboards(store, tmp_path / "out", reference="greedy", n_resamples=200)
    assert [p.name for p in written] == ["s.md", "s.csv", "s-rl.csv"]
    assert "## RL agents over training seeds" in written[0].read_text()
    table = pd.read_csv(written[2])
    assert table["group"].tolist() == ["sb3:ppo-paper", "greedy", "hpso"]
    print_summary(written)  # the RL CSV is listed, not summarised as a policy leaderboard
    printed = capsys.readouterr().out
    assert "full table: " in printed and printed.count("(lower total J is better)") == 1


def test_the_gap_to_the_best_known_is_the_mean_of_the_rows_episode_gaps(monkeypatch):
    from uav_penetration_env.benchmark import bestknown

    monkeypatch.setattr(bestknown, "best_known_total", lambda h: 16.0 if h == "h" else None)
    table = rl_table(pd.DataFrame(episode_rows()), n_resamples=200).set_index("group")
    # ppo episodes 20, 20, 22, 24, 18, 18, 30, 30 against J* = 16: mean cost 22.75 -> (22.75 - 16) / 16
    assert table.loc["sb3:ppo-paper", "gap"] == pytest.approx(6.75 / 16)
    assert table.loc["greedy", "gap"] == pytest.approx(5.0 / 16)
    assert "42.19%" in rl_markdown(table.reset_index())  # 6.75 / 16 = 42.1875 %
    monkeypatch.setattr(bestknown, "best_known_total", lambda h: None)  # no record: no gap
    assert np.isnan(rl_table(pd.DataFrame(episode_rows()), n_resamples=200)["gap"]).all()
