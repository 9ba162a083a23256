"""``uav-bench run --suite``: the seed rule, the guard, resuming, and the member-weighted tables."""

from __future__ import annotations

import json
import math
import sqlite3

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_scenario

from uav_penetration_env import catalogue
from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.leaderboard.suite import equal_weight_table, recorded_suites
from uav_penetration_env.benchmark.policies import GreedyPolicy, RandomPolicy, is_deterministic, make_policy
from uav_penetration_env.suites import default_seeds, load_suite

MEMBERS = ["uavpen-v1/paper", "uavpen-v1/d0.25/30000"]


@pytest.fixture(scope="module")
def v1():
    return load_suite("uavpen-v1")


def _run(tmp_path, *extra):
    store = tmp_path / "suite.sqlite"
    argv = ["run", "--suite", "uavpen-v1", "--store", str(store), "--out", str(tmp_path / "out")]
    return cli.main([*argv, "--jobs", "1", "--no-progress", *extra]), store


def _episodes(store):
    with sqlite3.connect(store) as connection:
        return pd.read_sql_query(
            "SELECT policy, scenario, seed, total_cost, run_id FROM episodes", connection
        )


def test_which_policies_are_deterministic():
    assert is_deterministic(GreedyPolicy()) and not is_deterministic(RandomPolicy())
    assert not is_deterministic(make_policy("pso", max_evals=50))

    class Agent:  # as baselines.SB3Policy declares it
        def config(self):
            return {"kind": "sb3", "deterministic": True}

    assert is_deterministic(Agent())


def test_the_seed_rule(v1):
    paper, procedural = v1.member("uavpen-v1/paper"), v1.member("uavpen-v1/d0.50/30100")
    scenario = paper.recipe.build()
    assert default_seeds(paper, scenario, deterministic=False) == [0, 1, 2, 3, 4]
    assert default_seeds(paper, scenario, deterministic=True) == [0]
    # With start jitter a deterministic policy's seeds are no longer replicates.
    jittered = scenario.updated({"start": {"jitter": {"xy_km": 1.0}}})
    assert default_seeds(paper, jittered, deterministic=True) == [0, 1, 2, 3, 4]
    assert default_seeds(procedural, procedural.recipe.build(), deterministic=False) == [0]


def test_run_suite_flies_the_seed_rule_resumes_and_writes_the_suite_tables(tmp_path, v1, capsys):
    status, store = _run(tmp_path, "--members", *MEMBERS, "--policies", "greedy", "random")
    assert status == 0
    out = capsys.readouterr().out
    assert "suite uavpen-v1: 2 policies x 2 members (the suite's seed rule) = 8 episodes" in out
    frame = _episodes(store)
    flown = {(p, s): sorted(g["seed"]) for (p, s), g in frame.groupby(["policy", "scenario"])}
    assert flown == {
        ("greedy", "paper-2022-sec5"): [0],
        ("greedy", "random-30000"): [0],
        ("random", "paper-2022-sec5"): [0, 1, 2, 3, 4],
        ("random", "random-30000"): [0],
    }
    # The greedy episode is the replay the fingerprint froze: the same total, to the file's tolerance.
    for member in MEMBERS:
        frozen = v1.member(member)
        flown_total = frame.loc[
            (frame["policy"] == "greedy") & (frame["scenario"] == frozen.scenario), "total_cost"
        ]
        assert math.isclose(flown_total.item(), frozen.fingerprint.replay_total_j, rel_tol=1e-9)
    with sqlite3.connect(store) as connection:
        settings = json.loads(connection.execute("SELECT settings FROM runs").fetchone()[0])
    assert settings["suite"] == "uavpen-v1" and settings["members"] == MEMBERS
    names = {p.name for p in (tmp_path / "out").iterdir()}
    for stem in ("uavpen-v1", "uavpen-v1-fixed", "uavpen-v1-d0.25", "uavpen-v1-members"):
        assert {f"{stem}.md", f"{stem}.csv"} <= names
    assert "uavpen-v1-d0.50.md" not in names  # no episode on that group
    assert "uavpen-v1 (lower total J is better)" in out and "uavpen-v1-members (lower" not in out
    overall = pd.read_csv(tmp_path / "out" / "uavpen-v1.csv").set_index("policy")
    greedy = frame[frame["policy"] == "greedy"].set_index("scenario")["total_cost"]
    assert overall.loc["greedy", "total_cost_mean"] == pytest.approx(greedy.mean(), rel=1e-12)
    assert overall.loc["random", "episodes"] == 6 and overall.loc["random", "members"] == 2
    text = (tmp_path / "out" / "uavpen-v1.md").read_text()
    assert "each member weighted equally" in text and "- Estimator: each member weighs the same" in text

    status, _ = _run(tmp_path, "--members", *MEMBERS, "--policies", "greedy", "random")
    assert status == 0
    assert len(_episodes(store)) == 8  # resumed: nothing flown twice


def test_explicit_seeds_apply_to_every_member_and_policy(tmp_path):
    status, store = _run(
        tmp_path, "--members", *MEMBERS, "--policies", "greedy", "--seeds", "2", "--no-report"
    )
    assert status == 0
    assert sorted(_episodes(store)["seed"]) == [0, 0, 1, 1]


def test_a_changed_generator_constant_refuses_the_run(tmp_path, monkeypatch, capsys, v1):
    monkeypatch.setattr(catalogue, "RANDOM_SQUARE_KM", (0.0, 99.0))
    status, store = _run(tmp_path, "--policies", "greedy", "--seeds", "1")
    assert status == 2 and not store.exists()
    error = capsys.readouterr().err.strip()
    frozen = v1.member("uavpen-v1/d0.25/30000").fingerprint.scenario_hash
    changed = v1.member("uavpen-v1/d0.25/30000").recipe.build().hash
    assert error.startswith(
        "uav-bench: error: --suite: suite uavpen-v1 member uavpen-v1/d0.25/30000: scenario hash"
    )
    assert f"'{changed}' != frozen '{frozen}'" in error and len(error.splitlines()) == 1


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--scenarios", "paper"], "--scenarios: not with --suite"),
        (["--weights", "0.3,0.5,0.2"], "--weights: not with --suite"),
        (["--members", "uavpen-v1/d0.3/*"], "no member matches 'uavpen-v1/d0.3/*'"),
    ],
)
def test_run_suite_refuses_flags_that_change_members(tmp_path, capsys, extra, message):
    status, store = _run(tmp_path, "--policies", "greedy", *extra)
    assert status == 2 and message in capsys.readouterr().err and not store.exists()


def test_unknown_suite_and_members_without_suite(tmp_path, capsys):
    status, _ = cli.main(["run", "--suite", "uavpen-1", "--store", str(tmp_path / "s.sqlite")]), None
    assert status == 2 and "unknown suite 'uavpen-1' — did you mean 'uavpen-v1', 'uavpen-heldout-v1', 'uavpen-dynamic-v1'?" in capsys.readouterr().err
    assert cli.main(["run", "--members", "x", "--store", str(tmp_path / "s.sqlite")]) == 2
    assert "--members: only with --suite" in capsys.readouterr().err


def _toy_episodes():
    """Policy a: 5 seeds on member A (costs 1..5, one crash), 1 on B; policy b: 1 seed on each."""
    rows = [
        ("a", "A", s, c, o)
        for s, c, o in zip(range(5), [1.0, 2.0, 3.0, 4.0, 5.0], ["success"] * 4 + ["collided"], strict=True)
    ]
    rows += [("a", "B", 0, 10.0, "success"), ("b", "A", 0, 4.0, "success"), ("b", "B", 0, 8.0, "collided")]
    frame = pd.DataFrame(rows, columns=["policy", "member", "seed", "total_cost", "outcome"])
    frame["policy_hash"] = frame["policy"] + "-hash"
    frame["scenario"] = frame["member"].str.lower()
    frame["scenario_hash"] = frame["member"].map({"A": "a" * 16, "B": "b" * 16})
    frame["member_index"] = frame["member"].map({"A": 0, "B": 1})
    frame["member_group"] = "fixed"
    frame["error"] = ""
    return frame


def test_equal_weight_aggregation_on_a_hand_computed_frame():
    table = equal_weight_table(_toy_episodes(), reference="a", n_resamples=500).set_index("policy")
    # a: member means 3 (A) and 10 (B) -> 6.5; pooling the 6 episodes would give 25/6 = 4.17.
    assert table.loc["a", "total_cost_mean"] == pytest.approx(6.5)
    assert table.loc["b", "total_cost_mean"] == pytest.approx(6.0)
    # success: a = mean(4/5, 1) = 0.9 (pooled: 5/6); b = mean(1, 0) = 0.5.
    assert table.loc["a", "success_rate"] == pytest.approx(0.9)
    assert table.loc["b", "success_rate"] == pytest.approx(0.5)
    assert table.loc["a", ["episodes", "successes", "collided", "members"]].tolist() == [6, 5, 1, 2]
    assert table.loc["b", ["episodes", "successes", "collided", "members"]].tolist() == [2, 1, 1, 2]
    # Blocks are members: a is cheaper on A (3 < 4), b on B (8 < 10): ranks 1.5 each; b - a = (1, -2).
    assert table.loc["a", "friedman_rank"] == 1.5 and table.loc["b", "friedman_rank"] == 1.5
    assert table.loc["b", "delta_mean"] == pytest.approx(-0.5) and table.loc["b", "n_pairs"] == 2
    assert table.attrs["blocks"] == "members"
    # The IQM of two member means is their mean; its interval bootstraps the two members.
    assert table.loc["a", "total_cost_iqm"] == pytest.approx(6.5)
    assert (
        table.loc["a", "total_cost_mean_ci_low"] >= 3.0 and table.loc["a", "total_cost_mean_ci_high"] <= 10.0
    )


def test_error_rows_count_but_do_not_enter_the_means():
    frame = _toy_episodes()
    broken = frame.iloc[[0]].assign(seed=9, total_cost=np.nan, outcome="error", error="ValueError: boom")
    table = equal_weight_table(pd.concat([frame, broken], ignore_index=True), reference="a", n_resamples=200)
    row = table.set_index("policy").loc["a"]
    assert row["errors"] == 1 and row["episodes"] == 6 and row["total_cost_mean"] == pytest.approx(6.5)


def test_recorded_suites_reads_run_settings():
    runs = pd.DataFrame({"settings": ['{"suite": "uavpen-v1"}', '{"seeds": [0]}', None, "not json"]})
    assert recorded_suites(runs) == ["uavpen-v1"]


def test_the_report_section_shows_the_group_means(tmp_path):
    from uav_penetration_env.benchmark.report import ReportContext, sections

    status, store = _run(tmp_path, "--members", *MEMBERS, "--policies", "greedy", "--no-report")
    assert status == 0
    render = {s.key: s.render for s in sections()}["suite"]
    context = ReportContext(store, tmp_path)
    try:
        page = render(context)
    finally:
        context.store.close()
    assert "<h3>uavpen-v1</h3>" in page and "2 of 63 members have episodes" in page
    assert "<th>d0.25</th>" in page and "<th>fixed</th>" in page


def test_leaderboard_refuses_a_pooled_table_under_a_frozen_suite_name(tmp_path, capsys):
    status, store = _run(tmp_path, "--members", "uavpen-v1/paper", "--policies", "greedy", "--no-report")
    assert status == 0
    argv = ["leaderboard", "--store", str(store), "--out", str(tmp_path / "lb"), "--suite", "uavpen-v1"]
    assert cli.main(argv) == 2
    assert "--suite uavpen-v1: names a frozen suite" in capsys.readouterr().err
    assert cli.main([*argv[:-2]]) == 0  # without --suite: the frozen suite's own tables
    assert (tmp_path / "lb" / "uavpen-v1.md").is_file()


def test_suite_tables_recompute_from_exported_rows(tmp_path):
    """The published suite tables must be rebuilt from committed rows alone."""
    status, store = _run(tmp_path, "--members", *MEMBERS, "--policies", "greedy", "random", "--no-report")
    assert status == 0
    assert cli.main(["leaderboard", "--store", str(store), "--out", str(tmp_path / "from-store")]) == 0
    assert (
        cli.main(
            ["export", "--format", "parquet", "--store", str(store), "--out", str(tmp_path / "rows" / "s")]
        )
        == 0
    )
    assert (
        cli.main(
            ["leaderboard", "--rows", str(tmp_path / "rows" / "s"), "--out", str(tmp_path / "from-rows")]
        )
        == 0
    )
    volatile = ("- Date: ",)
    for stem in ("uavpen-v1", "uavpen-v1-fixed", "uavpen-v1-d0.25", "uavpen-v1-members"):
        expected, got = tmp_path / "from-store", tmp_path / "from-rows"
        assert (got / f"{stem}.csv").read_bytes() == (expected / f"{stem}.csv").read_bytes()
        lines = [
            [x for x in (folder / f"{stem}.md").read_text().splitlines() if not x.startswith(volatile)]
            for folder in (expected, got)
        ]
        assert lines[0] == lines[1]


def test_gap_columns_are_member_weighted(monkeypatch):
    """With best-known records (J* = 2 on A, 8 on B) the gap columns weigh members equally too."""
    from uav_penetration_env.benchmark import bestknown

    records = {"a" * 16: 2.0, "b" * 16: 8.0}
    monkeypatch.setattr(bestknown, "best_known_total", records.get)
    table = equal_weight_table(_toy_episodes(), reference="a", n_resamples=200).set_index("policy")
    # a: gap of the member means (3 - 2)/2 = 0.5 and (10 - 8)/8 = 0.25 -> 0.375; b: 1 and 0 -> 0.5.
    assert table.loc["a", "gap_mean"] == pytest.approx(0.375) and table.loc["b", "gap_mean"] == pytest.approx(
        0.5
    )
    # within 10 %: a has 2 of 5 episodes on A (costs 1, 2) and 0 of 1 on B -> 0.2; b: 0 and 1 -> 0.5.
    assert table.loc["a", "within_10pct"] == pytest.approx(0.2) and table.loc[
        "b", "within_10pct"
    ] == pytest.approx(0.5)
    assert table.loc["a", "within_1pct"] == pytest.approx(0.2)  # cost 1 and cost 2 (gap 0) on A


def test_a_suite_that_cannot_be_loaded_is_named_not_silently_dropped(tmp_path):
    from uav_penetration_env.benchmark.evaluate import evaluate
    from uav_penetration_env.benchmark.leaderboard import write_leaderboards
    from uav_penetration_env.benchmark.policies import make_policy

    store = tmp_path / "run.sqlite"
    evaluate({"greedy": make_policy("greedy")}, [tiny_scenario(time={"max_steps": 5})], range(1), store=store,
             progress=False)  # fmt: skip
    missing = tmp_path / "moved-suite.yaml"
    with sqlite3.connect(store) as connection:  # as a `run --suite FILE` whose file has since moved
        connection.execute("UPDATE runs SET settings = ?", (json.dumps({"suite": str(missing)}),))
    with pytest.warns(UserWarning, match=f"suite {missing} .*member-weighted tables are left out"):
        written = write_leaderboards(store, tmp_path / "out", command="test")
    assert [p.name for p in written] == ["tiny.md", "tiny.csv"]  # the other tables are still written


def test_suite_tables_add_the_rl_table_over_the_members(tmp_path):
    """Agents of two training seeds and greedy on two held-out members: the RL section pools the seeds."""
    from uav_penetration_env.benchmark.leaderboard.registry import TableContext
    from uav_penetration_env.benchmark.leaderboard.suite import write_suite_tables

    held_out = load_suite("uavpen-heldout-v1")
    members = held_out.members[:2]
    costs = {"sb3:ppo-random-s0": (10.0, 14.0), "sb3:ppo-random-s1": (12.0, 16.0), "greedy": (13.0, 15.0)}
    from uav_penetration_env.benchmark.rows import store_tables
    from uav_penetration_env.benchmark.store import ResultsStore

    with ResultsStore(tmp_path / "h.sqlite") as store:
        for index, (policy, values) in enumerate(costs.items()):
            for member, cost in zip(members, values, strict=True):
                store.write_episode({"policy": policy, "policy_hash": f"{index:016d}", "scenario": member.scenario,
                                     "scenario_hash": member.fingerprint.scenario_hash, "seed": 0,
                                     "outcome": "success", "total_J": cost, "total_penalty": 0.0, "total_cost": cost,
                                     "planning_seconds": 1e-4, "steps": 40, "error": ""}, [])  # fmt: skip
    episodes = store_tables(tmp_path / "h.sqlite").episodes
    runs = pd.DataFrame({"run_id": [1], "started": ["2026-11-29T00:00:00+00:00"],
                         "provenance": ['{"command": "test"}'], "settings": ['{"suite": "uavpen-heldout-v1"}']})  # fmt: skip
    context = TableContext(tmp_path, tmp_path, episodes, runs, "greedy", 0, "test", 400, "today")
    written = {p.name for p in write_suite_tables(context, "uavpen-heldout-v1")}
    assert {"uavpen-heldout-v1.md", "uavpen-heldout-v1.csv", "uavpen-heldout-v1-rl.csv"} <= written
    rl = pd.read_csv(tmp_path / "uavpen-heldout-v1-rl.csv").set_index("group")
    # Runs: the seeds' scores (10, 14) and (12, 16); tasks: the 2 members; greedy 13 and 15.
    assert (rl.loc["sb3:ppo-random", "runs"], rl.loc["sb3:ppo-random", "tasks"]) == (2, 2)
    assert rl.loc["sb3:ppo-random", "mean"] == pytest.approx(13.0)
    assert rl.loc["sb3:ppo-random", "delta_greedy"] == pytest.approx(-1.0)  # (11 - 13 + 15 - 15) / 2
    assert "## RL agents over training seeds" in (tmp_path / "uavpen-heldout-v1.md").read_text()


def test_figures_add_the_aggregate_figures_of_a_recorded_suite(tmp_path):
    from uav_penetration_env.benchmark.figures import FIGURES, SCENARIO_FIGURES, write_figures

    status, store = _run(tmp_path, "--members", *MEMBERS, "--policies", "greedy", "random", "--no-report")
    assert status == 0
    names = {p.name for p in write_figures(store, tmp_path / "figures", formats=("png",), min_seeds=2)}
    aggregate = [f for f in FIGURES if f not in SCENARIO_FIGURES]
    assert {f"uavpen-v1-{f}.png" for f in aggregate} <= names
    assert not any(n.startswith("uavpen-v1-") and n[len("uavpen-v1-") : -4] in SCENARIO_FIGURES for n in names)
    # The paper member (random floor: 5 seeds) still gets its own figures; the one-seed member does not.
    assert "paper-2022-sec5-cost-box.png" in names and not any(n.startswith("random-30000-") for n in names)
