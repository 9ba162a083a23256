"""Fixed-target analysis (api.md §4.8): ERT, runtime ECDF, the windows command, ablations in a leaderboard."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from conftest import run_cli

from uav_penetration_env.benchmark import fixedtarget as ft
from uav_penetration_env.benchmark import fixedtarget_retired as ft_retired
from uav_penetration_env.benchmark.store import ResultsStore

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
    retired = ft_retired.paired_table(rows, "a").set_index("comparison")  # the v2/v3 rule, kept to rebuild them
    budget = retired.loc["fixed budget: J"]
    # b at a's nfev (300, 400): seed 0 → 1.1 (entry at 300), seed 1 → 1.0; a's finals 1.05, 1.08.
    assert (budget["reference_median"], budget["other_median"]) == (pytest.approx(1.065), pytest.approx(1.05))
    assert (budget["reference_better"], budget["other_better"], budget["pairs"]) == (1, 1, 2)
    target = retired.loc["fixed target: evaluations"]
    # Worse final per seed: 1.1 (seed 0: a 200, b 300), 1.08 (seed 1: a 300, b 100).
    assert (target["reference_median"], target["other_median"]) == (250.0, 200.0)


def _window_row(optimizer, step, seed, history, nfev, max_evals=400):
    return {
        "scenario": "s", "scenario_hash": "ab", "source_policy": "greedy", "source_policy_hash": "g",
        "episode_seed": 0, "step": step, "optimizer": optimizer, "seed": seed, "max_evals": max_evals,
        "fun": history[-1], "nfev": nfev[-1], "history": json.dumps(history), "history_nfev": json.dumps(nfev),
    }  # fmt: skip


def test_window_comparison_by_hand_with_windows_as_units():
    """Two windows, one seed each: the per-window log10 ERT ratios and budget gaps computed by hand."""
    rows = pd.DataFrame(
        [
            # Window 1: f_best = 1.0 (b). Δ=0.1 target 1.1: a at 200, b at 100 → log10(100/200).
            _window_row("a", 1, 0, [5.0, 1.05, 1.05], [100, 200, 300]),
            _window_row("b", 1, 0, [1.0], [100]),
            # Window 2: f_best = 2.0 (a). Δ=0.1 target 2.2: a at 100, b at 300 → log10(300/100).
            _window_row("a", 2, 0, [2.0], [100]),
            _window_row("b", 2, 0, [4.0, 3.0, 2.1], [100, 200, 300]),
        ]
    )
    table = ft.window_comparisons(rows, "a", precisions=(0.1, 0.01), n_resamples=200).set_index(["comparison", "precision"], drop=False)
    loose = table.loc[(ft.FIXED_TARGET, 0.1)]
    assert loose["units"] == 2 and (loose["other_better"], loose["reference_better"]) == (1, 1)
    assert loose["median"] == pytest.approx((math.log10(0.5) + math.log10(3.0)) / 2, rel=1e-12)
    # Δ=0.01: window 1's target 1.01: only b (a ended at 1.05) → −∞; window 2's 2.02: only a → +∞.
    tight = table.loc[(ft.FIXED_TARGET, 0.01)]
    assert (tight["other_better"], tight["reference_better"], tight["undefined"]) == (1, 1, 0)
    assert tight["median"] == 0.0  # −∞ and +∞ in the middle: the midpoint of a symmetric split
    budget = table[table["comparison"] == ft.FIXED_BUDGET].iloc[0]
    # Window 1: b at a's 300 evaluations is 1.0, a's final 1.05 → −0.05; window 2: b at 100 is 4.0 − 2.0 = +2.0.
    assert budget["median"] == pytest.approx((-0.05 + 2.0) / 2, rel=1e-12)
    assert (budget["other_better"], budget["reference_better"]) == (1, 1)


def test_a_long_search_sets_the_targets_but_is_not_compared():
    # The long search (budget 4000) found 0.5: at Δ=0.1 the target is 0.55, which neither compared run reached.
    rows = pd.DataFrame(
        [
            _window_row("a", 1, 0, [5.0, 1.0], [100, 200]),
            _window_row("b", 1, 0, [1.0], [100]),
            _window_row("a", 1, 0, [5.0, 0.5], [100, 4000], max_evals=4000),
        ]
    )
    table = ft.window_comparisons(rows, "a", precisions=(0.1,), n_resamples=50)
    assert set(table["other"]) == {"b"}
    target = table[table["comparison"] == ft.FIXED_TARGET].iloc[0]
    assert (target["units"], target["undefined"]) == (0, 1)  # neither reached f_best + 10 %: left out, counted
    compared, budget = ft.compared_runs(rows, "a")
    assert budget == 400 and len(compared) == 2


def test_the_pairs_own_finals_no_longer_decide_the_fixed_target():
    """The review's case: a stops early and finishes worse; b keeps improving to the budget.

    Under the retired rule the target is a's worse final, which b passes early but a reaches first
    only where b finishes worse; with targets from f_best, b reaches the tight targets and a never does.
    """
    rows = pd.DataFrame(
        [
            row
            for step in range(1, 7)
            for row in (
                _window_row("a", step, 0, [3.0, 1.01], [100, 200]),  # stops at 200 evaluations, at 1.01
                _window_row("b", step, 0, [3.0, 1.02, 1.0], [100, 150, 400]),  # slower to 1.02, but ends at 1.0
            )
        ]
    )
    table = ft.window_comparisons(rows, "a", precisions=(1e-3,), n_resamples=100)
    target = table[table["comparison"] == ft.FIXED_TARGET].iloc[0]
    assert target["median"] == -math.inf and target["other_better"] == 6  # only b reached 1.0 + 0.001
    assert target["pvalue"] == pytest.approx(2 / 2**6)  # six windows, all one sign: the exact two-sided p


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
    assert "Expected running time" in page and "Windows as units" in page and "fixed target Δ=1e-03" in page
    table = pd.read_csv(out / "tiny-fixed-target.csv")
    assert sorted(set(table["optimizer"])) == ["hpso", "ihpso"] and len(table) == 2 * len(
        ft.TARGET_PRECISIONS
    )
    assert (table["successes"] <= table["runs"]).all() and (table["runs"] == 4).all()
    # At the loosest target (f* + 10 %|f*|) the run that found f* solved it, so some optimiser has a finite ERT.
    assert np.isfinite(table[table["precision"] == 0.1]["ert"]).any()
    # The page's other tables as rows: the comparisons over windows (reference greedy is absent from the
    # window runs, so the first optimiser, hpso, is the reference), the ERT per window and the state machines.
    compared = pd.read_csv(out / "tiny-fixed-target-windows.csv")
    assert set(compared["reference"]) == {"hpso"} and set(compared["other"]) == {"ihpso"}
    assert sorted(compared["comparison"]) == [ft.FIXED_BUDGET] + [ft.FIXED_TARGET] * len(ft.TARGET_PRECISIONS)
    assert ((compared["units"] + compared["undefined"]) == 2).all()  # two windows
    assert (compared["reference_better"] + compared["other_better"] <= compared["units"]).all()
    per_window = pd.read_csv(out / "tiny-fixed-target-window-ert.csv")
    assert len(per_window) == 2 * 2 * len(ft.TARGET_PRECISIONS) and (per_window["runs"] == 2).all()
    assert not (out / "tiny-fixed-target-paired.csv").exists()
    retired = folder / "retired"
    assert run_cli("leaderboard", "--store", store, "--out", retired, "--reference", "greedy",
                   "--fixed-target-rule", "worse-final") == 0  # fmt: skip
    assert (retired / "tiny-fixed-target-paired.csv").is_file() and not (retired / "tiny-fixed-target-windows.csv").exists()
    assert run_cli("leaderboard", "--store", store, "--out", folder / "bad", "--fixed-target-rule", "pairs") == 2
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
    for title in ("Expected running time (ERT)", "Windows as units, against ihpso", "state machines"):
        assert title in section
    assert "fixed budget" in section and "fixed target Δ=1e-04" in section
    assert section.count("<tr>") == 1 + 2 * len(ft.TARGET_PRECISIONS) + 1 + (len(ft.TARGET_PRECISIONS) + 1) + 1 + 2
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
