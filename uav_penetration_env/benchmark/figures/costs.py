"""Figures of costs over seeds: J per track point, total cost per episode, performance profile."""

from __future__ import annotations

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark.figures.common import (
    FigureInput,
    cost_axis,
    family_figure,
    figure_title,
    finish_panel,
    finished_steps,
    mean_band,
    new_figure,
    note_empty,
    outside_legend,
)
from uav_penetration_env.benchmark.leaderboard import cost_table


def plot_j_per_point(inp: FigureInput):
    """Mean J(k) per track point vs k with 95 % t-bands over seeds, and how many runs reach each k (A30)."""
    episodes = finished_steps(inp.group, inp.steps)
    figure, panels = family_figure(list(episodes), 7.0, 5.5)
    title = f"{inp.group.name}: cost per track point (runs NaN-padded after they end)"
    for family, container, members in panels:
        top, bottom = container.subplots(2, 1, sharex=True, height_ratios=[3, 1])
        for label in members:
            runs = episodes[label]
            style = inp.styles[label]
            length = max(int(r["step"].max()) for r in runs)
            matrix = np.full((len(runs), length), np.nan)
            for i, rows in enumerate(runs):
                matrix[i, rows["step"].to_numpy(dtype=int) - 1] = rows["J"].to_numpy(dtype=np.float64)
            mean, low, high, count = mean_band(matrix)
            # With two runs the t quantile is 12.7 and the band fills the panel without saying anything.
            low, high = np.where(count >= 3, low, np.nan), np.where(count >= 3, high, np.nan)
            k = np.arange(1, length + 1)
            top.plot(k, mean, **style.line(), linewidth=1.5, label=f"{label} ({len(runs)} runs)")
            top.fill_between(k, low, high, color=style.colour, alpha=0.18, linewidth=0)
            bottom.step(k, count, where="mid", **style.line(), linewidth=1.2)
        top.set_ylabel("J(k) per track point\n(mean over seeds; 95% t-band where ≥ 3 runs)")
        bottom.set_ylabel("runs at k")
        bottom.set_xlabel("track point k")
        finish_panel(top, container, family, empty=not episodes)
    figure_title(figure, title)
    return figure


def plot_cost_box(inp: FigureInput):
    """Box plots of total cost (ΣJ + failure penalty) per planner, ordered by median, points overlaid.

    One panel whatever the number of policies: the policies are named on the axis, and each box's
    edge has the policy's line style (its family) and its fill the policy's colour.
    """
    valid = inp.group.episodes[~inp.group.episodes["is_error"]]
    samples = {
        label: valid.loc[valid["label"] == label, "total_cost"].dropna().to_numpy(dtype=np.float64)
        for label in sorted(valid["label"].unique())
    }
    samples = {k: v for k, v in samples.items() if v.size}
    order = sorted(samples, key=lambda label: (float(np.median(samples[label])), label))
    figure = new_figure(max(7.5, 0.42 * len(order) + 2.5), 5.2)
    ax = figure.add_subplot()
    if order:
        boxes = ax.boxplot(
            [samples[label] for label in order],
            patch_artist=True,
            widths=0.55,
            showfliers=False,  # every episode is drawn as a point below
            medianprops={"color": "black"},
        )
        for patch, label in zip(boxes["boxes"], order, strict=True):
            style = inp.styles[label]
            patch.set_facecolor((*style.colour[:3], 0.35))
            patch.set_edgecolor(style.colour)
            patch.set_linestyle(style.linestyle)
            patch.set_linewidth(1.4)
        for i, label in enumerate(order, start=1):
            values = samples[label]
            # Deterministic spread instead of random jitter, so the figure is reproducible.
            offsets = np.linspace(-0.12, 0.12, values.size) if values.size > 1 else np.zeros(1)
            ax.scatter(
                i + offsets,
                values,
                color=inp.styles[label].colour,
                s=14,
                edgecolors="black",
                linewidths=0.4,
                zorder=3,
            )
        ax.set_xticks(range(1, len(order) + 1))
        ax.set_xticklabels(order, rotation=35 if len(order) > 8 else 20, ha="right", fontsize=8)
    else:
        note_empty(ax, "no finished episode")
    cost_axis(ax, np.concatenate(list(samples.values())) if samples else [], "total J incl. failure penalty", "= −return")
    ax.set_title(f"{inp.group.name}: total cost per episode (lower is better)", fontsize=9)
    return figure


def _sparse_log_label(value: float, _position: object = None) -> str:
    """A log axis' minor tick label: ``value`` at 1.2, 1.5, 2, 3 and 5 x 10^k, else nothing."""
    if value <= 0:
        return ""
    mantissa = value / 10 ** np.floor(np.log10(value))
    return f"{value:g}" if any(abs(mantissa - m) < 1e-6 for m in (1.2, 1.5, 2, 3, 5)) else ""


def performance_profile(table: pd.DataFrame) -> tuple[dict[str, np.ndarray], float]:
    """Dolan-Moré ratios per policy over the seeds every policy finished.

    Args:
        table: seeds x policies costs (NaN = missing).

    Returns:
        label -> ratios (cost / best cost on the same seed), and the shift added to every cost
        first (0 unless some cost is <= 0, when costs are shifted so that the smallest is 1).
    """
    present = table.loc[:, table.notna().any(axis=0)]
    complete = present.dropna(axis=0, how="any")
    if complete.empty:
        return {}, 0.0
    values = complete.to_numpy(dtype=np.float64)
    smallest = float(values.min())
    shift = 0.0 if smallest > 0.0 else 1.0 - smallest  # ratios need positive costs
    values = values + shift
    ratios = values / values.min(axis=1, keepdims=True)
    return {label: ratios[:, j] for j, label in enumerate(complete.columns)}, shift


def plot_performance_profile(inp: FigureInput):
    """Fraction of seeds on which each planner's total cost is within a factor τ of the best planner's.

    The ratios are taken against the best of *all* policies, also when the figure has one panel
    per family.
    """
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ratios, shift = performance_profile(cost_table(inp.group.episodes))
    figure, panels = family_figure(list(ratios), 6.5, 4.6)
    if ratios:
        worst = max(float(r.max()) for r in ratios.values())
        end = max(worst * 1.1, 1.1)
        seeds = len(next(iter(ratios.values())))
        note = f"; costs shifted by {shift:.3g} to be positive" if shift else ""
        title = f"{inp.group.name}: performance profile over {seeds} seeds every planner finished{note}"
    else:
        title = f"{inp.group.name}: performance profile"
    for family, container, members in panels:
        ax = container.add_subplot()
        if ratios:
            for label in members:
                r = ratios[label]
                taus = np.concatenate([[1.0], np.sort(r), [end]])
                fraction = (r[None, :] <= taus[:, None]).mean(axis=1)
                ax.step(taus, fraction, where="post", **inp.styles[label].line(), linewidth=1.6, label=label)
            ax.set_xscale("log")
            ax.set_xlim(1.0, end)
            ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            # Minor ticks at 1.2 and 1.5 x 10^k too, where most profiles rise; labels at 1.2, 1.5, 2,
            # 3 and 5 x 10^k only (6, 7, 8, 9 crowd into each other), and none beyond three decades.
            ax.xaxis.set_minor_locator(LogLocator(subs=(1.2, 1.5, 2, 3, 4, 5, 6, 7, 8, 9)))
            ax.xaxis.set_minor_formatter(FuncFormatter(_sparse_log_label) if end <= 1000 else NullFormatter())
            outside_legend(container)
        else:
            note_empty(ax, "no seed finished by every planner")
        if family is not None:
            ax.set_title(family, fontsize=9)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel("τ (total cost / best total cost on the same seed, log scale)")
        ax.set_ylabel("fraction of seeds within τ of the best")
    figure_title(figure, title)
    return figure
