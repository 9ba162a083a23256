"""Fixed-target analysis (api.md §4.8): ERT, runtime ECDF, the windows command, ablations in a leaderboard."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_scenario

from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark import fixedtarget as ft
from uav_penetration_env.benchmark.store import ResultsStore


@pytest.fixture(scope="module")
def tiny_yaml(tmp_path_factory):
    return str(
        tiny_scenario(time={"max_steps": 20}).to_yaml(tmp_path_factory.mktemp("scenario") / "tiny.yaml")
    )


def run_cli(*argv):
    return cli.main([str(a) for a in argv])


# --- hand-made histories ------------------------------------------------------------------------------


def test_runtime_and_budget_read_the_history():
    history, nfev = [10.0, 6.0, 6.0, 3.0], [100, 200, 300, 400]
    assert ft.runtime_to_target(history, nfev, 6.0) == 200  # first entry at or below
    assert ft.runtime_to_target(history, nfev, 2.9) == math.inf
    assert ft.value_at_budget(history, nfev, 350) == 6.0  # last entry within 350 evaluations
    assert ft.value_at_budget(history, nfev, 400) == 3.0
    assert ft.value_at_budget(history, nfev, 99) == math.inf


def test_ert_on_a_hand_made_set_of_runs():
    # Three runs: solved after 200 and 400 evaluations, one never (spent 1000): (200 + 400 + 1000) / 2.
    assert ft.ert([200, 400, math.inf], [500, 400, 1000]) == 800.0
    assert ft.ert([math.inf, math.inf], [10, 10]) == math.inf
    assert ft.ert([300], [300]) == 300.0


def test_ert_table_from_window_rows_by_hand():
    # One window, two optimisers, two seeds; f* = 1.0 (b, seed 1).
    def row(optimizer, seed, history, nfev):
        return {
            "scenario": "s", "scenario_hash": "ab", "source_policy": "greedy", "source_policy_hash": "g",
            "episode_seed": 0, "step": 3, "optimizer": optimizer, "seed": seed, "max_evals": 400,
            "fun": history[-1], "nfev": nfev[-1], "history": json.dumps(history), "history_nfev": json.dumps(nfev),
        }  # fmt: skip

    rows = pd.DataFrame(
        [
            row("a", 0, [5.0, 1.05, 1.05], [100, 200, 300]),  # Δ=0.1 target 1.1: 200; Δ=0.01 (1.01): never
            row("a", 1, [2.0, 1.2, 1.08, 1.08], [100, 200, 300, 400]),  # 1.1: 300
            row("b", 0, [3.0, 1.5, 1.1, 1.1], [100, 200, 300, 400]),  # 1.1: 300
            row("b", 1, [1.0], [100]),  # 1.1 and 1.01: 100 (then stopped early)
        ]
    )
    targets = ft.target_runs(rows, precisions=(0.1, 0.01))
    table = ft.ert_table(targets, reference="a").set_index(["optimizer", "precision"])
    assert table.loc[("a", 0.1), "ert"] == (200 + 300) / 2
    assert table.loc[("a", 0.01), "ert"] == math.inf  # spent 300 + 400, no success
    assert table.loc[("b", 0.1), "ert"] == (300 + 100) / 2
    assert table.loc[("b", 0.01), "ert"] == (100 + 400) / 1  # seed 0 never reached 1.01, spent 400
    assert table.loc[("b", 0.1), "ert_ratio"] == pytest.approx(200 / 250)
    paired = ft.paired_table(rows, "a").set_index("comparison")
    budget = paired.loc["fixed budget: J"]
    # b at a's nfev (300, 400): seed 0 → 1.1 (entry at 300), seed 1 → 1.0; a's finals 1.05, 1.08.
    assert (budget["reference_median"], budget["other_median"]) == (pytest.approx(1.065), pytest.approx(1.05))
    assert (budget["reference_better"], budget["other_better"], budget["pairs"]) == (1, 1, 2)
    target = paired.loc["fixed target: evaluations"]
    # Worse final per seed: 1.1 (seed 0: a 200, b 300), 1.08 (seed 1: a 300, b 100).
    assert (target["reference_median"], target["other_median"]) == (250.0, 200.0)


def test_runtime_ecdf_is_monotone_and_ends_at_the_success_share():
    runtimes = [100, 300, 300, math.inf, 700, math.inf, math.inf, 50]
    grid = np.geomspace(1, 10_000, 50)
    ecdf = ft.runtime_ecdf(runtimes, grid)
    assert np.all(np.diff(ecdf) >= 0)
    assert ecdf[0] == 0.0 and ecdf[-1] == 5 / 8  # five of eight solved
    assert ft.runtime_ecdf(runtimes, [300])[0] == 4 / 8  # 50, 100, 300, 300


# --- the command on the tiny scenario ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def window_store(tmp_path_factory, tiny_yaml):
    folder = tmp_path_factory.mktemp("windows")
    store = folder / "w.sqlite"
    assert run_cli("run", "--policies", "greedy", "--scenarios", tiny_yaml, "--seeds", "1", "--store", store,
                   "--jobs", "1", "--no-report", "--no-progress") == 0  # fmt: skip
    argv = ["windows", "--store", store, "--from-policy", "greedy", "--scenario", "tiny", "--steps", "1,3",
            "--optimizers", "ihpso", "hpso", "--seeds", "2", "--max-evals", "400", "--horizon", "3"]  # fmt: skip
    assert run_cli(*argv) == 0
    assert run_cli(*argv) == 0  # a rerun skips what is stored
    return folder, store


def test_windows_command_writes_two_optimisers_two_seeds_two_windows(window_store):
    _, store = window_store
    with ResultsStore(store) as s:
        rows = s.window_runs()
        steps = s.steps()
    assert len(rows) == 2 * 2 * 2
    assert rows["run_id"].nunique() == 1  # the rerun skipped every stored run rather than rewriting it
    assert sorted(set(rows["optimizer"])) == ["hpso", "ihpso"] and sorted(set(rows["step"])) == [1, 3]
    for row in rows.itertuples():
        history, nfev = json.loads(row.history), json.loads(row.history_nfev)
        assert len(history) == len(nfev) == row.nit + 1 and nfev[-1] == row.nfev <= 400
        assert history[-1] == row.fun and bool(row.stopped_early) == (row.nfev < 400)
        assert np.all(np.diff(history) <= 0)
    ihpso = rows[rows["optimizer"] == "ihpso"]
    assert ihpso["switches"].notna().all() and rows[rows["optimizer"] == "hpso"]["switches"].isna().all()
    # The window state is the stored track's state at that step (x in m, the store in km).
    at_3 = json.loads(rows[rows["step"] == 3]["state"].iloc[0])
    assert at_3[0] / 1000 == pytest.approx(steps[steps["step"] == 3]["x_km"].iloc[0], rel=1e-12)
    # Same seed, same window: a rerun of the optimiser from the row's seed gives the stored cost.
    pairs = rows.groupby(["step", "seed"])["optimizer"].nunique()
    assert (pairs == 2).all()


def test_the_window_objective_is_the_mpc_policys(window_store, tiny_yaml):
    """A window run reproduces: same objective, same seed stream, same result."""
    from optimizers import get_optimizer
    from uav_penetration_env.benchmark.windows import collect_windows, run_seed, run_window

    _, store = window_store
    with ResultsStore(store) as s:
        rows = s.window_runs()
        (window,) = collect_windows(s, source_policy="greedy", scenario="tiny", steps=[3], horizon=3)
    stored = rows[(rows["step"] == 3) & (rows["optimizer"] == "hpso") & (rows["seed"] == 1)].iloc[0]
    result = run_window(get_optimizer("hpso"), window, np.random.default_rng(run_seed(window, 1)), 400)
    assert result.fun == stored["fun"] and result.nfev == stored["nfev"]


def test_leaderboard_and_plot_add_the_fixed_target_files(window_store):
    folder, store = window_store
    out = folder / "out"
    assert run_cli("leaderboard", "--store", store, "--out", out, "--reference", "greedy") == 0
    page = (out / "tiny-fixed-target.md").read_text()
    assert (
        "Expected running time" in page and "fixed budget: J" in page and "fixed target: evaluations" in page
    )
    table = pd.read_csv(out / "tiny-fixed-target.csv")
    assert sorted(set(table["optimizer"])) == ["hpso", "ihpso"] and len(table) == 2 * len(
        ft.TARGET_PRECISIONS
    )
    assert (table["successes"] <= table["runs"]).all() and (table["runs"] == 4).all()
    # At the loosest target (f* + 10 %|f*|) the run that found f* solved it, so some optimiser has a finite ERT.
    assert np.isfinite(table[table["precision"] == 0.1]["ert"]).any()
    # The page's other two tables as rows: the paired comparisons (reference greedy is absent from the
    # window runs, so the first optimiser, hpso, is the reference) and the state machines.
    paired = pd.read_csv(out / "tiny-fixed-target-paired.csv")
    assert set(paired["reference"]) == {"hpso"} and set(paired["other"]) == {"ihpso"}
    assert sorted(paired["comparison"]) == ["fixed budget: J", "fixed target: evaluations"]
    assert (paired["pairs"] == 4).all()
    assert (paired["reference_better"] + paired["other_better"] <= paired["pairs"]).all()
    traces = pd.read_csv(out / "tiny-fixed-target-traces.csv").set_index("optimizer")
    with ResultsStore(store) as s:
        rows = s.window_runs()
    assert traces["runs"].to_dict() == {"hpso": 4, "ihpso": 4}
    for name, group in rows.groupby("optimizer"):
        assert traces.loc[name, "nfev_mean"] == pytest.approx(group["nfev"].astype(float).mean(), rel=1e-12)
    assert np.isnan(traces.loc["hpso", "switches_mean"]) and np.isfinite(traces.loc["ihpso", "switches_mean"])
    assert run_cli("plot", "--store", store, "--out", out) == 0
    assert (out / "tiny-runtime-ecdf.png").is_file()


def test_runtime_ecdf_styles_each_optimiser_apart_with_the_legend_outside(window_store):
    from matplotlib.axes import Axes
    from matplotlib.colors import to_hex
    from matplotlib.legend import Legend

    from uav_penetration_env.benchmark import figures
    from uav_penetration_env.benchmark.leaderboard import scenario_groups

    _, store = window_store
    with ResultsStore(store) as s:
        (group,) = scenario_groups(s.episodes())
        runs = s.window_runs()
    # Ten names as in the published study: more than the palette, so colour and line style both count.
    names = ["hpso", "ihpso", "ihpso-2022v0", "ihpso-noreverse", "ihpso-noswitch", "ihpso-noterm",
             "ihpso-rtol1e-2", "ihpso-rtol1e-3", "ihpso-rtol1e-5", "ihpso-rtol1e-6"]  # fmt: skip
    many = pd.concat([runs.assign(optimizer=name) for name in names[:5]] + [runs[runs["optimizer"] == "hpso"].assign(optimizer=n) for n in names[5:]])
    figure = figures.plot_runtime_ecdf(group, many, figures.policy_styles(names))
    figure.canvas.draw()
    (ax,) = figure.findobj(Axes)
    pairs = {(to_hex(line.get_color()), repr(line._unscaled_dash_pattern)) for line in ax.get_lines()}
    assert len(ax.get_lines()) == len(pairs) == len(names)
    # The axis starts at the initial swarm's evaluations, not at 1.
    first = min(json.loads(h)[0] for h in runs["history_nfev"])
    assert ax.get_lines()[0].get_xdata()[0] == pytest.approx(first)
    renderer = figure.canvas.get_renderer()
    (legend,) = figure.findobj(Legend)
    assert not legend.get_window_extent(renderer).overlaps(ax.get_window_extent(renderer))


def test_report_shows_the_fixed_target_tables_and_writes_their_pages(window_store, capsys):
    import html as html_module

    from uav_penetration_env.benchmark.report import sections

    folder, store = window_store
    out = folder / "report"
    assert run_cli("report", "--store", store, "--out", out) == 0
    assert "fixed target: " in capsys.readouterr().out
    assert (out / "tiny-fixed-target.md").is_file() and (out / "tiny-fixed-target.csv").is_file()
    page = html_module.unescape((out / "index.html").read_text())
    assert [s.key for s in sections()].count("fixed-target") == 1
    assert 'id="fixed-target"' in page and "Fixed target and fixed budget" in page
    section = page[page.index('id="fixed-target"') :]
    section = section[: section.index("</section>")]
    # The three tables, with the reference ihpso paired against hpso on both comparisons.
    assert "tiny (reference ihpso)" in section
    for title in ("Expected running time (ERT)", "Paired per (window, seed) against ihpso", "state machines"):
        assert title in section
    assert "fixed budget: J" in section and "fixed target: evaluations" in section
    assert section.count("<tr>") == 1 + 2 * len(ft.TARGET_PRECISIONS) + 1 + 2 + 1 + 2  # headers + rows
    # Each of the 4 (window, seed) runs of each optimiser is counted in the ERT rows' "solved" cell.
    assert section.count("/4</td>") == 2 * len(ft.TARGET_PRECISIONS)


def test_report_without_window_runs_says_how_to_get_the_fixed_target_tables(tmp_path, tiny_yaml):
    store = tmp_path / "e.sqlite"
    assert run_cli("run", "--policies", "greedy", "--scenarios", tiny_yaml, "--seeds", "1", "--store", store,
                   "--jobs", "1", "--no-progress", "--out", tmp_path / "out") == 0  # fmt: skip
    page = (tmp_path / "out" / "index.html").read_text()
    section = page[page.index('id="fixed-target"') :]
    section = section[: section.index("</section>")]
    assert "holds no window runs" in section and "<table" not in section
    assert not list((tmp_path / "out").glob("*-fixed-target.*"))


def test_windows_command_rejects_bad_input(window_store, capsys):
    _, store = window_store
    assert (
        run_cli("windows", "--store", store, "--steps", "1", "--scenario", "tiny", "--optimizers", "ihpsoo")
        == 2
    )
    assert "--optimizers: unknown optimiser 'ihpsoo'" in capsys.readouterr().err
    assert run_cli("windows", "--store", store, "--steps", "99", "--scenario", "tiny") == 2
    assert "--steps: got [99]" in capsys.readouterr().err
    assert run_cli("windows", "--store", store, "--steps", "a,b", "--scenario", "tiny") == 2
    assert "--steps: got 'a,b'" in capsys.readouterr().err
    assert (
        run_cli("windows", "--store", store, "--steps", "1", "--scenario", "tiny", "--from-policy", "gredy")
        == 2
    )
    assert "--from-policy: no finished episodes of 'gredy'" in capsys.readouterr().err


# --- ablations through uav-bench run ---------------------------------------------------------------------


ABLATIONS = ("ihpso-noterm", "ihpso-noswitch", "ihpso-noreverse", "ihpso-2022v0")


def test_ablation_configurations_run_and_appear_in_a_leaderboard(tmp_path, tiny_yaml):
    store, out = tmp_path / "a.sqlite", tmp_path / "out"
    assert run_cli("run", "--policies", "ihpso", *ABLATIONS, "--scenarios", tiny_yaml, "--seeds", "1",
                   "--max-evals", "200", "--horizon", "2", "--store", store, "--jobs", "1",
                   "--no-report", "--no-progress") == 0  # fmt: skip
    assert run_cli("leaderboard", "--store", store, "--out", out) == 0
    table = pd.read_csv(out / "tiny.csv")
    assert set(table["policy"]) == {"ihpso", *ABLATIONS}
    assert table["nfev_per_step"].between(1, 200).all()
    assert table["stopped_early_share"].between(0, 1).all()
    # noterm never stops early (adaptive termination off); noswitch never switches.
    row = table.set_index("policy")
    assert row.loc["ihpso-noterm", "stopped_early_share"] == 0.0
    assert row.loc["ihpso-noswitch", "switches_per_step"] == 0.0
    assert row.loc["ihpso-noreverse", "reverse_switches_per_step"] == 0.0
    assert "stopped early" in (out / "tiny.md").read_text()


def test_ert_ratio_is_blank_where_an_ert_is_infinite():
    targets = pd.DataFrame(
        {
            "optimizer": ["a", "b"],
            "precision": [0.1, 0.1],
            "runtime": [math.inf, 300.0],
            "nfev": [400.0, 400.0],
        }
    )
    table = ft.ert_table(targets, reference="a").set_index("optimizer")
    assert table.loc["b", "ert"] == 300.0 and np.isnan(table.loc["b", "ert_ratio"])
