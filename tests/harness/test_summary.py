"""The terminal summary (100 columns whatever the names), the progress bar, `report` and `run`'s report."""

from __future__ import annotations

import io

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_scenario

from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.progress import ProgressBar
from uav_penetration_env.benchmark.summary import (
    MAX_WIDTH,
    gap_column,
    print_summary,
    summary_rows,
    table_reference,
)

PLANNERS = ["ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism", "pso", "cem", "cmaes", "de"]
FLOORS = ["greedy", "random", "ihpso-eq37", "ihpso-no-adaptive-inertia", "ihpso-no-mutation"]
AGENTS = [
    f"sb3:models/{algo}-paper-seed{seed}-1000000steps.zip" for algo in ("ppo", "sac") for seed in range(5)
]
POLICIES = PLANNERS + FLOORS + AGENTS  # 25 policies, ten of them 44 characters long


def leaderboard_frame(policies, gap: bool = False) -> pd.DataFrame:
    """A leaderboard CSV's summary columns; the first policy is the reference (no paired difference)."""
    n = len(policies)
    mean = 10.0 + 1.2345 * np.arange(n)
    frame = pd.DataFrame(
        {
            "policy": policies,
            "success_rate": np.linspace(1.0, 0.0, n),
            "total_cost_mean": mean,
            "total_cost_mean_ci_low": mean - 0.5678,
            "total_cost_mean_ci_high": mean + 123.456,
            "total_cost_iqm": mean - 0.25,
            "friedman_rank": np.linspace(1.0, float(n), n),
            "delta_mean": mean - mean[0],
            "pvalue_holm": np.linspace(0.0001, 1.0, n),
        }
    )
    frame.loc[0, ["delta_mean", "pvalue_holm"]] = np.nan
    frame.loc[1, "pvalue_holm"] = 0.0001
    if gap:
        frame["gap_best_known_mean"] = np.linspace(0.0, 0.5, n)
        frame["gap_best_known_mean_ci_low"] = 0.0
    return frame


def render(tmp_path, frame, width=MAX_WIDTH) -> str:
    path = tmp_path / "paper.csv"
    frame.to_csv(path, index=False)
    stream = io.StringIO()
    print_summary([path, path.with_suffix(".md")], report=tmp_path / "index.html", file=stream, width=width)
    return stream.getvalue()


@pytest.mark.parametrize("gap", [False, True])
def test_the_summary_fits_100_columns_with_25_long_names(tmp_path, gap):
    text = render(tmp_path, leaderboard_frame(POLICIES, gap=gap))
    lines = text.splitlines()
    assert max(len(line) for line in lines) <= MAX_WIDTH
    for name in POLICIES:  # long names fold inside their cell: their start is on one line
        assert name[:20] in text
    assert ("gap to J*" in text) == gap
    assert "Δ vs ihpso (p)" in text and "reference" in text
    assert "p<0.001" in text  # the second row: p = 0.0001
    assert f"full table: {tmp_path / 'paper.csv'}" in text and f"report: {tmp_path / 'index.html'}" in text


def test_summary_cells_say_what_the_csv_says():
    frame = leaderboard_frame(["ihpso", "greedy"], gap=True)
    header, rows = summary_rows(frame)
    assert header == ["policy", "success", "total J [95% CI]", "IQM", "gap to J*", "rank", "Δ vs ihpso (p)"]
    assert rows[0] == ["ihpso", "100%", "10 [9.43, 133]", "9.75", "0.0%", "1", "reference"]
    # greedy: mean 11.2345, CI [10.67, 134.7], delta 1.2345 at p = 0.0001 (set), gap 50 %
    assert rows[1] == ["greedy", "0%", "11.2 [10.7, 135]", "11", "50.0%", "2", "1.23 (p<0.001)"]
    assert (
        gap_column(["policy", "gap_best_known_mean_ci_low", "gap_best_known_mean"]) == "gap_best_known_mean"
    )
    assert gap_column(list(leaderboard_frame(["a"]).columns)) is None


def test_the_progress_bar_counts_and_shows_an_eta():
    from rich.console import Console

    stream = io.StringIO()
    console = Console(file=stream, width=100, force_terminal=False)
    with ProgressBar(10, "episodes", unit="ep", console=console) as bar:
        bar.update(3)
        bar.set_postfix(failures=1)
    assert bar.n == 3
    text = stream.getvalue()
    assert "episodes" in text and "3/10" in text and "ETA" in text and "failures=1" in text
    silent = ProgressBar(5, "x", enabled=False)
    silent.update(2)
    silent.close()
    assert silent.n == 2


def test_without_a_terminal_progress_is_plain_lines_one_per_tenth():
    from rich.console import Console

    stream = io.StringIO()
    console = Console(file=stream, force_terminal=False)
    with ProgressBar(45, "episodes", unit="ep", console=console) as bar:
        for _ in range(45):
            bar.update(1)
    lines = stream.getvalue().splitlines()
    # 45 // 10: the count crosses a tenth at 5, 9, 14, 18, 23, 27, 32, 36, 41 and 45 episodes
    assert [line.split(":", 1)[1].split()[0] for line in lines] == [
        "5/45", "9/45", "14/45", "18/45", "23/45", "27/45", "32/45", "36/45", "41/45", "45/45"
    ]  # fmt: skip
    assert all(line.startswith("episodes: ") and " elapsed, ETA " in line for line in lines)
    interrupted = io.StringIO()
    with ProgressBar(45, "episodes", unit="ep", console=Console(file=interrupted, force_terminal=False)) as bar:
        bar.update(7)
        bar.set_postfix(failures=1)
    assert interrupted.getvalue().splitlines()[-1].startswith("episodes: 7/45 ep")
    assert interrupted.getvalue().splitlines()[-1].endswith("failures=1")


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_the_eta_prices_each_remaining_episode_at_its_own_policy_median():
    from uav_penetration_env.benchmark.progress import EpisodeETA, format_eta

    clock = Clock()
    eta = EpisodeETA(["slow"] * 4 + ["fast"] * 4, clock=clock)
    assert eta.seconds_left() is None and format_eta(None) == "-:--:--"
    # Two workers: after 10 s, two slow episodes of 10 s each (one compile-inflated: 30 s would not
    # move the median of three) and two fast ones of 1 s finished.
    clock.now = 10.0
    for key, seconds in (("slow", 10.0), ("slow", 10.0), ("fast", 1.0), ("fast", 1.0)):
        eta.finished(key, seconds)
    # Left: 2 slow x 10 s + 2 fast x 1 s = 22 s of work; parallelism 22 s of episodes / 10 s = 2.2.
    assert eta.seconds_left() == 22.0 / 2.2
    assert format_eta(eta.seconds_left()) == "0:00:10" and format_eta(3725.4) == "1:02:05"
    eta.finished("slow", 30.0)  # the median of (10, 10, 30) stays 10
    clock.now = 20.0
    assert eta.seconds_left() == (1 * 10.0 + 2 * 1.0) / (52.0 / 20.0)


def test_the_parallelism_is_measured_from_when_the_work_began_not_from_the_workers_start_up():
    from uav_penetration_env.benchmark.progress import EpisodeETA

    clock = Clock()
    eta = EpisodeETA(["p"] * 6, clock=clock)
    clock.now = 13.0  # two workers took 3 s to start, then each flew a 10 s episode
    eta.finished("p", 10.0)
    eta.finished("p", 10.0)
    # work began at 13 - 10 = 3 s: parallelism 20 / 10 = 2, so 4 x 10 s left take 20 s (not 26 s)
    assert eta.seconds_left() == 4 * 10.0 / 2.0


def test_a_policy_not_seen_yet_is_priced_at_the_median_of_all_finished_episodes():
    from uav_penetration_env.benchmark.progress import EpisodeETA

    clock = Clock()
    eta = EpisodeETA(["a", "a", "b", "b"], clock=clock)
    clock.now = 4.0
    eta.finished("a", 2.0)
    eta.finished("a", 6.0)
    # b unseen: median of (2, 6) = 4 s each; parallelism (2 + 6) / 4 = 2.
    assert eta.seconds_left() == 2 * 4.0 / 2.0


def test_the_bar_shows_the_estimate_it_is_given():
    from rich.console import Console

    from uav_penetration_env.benchmark.progress import EpisodeETA

    clock = Clock()
    stream = io.StringIO()
    console = Console(file=stream, width=120, force_terminal=False)
    with ProgressBar(3, "episodes", unit="ep", console=console, eta=EpisodeETA(["p"] * 3, clock=clock)) as bar:
        clock.now = 100.0
        bar.finished("p", 100.0)
    assert bar.n == 1 and "0:03:20" in stream.getvalue()  # two more episodes of 100 s, one at a time


@pytest.fixture(scope="module")
def tiny_yaml(tmp_path_factory):
    return str(
        tiny_scenario(time={"max_steps": 12}).to_yaml(tmp_path_factory.mktemp("scenario") / "tiny.yaml")
    )


def test_run_writes_the_report_by_default_and_report_rewrites_it(tmp_path, tiny_yaml, capsys):
    store, out = tmp_path / "s.sqlite", tmp_path / "out"
    common = ["--scenarios", tiny_yaml, "--seeds", "2", "--store", store, "--no-progress", "--jobs", "1"]
    assert cli.main([str(a) for a in ["run", "--policies", "greedy", "random", *common, "--out", out]]) == 0
    printed = capsys.readouterr().out
    assert (out / "index.html").is_file() and (out / "tiny.csv").is_file()
    assert f"report: {out / 'index.html'}" in printed
    assert "total J [95% CI]" in printed and "greedy" in printed
    table = [line for line in printed.splitlines() if str(tmp_path) not in line]  # paths print whole
    assert max(len(line) for line in table) <= MAX_WIDTH

    # --no-report: the store grows, and no table, figure or page is written.
    quiet = tmp_path / "quiet"
    argv = ["run", "--policies", "greedy", *common, "--out", quiet, "--no-report"]
    assert cli.main([str(a) for a in argv]) == 0
    assert not quiet.exists() or not any(quiet.iterdir())
    assert "report:" not in capsys.readouterr().out

    page = tmp_path / "page"
    assert cli.main(["report", "--store", str(store), "--out", str(page), "--reference", "greedy"]) == 0
    printed = capsys.readouterr().out
    assert f"report: {page / 'index.html'}" in printed and "Δ vs greedy (p)" in printed
    html = (page / "index.html").read_text()
    assert 'id="policy-greedy"' in html and 'id="policy-random"' in html
    assert sorted(p.suffix for p in page.iterdir() if p.name.startswith("tiny-")) == [".png"] * 9
    assert 'id="compute"' in html and "Compute: decision time per step" in html

    assert cli.main(["report", "--store", str(tmp_path / "none.sqlite"), "--out", str(page)]) == 2
    error = capsys.readouterr().err
    assert error.startswith("uav-bench: error: --store ") and "not found" in error and error.count("\n") == 1


def test_the_summary_names_the_reference_the_table_compared_with():
    """Asked for the default ihpso in a run without it, the table compares with greedy (api.md §4.5):
    the summary says so, and marks greedy's row, as the Markdown and HTML do (repro_t4_summary_reference_label)."""
    frame = leaderboard_frame(["greedy", "random"])
    header, rows = summary_rows(frame, "ihpso")
    assert header[-1] == "Δ vs greedy (p)"
    assert rows[0][-1] == "reference" and rows[1][-1].startswith("1.23")
    assert table_reference(frame, "ihpso") == "greedy"


def test_the_summary_and_the_html_report_read_one_rule():
    from uav_penetration_env.benchmark import report

    frame = leaderboard_frame(["greedy", "random"])
    assert report._table_reference(frame, "ihpso") == table_reference(frame, "ihpso") == "greedy"
    unpaired = frame.assign(delta_mean=np.nan)  # the rows cannot tell: the requested name, if a row
    assert table_reference(unpaired, "random") == "random" and table_reference(unpaired, "ihpso") is None


def test_only_leaderboards_are_summarised_the_paired_tables_are_listed(tmp_path):
    import io

    import pandas as pd

    paired = tmp_path / "information.csv"
    pd.DataFrame({"comparison": ["price of information (P - oracle:P)"], "policy": ["lattice"], "pairs": [2],
                  "mean_difference": [0.01]}).to_csv(paired, index=False)  # fmt: skip
    stream = io.StringIO()
    print_summary([paired], file=stream, width=100)
    assert stream.getvalue() == f"full table: {paired}\n"
