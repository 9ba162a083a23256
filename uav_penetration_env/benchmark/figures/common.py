"""What every figure shares: an Agg canvas, saving, policy families and styles, legends, mean bands.

matplotlib is used through :class:`matplotlib.figure.Figure` and the Agg canvas only, never
pyplot, so nothing touches global state and figures can be drawn in any thread or process.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats as scipy_stats

from uav_penetration_env.atomic import atomic_path
from uav_penetration_env.benchmark.families import (  # noqa: F401 (re-exported: the figures' names)
    FAMILIES,
    FLOORS,
    MPC_FAMILIES,
    PAPER_PLANNERS,
    policy_family,
)
from uav_penetration_env.benchmark.leaderboard import ScenarioGroup

PNG_DPI = 150


def new_figure(width: float, height: float):
    """A Figure on an Agg canvas (no pyplot, no global state)."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as error:  # pragma: no cover - matplotlib is a core dependency
        raise ImportError("figures need matplotlib: pip install matplotlib") from error
    figure = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(figure)
    return figure


def save_figure(figure, out_dir: Path, name: str, formats: Sequence[str]) -> list[Path]:
    """Write ``out_dir/<name>.<format>`` for each format; PDFs carry no date (same store, same bytes)."""
    paths = []
    for extension in formats:
        path = out_dir / f"{name}.{extension}"
        with atomic_path(path) as temporary:  # whole or not at all (uav_penetration_env.atomic)
            if extension == "pdf":
                # No creation date in the PDF, so the same store gives the same bytes.
                figure.savefig(temporary, format=extension, metadata={"CreationDate": None})
            else:
                figure.savefig(temporary, format=extension, dpi=PNG_DPI)
        paths.append(path)
    return paths


def note_empty(ax, text: str) -> None:
    """Say on an empty panel why it is empty, rather than leave a blank figure."""
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, fontsize=10, wrap=True)


NO_STEPS = "no finished episode with stored steps"  # what an empty per-step panel says


def finish_panel(ax, container, family: str | None, *, empty: bool) -> None:
    """Close one family's panel: say so when ``empty`` (:data:`NO_STEPS`), title it, add its legend.

    Args:
        ax: the panel's axes (a 2-D one: the note is drawn in axes coordinates).
        container: the (sub-)figure whose legend is drawn outside its axes.
        family: the policy family the panel draws (``None``: one panel, no title).
        empty: nothing was drawn on it.
    """
    if empty:
        note_empty(ax, NO_STEPS)
    if family is not None:
        ax.set_title(family, fontsize=9)
    outside_legend(container)


@dataclass(frozen=True)
class FigureInput:
    """What a figure of a scenario group is drawn from.

    Attributes:
        group: the scenario group (its episodes, labels, name).
        steps: the transition rows (k >= 1) of the group's episodes.
        starts: the step-0 rows (start states).
        model: the scenario's PenetrationModel, or None (a suite, or no stored YAML).
        styles: label -> :class:`PolicyStyle` of every policy of the group.
        altitude: the radar-coverage altitude chosen by the user [m], or None (the MPC
            policies' median, :func:`~.tracks.coverage_altitude`).
    """

    group: ScenarioGroup
    steps: pd.DataFrame
    starts: pd.DataFrame
    model: Any
    styles: dict[str, Any]
    altitude: float | None = None


# --- who is who: families, colours, line styles, legends -------------------------------------------

PANEL_THRESHOLD = 10  # more policies than this in a figure: one panel per family
# Line style by family; a family with more members than colours continues with its second style.
FAMILY_LINESTYLES: dict[str, tuple[Any, ...]] = {
    "paper planners (MPC)": ("solid", (0, (9, 2, 2, 2, 2, 2))),
    "reference optimisers (MPC)": ((0, (5, 2)), (0, (2, 1, 2, 4))),
    "IHPSO ablations (MPC)": ((0, (3, 1.5, 1, 1.5, 1, 1.5)), (0, (8, 2, 1, 2, 1, 2, 1, 2))),
    "floors": ((0, (1, 1.5)), (0, (1, 4))),
    "classical planners": ((0, (10, 3)), (0, (4, 1, 1, 1))),
    "RL agents": ((0, (6, 2, 1.5, 2)), (0, (12, 2, 1.5, 2))),
    "imitation (distilled)": ((0, (2, 2, 6, 2)), (0, (1, 2, 1, 2, 6, 2))),
}


@dataclass(frozen=True)
class PolicyStyle:
    """How one policy is drawn: its family, colour and line style (``Line2D`` keywords by :meth:`line`)."""

    family: str
    colour: Any
    linestyle: Any

    def line(self) -> dict[str, Any]:
        """``color`` and ``linestyle`` keywords for ``plot``/``step``."""
        return {"color": self.colour, "linestyle": self.linestyle}


def _palette() -> list[Any]:
    from matplotlib import colormaps

    # Red is kept for the radars and their coverage, grey vanishes on the grey hillshade.
    return [c for i, c in enumerate(colormaps["tab10"].colors) if i not in (3, 7)]


def policy_order(labels: Sequence[str]) -> list[str]:
    """Labels sorted by family (in :data:`FAMILIES` order), then by name."""
    return sorted(set(labels), key=lambda label: (FAMILIES.index(policy_family(label)), label))


def policy_styles(labels: Sequence[str]) -> dict[str, PolicyStyle]:
    """A (colour, line style) pair per policy label, never the same pair twice.

    With at most as many policies as colours, every policy gets its own colour (in family order)
    and its family's line style; with more, the colour is the policy's index inside its family,
    so the line style tells the family and the colour the member.

    DECISION (api.md §4.6): colours come from tab10 without red (radars) and grey (terrain); a
    family with more members than colours continues with its second line style, so pairs are
    unique up to twice as many members per family as colours (16); beyond that they repeat.
    """
    palette = _palette()
    ordered = policy_order(labels)
    styles = {}
    distinct = len(ordered) <= len(palette)
    members: dict[str, int] = {}
    for overall, label in enumerate(ordered):
        family = policy_family(label)
        index = overall if distinct else members.get(family, 0)
        members[family] = members.get(family, 0) + 1
        dashes = FAMILY_LINESTYLES[family]
        round_ = (members[family] - 1) // len(palette) if not distinct else 0
        styles[label] = PolicyStyle(
            family, palette[index % len(palette)], dashes[min(round_, len(dashes) - 1)]
        )
    return styles


def policy_colours(labels: Sequence[str]) -> dict[str, Any]:
    """One colour per policy label, from :func:`policy_styles` (stable for the same set of labels)."""
    return {label: style.colour for label, style in policy_styles(labels).items()}


def family_figure(labels: Sequence[str], width: float, height: float):
    """A figure with one panel per family when there are many policies, else one panel.

    Args:
        labels: the policies the figure draws.
        width: the width of one panel [in].
        height: the height of one panel [in].

    Returns:
        The figure and a list of ``(family or None, container, labels)``: the container is a
        sub-figure, the only one (one panel) or one per family present, in :data:`FAMILIES` order.
        The figure's title goes on the figure (:func:`figure_title`), a family's on its panel.
    """
    ordered = policy_order(labels)
    if len(ordered) <= PANEL_THRESHOLD:
        figure = new_figure(width, height)
        # A sub-figure even for one panel: its legend sits beside the panel, under the figure's
        # title (figure_title), so a title wider than the axes never runs under the legend.
        return figure, [(None, figure.subfigures(1, 1), ordered)]
    families = [f for f in FAMILIES if any(policy_family(label) == f for label in ordered)]
    columns = 1 if len(families) == 1 else 2
    rows = -(-len(families) // columns)
    figure = new_figure(width * columns, height * rows)
    containers = figure.subfigures(rows, columns, squeeze=False).ravel()
    return figure, [
        (family, containers[i], [label for label in ordered if policy_family(label) == family])
        for i, family in enumerate(families)
    ]


TITLE_CHARACTER_WIDTH = 0.55  # [em] a character's mean width in the titles' font, to wrap them


def figure_title(figure, title: str, fontsize: float = 10.0) -> None:
    """The figure's title above all its panels and their legends, wrapped to the figure's width.

    DECISION (api.md §4.6): a figure's title is the figure's (``suptitle``), never its axes', and
    the panels with their legends lie in sub-figures below it (:func:`family_figure`): an axes
    title longer than the axes ran under the legend beside them, which the constrained layout
    does not prevent. A line wider than the figure is wrapped at word boundaries.
    """
    import textwrap

    characters = max(20, int(figure.get_figwidth() * 72.0 / (fontsize * TITLE_CHARACTER_WIDTH)))
    lines = [wrapped for line in title.split("\n") for wrapped in textwrap.wrap(line, characters) or [""]]
    figure.suptitle("\n".join(lines), fontsize=fontsize)


COST_LOG_SPAN = 4.0  # costs spanning more than this factor get a log axis (cost_axis)


LABEL_LINE = 48  # characters: a longer axis label overran a 5-inch-high axis and lost its end


def axis_label(quantity: str, detail: str) -> str:
    """``quantity (detail)``, on two lines when it would be longer than :data:`LABEL_LINE`."""
    label = f"{quantity} ({detail})"
    return label if len(label) <= LABEL_LINE else f"{quantity}\n({detail})"


def cost_axis(ax, values: Any, quantity: str, detail: str) -> bool:
    """Label a total-J axis (y), on a log scale when the costs span more than :data:`COST_LOG_SPAN`.

    DECISION (api.md §4.6, docs/rl-statistics.md §2): the random floor's ~150 and a failed
    episode's ~90 against the planners' ~13 would squeeze every planner into the bottom tenth of a
    linear axis; a log axis keeps their differences readable. Costs within a factor of 4 stay
    linear, where differences read directly. The label says which.

    Args:
        ax: the axes.
        values: the costs drawn (any shape; NaN and infinities ignored).
        quantity: what the axis shows (``total J incl. penalty``).
        detail: how (``mean, 95% CI``); the label is ``quantity (detail[; log scale]; lower is better)``.

    Returns:
        Whether the axis is logarithmic.
    """
    import matplotlib.ticker

    finite = np.asarray(values, dtype=np.float64).ravel()
    finite = finite[np.isfinite(finite)]
    low, high = (finite.min(), finite.max()) if finite.size else (0.0, 0.0)
    if low > 0 and high / low > COST_LOG_SPAN:
        ax.set_yscale("log")
        ax.set_ylabel(axis_label(quantity, f"{detail}; log scale; lower is better"))
        ax.yaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
        # 12 and 15 as well: the planners' costs often lie between 10 and 20, where the default
        # minor ticks (2, 3, ... x 10^k) would leave them without a labelled tick.
        ax.yaxis.set_minor_locator(matplotlib.ticker.LogLocator(subs=(1.2, 1.5, 2, 3, 4, 5, 6, 7, 8, 9)))
        ax.yaxis.set_minor_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}" if v < 100 else ""))
        return True
    ax.set_ylabel(axis_label(quantity, f"{detail}; lower is better"))
    return False


LEGEND_ROWS = 24  # entries (headers included) one column of the outside legend holds beside a 5-inch panel
LEGEND_COLUMN_INCHES = 3.4  # the width of one legend column of policy labels at 7 pt


def outside_legend(container, fontsize: float = 7.0) -> None:
    """One legend for a (sub-)figure's labelled artists, outside its axes (right, top).

    Policies are listed by family; with more than one family, each family's entries follow a
    bold header line. Other entries (radars, goal, start, coverage) come last.
    """
    from matplotlib.lines import Line2D

    entries: dict[str, Any] = {}
    for ax in container.axes:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            entries.setdefault(label, handle)
    if not entries:
        return
    policies = [label for label in entries if _is_policy(label)]
    others = [label for label in entries if not _is_policy(label)]
    families = [f for f in FAMILIES if any(policy_family(_policy_of(label)) == f for label in policies)]
    handles, texts, headers = [], [], []
    for family in families:
        if len(families) > 1:
            headers.append(len(texts))
            handles.append(Line2D([], [], linestyle="none"))
            texts.append(family)
        for label in sorted(
            (x for x in policies if policy_family(_policy_of(x)) == family), key=lambda x: _policy_of(x)
        ):
            handles.append(entries[label])
            texts.append(label)
    for label in others:
        handles.append(entries[label])
        texts.append(label)
    # A long list (every family of a v3 table, ~30 entries) is taller than the panel: two columns.
    columns = 1 if len(texts) <= LEGEND_ROWS else 2
    if columns == 2:  # widen the figure by the second column, so the panel keeps its width
        figure = container.figure
        width, height = figure.get_size_inches()
        figure.set_size_inches(width + LEGEND_COLUMN_INCHES, height)
    legend = container.legend(handles, texts, loc="outside right upper", fontsize=fontsize, ncols=columns)
    for index in headers:
        legend.get_texts()[index].set_fontweight("bold")


_NON_POLICY_PREFIXES = ("radars", "goal", "start", "P_d", "best known")


def _is_policy(label: str) -> bool:
    return not label.startswith(_NON_POLICY_PREFIXES)


def _policy_of(label: str) -> str:
    """The policy of a legend label such as ``ihpso (5 runs)``."""
    return label.split(" (", 1)[0]


def mean_band(matrix: np.ndarray, confidence: float = 0.95) -> tuple[np.ndarray, ...]:
    """Column-wise mean and Student-t confidence band of a NaN-padded (runs, points) matrix.

    Args:
        matrix: (n, m) values, NaN where a run has no value.
        confidence: band level.

    Returns:
        mean (m,), low (m,), high (m,), count (m,); mean is NaN where no run has a value, the
        band is NaN where fewer than two do. No warnings for empty columns.
    """
    finite = np.isfinite(matrix)
    count = finite.sum(axis=0)
    filled = np.where(finite, matrix, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(count > 0, filled.sum(axis=0) / np.maximum(count, 1), np.nan)
        squares = np.where(finite, (matrix - mean) ** 2, 0.0).sum(axis=0)
        sd = np.sqrt(squares / np.maximum(count - 1, 1))
        half = (
            scipy_stats.t.ppf(0.5 + confidence / 2.0, np.maximum(count - 1, 1))
            * sd
            / np.sqrt(np.maximum(count, 1))
        )
    half = np.where(count >= 2, half, np.nan)
    return mean, mean - half, mean + half, count


def finished_steps(group: ScenarioGroup, steps: pd.DataFrame) -> dict[str, list[pd.DataFrame]]:
    """The step rows of each finished episode, per policy label (sorted labels, episodes by seed)."""
    valid = group.episodes[~group.episodes["is_error"]].sort_values(["label", "seed"], kind="mergesort")
    by_episode = dict(tuple(steps.groupby("episode_id", sort=True)))
    result: dict[str, list[pd.DataFrame]] = {}
    for label, episode_id in zip(valid["label"], valid["episode_id"], strict=True):
        if episode_id in by_episode:
            result.setdefault(label, []).append(by_episode[episode_id].sort_values("step", kind="mergesort"))
    return result
