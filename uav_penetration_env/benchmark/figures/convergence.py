"""The optimisers' convergence within MPC steps, from the stored per-step histories."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark.figures.common import (
    FigureInput,
    family_figure,
    figure_title,
    finished_steps,
    mean_band,
    note_empty,
    outside_legend,
)

CONVERGENCE_NODES = 200  # points of the common evaluation grid of the convergence plot


def _parse_list(text: Any) -> np.ndarray:
    if text is None or (isinstance(text, float) and math.isnan(text)):
        return np.array([])
    value = json.loads(text) if isinstance(text, str) else text
    return np.asarray(value if value is not None else [], dtype=np.float64).ravel()


def convergence_curves(steps: pd.DataFrame, grid: np.ndarray) -> tuple[np.ndarray, int]:
    """Normalised best-so-far of every MPC step on a common evaluation grid.

    Each step's history h (best-so-far after initialisation and each iteration, at
    ``history_nfev`` evaluations) becomes (h − h_end)/(h_0 − h_end): 1 at the first record, 0 at
    the final best, the share of the step's total improvement still to come, so steps whose costs
    differ by orders of magnitude are comparable. Between records the curve holds its last value
    (best-so-far is a step function of evaluations); before the first record it is NaN. Steps whose
    optimiser never improved on its first record have no such curve (0/0); they are counted, not
    drawn, so they do not pull the mean towards 0 at the first evaluation.

    Args:
        steps: step rows with ``history`` and ``history_nfev`` (JSON lists).
        grid: evaluation counts (m,).

    Returns:
        (n, m) curves, one per improving step with at least two history entries, and the number of
        steps with a history but no improvement.
    """
    curves = []
    flat = 0
    for history_text, nfev_text in zip(steps["history"], steps["history_nfev"], strict=True):
        history, nfev = _parse_list(history_text), _parse_list(nfev_text)
        if history.size < 2 or history.size != nfev.size or not np.all(np.isfinite(history)):
            continue
        drop = history[0] - history[-1]
        if not drop > 0:
            flat += 1
            continue
        normalised = (history - history[-1]) / drop
        index = np.searchsorted(nfev, grid, side="right") - 1
        curves.append(np.where(index >= 0, normalised[np.clip(index, 0, None)], np.nan))
    return np.array(curves).reshape(len(curves), grid.size), flat


def plot_convergence(inp: FigureInput):
    """Mean normalised best-so-far against evaluations per optimiser, over all MPC steps and seeds."""
    episodes = finished_steps(inp.group, inp.steps)
    rows = {label: pd.concat(runs, ignore_index=True) for label, runs in episodes.items()}
    most = 0.0
    for frame in rows.values():
        for text in frame["history_nfev"]:
            values = _parse_list(text)
            if values.size:
                most = max(most, float(values.max()))
    grid = np.linspace(0.0, most, CONVERGENCE_NODES)
    curves = {}
    if most > 0:
        for label, frame in rows.items():
            drawn, flat = convergence_curves(frame, grid)
            if len(drawn):  # else no optimiser history (a floor or an RL agent), or no step improved
                curves[label] = (drawn, flat)
    figure, panels = family_figure(list(curves), 6.5, 4.6)
    title = (
        f"{inp.group.name}: optimiser convergence per planning step\n"
        "(legend: improving MPC steps drawn; flat: steps without improvement, not drawn)"
    )
    for family, container, members in panels:
        ax = container.add_subplot()
        for label in members:
            drawn, flat = curves[label]
            mean, low, high, _ = mean_band(drawn)
            text = f"{label} ({len(drawn)} steps; {flat} flat)"
            style = inp.styles[label]
            ax.plot(grid, mean, **style.line(), linewidth=1.6, label=text)
            ax.fill_between(grid, low, high, color=style.colour, alpha=0.18, linewidth=0)
        if curves:
            outside_legend(container)
        else:
            note_empty(ax, "no optimiser history in this group (floors and RL agents have none)")
        ax.set_xlabel("objective evaluations within one MPC step")
        ax.set_ylabel(
            "normalised best-so-far (h − h_end)/(h_0 − h_end)\nmean over improving MPC steps, 95% t-band"
        )
        if family is not None:
            ax.set_title(family, fontsize=9)
    figure_title(figure, title)
    return figure
