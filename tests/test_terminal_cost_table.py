"""The terminal-cost table (uav_penetration_env.benchmark.publishing.terminal_cost_table) on hand-made rows."""

from __future__ import annotations

import pandas as pd
import pytest

from uav_penetration_env.benchmark.publishing import terminal_cost_table


def test_terminal_cost_table_pairs_per_scenario_and_checks_each_conclusion_per_form(tmp_path):
    module = terminal_cost_table
    # Two scenarios x three seeds. Under `value` (the bare names) IHPSO is exactly 1.0 cheaper than
    # HPSO in every pair; under `distance` exactly 1.0 dearer, and one HPSO episode fails.
    rows = []
    for scenario, base in (("a", 10.0), ("b", 20.0)):
        for seed in range(3):
            rows += [("ihpso", scenario, seed, "success", base + seed), ("hpso", scenario, seed, "success", base + seed + 1),
                     ("ihpso-ctg-distance", scenario, seed, "success", base + seed + 2),
                     ("hpso-ctg-distance", scenario, seed, "collided" if (scenario, seed) == ("a", 0) else "success",
                      base + seed + 1), ("greedy", scenario, seed, "success", 99.0)]  # fmt: skip
    path = tmp_path / "episodes.csv"
    pd.DataFrame(rows, columns=["policy", "scenario", "seed", "outcome", "total_cost"]).to_csv(
        path, index=False
    )
    assert module.main(["--part", f"suite={path}", "--out", str(tmp_path / "out")]) == 0
    e = module.read_part([path], "value")
    assert set(e[e.planner == "greedy"].form) == {"-"} and set(e[e.planner == "ihpso"].form) == {
        "value",
        "distance",
    }
    value = module.paired(e, "value")
    assert (value["unit"], value["n"], value["mean"], value["low"], value["high"]) == (
        "scenario",
        2,
        -1.0,
        -1.0,
        -1.0,
    )
    assert module.paired(e, "distance")["mean"] == 1.0
    table = module.planner_table(e)
    ihpso = table[(table.planner == "ihpso") & (table.form == "value")].iloc[0]
    assert (ihpso.episodes, ihpso.success, ihpso.mean_rank) == (6, 1.0, 1.0)
    assert table[(table.planner == "hpso") & (table.form == "distance")].success.iloc[0] == 5 / 6
    text = (tmp_path / "out" / "sensitivity.md").read_text()
    # 5 of 6 is below the 99 % bar under distance only; the cheapest planner flips with the form.
    assert (
        "| every MPC planner reaches the goal in at least 99% of episodes | yes | – | no | depends on the form |"
        in text
    )
    assert "| ihpso has the lowest mean total cost | yes | – | no | depends on the form |" in text
    csv = pd.read_csv(tmp_path / "out" / "sensitivity.csv")
    assert set(csv.part) == {"suite"} and len(csv) == 5


def test_terminal_cost_table_refuses_a_malformed_part(tmp_path, capsys):
    module = terminal_cost_table
    with pytest.raises(SystemExit):
        module.main(["--part", "no-equals-sign", "--out", str(tmp_path)])
    assert "expected NAME=PATH" in capsys.readouterr().err


def test_terminal_cost_table_within_keeps_a_suite_by_its_seed_rule_or_one_scenario():
    """One export holds every scenario (leaderboard v3): ``--within`` keeps what ``run --suite`` flies."""
    import pandas as pd

    module = terminal_cost_table
    # the suite rule (docs/suite.md §4): seeds 0-4 on a fixed member, seed 0 on a procedural one
    rows = [("paper-2022-sec5", s) for s in range(7)] + [
        ("random-30000", 0),
        ("random-30000", 1),
        ("random-10000", 0),
    ]
    e = pd.DataFrame(rows, columns=["scenario", "seed"]).assign(policy="ihpso")
    suite = module.within(e, "uavpen-v1")
    assert list(zip(suite.scenario, suite.seed, strict=True)) == [
        ("paper-2022-sec5", s) for s in range(5)
    ] + [("random-30000", 0)]
    assert module.within(e, "random-30000").seed.tolist() == [0, 1]
    with pytest.raises(SystemExit, match=r"^--within: 'nowhere' is neither a suite nor a scenario"):
        module.within(e, "nowhere")
