"""benchmarks/results_page.py's helpers on small hand-made frames (hand-computed expectations)."""

from __future__ import annotations

import json
import math

import pandas as pd
import pytest

from uav_penetration_env.benchmark.publishing import results_page as rp


def episodes(rows: list[tuple[str, str, int, float]]) -> pd.DataFrame:
    """Episode rows (policy, scenario, seed, total_cost), as ``ctg.read_part`` gives them."""
    frame = pd.DataFrame(rows, columns=["policy", "scenario", "seed", "total_cost"]).assign(outcome="success")
    frame["form"] = frame.policy.str.extract(r"-ctg-(\w+)$")[0]
    frame["planner"] = frame.policy.str.replace(r"-ctg-\w+$", "", regex=True)
    mpc = frame.planner.isin(rp.ctg.PLANNERS)
    frame.loc[mpc & frame.form.isna(), "form"] = "value"
    frame["form"] = frame.form.fillna("-")
    return frame


def write_episodes(path, rows):
    pd.DataFrame(rows, columns=["policy", "scenario", "seed", "outcome", "total_cost"]).to_parquet(path)


def test_episode_rows_reads_the_exported_rows_else_the_checkpoint_chunks_else_refuses(tmp_path):
    folder, checkpoint = tmp_path / "v3", tmp_path / "v3-checkpoint"
    folder.mkdir()
    checkpoint.mkdir()
    write_episodes(checkpoint / "chunk-001-episodes.parquet", [("ihpso", "s", 0, "success", 1.0)])
    write_episodes(checkpoint / "chunk-002-episodes.parquet", [("hpso-ctg-dubins", "s", 0, "success", 2.0),
                                                               ("greedy", "s", 0, "success", 3.0)])  # fmt: skip
    write_episodes(checkpoint / "chunk-003-episodes.parquet", [("lpso", "s", 0, "success", 4.0)])  # not in the manifest
    (checkpoint / "manifest.json").write_text(json.dumps({"seeds": [], "chunks": [{"name": "chunk-001"}, {"name": "chunk-002"}]}))
    e = rp.episode_rows(folder)
    assert list(e.policy) == ["ihpso", "hpso-ctg-dubins", "greedy"]
    assert list(e.form) == ["value", "dubins", "-"] and list(e.planner) == ["ihpso", "hpso", "greedy"]
    (folder / "rows").mkdir()
    write_episodes(folder / "rows" / "leaderboard-episodes.parquet", [("cmaes", "s", 1, "success", 5.0)])
    assert list(rp.episode_rows(folder).policy) == ["cmaes"]  # the exported rows come first
    with pytest.raises(SystemExit, match=r"other: no episode rows; expected .*other/rows/leaderboard-episodes\.parquet"):
        rp.episode_rows(tmp_path / "other")
    # a folder rebuilt elsewhere: its rows named (a checkpoint folder, or an export stem)
    assert list(rp.episode_rows(tmp_path / "other", rows=checkpoint).policy) == ["ihpso", "hpso-ctg-dubins", "greedy"]
    assert list(rp.episode_rows(tmp_path / "other", rows=folder / "rows" / "leaderboard").policy) == ["cmaes"]
    with pytest.raises(SystemExit, match=r"--rows .*nothing: no episodes table"):
        rp.episode_rows(folder, rows=tmp_path / "nothing")


def test_direction_verdict_and_flown():
    assert rp.direction(-0.3, 0.01) == -1 and rp.direction(0.3, 0.04) == 1
    assert rp.direction(0.3, 0.05) == 0 and rp.direction(-0.3, math.nan) == 0 and rp.direction(0.0, 0.001) == 0
    assert rp.verdict(1, "IHPSO", "HPSO") == "HPSO cheaper" and rp.verdict(0, "a", "b") == "no significant difference"
    assert rp.flown({"n": 3}, 6) and not rp.flown({"n": 2}, 6) and not rp.flown(None, 6)


def test_ihpso_vs_hpso_reads_hpsos_row_as_ihpso_minus_hpso():
    table = pd.DataFrame({
        "policy": ["ihpso", "hpso"], "success_rate": [1.0, 0.95], "total_cost_mean": [12.0, 11.5],
        "total_cost_iqm": [11.8, 11.4], "delta_mean": [math.nan, -0.5], "delta_mean_ci_low": [math.nan, -0.8],
        "delta_mean_ci_high": [math.nan, -0.2], "median_difference": [math.nan, -0.4],
        "pvalue_holm": [math.nan, 0.01], "nfev_per_step": [4000.0, 10000.0],
    }).set_index("policy")  # fmt: skip
    r = rp.ihpso_vs_hpso(table)
    assert (r["delta"], r["low"], r["high"], r["median"]) == (0.5, 0.2, 0.8, 0.4)
    assert r["sign"] == 1 and r["p"] == 0.01 and r["evals_share"] == 0.4 and r["hpso_success"] == 0.95
    assert rp.ihpso_vs_hpso(table.drop(index="hpso")) is None


def test_pairs_by_form_pairs_a_learned_planner_under_every_form_and_robustness_checks_each():
    rows = []
    for seed in range(6):
        rows += [("hpso", "s", seed, 10.0), ("hpso-ctg-dubins", "s", seed, 10.0), ("distill:n", "s", seed, 9.0 - seed / 10),
                 ("ihpso", "s", seed, 10.0 - (seed + 1) / 10), ("ihpso-ctg-dubins", "s", seed, 10.0 - (seed + 1) / 10)]  # fmt: skip
    for seed in range(2):  # distance flown on 2 of the 6 seeds only
        rows += [("hpso-ctg-distance", "s", seed, 10.0), ("ihpso-ctg-distance", "s", seed, 11.0)]
    e = episodes(rows)
    pairs = rp.pairs_by_form(e, "ihpso", "hpso")
    assert set(pairs) == {"value", "dubins", "distance"}
    value = pairs["value"]
    # Differences -0.1 ... -0.6 over 6 seeds: mean and median -0.35, all six negative: exact p = 2 / 2^6.
    assert value["n"] == 6 and value["unit"] == "seed" and value["a_cheaper"] == 6
    assert value["mean"] == pytest.approx(-0.35) and value["median"] == pytest.approx(-0.35)
    assert value["p"] == pytest.approx(2 / 2**6)
    assert pairs["distance"]["n"] == 2
    assert rp.robustness(-1, pairs) == "value form only"  # distance on 2 of 6 seeds: not flown on the table
    pairs["distance"] = dict(pairs["dubins"])
    assert rp.robustness(-1, pairs) == "**robust**" and rp.robustness(0, pairs) == "not robust"
    assert rp.robustness(0, {}) == "-"
    assert "distance" not in rp.form_medians({"value": value}) and rp.form_medians({}) == "-"
    # The distilled network (no terminal cost) against HPSO under each HPSO form: 9 - s/10 - 10 per seed.
    learned = rp.pairs_by_form(e, "distill:n", "hpso")
    assert set(learned) == {"value", "dubins", "distance"} and learned["distance"]["n"] == 2
    assert learned["value"]["median"] == pytest.approx(-1.25) and learned["dubins"]["a_cheaper"] == 6


def test_window_verdicts_and_counts():
    def study(budget_p, target_p, target_better, target_median=200.0):
        # median_difference is HPSO - IHPSO, paired: positive favours IHPSO
        return pd.DataFrame({
            "comparison": ["fixed budget: J", "fixed target: evaluations"], "pvalue": [budget_p, target_p],
            "reference_better": [5, target_better[0]], "other_better": [4, target_better[1]],
            "reference_median": [1.0, 3000.0], "other_median": [1.1, 3200.0], "pairs": [9, 9],
            "median_difference": [0.1, target_median],
        }).set_index("comparison")  # fmt: skip

    studies = {"a": study(0.5, 0.001, (7, 2)), "b": study(0.01, 0.001, (2, 7), -200.0), "c": study(0.2, 0.3, (5, 4))}
    assert rp.window_verdict(studies["a"].loc["fixed target: evaluations"]) == -1
    assert rp.window_verdict(studies["b"].loc["fixed budget: J"]) == -1  # HPSO's J higher in the typical pair
    assert rp.window_verdict(studies["b"].loc["fixed target: evaluations"]) == 1
    # the paired median decides against the pair wins; a zero median falls back to the wins
    assert rp.window_verdict(study(0.5, 0.001, (2, 7), 100.0).loc["fixed target: evaluations"]) == -1
    assert rp.window_verdict(study(0.5, 0.001, (2, 7), 0.0).loc["fixed target: evaluations"]) == 1
    assert rp.window_verdict(study(0.5, 0.001, (4, 4), 0.0).loc["fixed target: evaluations"]) == 0
    assert rp.window_counts(studies) == (1, 2, 3)
    text = "\n".join(rp.window_lines(studies, "../lb"))
    assert "in 1 of 3 studies" in text and "in 2 of 3." in text and "[a](../lb/a-fixed-target.md)" in text


def test_learned_entries_pick_the_cheapest_complete_members_and_the_rl_group():
    table = pd.DataFrame({
        "policy": ["distill:a", "distill-shield:b", "ps2o", "hpso", "ihpso", "sb3:x-s0", "sb3:x-s1"],
        "members": [3, 2, 3, 3, 3, 3, 3], "total_cost_iqm": [12.0, 11.0, 10.0, 10.5, 11.5, 20.0, 21.0],
        "total_cost_iqm_ci_low": [11.0] * 7, "total_cost_iqm_ci_high": [13.0] * 7,
        "success_rate": [1.0, 1.0, 1.0, 1.0, 1.0, 0.75, 1.0], "successes": [4, 4, 4, 4, 4, 3, 4],
        "episodes": [4] * 7, "planning_seconds": [0.002, 0.001, 0.08, 0.07, 0.03, 0.0003, 0.0003],
        "delta_mean": [0.5, -0.5, -1.5, -1.0, math.nan, 8.5, 9.5], "delta_mean_ci_low": [0.1] * 7,
        "delta_mean_ci_high": [0.9] * 7, "pvalue_holm": [0.04] * 7,
        "median_difference": [0.4, -0.4, -1.4, -0.9, math.nan, 8.0, 9.0],
    }).set_index("policy")  # fmt: skip
    rl = pd.DataFrame({
        "group": ["sb3:x", "sb3:y", "ihpso+sb3:z", "greedy"], "kind": ["RL group", "RL group", "RL group", "reference"],
        "members": ["sb3:x-s0 sb3:x-s1", "sb3:y-s0", "ihpso+sb3:z-s0", "greedy"], "tasks": [3, 2, 3, 3],
        "iqm": [20.5, 15.0, 14.0, 16.0], "iqm_ci_low": [20.0] * 4, "iqm_ci_high": [21.0] * 4,
        "decision_seconds": [0.0003, 0.0003, 0.02, 0.0001],
    })  # fmt: skip
    entries = rp.learned_entries(table, rl)
    assert [(e["role"], e["name"]) for e in entries] == [
        ("distilled network", "distill:a"), ("RL agent group", "sb3:x"), ("best swarm planner", "ps2o"), ("IHPSO", "ihpso")]
    group = entries[1]
    assert group["success"] == 7 / 8 and group["iqm"] == 20.5 and math.isnan(group["delta"])
    assert entries[0]["ms"] == 2.0 and entries[2]["delta"] == -1.5
    text = "\n".join(rp.learned_table({"s": entries}))
    assert "| IHPSO cheaper |" in text and "| best swarm planner cheaper |" in text  # verdicts from the medians
    relabelled = rp.relabel_group(episodes([("sb3:x-s0", "s", 0, 1.0), ("sb3:x-s1", "s", 0, 3.0), ("hpso", "s", 0, 2.0)]),
                                  rp.best_rl_group(rl))  # fmt: skip
    assert list(relabelled.planner) == ["sb3:x", "sb3:x", "hpso"]
    assert rp.best_rl_group(rl[rl.kind == "reference"]) is None and rp.best_rl_group(None) is None


def test_success_bar_counts_planners_and_formulation_variants_apart(tmp_path):
    table = pd.DataFrame({
        "policy": ["ihpso", "hpso", "cmaes", "ihpso-noterm", "ihpso-eq37", "ps2o-ctg-distance", "greedy", "distill:a"],
        "success_rate": [1.0, 0.98, 1.0, 1.0, 0.8, 1.0, 0.5, 0.5], "successes": [50, 49, 50, 50, 40, 50, 25, 25],
        "episodes": [50] * 8, "fail_goal_pass": [0, 0, 1, 0, 3, 0, 9, 9],
    }).set_index("policy")  # fmt: skip
    planners, variants, n_planners, n_variants = rp.success_bar(table, rp.goal_passes(tmp_path, "t", table))
    assert planners == ["`hpso` 49/50, 0 goal passes", "`cmaes` 50/50, 1 goal pass"] and n_planners == 4
    assert variants == ["`ihpso-eq37` 40/50, 3 goal passes"] and n_variants == 2
    lines = rp.bar_lines({"t": (planners, variants, n_planners, n_variants)})
    assert lines[0].startswith("- `t`, 4 MPC planners: 2 do not: `hpso`") and "1 of 2 below it" in lines[1]
    # A suite table has no failure kinds: summed from <suite>-members.csv, a level's members for <suite>-<level>.
    suite = table.drop(columns="fail_goal_pass")
    pd.DataFrame({"policy": ["hpso", "hpso", "cmaes"], "member_group": ["d0.25", "fixed", "fixed"],
                  "fail_goal_pass": [2, 1, 0]}).to_csv(tmp_path / "u-members.csv", index=False)  # fmt: skip
    assert rp.goal_passes(tmp_path, "u", suite)["hpso"] == 3 and rp.goal_passes(tmp_path, "u-d0.25", suite)["hpso"] == 2
    assert math.isnan(rp.goal_passes(tmp_path, "v", suite)["hpso"])


def test_tally_and_count_signs():
    assert rp.count_signs([-1, 1, 0, 1]) == (1, 2, 1)
    assert rp.tally([-1, 1, 0, 1], "A", "B") == ("A is significantly cheaper than B on 1, significantly costlier on 2 "
                                                 "and neither on 1 of 4 tables")  # fmt: skip
