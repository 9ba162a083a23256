"""The report at a glance: the headline sentence, computed from a leaderboard of a small synthetic store."""

from __future__ import annotations

import pandas as pd
import pytest

from uav_penetration_env.benchmark import glance
from uav_penetration_env.benchmark.columns import leaderboard_columns
from uav_penetration_env.benchmark.leaderboard import write_leaderboards
from uav_penetration_env.benchmark.leaderboard.formatting import format_interval, format_number, p_text
from uav_penetration_env.benchmark.store import ResultsStore

# Total J per (policy, seed): pso is cheaper than ihpso on every seed, greedy costlier, so with
# eight paired seeds both differences to ihpso are significant after Holm's correction.
COSTS = {"ihpso": 10.0, "pso": 9.0, "greedy": 12.0}
SEEDS = range(8)


def synthetic_store(path, costs=COSTS, seeds=SEEDS):
    with ResultsStore(path) as store:
        for index, (policy, cost) in enumerate(costs.items()):
            for seed in seeds:
                store.write_episode(
                    {
                        "policy": policy,
                        "policy_hash": f"h{index:015d}",
                        "scenario": "tiny",
                        "scenario_hash": "a" * 16,
                        "seed": seed,
                        "outcome": "success",
                        "total_J": cost + 0.1 * seed,
                        "total_penalty": 0.0,
                        "total_cost": cost + 0.1 * seed + 0.01 * index * (seed % 3),
                        "steps": 8,
                        "planning_seconds": 0.01,
                        "error": "",
                    },
                    [],
                )
    return path


def leaderboard(tmp_path, reference="ihpso", **store):
    path = synthetic_store(tmp_path / "s.sqlite", **store)
    written = write_leaderboards(path, tmp_path / reference, reference=reference, n_resamples=200, command="t")
    (csv,) = [p for p in written if p.suffix == ".csv"]
    return pd.read_csv(csv)


def mean_text(frame, policy):
    r = frame.set_index("policy").loc[policy]
    text = format_interval(r.total_cost_mean, r.total_cost_mean_ci_low, r.total_cost_mean_ci_high, 3)
    return text.replace(" [", " [95% CI ", 1)


def test_the_cheapest_against_the_reference_with_its_paired_test(tmp_path):
    frame = leaderboard(tmp_path)
    text = glance.headline(frame, "tiny", list(SEEDS))
    pso = frame.set_index("policy").loc["pso"]
    ihpso = frame.set_index("policy").loc["ihpso"]
    assert text.startswith(f"pso is cheapest on tiny: mean total J (incl. penalty) {mean_text(frame, 'pso')}, ")
    share = 100.0 * abs(pso.delta_mean) / ihpso.total_cost_mean
    delta = format_interval(pso.delta_mean, pso.delta_mean_ci_low, pso.delta_mean_ci_high, 3)
    assert f"{format_number(abs(pso.delta_mean), 3)} ({share:.1f}%) below the reference ihpso (paired Δ {delta})." in text
    assert pso.pvalue_holm < 0.05
    assert f"Significant at α = 0.05: Wilcoxon signed-rank test over the table's seeds, Holm-adjusted {p_text(pso.pvalue_holm)}." in text
    assert f"Next: greedy at {mean_text(frame, 'greedy')}." not in text  # the next is the reference itself
    assert text.endswith("Over 8 seeds (0–7) on one scenario: 3 policies, 24 finished episodes.")
    assert "**" not in text and "_" not in text


def test_the_reference_cheapest_compares_the_next_and_few_seeds_say_so(tmp_path):
    frame = leaderboard(tmp_path, reference="pso", seeds=range(3))
    text = glance.headline(frame, "tiny", [0, 1, 2])
    assert text.startswith(f"pso is cheapest on tiny: mean total J (incl. penalty) {mean_text(frame, 'pso')}, and it is the reference.")
    assert f"The next, ihpso at {mean_text(frame, 'ihpso')}, costs " in text and "more than the reference pso" in text
    assert "Not significant at α = 0.05" in text
    assert "(3 paired seeds cannot reach p < 0.05: run more seeds)" in text
    assert "Over 3 seeds (0–2)" in text


def test_without_a_reference_there_is_no_paired_test_and_one_policy_is_alone(tmp_path):
    frame = leaderboard(tmp_path, reference="cmaes")
    text = glance.headline(frame, "tiny", list(SEEDS), scenarios=("a", "b"))
    assert f"pso is cheapest on tiny: mean total J (incl. penalty) {mean_text(frame, 'pso')}; next: ihpso at " in text
    assert "No paired test: the table has no reference policy (--reference)." in text
    assert "on 2 scenarios" in text
    alone = glance.headline(frame[frame["policy"] == "greedy"], "tiny")
    assert "the only policy in this table" in alone and "Over the stored seeds" in alone
    assert "nothing to compare" in glance.headline(frame.iloc[:0], "tiny")


def test_the_glance_columns_come_first_and_keep_the_registry_labels():
    first, rest = glance.split_columns(leaderboard_columns())
    assert [c.name for c in first] == list(glance.GLANCE_COLUMNS)
    assert {c.name for c in first} | {c.name for c in rest} == {c.name for c in leaderboard_columns()}
    assert glance.column_label("delta_mean", "ihpso") == "Δ vs ihpso [95% CI]"
    assert glance.column_label("total_cost_mean", short=True) == "total J (incl. penalty)"
    with pytest.raises(KeyError, match="total_cost_means"):
        glance.column_label("total_cost_means")


def test_a_frozen_suite_table_names_its_members(tmp_path):
    frame = leaderboard(tmp_path).assign(members=[2, 3, 3])
    text = glance.headline(frame, "uavpen-v1", list(SEEDS), scenarios=("a", "b", "c"))
    assert text.endswith("Over 8 seeds (0–7) on 3 suite members: 3 policies, 24 finished episodes.")
