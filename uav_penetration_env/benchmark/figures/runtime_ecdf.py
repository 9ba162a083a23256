"""Runtime ECDF of the optimisers on identical MPC windows (``window_runs``; api.md §4.8, COCO)."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark.figures.common import new_figure, note_empty, outside_legend
from uav_penetration_env.benchmark.fixedtarget import TARGET_PRECISIONS, runtime_ecdf, target_runs
from uav_penetration_env.benchmark.leaderboard import ScenarioGroup

ECDF_NODES = 200  # points of the evaluation grid (log-spaced)


def plot_runtime_ecdf(group: ScenarioGroup, windows: pd.DataFrame, styles: dict[str, Any]):
    """Share of (run, target) pairs solved within x evaluations, per optimiser, over the group's windows.

    Targets are f* + Δ|f*| for every Δ of :data:`~uav_penetration_env.benchmark.fixedtarget.TARGET_PRECISIONS`
    (f* the best cost any run found on the window); each curve ends at its success share.

    Args:
        group: the scenario group (for the title).
        windows: its ``window_runs`` rows.
        styles: optimiser name -> :class:`~.common.PolicyStyle` (:func:`~.common.policy_styles`:
            colour by family member, line style by family, never the same pair twice).

    The evaluation axis starts at the fewest evaluations any run had made at its first record (the
    initial swarm), where every curve is still at zero; the legend lies outside the axes.
    """
    figure = new_figure(7.5, 4.8)
    panel = figure.subfigures(1, 1)  # the legend beside the panel, the title above both
    axes = panel.add_subplot(1, 1, 1)
    if windows.empty:
        note_empty(axes, "no window runs (uav-bench windows)")
        return figure
    targets = target_runs(windows)
    budget = float(pd.to_numeric(windows["max_evals"]).max())
    first = min(float(json.loads(h)[0]) for h in windows["history_nfev"])
    grid = np.geomspace(max(1.0, min(first, budget)), budget, ECDF_NODES)
    for optimizer, rows in targets.groupby("optimizer", sort=True):
        axes.step(grid, runtime_ecdf(rows["runtime"], grid), where="post", label=str(optimizer),
                  **styles[optimizer].line())  # fmt: skip
    axes.set_xscale("log")
    axes.set_ylim(0.0, 1.02)
    axes.set_xlabel("objective evaluations")
    axes.set_ylabel("share of (run, target) pairs solved")
    n_windows = windows.drop_duplicates(
        ["scenario_hash", "source_policy_hash", "episode_seed", "step"]
    ).shape[0]
    precisions = ", ".join(f"{p:g}" for p in TARGET_PRECISIONS)
    figure.suptitle(  # above the axes and the legend: a long axes title would run under the legend
        f"{group.name}: runtime ECDF, {n_windows} windows x {windows['seed'].nunique()} seeds\n"
        f"targets f* + Δ|f*|, Δ ∈ {{{precisions}}}, f* the best cost found on the window",
        fontsize=9,
    )
    axes.grid(True, alpha=0.3)
    outside_legend(panel, fontsize=8)
    return figure
