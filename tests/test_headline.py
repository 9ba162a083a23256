"""benchmarks/headline.py and results_page.py: the published numbers, read back from a leaderboard folder."""

from __future__ import annotations

import json

import pytest
from conftest import tiny_scenario

from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.publishing import headline, results_page
from uav_penetration_env.benchmark.store import ResultsStore


def run_cli(*argv: object) -> int:
    return cli.main([str(a) for a in argv])


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A leaderboard folder from a tiny store: IHPSO, HPSO and greedy episodes, one window study."""
    root = tmp_path_factory.mktemp("headline")
    scenario = str(tiny_scenario(time={"max_steps": 12}).to_yaml(root / "tiny.yaml"))
    store = root / "h.sqlite"
    assert run_cli("run", "--policies", "ihpso", "hpso", "greedy", "--scenarios", scenario, "--seeds", "2",
                   "--max-evals", "400", "--horizon", "2", "--store", store, "--jobs", "1",
                   "--no-report", "--no-progress") == 0  # fmt: skip
    assert run_cli("windows", "--store", store, "--from-policy", "greedy", "--scenario", "tiny", "--steps", "1,3",
                   "--optimizers", "ihpso", "hpso", "--seeds", "2", "--max-evals", "400", "--horizon", "2") == 0  # fmt: skip
    assert run_cli("leaderboard", "--store", store, "--out", root / "out") == 0
    attempts = [{"part": "paper", "command": "a", "wall_s": 1800.0, "cpu_s": 3600.0, "status": 0},
                {"part": "paper", "command": "a", "wall_s": 1800.0, "cpu_s": 0.0, "status": 0},
                {"part": "tables", "command": "b", "wall_s": 360.0, "cpu_s": 720.0, "status": 0}]  # fmt: skip
    (root / "out" / "compute.jsonl").write_text("".join(json.dumps(a) + "\n" for a in attempts))
    with ResultsStore(store) as s:
        return root / "out", s.episodes(), s.window_runs()


def test_headline_numbers_equal_those_computed_from_the_rows(folder):
    out, episodes, windows = folder
    text = headline.headline(out, ["tiny"])
    # §1: every PSO variant flown appears with its mean total J; the reference has no Δ.
    mean = episodes.groupby("policy")["total_cost"].mean()
    assert f"| ihpso | {headline.number(mean['ihpso'], 4)}, IQM " in text
    assert f"| hpso | {headline.number(mean['hpso'], 4)}, IQM " in text and "; Δ " in text
    # §2, episodes: IHPSO's evaluations per step as a share of HPSO's, from the episodes themselves.
    per_step = episodes.groupby("policy")["nfev_per_step"].mean()
    assert f"| {headline.percent(per_step['ihpso'] / per_step['hpso'])} |" in text
    # §2, window study: the same from the window runs, and the paired lines over 2 windows x 2 seeds.
    per_run = windows.groupby("optimizer")["nfev"].mean()
    assert "Window study `tiny`" in text
    assert f"| ihpso | 4 | {headline.number(per_run['ihpso'], 4)} | {headline.percent(per_run['ihpso'] / per_run['hpso'])} |" in text
    # Windows as units (api.md §4.8): the fixed budget and four targets, each over the 2 windows.
    assert text.count("over 2 windows") == 5 and "fixed budget: J, hpso vs ihpso" in text
    assert "- target f* + 0.1|f*|: " in text
    # §4: no agent in this store; §6: hours summed over every attempt of a part.
    assert "No RL table in this folder." in text
    assert "| paper | 2 | 1.00 | 1.00 | - | - |" in text and "| tables | 1 | 0.10 | 0.20 | - | - |" in text
    assert "| total | | 1.10 | 1.20 | | " in text


def test_headline_refuses_a_folder_without_tables(tmp_path):
    with pytest.raises(SystemExit, match=r"none of the tables tiny\.csv; expected a leaderboard folder"):
        headline.headline(tmp_path, ["tiny"])


def test_rl_section_reads_the_rl_table_with_its_paired_difference(tmp_path):
    import pandas as pd

    from uav_penetration_env.benchmark.leaderboard import rl_table

    rows = []
    for policy, cost, seconds in (("sb3:ppo-paper-s0", 20.0, 1e-4), ("sb3:ppo-paper-s1", 24.0, 1e-4),
                                  ("greedy", 21.0, 5e-5), ("hpso", 19.0, 0.3)):  # fmt: skip
        rows.append({"policy": policy, "policy_hash": policy[:16].ljust(16, "0"), "scenario": "s",
                     "scenario_hash": "h", "seed": 0, "outcome": "success", "total_J": cost, "total_penalty": 0.0,
                     "total_cost": cost, "planning_seconds": seconds, "steps": 10, "error": ""})  # fmt: skip
    rl_table(pd.DataFrame(rows), n_resamples=200).to_csv(tmp_path / "s-rl.csv", index=False)
    text = "\n".join(headline.rl_section(tmp_path, ["s"]))
    assert "`s` (best planner: hpso):" in text
    # The group's runs 20 and 24 against greedy's 21: +1; the planner decides 3 000 times slower.
    assert "| sb3:ppo-paper | RL group | 2 | " in text and "| 1 [" in text and "| 3000 |" in text


def test_the_results_page_and_the_readme_headline_are_what_the_published_tables_give():
    """docs/results.md and the README's headline paragraph are regenerated from leaderboards/v3 without a difference."""
    assert results_page.main(["--check"]) == 0


@pytest.fixture
def v3_folder(folder, tmp_path):
    """The tiny leaderboard laid out as a v3 folder: its table named as the paper's, its episodes exported."""
    import shutil

    out, episodes, _ = folder
    v3 = tmp_path / "v3"
    shutil.copytree(out, v3)
    shutil.copy(v3 / "tiny.csv", v3 / "paper-2022-sec5.csv")
    (v3 / "rows").mkdir(exist_ok=True)
    episodes.to_parquet(v3 / "rows" / "leaderboard-episodes.parquet")
    return v3


def test_results_page_check_fails_on_a_stale_page(v3_folder, tmp_path):
    out, readme = tmp_path / "results.md", tmp_path / "README.md"
    out.write_text("stale\n")
    readme.write_text(f"x\n{results_page.README_START}\nSTALE-HEADLINE\n{results_page.README_END}\n")
    flags = ["--folder", str(v3_folder), "--out", str(out), "--readme", str(readme)]
    assert results_page.main(["--check", *flags]) == 1
    assert results_page.main(flags) == 0
    assert results_page.main(["--check", *flags]) == 0
    text = out.read_text()
    assert "STALE-HEADLINE" not in readme.read_text() and text.startswith("# Results")
    # The tiny episodes are not on the paper scenario: IHPSO against HPSO from the table, no form pairing.
    assert "| `paper-2022-sec5` | " in text and "## 1. Does IHPSO's adaptivity help?" in text
    # This folder's window study is written under the COCO rule (-fixed-target-windows.csv); the v3 page's
    # window section reads only the retired pairing, and says so rather than misreading the new rows.
    assert "No identical-window study in this folder." in text and "retired pairing rule" in text
    # The declared comparisons name scenarios these rows lack: each reads "not flown", none is invented.
    assert "`paper-2022-sec5` not flown" in readme.read_text() and "| not flown |" in text


def test_results_page_refuses_a_readme_without_the_headline_block():
    with pytest.raises(SystemExit, match=r"no .* block to write the headline into"):
        results_page.with_headline("no block\n", "paragraph")
