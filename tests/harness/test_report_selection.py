"""Output commands on a store of several scenarios: which scenarios get figures and 3-D views
(``--min-seeds``, ``MAX_3D_VIEWS``: a full-suite store must give a readable page), extra figures
(``--figures``), an explicit ``--reference`` that must exist, ``export`` into a folder."""

from __future__ import annotations

import pytest
from conftest import tiny_scenario

from uav_penetration_env.benchmark import cli, report


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """Two scenarios: ``tiny`` flown with 3 seeds, ``tiny-b`` with 1 (as a suite's procedural member)."""
    from uav_penetration_env.benchmark.evaluate import evaluate
    from uav_penetration_env.benchmark.policies import make_policy

    path = tmp_path_factory.mktemp("selection") / "run.sqlite"
    many = tiny_scenario(time={"max_steps": 8})
    one = tiny_scenario(name="tiny-b", time={"max_steps": 8}, goal={"x_km": 3.0})
    evaluate({"greedy": make_policy("greedy")}, [many], range(3), store=path, progress=False)
    evaluate({"greedy": make_policy("greedy")}, [one], range(1), store=path, progress=False)
    return path


def test_min_seeds_leaves_out_the_single_seed_scenario(store, tmp_path):
    from uav_penetration_env.benchmark.figures import write_figures

    everything = [p.name for p in write_figures(store, tmp_path / "all", formats=("png",))]
    assert any(n.startswith("tiny-b-") for n in everything) and any(
        n.startswith("tiny-t") for n in everything
    )
    selected = write_figures(store, tmp_path / "two", formats=("png",), min_seeds=2)
    assert selected and not any(p.name.startswith("tiny-b-") for p in selected)
    with pytest.raises(ValueError, match="min_seeds: got 0, expected an integer >= 1"):
        write_figures(store, tmp_path / "zero", min_seeds=0)


def test_the_page_caps_its_3d_views(store, tmp_path, monkeypatch):
    page = report.write_report(store, tmp_path / "a").read_text()
    assert page.count('class="plotly-graph-div"') == 2 and "scenarios shown" not in page
    page = report.write_report(store, tmp_path / "b", min_seeds=2).read_text()
    assert page.count('class="plotly-graph-div"') == 1
    assert "1 of 2 scenarios shown (at most 6, flown with at least 2 seeds" in page
    monkeypatch.setattr(report, "MAX_3D_VIEWS", 1)
    page = report.write_report(store, tmp_path / "c").read_text()
    assert page.count('class="plotly-graph-div"') == 1  # the scenario with the most episodes
    assert "tiny: seed" in page and "tiny-b: seed" not in page


def test_report_embeds_extra_figures_and_refuses_a_non_png(store, tmp_path, capsys):
    from PIL import Image

    figure = tmp_path / "learning-curves.png"
    Image.new("RGB", (8, 4), (255, 0, 0)).save(figure)
    (tmp_path / "x").write_bytes(b"")
    truncated = tmp_path / "cut.png"
    truncated.write_bytes(b"\x89PNG\r\n\x1a\n")  # the signature alone: named, not a crash
    out = tmp_path / "out"
    assert (
        cli.main(
            ["report", "--store", str(store), "--out", str(out), "--min-seeds", "2", "--figures", str(figure)]
        )
        == 0
    )
    page = (out / "index.html").read_text()
    assert "<figcaption>learning-curves.png</figcaption>" in page
    assert not any(p.name.startswith("tiny-b-") for p in out.iterdir())
    for bad in (tmp_path / "x", truncated):
        assert cli.main(["report", "--store", str(store), "--out", str(out), "--figures", str(bad)]) == 2
        assert f"--figures {bad}: not a PNG file" in capsys.readouterr().err


def test_an_explicit_reference_must_be_stored_and_the_default_may_be_absent(store, tmp_path, capsys):
    for command in ("leaderboard", "report"):
        out = tmp_path / command
        assert cli.main([command, "--store", str(store), "--out", str(out), "--reference", "grredy"]) == 2
        assert (
            "--reference grredy: no such policy in the results; did you mean 'greedy'?"
            in capsys.readouterr().err
        )
    assert (
        cli.main(["leaderboard", "--store", str(store), "--out", str(tmp_path / "default")]) == 0
    )  # no ihpso


def test_export_into_a_folder_names_the_files_after_the_store(store, tmp_path):
    folder = tmp_path / "rows"
    assert cli.main(["export", "--format", "csv", "--store", str(store), "--out", f"{folder}/"]) == 0
    assert sorted(p.name for p in folder.iterdir()) == [
        "run-episodes.csv", "run-manifest.json", "run-policies.csv", "run-runs.csv", "run-scenarios.csv",
        "run-steps.csv", "run-window_runs.csv",
    ]  # fmt: skip


def test_suite_list_refuses_a_name_it_would_ignore(capsys):
    assert cli.main(["suite", "list", "uavpen-v1"]) == 2
    assert "list takes no suite name; use `uav-bench suite show uavpen-v1`" in capsys.readouterr().err


def test_plot_says_which_scenarios_min_seeds_left_out(store, tmp_path, capsys):
    assert cli.main(["plot", "--store", str(store), "--out", str(tmp_path / "p"), "--min-seeds", "2"]) == 0
    assert (
        "no figures for 1 of 2 scenarios flown with fewer than 2 seeds (tiny-b; --min-seeds)"
        in capsys.readouterr().out
    )
    assert cli.main(["plot", "--store", str(store), "--out", str(tmp_path / "q"), "--min-seeds", "2",
                     "--suite", "all"]) == 2  # fmt: skip
    assert "--min-seeds 2: selects per-scenario figures" in capsys.readouterr().err
    page = report.write_report(store, tmp_path / "r", min_seeds=5).read_text()  # no scenario qualifies
    assert 'class="plotly-graph-div"' not in page and "0 of 2 scenarios shown" in page


def test_reference_names_include_labels_and_window_optimizers():
    from types import SimpleNamespace

    import pandas as pd

    from uav_penetration_env.benchmark.commands.common import reference_names

    episodes = pd.DataFrame(
        {"policy": ["pso", "pso", "greedy"], "policy_hash": ["aaaaaaaa11", "bbbbbbbb22", "c"]}
    )
    windows = pd.DataFrame({"optimizer": ["ihpso-rtol1e-6", "hpso"]})
    names = reference_names(SimpleNamespace(episodes=episodes, window_runs=windows))
    assert names == ["greedy", "hpso", "ihpso-rtol1e-6", "pso", "pso@aaaaaaaa", "pso@bbbbbbbb"]


def test_leaderboards_show_the_markdown_cells_and_fold_the_one_seed_tables(store, tmp_path):
    import html
    import re

    import pandas as pd

    from uav_penetration_env.benchmark.leaderboard import write_leaderboards

    out = tmp_path / "folded"
    tables = [p for p in write_leaderboards(store, out, command="test") if p.suffix == ".csv"]
    page = html.unescape(report.write_report(store, out, tables=tables, min_seeds=2).read_text())
    section = page[page.index('id="leaderboards"') :]
    section = section[: section.index("</section>")]
    shown, folded = section.split('<details class="folded">', 1)  # each table has its own toggle too
    assert "<h3>tiny (" in shown and "tiny-b" not in shown  # three seeds: shown
    assert "<h3>tiny-b (" in folded and "1 more scenario tables, each flown with fewer than 2" in folded
    # The cells read as in the Markdown table: the mean with its interval, not raw CSV floats.
    markdown = (out / "tiny.md").read_text()
    # greedy is the reference here (no ihpso stored: the floor, api.md §4.5), so its name is bold
    header = next(line for line in markdown.splitlines() if line.startswith("| policy")).split("|")
    mean = next(i for i, name in enumerate(header) if name.strip().startswith("total J (incl. penalty) mean"))
    mean_cell = re.search(r"\| \*\*greedy\*\* +\|.*", markdown).group(0).split("|")[mean].strip()
    assert "[" in mean_cell and f"<td>{mean_cell}</td>" in shown
    raw = pd.read_csv(out / "tiny.csv")["total_cost_mean_ci_low"].iloc[0]
    assert repr(float(raw)) not in shown  # e.g. 3.9174035152227307: never a full-precision float
    page = html.unescape(report.write_report(store, tmp_path / "all", tables=tables).read_text())
    assert '<details class="folded">' not in page[page.index('id="leaderboards"') :].split("</section>", 1)[0]
