"""RL versus swarm: total J against decision time per step, and run-score performance profiles.

docs/rl-statistics.md §2. Both figures pool RL agents by group (all training seeds of one
algorithm and regime, :func:`~uav_penetration_env.benchmark.leaderboard.rl.methods`) and keep
every other policy alone; both read the store's episode rows only (no model is loaded), so they
are drawn with the core install.
"""

from __future__ import annotations

import numpy as np

from uav_penetration_env.benchmark import rl_stats
from uav_penetration_env.benchmark.figures.common import (
    FigureInput,
    cost_axis,
    figure_title,
    new_figure,
    note_empty,
    outside_legend,
    policy_styles,
)
from uav_penetration_env.benchmark.leaderboard.rl import (
    best_planner,
    compute_points,
    label_seed,
    methods,
    run_scores,
)

PROFILE_TAUS = 200  # thresholds of a performance profile
PROFILE_RESAMPLES = 1_000  # bootstrap resamples of its band (per figure; rliable uses 2 000)
COMPUTE_RESAMPLES = 2_000
_MARKERS = {
    "paper planners (MPC)": "o",
    "reference optimisers (MPC)": "s",
    "IHPSO ablations (MPC)": "D",
    "floors": "v",
    "RL agents": "^",
}
HYBRID_MARKER = "P"  # an MPC planner warm-started by an agent (``ihpso+sb3:...``): planning time, RL family


def _is_hybrid(label: str) -> bool:
    return "+" in label.partition(":")[0]


def plot_compute_axis(inp: FigureInput):
    """Total J (incl. penalty) against decision time per step, log x, one point per policy or RL group.

    Each point is the mean over runs x scenarios with its stratified-bootstrap 95 % interval in both
    directions (runs: training seeds of an RL group, episode seeds of any other policy); colour and
    marker by family (a filled plus for the agent-warm-started hybrids), colour and bar line style as
    in the other figures (:func:`~.common.policy_styles`). The decision time is the evaluator's
    wall-clock seconds per action, so the figure is machine-dependent in x.
    """
    points = compute_points(inp.group.episodes, n_resamples=COMPUTE_RESAMPLES)
    figure = new_figure(7.8, 5.0)
    panel = figure.subfigures(1, 1)  # the legend beside the panel, the title above both
    ax = panel.add_subplot()
    figure_title(figure, f"{inp.group.name}: total J vs decision time per step")
    ax.set_xlabel("decision time per step [s] (wall clock, log scale; this machine)")
    finite = (
        points[np.isfinite(points["decision_seconds"]) & (points["decision_seconds"] > 0)]
        if len(points)
        else points
    )
    if finite.empty:
        note_empty(ax, "no finished episode with a recorded decision time")
        cost_axis(ax, [], "total J incl. failure penalty", "mean, 95% CI")
        return figure
    styles = policy_styles(finite["method"].tolist())
    for r in finite.itertuples(index=False):
        style = styles[r.method]
        x, y = r.decision_seconds, r.total_cost
        xerr = np.array([[x - r.decision_seconds_ci_low], [r.decision_seconds_ci_high - x]])
        yerr = np.array([[y - r.total_cost_ci_low], [r.total_cost_ci_high - y]])
        unit = "training seed" if r.family == "RL agents" else "run"
        runs = f"{r.runs} {unit}{'' if r.runs == 1 else 's'}"
        bars = ax.errorbar(
            x,
            y,
            xerr=np.clip(xerr, 0.0, None),
            yerr=np.clip(yerr, 0.0, None),
            fmt=HYBRID_MARKER if _is_hybrid(r.method) else _MARKERS.get(r.family, "o"),
            color=style.colour,
            markersize=6,
            capsize=2.5,
            linewidth=1.0,
            label=f"{r.method} ({runs})",
        )
        for collection in bars.lines[2]:  # the bars carry the family's line style, as elsewhere
            collection.set_linestyle(style.linestyle)
    ax.set_xscale("log")
    cost_axis(ax, finite["total_cost"], "total J incl. failure penalty", "mean, 95% CI")
    ax.grid(True, which="major", alpha=0.3)
    outside_legend(panel)
    return figure


def plot_rl_profile(inp: FigureInput):
    """Run-score performance profiles: the fraction of runs x scenarios with total J below tau, with bands.

    rliable's profile (Agarwal et al. 2021) in the cost direction: for every tau, the share of the
    method's runs whose total J is below tau, with a pointwise stratified-bootstrap 95 % band. RL
    groups pool their training seeds; other policies' runs are their episode seeds. Unlike the
    Dolan-Moré profile (``performance-profile``) it needs no pairing of seeds. With RL agents in the
    group it shows the RL groups, the greedy floor and the best swarm planner (the RL table's rows),
    otherwise every policy.
    """
    frame = inp.group.episodes
    found = methods(frame)
    if any(m.grouped for m in found):
        # RL groups against the yardsticks of the RL table: the greedy floor and the best swarm planner.
        planner = best_planner(frame, found)
        found = [
            m for m in found if m.grouped or m.label == "greedy" or (planner and m.label == planner.label)
        ]
    scores = {m.label: run_scores(frame, m) for m in found}
    scores = {label: table for label, table in scores.items() if not table.empty}
    figure = new_figure(7.8, 5.0)
    panel = figure.subfigures(1, 1)  # the legend beside the panel, the title above both
    ax = panel.add_subplot()
    figure_title(figure, f"{inp.group.name}: performance profiles over runs")
    ax.set_xlabel("τ: total J incl. failure penalty")
    ax.set_ylabel("fraction of runs with total J < τ (95% band)")
    if not scores:
        note_empty(ax, "no finished episode")
        return figure
    values = np.concatenate([table.to_numpy().ravel() for table in scores.values()])
    low, high = float(values.min()), float(values.max())
    span = max(high - low, 1e-9)
    taus = np.linspace(low - 0.02 * span, high + 0.02 * span, PROFILE_TAUS)
    styles = policy_styles(list(scores))
    for label, table in sorted(scores.items()):
        profile = rl_stats.performance_profile(
            table.to_numpy(), taus, seed=label_seed(0, label, 30), n_resamples=PROFILE_RESAMPLES
        )
        style = styles[label]
        ax.plot(taus, profile.fraction, **style.line(), linewidth=1.5, label=f"{label} ({len(table)} runs)")
        ax.fill_between(taus, profile.low, profile.high, color=style.colour, alpha=0.15, linewidth=0)
    if high / max(low, 1e-12) > 20 and low > 0:
        ax.set_xscale("log")
    ax.set_ylim(-0.02, 1.02)
    outside_legend(panel)
    return figure
