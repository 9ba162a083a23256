"""One self-contained HTML page per results store: provenance, tables, figures, 3-D tracks.

``write_report(store, out_dir, tables=..., figures=...)`` writes ``out_dir/index.html``. The page
needs no network: figures are embedded as data URIs and plotly's script is inlined once. Every
part of the page is a *section*, a function from a :class:`ReportContext` to an HTML fragment,
registered with :func:`register_section`; a new table or figure is one registration, never an edit
of the page template (docs/architecture.md, "a new figure or report section").
"""

from __future__ import annotations

import base64
import datetime as dt
import html
import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import pandas as pd

from uav_penetration_env.atomic import write_text_atomic
from uav_penetration_env.benchmark.store import ResultsStore
from uav_penetration_env.wording import counted

SectionRenderer = Callable[["ReportContext"], "str | None"]

MAX_3D_VIEWS = 6  # interactive 3-D views per page (each embeds a terrain surface)
MAX_SURFACE_NODES = 120  # terrain surface nodes per axis in the 3-D view (keeps the page small)


@dataclass(frozen=True)
class Section:
    """A part of the report: an anchor id, a heading and the function that renders its body."""

    key: str
    title: str
    render: SectionRenderer


_SECTIONS: list[Section] = []


def register_section(key: str, title: str) -> Callable[[SectionRenderer], SectionRenderer]:
    """Register a report section (decorator); sections appear in registration order.

    The renderer gets the :class:`ReportContext` and returns an HTML fragment, or ``None`` to omit
    the section (e.g. no figures were written).

    Raises:
        ValueError: ``key`` is already registered.
    """

    def decorator(render: SectionRenderer) -> SectionRenderer:
        if any(s.key == key for s in _SECTIONS):
            raise ValueError(f"report section {key!r} is already registered")
        _SECTIONS.append(Section(key, title, render))
        return render

    return decorator


def sections() -> list[Section]:
    """The registered sections, in page order."""
    return list(_SECTIONS)


@dataclass
class ReportContext:
    """What sections read: the store's rows and the files written beside the report."""

    store_path: Path
    out_dir: Path
    tables: Sequence[Path] = ()
    figures: Sequence[Path] = ()
    reference: str = "ihpso"
    min_seeds: int = 1
    fixed_target_rule: str = "coco"
    _store: ResultsStore | None = field(default=None, repr=False)

    @property
    def store(self) -> ResultsStore:
        """The results store, opened on first use."""
        if self._store is None:
            self._store = ResultsStore(self.store_path, create=False)
        return self._store

    @cached_property
    def episodes(self) -> pd.DataFrame:
        """Episode rows; ``label`` = policy name, errors flagged in ``is_error``."""
        frame = self.store.episodes()
        frame["is_error"] = frame["error"].fillna("") != ""
        frame["label"] = frame["policy"]
        return frame

    @cached_property
    def runs(self) -> pd.DataFrame:
        """Run provenance rows."""
        return self.store.runs()

    @cached_property
    def scenarios(self) -> dict[str, tuple[str, str]]:
        """Stored scenarios: ``hash -> (name, yaml text)``."""
        return self.store.scenarios()

    @cached_property
    def window_runs(self) -> pd.DataFrame:
        """Window-run rows of ``uav-bench windows`` (empty when the store holds none)."""
        return self.store.window_runs()

    @cached_property
    def table_frames(self) -> dict[Path, pd.DataFrame]:
        """Each table CSV of the page, read once (the headline and the leaderboards share them)."""
        return {path: pd.read_csv(path) for path in self.tables}

    def folded(self, frame: pd.DataFrame) -> bool:
        """Whether a table's scenario was flown with fewer than ``min_seeds`` episodes per policy."""
        return bool("episodes" in frame and len(frame) and int(frame["episodes"].max()) < self.min_seeds)

    def steps(self, episode_ids: Sequence[int]) -> pd.DataFrame:
        """Step rows of some episodes, the start state (step 0) included."""
        return self.store.steps(episode_ids, include_start=True)


# --- page assembly -------------------------------------------------------------------------------------

_STYLE = """
body{font-family:system-ui,sans-serif;margin:0;color:#1d2430}
header{background:#1d2430;color:#fff;padding:12px 24px}
nav{padding:8px 24px;background:#eef1f5;position:sticky;top:0;z-index:2}
nav a{margin-right:16px;color:#1d4ed8;text-decoration:none}
main{padding:0 24px 48px}
section{margin-top:28px;scroll-margin-top:64px}
table{border-collapse:collapse;font-size:13px;margin:8px 0 16px}
th,td{border:1px solid #ccd3dd;padding:3px 7px;text-align:right;white-space:nowrap}
th{background:#eef1f5;cursor:pointer;position:relative}
th.sorted-asc::after{content:" \\25B2"} th.sorted-desc::after{content:" \\25BC"}
td:first-child,th:first-child{text-align:left}
.scroll{overflow-x:auto}
figure{margin:12px 0;display:inline-block;max-width:100%}
figure img{max-width:100%;border:1px solid #ccd3dd}
figcaption{font-size:12px;color:#555}
code{background:#eef1f5;padding:1px 4px}
p.headline{font-size:16px;line-height:1.45;max-width:1100px;margin:10px 0}
table.glance th{white-space:normal;vertical-align:bottom}
table.glance td.policy{white-space:normal;overflow-wrap:anywhere;max-width:240px}
th.policy,td.policy,td.text{text-align:left} td.text{white-space:normal;overflow-wrap:anywhere;min-width:160px}
.badge{display:inline-block;font-size:11px;font-weight:600;padding:0 5px;margin-left:4px;border-radius:8px;background:#1d4ed8;color:#fff}
details{margin:4px 0 16px} summary{cursor:pointer;color:#1d4ed8}
"""

# Sorting: a click on a header sorts the rows by that column (numbers as numbers, "12.3 [1, 2]"
# by its leading number, "10,000" as ten thousand); a second click reverses.
_SORT_SCRIPT = """
document.querySelectorAll("table.sortable").forEach(function (table) {
  table.querySelectorAll("th").forEach(function (th, column) {
    th.addEventListener("click", function () {
      var body = table.tBodies[0];
      var ascending = !th.classList.contains("sorted-asc");
      table.querySelectorAll("th").forEach(function (h) { h.classList.remove("sorted-asc", "sorted-desc"); });
      th.classList.add(ascending ? "sorted-asc" : "sorted-desc");
      var key = function (row) {
        var text = row.cells[column].textContent.trim();
        var number = parseFloat(text.replace(/[%*,]/g, ""));
        return isNaN(number) ? text : number;
      };
      Array.from(body.rows).sort(function (a, b) {
        var x = key(a), y = key(b);
        var order = (typeof x === "number" && typeof y === "number") ? x - y : String(x).localeCompare(String(y));
        return ascending ? order : -order;
      }).forEach(function (row) { body.appendChild(row); });
    });
  });
});
"""


def _atomic_write(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename: never a truncated page."""
    write_text_atomic(path, text)


def _plotly_script() -> str:
    from plotly.offline import get_plotlyjs

    return get_plotlyjs()


def render_report(context: ReportContext) -> str:
    """The whole page as HTML text (sections in registration order, empty ones left out)."""
    parts, links = [], []
    for section in sections():
        body = section.render(context)
        if body is None:
            continue
        links.append(f'<a href="#{section.key}">{html.escape(section.title)}</a>')
        parts.append(f'<section id="{section.key}"><h2>{html.escape(section.title)}</h2>{body}</section>')
    uses_plotly = any('class="plotly-graph-div"' in part for part in parts)
    plotly = f"<script>{_plotly_script()}</script>" if uses_plotly else ""
    title = f"uav-bench report: {context.store_path.name}"
    return (
        "<!DOCTYPE html>\n"
        f'<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>'
        f"<style>{_STYLE}</style>{plotly}</head><body>"
        f"<header><h1>{html.escape(title)}</h1></header><nav>{''.join(links)}</nav>"
        f"<main>{''.join(parts)}</main><script>{_SORT_SCRIPT}</script></body></html>\n"
    )


def write_report(
    store_path: str | Path,
    out_dir: str | Path,
    *,
    tables: Sequence[str | Path] = (),
    figures: Sequence[str | Path] = (),
    reference: str = "ihpso",
    min_seeds: int = 1,
    fixed_target_rule: str = "coco",
) -> Path:
    """Write ``out_dir/index.html`` for a results store, atomically.

    Args:
        store_path: the SQLite results store.
        out_dir: the folder of the report (created if needed).
        tables: leaderboard CSV files to show (the Markdown twins are linked, not shown).
        figures: PNG figures to embed (other formats are ignored).
        reference: the optimiser the fixed-target section pairs the others with.
        min_seeds: 3-D views only for scenarios flown with at least this many seeds (at most
            ``MAX_3D_VIEWS`` of them, those with the most episodes first).
        fixed_target_rule: the window comparisons' rule (:data:`~.fixedtarget.FIXED_TARGET_RULES`).

    Returns:
        The path of ``index.html``.

    Raises:
        FileNotFoundError: there is no store at ``store_path``.
    """
    store_path, out_dir = Path(store_path), Path(out_dir)
    if not store_path.is_file():
        raise FileNotFoundError(f"--store {store_path}: no results store there")
    context = ReportContext(
        store_path,
        out_dir,
        tables=[Path(t) for t in tables if str(t).endswith(".csv")],
        figures=[Path(f) for f in figures if str(f).endswith(".png")],
        reference=reference,
        min_seeds=min_seeds,
        fixed_target_rule=fixed_target_rule,
    )
    try:
        page = render_report(context)
    finally:
        if context._store is not None:
            context._store.close()
    path = out_dir / "index.html"
    _atomic_write(path, page)
    return path


# --- sections ------------------------------------------------------------------------------------------


def _html_table(frame: pd.DataFrame) -> str:
    cells = [[html.escape("" if _missing(v) else str(v)) for v in values] for values in frame.itertuples(index=False)]
    return _table_markup([str(c) for c in frame.columns], cells)


def _table_markup(
    header: Sequence[str], rows: Sequence[Sequence[str]], kind: str = "", classes: Sequence[str] = ()
) -> str:
    """A sortable table: ``header`` texts (escaped here) and cells already HTML.

    Args:
        header: the column headers, plain text.
        rows: the cells of each row, HTML.
        kind: an extra class of the table (``glance``: headers may wrap).
        classes: a class per column for its cells (``policy``: a name that may wrap); "" for none.
    """
    styled = list(classes) + [""] * (len(header) - len(classes))
    head = "".join(
        f'<th class="{c}">{html.escape(text)}</th>' if c else f"<th>{html.escape(text)}</th>"
        for c, text in zip(styled, header, strict=True)
    )
    body = "".join(
        "<tr>"
        + "".join(f'<td class="{c}">{v}</td>' if c else f"<td>{v}</td>" for c, v in zip(styled, row, strict=True))
        + "</tr>"
        for row in rows
    )
    table_class = f"sortable {kind}".strip()
    return (
        f'<div class="scroll"><table class="{table_class}"><thead><tr>{head}</tr></thead>'
        f"<tbody>{body}</tbody></table></div>"
    )


def _missing(value: object) -> bool:
    return value is None or (isinstance(value, float) and np.isnan(value))


def _is_leaderboard(frame: pd.DataFrame) -> bool:
    """A scenario group's leaderboard CSV (not a suite's stacked per-member table, not an RL table)."""
    return {"policy", "total_cost_mean"} <= set(frame.columns) and "member" not in frame.columns


def _is_rl_table(frame: pd.DataFrame) -> bool:
    return {"group", "kind", "iqm"} <= set(frame.columns)


def _table_reference(frame: pd.DataFrame, reference: str) -> str | None:
    """The table's reference, as the terminal summary reads it (:func:`~.summary.table_reference`)."""
    from uav_penetration_env.benchmark.summary import table_reference

    return table_reference(frame, reference)


def _policy_cell(policy: str, reference: str | None) -> str:
    """A policy's name; the reference in bold with a badge (HTML, never Markdown's ``**name**``)."""
    name = html.escape(policy)
    return f'<strong>{name}</strong><span class="badge">reference</span>' if policy == reference else name


def _leaderboard_tables(frame: pd.DataFrame, reference: str | None) -> str:
    """A leaderboard as the page shows it: the most-read columns, the others behind a toggle.

    The cells are those of the Markdown twin (:func:`~.leaderboard.markdown.cell`: means with their
    intervals, p-values, shares), the headers the column registry's; the first table holds
    :data:`~.glance.GLANCE_COLUMNS`, a closed ``<details>`` block the policy and every other column.
    """
    from uav_penetration_env.benchmark.glance import split_columns
    from uav_penetration_env.benchmark.leaderboard.markdown import cell, shown_columns

    first, rest = split_columns(shown_columns(frame))
    records = [r for _, r in frame.iterrows()]

    def table(columns, kind: str) -> str:
        header = [c.board.header.format(reference=reference or "reference") for c in columns]
        rows = [
            [
                _policy_cell(str(r["policy"]), reference) if c.name == "policy" else html.escape(cell(c, r, reference))
                for c in columns
            ]
            for r in records
        ]
        return _table_markup(header, rows, kind, ["policy" if c.name == "policy" else "" for c in columns])

    policy = [c for c in first if c.name == "policy"]
    parts = [table(first, "glance")]
    if rest:
        names = ", ".join(c.board.name or c.board.header.format(reference=reference or "reference") for c in rest)
        parts.append(
            f"<details><summary>{len(rest)} more columns: {html.escape(names)}</summary>"
            f"{table(policy + rest, '')}</details>"
        )
    return "".join(parts)


def _rl_table(frame: pd.DataFrame) -> str:
    """An RL table (``*-rl.csv``) with the column registry's headers and the Markdown's cells."""
    from uav_penetration_env.benchmark.leaderboard.rl import rl_rows

    header, rows = rl_rows(frame)
    return _table_markup(header, [[html.escape(c) for c in row] for row in rows], "glance", ["policy"])


def _display_table(frame: pd.DataFrame) -> pd.DataFrame:
    """Any other table CSV: its columns kept, numbers to four significant digits."""
    from uav_penetration_env.benchmark.leaderboard.formatting import format_number

    return pd.DataFrame(
        {
            column: [
                format_number(v) if isinstance(v, float) else ("" if _missing(v) else str(v)) for v in frame[column]
            ]
            for column in frame.columns
        }
    )


def _group_seeds(context: ReportContext) -> tuple[dict[str, tuple[list[int], tuple[str, ...]]], tuple]:
    """Per scenario group's stem: its episode seeds and scenario; and the same over the whole store.

    A table of no single scenario group (``leaderboard --suite``, a frozen suite's) covers the
    store's episodes: the second item, every seed and scenario of the store.
    """
    from uav_penetration_env.benchmark.leaderboard import scenario_groups

    episodes = context.store.episodes()
    found = {}
    for group in scenario_groups(episodes):
        seeds = sorted(int(s) for s in group.episodes["seed"].dropna().unique())
        found[group.stem] = (seeds, (group.name,))
    every = (sorted(int(s) for s in episodes["seed"].dropna().unique()), tuple(sorted(set(episodes["scenario"]))))
    return found, every


# Headline sentences at most on the page's top; the other tables are one click away.
MAX_HEADLINES = 6


@register_section("glance", "At a glance")
def _glance(context: ReportContext) -> str:
    """One headline sentence per leaderboard shown (:func:`~.glance.headline`), computed from its CSV.

    DECISION (api.md §4.6, "the page at a glance"): the first section of the page, one sentence for
    each leaderboard that is not folded away (``--min-seeds``), at most ``MAX_HEADLINES``.
    """
    from uav_penetration_env.benchmark.glance import headline

    boards = [
        (path, frame)
        for path, frame in context.table_frames.items()
        if _is_leaderboard(frame) and not context.folded(frame)
    ]
    if not boards:
        return (
            "<p>No leaderboard on this page: <code>uav-bench report</code> writes them from the store "
            "(<code>uav-bench leaderboard</code> alone writes the Markdown and CSV files).</p>"
        )
    seeds, every = _group_seeds(context)
    parts = []
    for path, frame in boards[:MAX_HEADLINES]:
        group_seeds, scenarios = seeds.get(path.stem, every)
        text = headline(frame, path.stem, group_seeds, scenarios)
        parts.append(f'<p class="headline">{html.escape(text)}</p>')
    if len(boards) > MAX_HEADLINES:
        parts.append(f"<p>{len(boards) - MAX_HEADLINES} more leaderboards below (Leaderboards).</p>")
    parts.append(
        "<p>Lower total J is better. Intervals: bootstrap 95 %; the paired test is the leaderboard's "
        "(Wilcoxon signed-rank over shared seeds, Holm-adjusted); every column is explained in the "
        "Markdown files beside this page and in docs/columns.md.</p>"
    )
    return "".join(parts)


@register_section("provenance", "Provenance")
def _provenance(context: ReportContext) -> str:
    episodes = context.episodes
    lines = [
        f"<p>Store <code>{html.escape(str(context.store_path))}</code>: {counted(len(episodes), 'episode')} "
        f"({counted(int(episodes['is_error'].sum()), 'error')}), "
        f"{counted(episodes['policy'].nunique(), 'policy', 'policies')}, "
        f"{counted(episodes['scenario_hash'].nunique(), 'scenario')}. Report written "
        f"{dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat()}.</p>"
    ]
    rows = []
    for run in context.runs.itertuples(index=False):
        record = json.loads(run.provenance or "{}")
        versions = record.get("versions", {})
        rows.append(
            {
                "run": run.run_id,
                "started": record.get("date", ""),
                "command": record.get("command", ""),
                "commit": record.get("commit", ""),
                "versions": ", ".join(f"{k} {v}" for k, v in sorted(versions.items())) if versions else "",
                "machine": f"{record.get('cpu', '')} ({record.get('cores', '?')} cores)",
            }
        )
    if rows:
        # Long commands and version lists wrap inside their cells rather than widen the page.
        header = list(rows[0])
        cells = [[html.escape(str(row[key])) for key in header] for row in rows]
        wrapped = ["text" if key in ("command", "versions", "machine") else "" for key in header]
        lines.append(_table_markup(header, cells, "", wrapped))
    return "".join(lines)


@register_section("leaderboards", "Leaderboards")
def _leaderboards(context: ReportContext) -> str | None:
    """Every leaderboard, its most-read columns first; one-seed scenario tables folded away (``min_seeds``).

    DECISION (api.md §4.6): a store holding a whole suite has a table per member; those flown with
    fewer than ``min_seeds`` episodes per policy (the procedural members at one seed each) are folded
    into one closed ``<details>`` block after the others, so the paper scenario and the suite tables
    come first. A stacked per-member CSV (``*-members.csv``) is linked, not repeated.
    """
    if not context.tables:
        return None
    shown, folded = [], []
    for path, frame in context.table_frames.items():
        markdown = path.with_suffix(".md")
        href = html.escape(os.path.relpath(markdown, context.out_dir))
        link = f' (<a href="{href}">Markdown with provenance</a>)' if markdown.exists() else ""
        if "member" in frame.columns:
            shown.append(f"<p>Per-member tables of a suite: <a href=\"{href}\">{html.escape(markdown.name)}</a>.</p>")
            continue
        if _is_leaderboard(frame):
            body = _leaderboard_tables(frame, _table_reference(frame, context.reference))
        elif _is_rl_table(frame):
            body = _rl_table(frame)
        else:
            body = _html_table(_display_table(frame))
        block = f"<h3>{html.escape(path.stem)}{link}</h3>{body}"
        (folded if context.folded(frame) else shown).append(block)
    if folded:
        shown.append(
            f'<details class="folded"><summary>{len(folded)} more scenario tables, each flown with fewer than '
            f"{context.min_seeds} episodes per policy (--min-seeds)</summary>{''.join(folded)}</details>"
        )
    return "".join(shown)


@register_section("fixed-target", "Fixed target and fixed budget (identical windows)")
def _fixed_target(context: ReportContext) -> str:
    """The tables of :func:`~.fixedtarget.fixed_target_frames` per scenario of the window runs (api.md §4.8)."""
    rows = context.window_runs
    if rows.empty:
        return (
            "<p>The store holds no window runs: <code>uav-bench windows</code> reruns optimisers on the "
            "same stored MPC window states and adds the fixed-target and fixed-budget tables here.</p>"
        )
    from uav_penetration_env.benchmark.fixedtarget import fixed_target_frames

    parts = [
        "<p>From <code>uav-bench windows</code>: every optimiser rerun on the same stored MPC window "
        "states, many seeds (api.md §4.8). f_best is the best cost any run (long searches included) found "
        "on a window; the targets are f_best + Δ|f_best|. ERT = (evaluations of the successful runs to the "
        "target + evaluations of the unsuccessful runs) / successes. Windows are the units: per window, "
        "log10(ERT other / ERT reference) at each target, and the other's best-so-far J at the "
        "reference's evaluation count minus the reference's final J; median over windows, bootstrap "
        "interval over windows, two-sided Wilcoxon signed-rank test over windows (raw p).</p>"
    ]
    for scenario_hash, group in rows.groupby("scenario_hash", sort=True):
        name = context.scenarios.get(scenario_hash, (str(group["scenario"].iloc[0]), ""))[0]
        reference, frames = fixed_target_frames(group, context.reference, context.fixed_target_rule)
        parts.append(f"<h3>{html.escape(str(name))} (reference {html.escape(reference)})</h3>")
        for title, frame in frames.items():
            if not frame.empty:
                parts.append(f"<h4>{html.escape(title)}</h4>{_html_table(frame)}")
    return "".join(parts)


@register_section("suite", "Frozen suite")
def _frozen_suite(context: ReportContext) -> str:
    """Each frozen suite the store's runs were made for: mean total J per member group (docs/suite.md §5)."""
    from uav_penetration_env.benchmark.leaderboard.formatting import format_number
    from uav_penetration_env.benchmark.leaderboard.suite import (
        group_overview,
        recorded_suites,
        suite_episodes,
    )
    from uav_penetration_env.suites import SuiteError, load_suite

    parts = []
    for name in recorded_suites(context.runs):
        try:
            suite = load_suite(name)
        except SuiteError:
            continue
        frame = suite_episodes(context.store.episodes(), suite)
        if frame.empty:
            continue
        overview = group_overview(frame, suite)
        shown = pd.DataFrame(
            {"policy": overview.index, "members": overview["members"].astype(int)}
            | {column: [format_number(v) for v in overview[column]] for column in overview.columns[1:]}
        )
        links = [
            f'<a href="{html.escape(os.path.relpath(path.with_suffix(".md"), context.out_dir))}">{html.escape(path.stem)}</a>'
            for path in context.tables
            if path.stem == suite.name or path.stem.startswith(f"{suite.name}-")
        ]
        parts.append(
            f"<h3>{html.escape(suite.name)}</h3><p>{len(set(frame['member']))} of {len(suite.members)} members "
            "have episodes. Mean total J (incl. penalty) per member group, each member weighing the same (a "
            "policy's episodes on a member are averaged first); lower is better. Full statistics: "
            f"{', '.join(links) or 'uav-bench leaderboard'}.</p>{_html_table(shown)}"
        )
    if not parts:
        # Always present, so a reader of any report learns the suite exists (and the page layout is fixed).
        return (
            "<p>No run of this store was a frozen-suite run (<code>uav-bench run --suite uavpen-v1</code>; "
            "<code>uav-bench suite list</code>; docs/suite.md).</p>"
        )
    return "".join(parts)


@register_section("tracks-3d", "Tracks over the terrain (3-D, interactive)")
def _tracks_3d(context: ReportContext) -> str | None:
    episodes = context.episodes[~context.episodes["is_error"]]
    if episodes.empty:
        return None
    # DECISION (api.md §4.6): at most MAX_3D_VIEWS views, for the scenarios flown with at least
    # min_seeds seeds, those with the most episodes first (each view embeds a terrain surface).
    sizes = episodes.groupby("scenario_hash", sort=True).agg(seeds=("seed", "nunique"), n=("seed", "size"))
    eligible = sizes[sizes["seeds"] >= context.min_seeds].sort_values("n", ascending=False, kind="stable")
    shown = list(eligible.index[:MAX_3D_VIEWS])
    parts = []
    for scenario_hash in sorted(shown):
        group = episodes[episodes["scenario_hash"] == scenario_hash]
        name, yaml_text = context.scenarios.get(scenario_hash, (str(group["scenario"].iloc[0]), ""))
        seed = int(group.groupby("seed")["policy"].nunique().idxmax())
        chosen = group[group["seed"] == seed]
        steps = context.steps(chosen["episode_id"].tolist())
        if steps.empty:
            continue
        figure = tracks_figure(yaml_text, chosen, steps, title=f"{name}: seed {seed}")
        parts.append(
            figure.to_html(include_plotlyjs=False, full_html=False, div_id=f"tracks-{scenario_hash}")
        )
    left_out = len(sizes) - len(shown)
    if left_out:
        parts.append(
            f"<p>{len(shown)} of {len(sizes)} scenarios shown (at most {MAX_3D_VIEWS}, flown with at least "
            f"{context.min_seeds} seeds, most episodes first); every track is exported by "
            "<code>uav-bench export --tracks</code>.</p>"
        )
    return "".join(parts) or None


def tracks_figure(yaml_text: str, episodes: pd.DataFrame, steps: pd.DataFrame, title: str):
    """A plotly 3-D figure: the terrain surface, the radars and one track per policy [km, km, m]."""
    import plotly.graph_objects as go

    figure = go.Figure()
    built = _built_scenario(yaml_text)
    if built is not None:
        stride = max(1, int(np.ceil(max(built.grid.nx, built.grid.ny) / MAX_SURFACE_NODES)))
        x_km = built.grid.x_nodes[::stride] / 1000.0
        y_km = built.grid.y_nodes[::stride] / 1000.0
        heights = np.asarray(built.terrain)[::stride, ::stride]
        figure.add_trace(
            go.Surface(
                x=x_km, y=y_km, z=heights.T, colorscale="Earth", showscale=False, opacity=0.9, name="terrain"
            )
        )
        radars = np.asarray(built.radar_xyz)
        if len(radars):
            figure.add_trace(
                go.Scatter3d(
                    x=radars[:, 0] / 1000.0,
                    y=radars[:, 1] / 1000.0,
                    z=radars[:, 2],
                    mode="markers+text",
                    text=[r.name for r in built.scenario.radars],
                    marker={"size": 6, "color": "red", "symbol": "diamond"},
                    name="radars",
                )
            )
    styles = _plotly_styles(episodes["policy"].astype(str).unique())
    for policy, ids in episodes.groupby("policy", sort=True)["episode_id"]:
        rows = steps[steps["episode_id"].isin(ids)].sort_values("step", kind="mergesort")
        figure.add_trace(
            go.Scatter3d(
                x=rows["x_km"],
                y=rows["y_km"],
                z=rows["z_m"],
                mode="lines",
                line={"width": 5, **styles[str(policy)]},
                name=str(policy),
            )
        )
    figure.update_layout(
        title=title,
        height=640,
        margin={"l": 0, "r": 0, "t": 40, "b": 0},
        scene={
            "xaxis_title": "x [km]",
            "yaxis_title": "y [km]",
            "zaxis_title": "z [m]",
            "aspectmode": "manual",
            "aspectratio": {"x": 1, "y": 1, "z": 0.35},
        },
        legend={"x": 1.0, "xanchor": "left"},
    )
    return figure


# plotly's 3-D lines know six dash names only: one per family, the two learned families sharing
# one (the second style of a large family is drawn long-dashed).
_PLOTLY_DASH = {
    "paper planners (MPC)": "solid",
    "reference optimisers (MPC)": "dash",
    "IHPSO ablations (MPC)": "dashdot",
    "floors": "dot",
    "classical planners": "longdash",
    "RL agents": "longdashdot",
    "imitation (distilled)": "longdashdot",  # shared with the RL agents: both learned planners
}


def _plotly_styles(labels) -> dict[str, dict[str, str]]:
    """The figures' colour of each policy and its family's dash, as plotly ``line`` keys."""
    from matplotlib.colors import to_hex

    from uav_penetration_env.benchmark.figures.common import FAMILY_LINESTYLES, policy_styles

    styles = {}
    for label, style in policy_styles(labels).items():
        first = style.linestyle == FAMILY_LINESTYLES[style.family][0]
        styles[label] = {
            "color": to_hex(style.colour),
            "dash": _PLOTLY_DASH[style.family] if first else "longdash",
        }
    return styles


def _built_scenario(yaml_text: str):
    """The stored scenario built (terrain grid, radars), or None when the YAML cannot be read."""
    if not yaml_text:
        return None
    import yaml

    from uav_penetration_env.build import build_scenario
    from uav_penetration_env.scenario import load_scenario

    try:
        return build_scenario(load_scenario(yaml.safe_load(yaml_text)))
    except (ValueError, KeyError, TypeError, OSError):  # ScenarioError is a ValueError
        return None


def embedded_png(path: Path) -> bytes:
    """The PNG at ``path`` with its colours reduced to a 256-colour palette, for embedding in the page.

    DECISION (api.md §4.6, report size): the figures are line plots over a grey hillshade, which a
    256-colour palette renders with barely visible banding at about a quarter of the bytes (the
    29 figures of the v2 store before its agents part: 11.1 MB as written, 2.9 MB in the palette), and the page
    carries every figure base64-encoded. The PNG files beside the page stay full colour.
    """
    import io

    from PIL import Image

    with Image.open(path) as image:
        palette = image.convert("RGB").quantize(256, method=Image.Quantize.FASTOCTREE)
    buffer = io.BytesIO()
    palette.save(buffer, format="PNG", optimize=True)
    return buffer.getvalue()


@register_section("figures", "Figures")
def _figures(context: ReportContext) -> str | None:
    if not context.figures:
        return None
    parts = []
    for path in context.figures:
        data = base64.b64encode(embedded_png(path)).decode("ascii")
        parts.append(
            f'<figure><img alt="{html.escape(path.stem)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html.escape(path.name)}</figcaption></figure>"
        )
    return "".join(parts)


def _policy_headers() -> dict[str, str]:
    """The per-policy tables' headers: the column registry's labels (never a snake_case name)."""
    from uav_penetration_env.benchmark.glance import column_label

    total = column_label("total_cost_mean", short=True)
    return {
        "episodes": column_label("episodes"),
        "success": column_label("success_rate", short=True),
        "mean_total_cost": f"{total} mean",
        "median_total_cost": f"{total} median",
        "mean_steps": f"{column_label('steps')} (mean)",
        "evals_per_step": column_label("nfev_per_step"),
        "planning_s_per_step": column_label("planning_seconds"),
    }


@register_section("policies", "Policies")
def _policies(context: ReportContext) -> str | None:
    episodes = context.episodes
    if episodes.empty:
        return None
    parts = []
    for policy, rows in episodes.groupby("policy", sort=True):
        good = rows[~rows["is_error"]]
        summary = (
            good.groupby("scenario", sort=True)
            .agg(
                episodes=("seed", "size"),
                success=("outcome", lambda o: f"{100.0 * np.mean(o == 'success'):.0f}%"),
                mean_total_cost=("total_cost", lambda v: f"{v.mean():.4g}"),
                median_total_cost=("total_cost", lambda v: f"{v.median():.4g}"),
                mean_steps=("steps", lambda v: f"{v.mean():.1f}"),
                evals_per_step=("nfev_per_step", lambda v: f"{v.mean():.0f}"),
                planning_s_per_step=("planning_seconds", lambda v: f"{v.mean():.3g}"),
            )
            .reset_index()
        )
        summary = summary.rename(columns=_policy_headers())
        errors = int(rows["is_error"].sum())
        note = f"<p>{errors} error episodes (retried on the next run).</p>" if errors else ""
        parts.append(f'<h3 id="policy-{html.escape(str(policy))}">{html.escape(str(policy))}</h3>{note}')
        parts.append(_html_table(summary))
    return "".join(parts)


@register_section("compute", "Compute: decision time per step and training budget")
def _compute(context: ReportContext) -> str | None:
    """Per scenario group, each policy's (RL agents: each group's) decision time, total J and training.

    docs/rl-statistics.md §2: the numbers behind the ``compute-axis`` figure, means with
    stratified-bootstrap 95 % intervals over runs (training seeds of an RL group, episode seeds of
    any other policy).
    """
    from uav_penetration_env.benchmark.leaderboard import compute_points, scenario_groups
    from uav_penetration_env.benchmark.leaderboard.formatting import format_interval, format_number

    parts = []
    for group in scenario_groups(context.store.episodes()):
        points = compute_points(group.episodes)
        if points.empty:
            continue
        rows = pd.DataFrame(
            {
                "policy / RL group": points["method"],
                "family": points["family"],
                "runs": points["runs"],
                "decision [s/step] [95% CI]": [
                    format_interval(
                        r.decision_seconds, r.decision_seconds_ci_low, r.decision_seconds_ci_high, 3
                    )
                    for r in points.itertuples()
                ],
                "total J [95% CI]": [
                    format_interval(r.total_cost, r.total_cost_ci_low, r.total_cost_ci_high)
                    for r in points.itertuples()
                ],
                "train steps": [
                    f"{int(v):,}" if np.isfinite(v) else ""
                    for v in points["train_timesteps"].to_numpy(dtype=float)
                ],
                "train [s]": [format_number(v) for v in points["train_seconds"]],
            }
        )
        parts.append(f"<h3>{html.escape(group.name)}</h3>{_html_table(rows)}")
    if not parts:
        return None
    note = (
        "<p>Decision time: wall-clock seconds per action as the evaluator measured them (MPC planning, "
        "network inference, the greedy rule), on the machine of the run. RL agents are pooled over "
        "training seeds (runs); other policies' runs are their episode seeds. Intervals: stratified "
        "bootstrap over runs within scenarios (docs/rl-statistics.md).</p>"
    )
    return note + "".join(parts)
