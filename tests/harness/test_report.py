"""The HTML report: one self-contained page, checked as text and in a real browser."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest
from browser import browser_available, check_report
from conftest import tiny_scenario

from uav_penetration_env.benchmark import report


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    from uav_penetration_env.benchmark.evaluate import evaluate
    from uav_penetration_env.benchmark.figures import write_figures
    from uav_penetration_env.benchmark.leaderboard import write_leaderboards
    from uav_penetration_env.benchmark.policies import make_policy

    folder = tmp_path_factory.mktemp("report")
    store = folder / "run.sqlite"
    policies = {"pso": make_policy("pso", max_evals=200), "greedy": make_policy("greedy")}
    policies["random"] = make_policy("random")
    evaluate(policies, [tiny_scenario(time={"max_steps": 15})], range(2), store=store, progress=False)
    # pso is the reference: the page marks it and compares the others with it.
    tables = write_leaderboards(store, folder, command="test", reference="pso")
    figures = write_figures(store, folder, formats=("png",))
    path = report.write_report(store, folder, tables=tables, figures=figures, reference="pso")
    return path, store, tables, figures


def test_the_page_is_self_contained(written):
    path, *_ = written
    page = path.read_text()
    assert path.name == "index.html"
    # No network needed: no external script, stylesheet or image.
    assert not re.search(r"<script[^>]+src=", page)
    assert not re.search(r"<link[^>]+href=\"?https?:", page)
    assert not re.search(r"<img[^>]+src=\"?https?:", page)
    assert page.split("<main>", 1)[1].count('src="data:image/png;base64,') == len(
        [f for f in written[3] if f.suffix == ".png"]
    )
    for section in report.sections():
        assert f'id="{section.key}"' in page
    assert page.count('class="plotly-graph-div"') == 1  # one scenario: one 3-D view
    assert "Plotly.newPlot" in page


def test_every_policy_has_its_section(written):
    page = written[0].read_text()
    for policy in ("pso", "greedy", "random"):
        assert f'id="policy-{policy}"' in page


def test_a_new_section_is_one_registration(written, tmp_path):
    _, store, tables, figures = written

    @report.register_section("test-extra", "An extra table")
    def extra(context):
        return f"<p>{len(context.episodes)} episodes</p>"

    try:
        page = report.write_report(store, tmp_path, tables=tables, figures=figures).read_text()
        assert '<section id="test-extra"><h2>An extra table</h2><p>6 episodes</p></section>' in page
        assert '<a href="#test-extra">' in page
        with pytest.raises(ValueError, match="already registered"):
            report.register_section("test-extra", "again")(extra)
    finally:
        report._SECTIONS[:] = [s for s in report._SECTIONS if s.key != "test-extra"]


def test_the_page_opens_with_its_headline_and_a_compact_leaderboard(written):
    import html

    import pandas as pd

    from uav_penetration_env.benchmark import glance
    from uav_penetration_env.benchmark.columns import leaderboard_columns

    path, _, tables, _ = written
    page = path.read_text()
    main = page.split("<main>", 1)[1]
    assert main.startswith('<section id="glance"><h2>At a glance</h2><p class="headline">')
    (csv,) = [t for t in tables if t.suffix == ".csv"]
    sentence = glance.headline(pd.read_csv(csv), csv.stem, [0, 1])
    assert f'<p class="headline">{html.escape(sentence)}</p>' in main
    assert sentence.startswith(f"{pd.read_csv(csv).sort_values('total_cost_mean')['policy'].iloc[0]} is cheapest on tiny")
    board = main[main.index('id="leaderboards"') :].split("</section>", 1)[0]
    first = re.search(r'<table class="sortable glance"><thead><tr>(.*?)</tr>', board).group(1)
    headers = [html.unescape(h) for h in re.findall(r"<th[^>]*>(.*?)</th>", first)]
    assert headers[:3] == ["rank", "policy", glance.column_label("total_cost_mean")]
    assert glance.column_label("delta_mean", "pso") in headers and "p (Holm)" in headers
    assert len(headers) < len(leaderboard_columns()) // 2  # the rest behind the toggle
    assert re.search(r"<details><summary>\d+ more columns: episodes, errors, ", board)
    assert '<td class="policy"><strong>pso</strong><span class="badge">reference</span></td>' in board
    assert "**" not in main  # never Markdown's bold in the page
    # Every header of every table reads as words: the registry's labels, never a snake_case name.
    for header in re.findall(r"<th[^>]*>(.*?)</th>", main):
        assert not re.search(r"[a-z]_[a-z]", html.unescape(header)), header


def test_a_missing_store_is_an_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="--store"):
        report.write_report(tmp_path / "none.sqlite", tmp_path)


# --- in a real browser -------------------------------------------------------------------------------

needs_browser = pytest.mark.skipif(
    not browser_available() and not os.environ.get("CI"),
    reason="needs Debian's chromium and chromium-driver and selenium (installed by .ci/run)",
)


@needs_browser
def test_the_report_opens_in_a_browser_and_draws(written):
    check = check_report(written[0])
    assert check.errors == []
    assert check.tables >= 2  # leaderboard(s) and the per-policy tables
    assert check.plots == 1
    assert check.drawn_pixels > 5_000, "the 3-D view drew nothing (WebGL failed?)"
    assert check.sorted_ok
    # At a 1 400 px wide window: the headline is there and the main table needs no sideways scroll.
    import pandas as pd

    from uav_penetration_env.benchmark import glance

    (csv,) = [t for t in written[2] if t.suffix == ".csv"]
    assert check.headline == glance.headline(pd.read_csv(csv), csv.stem, [0, 1])
    assert check.table_fits and check.page_fits


def check_changed_page(page: Path, folder: Path, old: str, new: str):
    """The browser check of a copy of the report ``page`` in ``folder``, its first ``old`` made ``new``."""
    changed = folder / "index.html"
    changed.write_text(page.read_text().replace(old, new, 1))
    return check_report(changed)


@needs_browser
def test_the_browser_check_sees_a_leaderboard_wider_than_the_window(written, tmp_path):
    check = check_changed_page(written[0], tmp_path, '<table class="sortable glance">',
                               '<table class="sortable glance" style="min-width:3000px">')  # fmt: skip
    assert not check.table_fits and check.page_fits  # the table scrolls inside its box, not the page


@needs_browser
def test_the_browser_check_fails_on_a_broken_script(written, tmp_path):
    # A syntax error in the plot's own script: the view must not draw and the console must say so.
    check = check_changed_page(written[0], tmp_path, "Plotly.newPlot(", "Plotly.newPlot((")
    assert check.errors, "a broken script must leave an error in the console"
    assert check.drawn_pixels == 0


def test_embedded_figures_keep_their_size_and_look_in_a_256_colour_palette(written):
    import io

    from PIL import Image

    figure = next(f for f in written[3] if f.suffix == ".png" and "tracks-top" in f.name)
    data = report.embedded_png(figure)
    with Image.open(figure) as original, Image.open(io.BytesIO(data)) as embedded:
        assert embedded.format == "PNG" and embedded.mode == "P" and embedded.size == original.size
        assert len(embedded.getcolors(256)) <= 256
        before = np.asarray(original.convert("RGB"), dtype=np.int16)
        after = np.asarray(embedded.convert("RGB"), dtype=np.int16)
    assert np.abs(before - after).mean() < 3.0  # of 255: the palette barely changes a pixel on average
    assert len(data) < figure.stat().st_size
