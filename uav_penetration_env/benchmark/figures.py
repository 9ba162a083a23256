"""Figures of a results store, per scenario group, as PNG and PDF (the paper's Figs. 14-18 and more).

For each scenario group (:func:`~uav_penetration_env.benchmark.leaderboard.scenario_groups`):

* ``<stem>-tracks-top`` / ``<stem>-tracks-3d``: every planner's track for one seed over the terrain,
  with the radars and their coverage at the median flown altitude (Figs. 14/16). The seed is the
  smallest one every planner finished, so the tracks are paired (same start, same jitter).
* ``<stem>-j-per-point``: mean J(k) per track point against k with 95 % bands over seeds, runs of
  different length NaN-padded, and the number of runs still flying at each k (Figs. 15/18, A30).
* ``<stem>-cost-box``: total cost (ΣJ + failure penalty) per planner.
* ``<stem>-performance-profile``: Dolan-Moré profile of total cost over seeds.
* ``<stem>-convergence``: the optimisers' normalised best-so-far against evaluations, averaged
  over MPC steps (policies without an optimiser history, e.g. floors, are left out).
* ``<stem>-timeline``: altitude above ground and detection probability per step, same seed as the tracks.

matplotlib is used through :class:`matplotlib.figure.Figure` and the Agg canvas only, never
pyplot, so nothing touches global state and figures can be drawn in any thread or process.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats as scipy_stats

from uav_penetration_env.benchmark.leaderboard import ScenarioGroup, cost_table, scenario_groups, suite_group
from uav_penetration_env.benchmark.store import ResultsStore

PNG_DPI = 150
COVERAGE_LEVEL = 0.5  # the coverage envelope is where the fused detection probability crosses 0.5
CONVERGENCE_NODES = 200  # points of the common evaluation grid of the convergence plot
SURFACE_NODES = 60  # at most this many terrain nodes per axis in the 3-D view (PDF size and speed)
FIGURES = (
    "tracks-top",
    "tracks-3d",
    "j-per-point",
    "cost-box",
    "performance-profile",
    "convergence",
    "timeline",
)
SCENARIO_FIGURES = ("tracks-top", "tracks-3d", "timeline")  # drawn over one scenario's terrain


def _figure(width: float, height: float):
    """A Figure on an Agg canvas (no pyplot, no global state)."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as error:  # pragma: no cover - matplotlib is a core dependency
        raise ImportError("figures need matplotlib: pip install matplotlib") from error
    figure = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(figure)
    return figure


def _save(figure, out_dir: Path, name: str, formats: Sequence[str]) -> list[Path]:
    paths = []
    for extension in formats:
        path = out_dir / f"{name}.{extension}"
        if extension == "pdf":
            # No creation date in the PDF, so the same store gives the same bytes.
            figure.savefig(path, metadata={"CreationDate": None})
        else:
            figure.savefig(path, dpi=PNG_DPI)
        paths.append(path)
    return paths


def _note(ax, text: str) -> None:
    """Say on an empty panel why it is empty, rather than leave a blank figure."""
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, fontsize=10, wrap=True)


def policy_colours(labels: Sequence[str]) -> dict[str, Any]:
    """One colour per policy label, fixed by the sorted label order (the same planner, the same colour)."""
    from matplotlib import colormaps

    ordered = sorted(labels)
    # Red is kept for the radars and their coverage, so no track is drawn in it.
    if len(ordered) <= 9:
        palette = [c for i, c in enumerate(colormaps["tab10"].colors) if i != 3]
    else:
        palette = [c for i, c in enumerate(colormaps["tab20"].colors) if i not in (6, 7)]
    return {label: palette[i % len(palette)] for i, label in enumerate(ordered)}


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


def track_seed(episodes: pd.DataFrame, steps: pd.DataFrame) -> int | None:
    """The smallest seed every policy finished with stored steps, else the one most policies finished."""
    valid = episodes[~episodes["is_error"] & episodes["episode_id"].isin(steps["episode_id"].unique())]
    if valid.empty:
        return None
    per_seed = valid.groupby("seed")["label"].nunique()
    best = int(per_seed.max())
    return int(min(per_seed[per_seed == best].index))


def _model(yaml_text: str | None):
    """The scenario's PenetrationModel built from the stored YAML, or None when it cannot be.

    Only for what the figures draw of the scenario (terrain, radars, goal, coverage): start states
    come from the stored step-0 rows, never from replaying a reset.
    """
    if not yaml_text:
        return None
    import yaml

    from uav_penetration_env import PenetrationModel, load_scenario

    try:
        return PenetrationModel(load_scenario(yaml.safe_load(yaml_text)))
    except (ValueError, KeyError, TypeError):  # ScenarioError is a ValueError: an incompatible stored file
        return None


def _start_state(episodes: pd.DataFrame, starts: pd.DataFrame, seed: int) -> np.ndarray | None:
    """The start [x m, y m, z m] of ``seed``'s episodes, from their step-0 rows, or None when not stored.

    Paired seeding gives every policy the same start on a seed, so any episode's step-0 row is it.
    """
    ids = episodes.loc[(episodes["seed"] == seed) & ~episodes["is_error"], "episode_id"]
    rows = starts[starts["episode_id"].isin(ids)]
    if rows.empty:
        return None
    first = rows.iloc[0]
    return np.array([first["x_km"] * 1000.0, first["y_km"] * 1000.0, first["z_m"]], dtype=np.float64)


def _tracks(episodes: pd.DataFrame, steps: pd.DataFrame, seed: int) -> dict[str, pd.DataFrame]:
    """The step rows of each policy's episode on ``seed``, by sorted label."""
    chosen = episodes[(episodes["seed"] == seed) & ~episodes["is_error"]]
    tracks = {}
    for label in sorted(chosen["label"].unique()):
        ids = chosen.loc[chosen["label"] == label, "episode_id"]
        rows = steps[steps["episode_id"].isin(ids)].sort_values("step", kind="mergesort")
        if not rows.empty:
            tracks[label] = rows
    return tracks


def _with_start(rows: pd.DataFrame, start: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x, y, z = (rows[c].to_numpy(dtype=np.float64) for c in ("x_km", "y_km", "z_m"))
    if start is None:
        return x, y, z
    return (
        np.concatenate([[start[0] / 1000.0], x]),
        np.concatenate([[start[1] / 1000.0], y]),
        np.concatenate([[start[2]], z]),
    )


def _scenario_markers(ax, model, start: np.ndarray | None, three_d: bool) -> None:
    scenario = model.scenario
    present = model.radar_present[0] > 0
    radars = model.radar_xyz[0][present]
    names = [r.name for r in scenario.radars]
    goal_x, goal_y, goal_r = model.goal[0] / 1000.0
    sx, sy = (start[0] / 1000.0, start[1] / 1000.0) if start is not None else model.start[0] / 1000.0
    if three_d:
        ax.scatter(
            radars[:, 0] / 1000.0,
            radars[:, 1] / 1000.0,
            radars[:, 2],
            c="red",
            marker="^",
            s=45,
            depthshade=False,
            label="radars",
        )
        goal_z = float(model.height(np.array([goal_x * 1000.0]), np.array([goal_y * 1000.0]))[0])
        ax.scatter(
            [goal_x],
            [goal_y],
            [goal_z],
            c="gold",
            edgecolors="black",
            marker="*",
            s=140,
            depthshade=False,
            label="goal",
        )
        return
    ax.scatter(
        radars[:, 0] / 1000.0,
        radars[:, 1] / 1000.0,
        c="red",
        marker="^",
        s=55,
        edgecolors="black",
        zorder=5,
        label="radars",
    )
    for (x, y, _), name in zip(radars, names, strict=False):
        ax.annotate(name, (x / 1000.0, y / 1000.0), xytext=(4, 4), textcoords="offset points", fontsize=8)
    from matplotlib.patches import Circle

    ax.add_patch(Circle((goal_x, goal_y), goal_r, fill=False, edgecolor="black", linestyle="--", zorder=5))
    ax.scatter([goal_x], [goal_y], c="gold", edgecolors="black", marker="*", s=160, zorder=6, label="goal")
    ax.scatter([sx], [sy], c="white", edgecolors="black", marker="o", s=50, zorder=6, label="start")


def _coverage(model, tracks: dict[str, pd.DataFrame], start: np.ndarray | None):
    """Coverage grid at the median flown altitude [m above datum] and a representative heading."""
    from uav_penetration_env.render import coverage_grid

    altitudes = np.concatenate([rows["z_m"].to_numpy(dtype=np.float64) for rows in tracks.values()])
    altitude = float(np.median(altitudes))
    sx, sy = (start[0], start[1]) if start is not None else model.start[0]
    heading = math.atan2(model.goal[0, 1] - sy, model.goal[0, 0] - sx)  # the start-goal bearing
    xs, ys, threat = coverage_grid(model, altitude, heading)
    return altitude, xs, ys, threat


def plot_tracks_top(
    group: ScenarioGroup,
    steps: pd.DataFrame,
    model,
    colours: dict[str, Any],
    starts: pd.DataFrame | None = None,
):
    """Top view: hillshaded terrain, radar coverage at the median flown altitude, every planner's track."""
    from matplotlib.colors import LightSource
    from matplotlib.patches import Rectangle

    figure = _figure(7.5, 6.5)
    ax = figure.add_subplot()
    seed = track_seed(group.episodes, steps)
    tracks = _tracks(group.episodes, steps, seed) if seed is not None else {}
    start = _start_state(group.episodes, starts, seed) if seed is not None and starts is not None else None
    title = f"{group.name}: tracks, seed {seed}"
    if model is None:
        title += " (scenario not in the store: no terrain, radars or coverage)"
    else:
        built = model.built[0]
        x_km, y_km = built.grid.x_nodes / 1000.0, built.grid.y_nodes / 1000.0
        extent = (x_km[0], x_km[-1], y_km[0], y_km[-1])
        terrain = built.terrain.T  # [iy, ix] for imshow
        # A grey hillshade with labelled height contours keeps the red coverage and the coloured
        # tracks legible; a coloured terrain would mix with both.
        spacing = built.grid.dx_m  # [m], so the shading slope is the true slope times vert_exag
        shade = LightSource(azdeg=315, altdeg=45).hillshade(terrain, vert_exag=10.0, dx=spacing, dy=spacing)
        ax.imshow(
            shade, extent=extent, origin="lower", cmap="gray", vmin=-0.3, vmax=1.3, interpolation="bilinear"
        )
        if float(terrain.max()) > float(terrain.min()):
            lines = ax.contour(x_km, y_km, terrain, levels=6, colors="0.3", linewidths=0.5)
            ax.clabel(lines, fontsize=6, fmt="%.0f m")
        if tracks:
            altitude, xs, ys, threat = _coverage(model, tracks, start)
            if threat.max() >= COVERAGE_LEVEL:
                ax.contourf(
                    xs,
                    ys,
                    threat.T,
                    levels=[COVERAGE_LEVEL, max(1.0, float(threat.max())) + 1e-9],
                    colors=["red"],
                    alpha=0.15,
                )
            if threat.max() > COVERAGE_LEVEL > threat.min():
                ax.contour(xs, ys, threat.T, levels=[COVERAGE_LEVEL], colors="red", linewidths=1.0)
            coverage = f"P_d ≥ {COVERAGE_LEVEL} at {altitude:.0f} m"
            ax.add_patch(
                Rectangle((0, 0), 0, 0, facecolor="red", alpha=0.15, edgecolor="red", label=coverage)
            )
            title += f"; radar coverage {coverage} (the median flown altitude)"
        _scenario_markers(ax, model, start, three_d=False)
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
    for label, rows in tracks.items():
        x, y, _ = _with_start(rows, start)
        ax.plot(x, y, color=colours[label], linewidth=1.6, marker="o", markersize=2.2, label=label, zorder=4)
    if not tracks:
        _note(ax, "no finished episode with stored steps")
    ax.set_aspect("equal")
    ax.set_xlabel("x [km]")
    ax.set_ylabel("y [km]")
    ax.set_title(title, fontsize=9)
    ax.legend(loc="upper left", fontsize=7, framealpha=0.85)
    return figure


def _terrain_colormap():
    """The ``terrain`` colormap without its sea blues (heights here are land above a datum)."""
    from matplotlib import colormaps
    from matplotlib.colors import ListedColormap

    return ListedColormap(colormaps["terrain"](np.linspace(0.25, 0.95, 256)))


def plot_tracks_3d(
    group: ScenarioGroup,
    steps: pd.DataFrame,
    model,
    colours: dict[str, Any],
    starts: pd.DataFrame | None = None,
):
    """3-D view: terrain surface, radars, coverage contour at the median flown altitude, tracks."""
    figure = _figure(8.0, 6.5)
    ax = figure.add_subplot(projection="3d")
    seed = track_seed(group.episodes, steps)
    tracks = _tracks(group.episodes, steps, seed) if seed is not None else {}
    start = _start_state(group.episodes, starts, seed) if seed is not None and starts is not None else None
    top = max((float(rows["z_m"].max()) for rows in tracks.values()), default=0.0)
    if model is not None:
        built = model.built[0]
        stride = max(1, math.ceil(max(built.grid.nx, built.grid.ny) / SURFACE_NODES))
        x = built.grid.x_nodes[::stride] / 1000.0
        y = built.grid.y_nodes[::stride] / 1000.0
        gx, gy = np.meshgrid(x, y, indexing="ij")
        heights = built.terrain[::stride, ::stride]
        ax.plot_surface(gx, gy, heights, cmap=_terrain_colormap(), linewidth=0, antialiased=False, alpha=0.6)
        if tracks:
            altitude, xs, ys, threat = _coverage(model, tracks, start)
            if threat.max() > COVERAGE_LEVEL > threat.min():
                cx, cy = np.meshgrid(xs, ys, indexing="ij")
                ax.contour(
                    cx,
                    cy,
                    threat,
                    levels=[COVERAGE_LEVEL],
                    offset=altitude,
                    colors="red",
                    linewidths=0.8,
                    linestyles="dashed",
                )
        _scenario_markers(ax, model, start, three_d=True)
        top = max(top, float(built.terrain.max()))
    for label, rows in tracks.items():
        x, y, z = _with_start(rows, start)
        ax.plot(x, y, z, color=colours[label], linewidth=1.6, label=label)
    if not tracks:
        ax.text2D(0.5, 0.5, "no finished episode with stored steps", transform=ax.transAxes, ha="center")
    ax.set_zlim(0.0, max(top * 1.3, 1.0))
    ax.view_init(elev=35, azim=-60)
    ax.set_xlabel("x [km]")
    ax.set_ylabel("y [km]")
    ax.set_zlabel("z [m]")
    ax.set_title(f"{group.name}: tracks, seed {seed}", fontsize=9)
    ax.legend(loc="upper left", fontsize=7)
    return figure


def _valid_steps(group: ScenarioGroup, steps: pd.DataFrame) -> dict[str, list[pd.DataFrame]]:
    """The step rows of each finished episode, per policy label (sorted labels, episodes by seed)."""
    valid = group.episodes[~group.episodes["is_error"]].sort_values(["label", "seed"], kind="mergesort")
    by_episode = dict(tuple(steps.groupby("episode_id", sort=True)))
    result: dict[str, list[pd.DataFrame]] = {}
    for label, episode_id in zip(valid["label"], valid["episode_id"], strict=True):
        if episode_id in by_episode:
            result.setdefault(label, []).append(by_episode[episode_id].sort_values("step", kind="mergesort"))
    return result


def plot_j_per_point(group: ScenarioGroup, steps: pd.DataFrame, colours: dict[str, Any]):
    """Mean J(k) per track point vs k with 95 % t-bands over seeds, and how many runs reach each k (A30)."""
    figure = _figure(7.5, 6.0)
    top, bottom = figure.subplots(2, 1, sharex=True, height_ratios=[3, 1])
    episodes = _valid_steps(group, steps)
    for label, runs in episodes.items():
        length = max(int(r["step"].max()) for r in runs)
        matrix = np.full((len(runs), length), np.nan)
        for i, rows in enumerate(runs):
            matrix[i, rows["step"].to_numpy(dtype=int) - 1] = rows["J"].to_numpy(dtype=np.float64)
        mean, low, high, count = mean_band(matrix)
        # With two runs the t quantile is 12.7 and the band fills the panel without saying anything.
        low, high = np.where(count >= 3, low, np.nan), np.where(count >= 3, high, np.nan)
        k = np.arange(1, length + 1)
        top.plot(k, mean, color=colours[label], linewidth=1.5, label=f"{label} ({len(runs)} runs)")
        top.fill_between(k, low, high, color=colours[label], alpha=0.18, linewidth=0)
        bottom.step(k, count, where="mid", color=colours[label], linewidth=1.2)
    if not episodes:
        _note(top, "no finished episode with stored steps")
    top.set_ylabel("J(k) per track point\n(mean over seeds; 95% t-band where ≥ 3 runs)")
    top.set_title(f"{group.name}: cost per track point (runs NaN-padded after they end)", fontsize=9)
    top.legend(fontsize=7)
    bottom.set_ylabel("runs at k")
    bottom.set_xlabel("track point k")
    return figure


def plot_cost_box(group: ScenarioGroup, colours: dict[str, Any]):
    """Box plots of total cost (ΣJ + failure penalty) per planner, ordered by median, points overlaid."""
    figure = _figure(7.5, 4.8)
    ax = figure.add_subplot()
    valid = group.episodes[~group.episodes["is_error"]]
    samples = {
        label: valid.loc[valid["label"] == label, "total_cost"].dropna().to_numpy(dtype=np.float64)
        for label in sorted(valid["label"].unique())
    }
    samples = {k: v for k, v in samples.items() if v.size}
    order = sorted(samples, key=lambda label: (float(np.median(samples[label])), label))
    if order:
        boxes = ax.boxplot(
            [samples[label] for label in order],
            patch_artist=True,
            widths=0.55,
            showfliers=False,  # every episode is drawn as a point below
            medianprops={"color": "black"},
        )
        for patch, label in zip(boxes["boxes"], order, strict=True):
            patch.set_facecolor(colours[label])
            patch.set_alpha(0.35)
        for i, label in enumerate(order, start=1):
            values = samples[label]
            # Deterministic spread instead of random jitter, so the figure is reproducible.
            offsets = np.linspace(-0.12, 0.12, values.size) if values.size > 1 else np.zeros(1)
            ax.scatter(
                i + offsets, values, color=colours[label], s=14, edgecolors="black", linewidths=0.4, zorder=3
            )
        ax.set_xticks(range(1, len(order) + 1))
        ax.set_xticklabels(order, rotation=20, ha="right")
    else:
        _note(ax, "no finished episode")
    ax.set_ylabel("total J incl. failure penalty (= −return)")
    ax.set_title(f"{group.name}: total cost per episode (lower is better)", fontsize=9)
    return figure


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


def plot_performance_profile(group: ScenarioGroup, colours: dict[str, Any]):
    """Fraction of seeds on which each planner's total cost is within a factor τ of the best planner's."""
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    figure = _figure(7.0, 4.8)
    ax = figure.add_subplot()
    ratios, shift = performance_profile(cost_table(group.episodes))
    if ratios:
        worst = max(float(r.max()) for r in ratios.values())
        end = max(worst * 1.1, 1.1)
        for label, r in ratios.items():
            taus = np.concatenate([[1.0], np.sort(r), [end]])
            fraction = (r[None, :] <= taus[:, None]).mean(axis=1)
            ax.step(taus, fraction, where="post", color=colours[label], linewidth=1.6, label=label)
        ax.set_xscale("log")
        ax.set_xlim(1.0, end)
        ax.xaxis.set_major_formatter(ScalarFormatter())
        # Label the minor ticks (2, 3, ...) only on short ranges, where they do not crowd.
        ax.xaxis.set_minor_formatter(ScalarFormatter() if end < 20 else NullFormatter())
        seeds = len(next(iter(ratios.values())))
        note = f"; costs shifted by {shift:.3g} to be positive" if shift else ""
        ax.set_title(
            f"{group.name}: performance profile over {seeds} seeds every planner finished{note}", fontsize=9
        )
        ax.legend(fontsize=7, loc="lower right")
    else:
        _note(ax, "no seed finished by every planner")
        ax.set_title(f"{group.name}: performance profile", fontsize=9)
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("τ (total cost / best total cost on the same seed, log scale)")
    ax.set_ylabel("fraction of seeds within τ of the best")
    return figure


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


def plot_convergence(group: ScenarioGroup, steps: pd.DataFrame, colours: dict[str, Any]):
    """Mean normalised best-so-far against evaluations per optimiser, over all MPC steps and seeds."""
    figure = _figure(7.0, 4.8)
    ax = figure.add_subplot()
    episodes = _valid_steps(group, steps)
    rows = {label: pd.concat(runs, ignore_index=True) for label, runs in episodes.items()}
    most = 0.0
    for frame in rows.values():
        for text in frame["history_nfev"]:
            values = _parse_list(text)
            if values.size:
                most = max(most, float(values.max()))
    drawn = 0
    if most > 0:
        grid = np.linspace(0.0, most, CONVERGENCE_NODES)
        for label, frame in rows.items():
            curves, flat = convergence_curves(frame, grid)
            if not len(curves):
                continue  # no optimiser history (a floor or an RL agent), or no step ever improved
            mean, low, high, _ = mean_band(curves)
            text = f"{label} ({len(curves)} MPC steps; {flat} without improvement not drawn)"
            ax.plot(grid, mean, color=colours[label], linewidth=1.6, label=text)
            ax.fill_between(grid, low, high, color=colours[label], alpha=0.18, linewidth=0)
            drawn += 1
    if drawn:
        ax.legend(fontsize=7)
    else:
        _note(ax, "no optimiser history in this group (floors and RL agents have none)")
    ax.set_xlabel("objective evaluations within one MPC step")
    ax.set_ylabel(
        "normalised best-so-far (h − h_end)/(h_0 − h_end)\nmean over improving MPC steps, 95% t-band"
    )
    ax.set_title(f"{group.name}: optimiser convergence per planning step", fontsize=9)
    return figure


def plot_timeline(group: ScenarioGroup, steps: pd.DataFrame, colours: dict[str, Any]):
    """Altitude above ground and detection probability per step, one line per planner, the track seed."""
    figure = _figure(7.5, 5.5)
    altitude_ax, detection_ax = figure.subplots(2, 1, sharex=True)
    seed = track_seed(group.episodes, steps)
    tracks = _tracks(group.episodes, steps, seed) if seed is not None else {}
    for label, rows in tracks.items():
        k = rows["step"].to_numpy(dtype=int)
        style = {"color": colours[label], "marker": "o", "markersize": 2.5, "linewidth": 1.3}
        altitude_ax.plot(k, rows["altitude_agl"].to_numpy(dtype=np.float64), label=label, **style)
        detection_ax.plot(k, rows["detection_prob"].to_numpy(dtype=np.float64), **style)
    if not tracks:
        _note(altitude_ax, "no finished episode with stored steps")
    altitude_ax.set_ylabel("altitude AGL [m]")
    altitude_ax.set_title(f"{group.name}: seed {seed}", fontsize=9)
    altitude_ax.legend(fontsize=7)
    detection_ax.set_ylabel("detection probability")
    detection_ax.set_ylim(-0.02, 1.02)
    detection_ax.set_xlabel("track point k")
    return figure


def _draw(
    name: str, group: ScenarioGroup, steps: pd.DataFrame, model, colours: dict[str, Any], starts: pd.DataFrame
):
    """One figure of :data:`FIGURES` for one scenario group (``starts``: its step-0 rows)."""
    if name == "tracks-top":
        return plot_tracks_top(group, steps, model, colours, starts)
    if name == "tracks-3d":
        return plot_tracks_3d(group, steps, model, colours, starts)
    if name == "j-per-point":
        return plot_j_per_point(group, steps, colours)
    if name == "cost-box":
        return plot_cost_box(group, colours)
    if name == "performance-profile":
        return plot_performance_profile(group, colours)
    if name == "convergence":
        return plot_convergence(group, steps, colours)
    if name == "timeline":
        return plot_timeline(group, steps, colours)
    raise KeyError(f"figure: got {name!r}, expected one of {', '.join(FIGURES)}")


def write_figures(
    store_path: str | Path,
    out_dir: str | Path,
    *,
    formats: Sequence[str] = ("png", "pdf"),
    suite: str | None = None,
) -> list[Path]:
    """Write every figure of every scenario group of a results store, in each of ``formats``.

    With ``suite``, the store's episodes form one group (see ``leaderboard.suite_group``) and only
    the figures that aggregate over episodes are drawn (no tracks or timeline: they show one
    scenario).

    Args:
        store_path: the SQLite results store.
        out_dir: output folder (created if needed).
        formats: file types, each one of ``png``, ``pdf``, ``svg``.
        suite: draw one group over all scenarios, named ``suite``.

    Returns:
        The written paths, ``<stem>-<figure>.<format>`` in the order of ``formats``, groups sorted
        by (name, hash) and figures in the order of :data:`FIGURES`.

    Raises:
        FileNotFoundError: there is no store at ``store_path``.
        ValueError: an unknown format.
    """
    unknown = [f for f in formats if f not in ("png", "pdf", "svg")]
    if unknown:
        raise ValueError(f"formats: got {unknown}, expected png, pdf or svg")
    store_path, out_dir = Path(store_path), Path(out_dir)
    if not store_path.is_file():
        raise FileNotFoundError(
            f"results store {store_path}: not found; expected an SQLite file from `uav-bench run`"
        )
    out_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    with ResultsStore(store_path) as store:
        episodes = store.episodes()
        scenarios = store.scenarios()
        if suite is not None and not episodes.empty:
            groups, names = [suite_group(episodes, suite)], [f for f in FIGURES if f not in SCENARIO_FIGURES]
        else:
            groups, names = scenario_groups(episodes), list(FIGURES)
        for group in groups:
            rows = store.steps(group.episodes["episode_id"].astype(int).tolist(), include_start=True)
            starts, steps = rows[rows["step"] == 0], rows[rows["step"] > 0]
            model = None if group.scenarios else _model(scenarios.get(group.scenario_hash, (None, None))[1])
            colours = policy_colours(group.episodes["label"].unique())
            for name in names:
                figure = _draw(name, group, steps, model, colours, starts)
                written += _save(figure, out_dir, f"{group.stem}-{name}", formats)
    return written
