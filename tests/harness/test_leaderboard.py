"""Leaderboards on a synthetic store whose expected table is computable by hand."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest
from conftest import successful_episode, tiny_scenario

from uav_penetration_env.benchmark import leaderboard as lb
from uav_penetration_env.benchmark.columns import legend_lines
from uav_penetration_env.benchmark.provenance import provenance
from uav_penetration_env.benchmark.store import ResultsStore

SEEDS = range(8)
# Cost of seed s: offset + s. Every seed orders the policies ppo < ihpso < pso < greedy.
OFFSETS = {"ihpso": 10.0, "pso": 12.0, "greedy": 20.0, "ppo": 8.0}
STEPS = 10


def episode(policy: str, seed: int, scenario: str = "tiny", scenario_hash: str = "a" * 16, **changes) -> dict:
    cost = OFFSETS.get(policy, 5.0) + seed
    row = successful_episode(policy, seed, scenario, scenario_hash, cost) | {
        "mean_J": cost / STEPS,
        "terrain_total": 1.0,
        "radar_total": 2.0 * cost,
        "third_total": 0.1,
        "fuel_kg": 0.5,
        "p_detected": 0.25,
        "detected_steps": 2,
        "max_detection_prob": 0.6,
        "path_length_km": 30.0,
        "steps": STEPS,
        "nfev": 1000 * STEPS if policy in ("ihpso", "pso") else 0,
        "nfev_per_step": 1000.0 if policy in ("ihpso", "pso") else 0.0,
        "planning_seconds": 0.01,
        "weights": "0.3,0.4,0.3",
        "profile": "benchmark",
        "horizon": 5 if policy in ("ihpso", "pso") else None,
        "max_evals": 1000 if policy in ("ihpso", "pso") else None,
        "error": "",
    }
    if policy == "ppo":
        row |= {"train_timesteps": 100_000, "train_seconds": 50.0}
    if policy == "pso" and seed == 7:  # a crash: ΣJ 9 + penalty 10 = the same total cost 19
        row |= {"outcome": "collided", "total_J": 9.0, "total_penalty": 10.0}
    if policy == "ppo" and seed in (0, 1):
        row["outcome"] = "truncated"
    return row | changes


def write_store(path, extra_groups: bool = False):
    with ResultsStore(path) as store:
        run_id = store.start_run(provenance("uav-bench run --seeds 8"), {"seeds": list(SEEDS)})
        store.register({}, {"a" * 16: ("tiny", "name: tiny\n")})
        for seed in SEEDS:
            for policy in OFFSETS:
                store.write_episode(episode(policy, seed) | {"run_id": run_id}, [])
        # A harness error: must count in `errors` and nowhere else (its cost of 0 would drag the mean).
        store.write_episode(
            episode("greedy", 8, outcome="error", total_cost=0.0, total_J=0.0, error="RuntimeError: boom"), []
        )
        if extra_groups:
            # Same name, another hash (e.g. other weights), and a name that needs sanitising.
            for seed in range(3):
                for policy in ("ihpso", "greedy"):
                    store.write_episode(
                        episode(policy, seed, scenario_hash="b" * 16, weights="0.3,0.5,0.2"), []
                    )
                    store.write_episode(
                        episode(policy, seed, scenario="my scenario/2", scenario_hash="c" * 16), []
                    )
    return path


@pytest.fixture(scope="module")
def store_path(tmp_path_factory):
    return write_store(tmp_path_factory.mktemp("lb") / "results.sqlite")


@pytest.fixture(scope="module")
def table(store_path):
    with ResultsStore(store_path) as store:
        episodes = store.episodes()
    return lb.leaderboard_table(episodes, reference="ihpso", seed=0, n_resamples=2000)


def test_rows_sorted_by_friedman_rank(table):
    assert table["policy"].tolist() == ["ppo", "ihpso", "pso", "greedy"]
    assert table["friedman_rank"].tolist() == [1.0, 2.0, 3.0, 4.0]
    friedman = table.attrs["friedman"]
    assert friedman.blocks == 8  # seed 8 has only greedy's error row
    assert friedman.statistic == pytest.approx(24.0)  # 12/(8*4*5) * (8^2+16^2+24^2+32^2) - 3*8*5


def test_hand_computed_means_and_success(table):
    row = table.set_index("policy")
    assert row["total_cost_mean"].to_dict() == pytest.approx(
        {"ppo": 11.5, "ihpso": 13.5, "pso": 15.5, "greedy": 23.5}
    )
    assert row.loc["ihpso", "total_cost_iqm"] == pytest.approx(13.5)  # mean of 12..15
    assert row.loc["pso", "total_J_mean"] == pytest.approx((sum(12 + s for s in range(7)) + 9) / 8)
    assert row.loc["ihpso", "mean_J"] == pytest.approx(1.35)
    assert row.loc["ihpso", "radar_total"] == pytest.approx(27.0)
    assert row["successes"].to_dict() == {"ppo": 6, "ihpso": 8, "pso": 7, "greedy": 8}
    assert row.loc["pso", "collided"] == 1 and row.loc["ppo", "truncated"] == 2
    assert row.loc["pso", "success_rate"] == 7 / 8
    low, high = row.loc["pso", ["success_rate_ci_low", "success_rate_ci_high"]]
    assert low < 7 / 8 < high
    mean_low, mean_high = row.loc["ihpso", ["total_cost_mean_ci_low", "total_cost_mean_ci_high"]]
    assert 10.0 <= mean_low < 13.5 < mean_high <= 17.0


def test_error_rows_count_but_stay_out_of_the_statistics(table):
    greedy = table.set_index("policy").loc["greedy"]
    assert greedy["episodes"] == 8 and greedy["errors"] == 1
    assert greedy["total_cost_mean"] == pytest.approx(23.5)
    assert greedy["n_pairs"] == 8


def test_comparison_with_the_reference(table):
    row = table.set_index("policy")
    assert row["delta_mean"].drop("ihpso").to_dict() == pytest.approx(
        {"ppo": -2.0, "pso": 2.0, "greedy": 10.0}
    )
    assert row.loc["ihpso", ["delta_mean", "pvalue_holm"]].isna().all()
    # 8 pairs, all the same sign: exact p = 2 / 2^8; three comparisons, all equal -> Holm x 3.
    assert row.loc["pso", "pvalue"] == pytest.approx(2 / 256)
    assert row.loc[["ppo", "pso", "greedy"], "pvalue_holm"].tolist() == pytest.approx([3 * 2 / 256] * 3)
    assert row.loc["pso", ["delta_mean_ci_low", "delta_mean_ci_high"]].tolist() == [2.0, 2.0]


def test_rl_training_columns(table):
    row = table.set_index("policy")
    assert row.loc["ppo", "train_timesteps"] == 100_000
    assert row.loc["ppo", "train_seconds"] == 50.0
    assert row.loc[["ihpso", "pso", "greedy"], "train_timesteps"].isna().all()


def test_one_group_only(store_path):
    path = write_store(store_path.parent / "two.sqlite", extra_groups=True)
    with ResultsStore(path) as store:
        episodes = store.episodes()
    with pytest.raises(ValueError, match="scenario group"):
        lb.leaderboard_table(episodes)


def test_formatters():
    assert lb.format_number(12.3456) == "12.35"
    assert lb.format_number(0.000123456) == "0.0001235"
    assert lb.format_number(123456.7) == "123457"
    assert lb.format_number(float("nan")) == ""
    assert lb.format_number(0) == "0"
    assert lb.format_pvalue(0.0004) == "<0.001"
    assert lb.format_pvalue(0.0234375) == "0.023"
    assert lb.compact_ranges([9, 0, 1, 2, 3, 5, 7, 8]) == "0–3, 5, 7–9"
    assert lb.compact_ranges([4]) == "4"
    table = lb.markdown_table(["a", "b"], [["x|y", "1"]], ["l", "r"])
    assert table.splitlines() == ["| a    |   b |", "| ---- | --: |", "| x\\|y |   1 |"]
    assert lb.sanitize("my scenario/2") == "my-scenario-2"


def read_markdown(paths):
    return {p.name: p.read_text(encoding="utf-8") for p in paths if p.suffix == ".md"}


def test_markdown_header_table_and_statistics(store_path, tmp_path):
    paths = lb.write_leaderboards(
        store_path, tmp_path, command="uav-bench leaderboard --out X", n_resamples=2000
    )
    assert [p.name for p in paths] == ["tiny.md", "tiny.csv"]
    text = read_markdown(paths)["tiny.md"]
    assert text.startswith("# Leaderboard: tiny\n")
    for needle in (
        "Generated by `uav-bench leaderboard`",
        "do not edit this file by hand",
        ", by `uav-bench leaderboard --out X`",  # on the date line, the only line that may differ
        "Run commands: `uav-bench run --seeds 8`",
        "Commits: `",
        "numpy ",
        " cores",
        "Scenario: tiny (hash `aaaaaaaaaaaaaaaa`)",
        "Weights: 0.3,0.4,0.3; profile: benchmark",
        "Seeds: 0–8 (9 seeds",
        "Budget: max_evals 1000, horizon 5 (ihpso, pso); no planning budget (greedy, ppo)",
        "Episodes: 33 (1 error,",
        "- Date: ",
        "## Statistics",
        "χ² = 24, p < 0.001",
        "(2,000 resamples, seeded)",
        "Significantly cheaper than `ihpso`: `ppo` (p = 0.023)",
        "Significantly costlier than `ihpso`: `pso` (p = 0.023), `greedy` (p = 0.023)",
        "## Columns",
        "**total J (incl. penalty)**",
    ):
        assert needle in text, needle
    rows = [line for line in text.splitlines() if line.startswith("|")]
    header = [c.strip() for c in rows[0].strip("|").split("|")]
    assert header[:6] == [
        "policy",
        "episodes",
        "errors",
        "success [95% CI]",
        "collided/out/truncated",
        "total J (incl. penalty) mean [95% CI]",
    ]
    assert header[-2:] == ["train steps", "train [s]"]
    cells = {line.split("|")[1].strip(): [c.strip() for c in line.strip("|").split("|")] for line in rows[2:]}
    assert list(cells) == ["ppo", "**ihpso**", "pso", "greedy"]
    assert cells["greedy"][1:3] == ["8", "1"]
    assert cells["ppo"][-2:] == ["100,000", "50"]
    assert cells["pso"][-2:] == ["", ""]
    assert cells["pso"][4] == "1/0/0"
    assert cells["**ihpso**"][5].startswith("13.5 [")


def test_csv_holds_full_precision_and_interval_columns(store_path, tmp_path):
    paths = lb.write_leaderboards(store_path, tmp_path, n_resamples=500)
    frame = pd.read_csv(next(p for p in paths if p.suffix == ".csv"))
    for column in (
        "total_cost_mean_ci_low",
        "total_cost_iqm_ci_high",
        "success_rate_ci_low",
        "delta_mean_ci_high",
    ):
        assert column in frame
    assert frame.loc[frame["policy"] == "pso", "total_J_mean"].item() == 114 / 8  # (12 + ... + 18) + 9


def without_date(text: str) -> str:
    return re.sub(r"^- Date: .*$", "- Date:", text, flags=re.MULTILINE)


def test_two_runs_give_identical_files_apart_from_the_date(store_path, tmp_path):
    first = lb.write_leaderboards(
        store_path, tmp_path / "one", command="uav-bench leaderboard", n_resamples=1000
    )
    second = lb.write_leaderboards(
        store_path, tmp_path / "two", command="uav-bench leaderboard", n_resamples=1000
    )
    assert [p.name for p in first] == [p.name for p in second]
    for a, b in zip(first, second, strict=True):
        if a.suffix == ".csv":
            assert a.read_bytes() == b.read_bytes()
        else:
            assert without_date(a.read_text()) == without_date(b.read_text())
    other_seed = lb.write_leaderboards(
        store_path, tmp_path / "three", command="uav-bench leaderboard", seed=1, n_resamples=1000
    )
    assert other_seed[1].read_bytes() != first[1].read_bytes()  # the bootstrap is seeded, not fixed


def test_bootstrap_of_a_policy_does_not_depend_on_the_others(store_path):
    with ResultsStore(store_path) as store:
        episodes = store.episodes()
    full = lb.leaderboard_table(episodes, n_resamples=500).set_index("policy")
    fewer = lb.leaderboard_table(episodes[episodes["policy"] != "greedy"], n_resamples=500).set_index(
        "policy"
    )
    columns = ["total_cost_mean_ci_low", "total_cost_mean_ci_high", "total_cost_iqm_ci_low"]
    assert full.loc["pso", columns].tolist() == fewer.loc["pso", columns].tolist()


def test_several_scenario_groups_and_stems(tmp_path):
    path = write_store(tmp_path / "groups.sqlite", extra_groups=True)
    paths = lb.write_leaderboards(path, tmp_path / "out", n_resamples=200)
    assert [p.name for p in paths] == [
        "my-scenario-2.md",
        "my-scenario-2.csv",
        "tiny-aaaaaaaa.md",
        "tiny-aaaaaaaa.csv",
        "tiny-bbbbbbbb.md",
        "tiny-bbbbbbbb.csv",
    ]
    small = read_markdown(paths)["tiny-bbbbbbbb.md"]
    assert "Weights: 0.3,0.5,0.2" in small
    assert "Friedman test not run" in small  # two policies
    assert "smallest attainable p-value is 0.25" in small  # 3 paired seeds cannot reach 0.05
    assert "Run commands: not recorded" in small


def test_reference_absent_and_ambiguous_names(tmp_path):
    path = tmp_path / "ref.sqlite"
    with ResultsStore(path) as store:
        for seed in range(4):
            store.write_episode(episode("greedy", seed), [])
            store.write_episode(episode("pso", seed), [])
            # Two configurations named ihpso: labels carry the hash, the reference resolves to the larger one.
            store.write_episode(episode("ihpso", seed, policy_hash="1" * 16), [])
            if seed < 2:
                store.write_episode(episode("ihpso", seed, policy_hash="2" * 16, total_cost=99.0), [])
        episodes = store.episodes()
    table = lb.leaderboard_table(episodes, reference="ihpso", n_resamples=200)
    assert set(table["policy"]) == {"greedy", "pso", "ihpso@11111111", "ihpso@22222222"}
    assert table.attrs["reference"] == "ihpso@11111111"
    # without ihpso the default falls back to the greedy floor; a named reference never falls back
    fallback = lb.leaderboard_table(episodes[episodes["policy"] != "ihpso"], reference="ihpso", n_resamples=200)
    assert fallback.attrs["reference"] == "greedy"
    assert fallback.set_index("policy").loc["pso", "n_pairs"] == 4
    without = episodes[~episodes["policy"].isin(["ihpso", "greedy"])]
    assert lb.leaderboard_table(without, reference="ihpso", n_resamples=200).attrs["reference"] == "pso"
    none = lb.leaderboard_table(episodes[episodes["policy"] != "ihpso"], reference="cem", n_resamples=200)
    assert none.attrs["reference"] is None and none["pvalue_holm"].isna().all()
    assert "No reference policy" in lb.statistics_paragraph(none)


def test_finished_episode_without_a_cost_is_an_error(store_path):
    with ResultsStore(store_path) as store:
        episodes = store.episodes()
    episodes.loc[(episodes["policy"] == "pso") & (episodes["seed"] == 3), "total_cost"] = None
    with pytest.raises(ValueError, match=r"'pso' has no finite total_cost for seeds \[3\]"):
        lb.leaderboard_table(episodes, n_resamples=100)


def test_missing_store_is_an_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="results store"):
        lb.write_leaderboards(tmp_path / "nothing.sqlite", tmp_path)
    assert not (tmp_path / "nothing.sqlite").exists()


def test_leaderboard_of_a_real_sweep(tmp_path):
    from uav_penetration_env.benchmark.evaluate import evaluate
    from uav_penetration_env.benchmark.policies import make_policy

    policies = {"ihpso": make_policy("ihpso", max_evals=200), "pso": make_policy("pso", max_evals=200)}
    policies |= {"greedy": make_policy("greedy"), "random": make_policy("random")}
    store = tmp_path / "real.sqlite"
    evaluate(policies, [tiny_scenario()], range(3), store=store, progress=False, command="pytest")
    paths = lb.write_leaderboards(store, tmp_path / "out")
    text = read_markdown(paths)["tiny.md"]
    assert "Run commands: `pytest`" in text
    assert len([line for line in text.splitlines() if line.startswith("|")]) == 2 + len(policies)


def test_leaderboard_is_the_one_the_code_before_the_column_table_made(store_path, tmp_path):
    """data/leaderboard-synthetic was written from this file's store by the code before columns.py."""
    from pathlib import Path

    paths = lb.write_leaderboards(
        store_path, tmp_path, command="uav-bench leaderboard (fixture)", n_resamples=500
    )
    old = Path(__file__).parent / "data" / "leaderboard-synthetic"
    # The store is rebuilt here, so its run record names this machine, commit and versions.
    machine = re.compile(r"^- (Commits|Versions|Machine|Date): .*$", flags=re.MULTILINE)
    # Since then the statistics name the table's seed set first (api.md §4.5); nothing else moved.
    seed_set = "Every statistic of a ranked policy is over the same 8 seeds (the reference's: 0–7). "
    text = paths[0].read_text()
    assert text.count(seed_set) == 1
    assert machine.sub("", text.replace(seed_set, "")) == machine.sub("", (old / "tiny.md").read_text())
    assert paths[1].read_bytes() == (old / "tiny.csv").read_bytes()


def traced(policy: str, seed: int) -> dict:
    """A synthetic episode with the state-machine trace summaries (ihpso: a quarter of the steps stop early)."""
    if policy == "ihpso":
        return {
            "stopped_early_share": 0.25,
            "switches_per_step": 1.0,
            "reverse_switches_per_step": 0.5 * (seed % 2),
        }
    if policy == "pso":  # an optimiser without switches records none
        return {"stopped_early_share": 0.0}
    return {}


def test_trace_summaries_are_averaged_per_planner_and_left_out_when_never_recorded(tmp_path):
    with ResultsStore(tmp_path / "traced.sqlite") as store:
        for seed in SEEDS:
            for policy in OFFSETS:
                store.write_episode(episode(policy, seed) | traced(policy, seed), [])
        table = lb.leaderboard_table(store.episodes(), reference="ihpso", seed=0, n_resamples=200)
    row = table.set_index("policy")
    assert row.loc["ihpso", "stopped_early_share"] == pytest.approx(0.25)
    assert row.loc["ihpso", "reverse_switches_per_step"] == pytest.approx(0.25)  # half the seeds at 0.5
    assert row.loc["pso", "stopped_early_share"] == 0.0
    assert np.isnan(row.loc["pso", "switches_per_step"]) and np.isnan(
        row.loc["greedy", "stopped_early_share"]
    )
    header, rows, _ = lb.markdown_rows(table, "ihpso")
    ihpso = dict(zip(header, rows[table["policy"].tolist().index("ihpso")], strict=True))
    assert (ihpso["stopped early"], ihpso["switches/step"], ihpso["reverse/step"]) == ("0.25", "1", "0.25")


def test_a_store_without_trace_summaries_has_no_such_columns(table):
    assert not {"stopped_early_share", "switches_per_step", "reverse_switches_per_step"} & set(table.columns)
    assert "stopped early" not in lb.markdown_rows(table, "ihpso")[0]
    assert not any("stopped early" in line for line in legend_lines("2,000", set(table.columns)))
    assert any("stopped early" in line for line in legend_lines("2,000"))


def test_table_columns_are_the_column_tables(table):
    from uav_penetration_env.benchmark.columns import leaderboard_columns

    # recorded_only columns (trace summaries) are absent here: the store never recorded them.
    declared = [c for c in leaderboard_columns() if not c.board.recorded_only]
    written = [name for column in declared for name in column.csv]
    assert sorted(written) == sorted(table.columns)  # every CSV column is declared, once
    header, rows, _ = lb.markdown_rows(table, "ihpso")
    assert header == [c.board.header.format(reference="ihpso") for c in declared]
    assert all(len(row) == len(header) for row in rows)


def test_a_policy_on_fewer_seeds_is_listed_unranked_and_moves_no_other_number(store_path, tmp_path):
    with ResultsStore(store_path) as store:
        episodes = store.episodes()
    before = lb.leaderboard_table(episodes, reference="ihpso", n_resamples=500)
    # a new agent, cheapest of all, flown on two of the eight seeds
    short = pd.DataFrame([episode("new-agent", seed, total_cost=0.5, total_J=0.5) for seed in (0, 1)])
    after = lb.leaderboard_table(pd.concat([episodes, short], ignore_index=True), reference="ihpso", n_resamples=500)
    assert after["policy"].tolist() == [*before["policy"], "new-agent"]
    shared = [c for c in before.columns if c in after.columns]
    pd.testing.assert_frame_equal(after.iloc[:-1][shared].reset_index(drop=True), before[shared])
    agent = after.set_index("policy").loc["new-agent"]
    assert np.isnan(agent["friedman_rank"]) and np.isnan(agent["delta_mean"])
    assert agent["episodes"] == 2 and agent["total_cost_mean"] == 0.5
    assert after.attrs["seeds"] == list(range(8)) and after.attrs["unranked"] == {"new-agent": [0, 1]}
    sentence = lb.statistics_paragraph(after)
    assert "Not ranked, because not flown on each of them" in sentence and "`new-agent` (0–1)" in sentence


def test_a_ranked_policy_is_summarised_on_the_table_seeds_only(store_path):
    with ResultsStore(store_path) as store:
        episodes = store.episodes()
    # ihpso (the reference) is flown on seeds 0-7; pso also on 8-9, which the table leaves out
    extra = pd.DataFrame([episode("pso", seed) for seed in (8, 9)])
    table = lb.leaderboard_table(pd.concat([episodes, extra], ignore_index=True), reference="ihpso", n_resamples=500)
    pso = table.set_index("policy").loc["pso"]
    assert pso["episodes"] == 8
    assert pso["total_cost_mean"] == pytest.approx(np.mean([OFFSETS["pso"] + s for s in range(8)]), rel=1e-15)


def test_without_a_reference_the_seed_set_most_policies_share_is_the_table_s(store_path):
    with ResultsStore(store_path) as store:
        episodes = store.episodes()
    table = lb.leaderboard_table(episodes[episodes["policy"] != "ihpso"], reference="none", n_resamples=200)
    # pso and ppo cover 0-7; greedy 0-8 (its error row on 8): the most common set is 0-7
    assert table.attrs["reference"] is None and table.attrs["seeds"] == list(range(8))
    assert table.attrs["unranked"] == {}
