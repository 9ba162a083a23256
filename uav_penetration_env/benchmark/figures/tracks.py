"""Figures of one seed's tracks over one scenario: top view, 3-D view and the altitude/detection timeline.

The seed is the smallest one every planner finished, so the tracks are paired (same start, same
jitter). Each track starts at its episode's stored step-0 row (the start state); the scenario's
model is built from the stored YAML only to draw its terrain, radars, goal and coverage. When the
scenario has a best-known record (docs/best-known.md §4), its controls are replayed through the env and
drawn as a dashed black track labelled with J*.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark.figures.common import (
    MPC_FAMILIES,
    NO_STEPS,
    FigureInput,
    family_figure,
    figure_title,
    finish_panel,
)
from uav_penetration_env.render import scatter_radars_3d

COVERAGE_LEVEL = (
    0.5  # the envelope is where the model's coverage level (fused P_d or ratio detection) crosses 0.5
)
SURFACE_NODES = 60  # at most this many terrain nodes per axis in the 3-D view (PDF size and speed)


def track_seed(episodes: pd.DataFrame, steps: pd.DataFrame) -> int | None:
    """The smallest seed every policy finished with stored steps, else the one most policies finished."""
    valid = episodes[~episodes["is_error"] & episodes["episode_id"].isin(steps["episode_id"].unique())]
    if valid.empty:
        return None
    per_seed = valid.groupby("seed")["label"].nunique()
    best = int(per_seed.max())
    return int(min(per_seed[per_seed == best].index))


def scenario_model(yaml_text: str | None):
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
    except (ValueError, KeyError, TypeError, yaml.YAMLError):  # ScenarioError is a ValueError
        return None


def start_state(episodes: pd.DataFrame, starts: pd.DataFrame, seed: int) -> np.ndarray | None:
    """The start [x m, y m, z m] of ``seed``'s episodes, from their step-0 rows, or None when not stored.

    Paired seeding gives every policy the same start on a seed, so any episode's step-0 row is it.
    """
    ids = episodes.loc[(episodes["seed"] == seed) & ~episodes["is_error"], "episode_id"]
    rows = starts[starts["episode_id"].isin(ids)]
    if rows.empty:
        return None
    first = rows.iloc[0]
    return np.array([first["x_km"] * 1000.0, first["y_km"] * 1000.0, first["z_m"]], dtype=np.float64)


def seed_tracks(episodes: pd.DataFrame, steps: pd.DataFrame, seed: int) -> dict[str, pd.DataFrame]:
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


def clip_to_box(
    x: np.ndarray, y: np.ndarray, z: np.ndarray, box: tuple[tuple[float, float], ...]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A track held inside a 3-D view's box, and which of its points were moved onto the box.

    Matplotlib's 3-D axes do not clip lines to their limits: a crash's last point, metres below
    the ground (and below the z axis), or a point past the map's edge, would be drawn across the
    tick labels. Each coordinate is clamped to its ``(low, high)`` in ``box`` (x, y in km; z in m);
    the moved points are marked by the caller, as the timeline marks a step below ground.

    Returns:
        ``x, y, z`` clamped (shape of the inputs) and a bool mask of the points that moved.
    """
    clamped = [np.clip(values, low, high) for values, (low, high) in zip((x, y, z), box, strict=True)]
    moved = np.zeros(x.shape, dtype=bool)
    for values, inside in zip((x, y, z), clamped, strict=True):
        moved |= values != inside
    return clamped[0], clamped[1], clamped[2], moved


def _scenario_markers(ax, model, start: np.ndarray | None, three_d: bool) -> None:
    scenario = model.scenario
    present = model.radar_present[0] > 0
    radars = model.radar_xyz[0][present]
    names = [r.name for r in scenario.radars]
    goal_x, goal_y, goal_r = model.goal[0] / 1000.0
    sx, sy = (start[0] / 1000.0, start[1] / 1000.0) if start is not None else model.start[0] / 1000.0
    if three_d:
        scatter_radars_3d(ax, radars, size=45)
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


def coverage_altitude(
    tracks: dict[str, pd.DataFrame], styles: dict[str, Any], chosen: float | None = None
) -> tuple[float, str]:
    """The altitude at which the radar coverage is drawn [m above datum], and why that one.

    DECISION (model.md §5): the median altitude of the MPC policies' track points (the paper's
    planners, the reference optimisers and the ablations), not of every track: high-flying RL
    agents or floors would lift it to where the radars see the whole map. Without MPC tracks it is
    the median of every track; ``chosen`` (``--altitude``) overrides both.

    Returns:
        The altitude and the phrase that says how it was chosen (for the title).
    """
    if chosen is not None:
        return float(chosen), "chosen with --altitude"
    mpc = [label for label in tracks if styles[label].family in MPC_FAMILIES]
    members, reason = (
        (mpc, "the median altitude of the MPC planners' tracks")
        if mpc
        else (
            list(tracks),
            "the median altitude of all tracks (no MPC planner)",
        )
    )
    altitudes = np.concatenate([tracks[label]["z_m"].to_numpy(dtype=np.float64) for label in members])
    return float(np.median(altitudes)), reason


def coverage_at(model, altitude: float, start: np.ndarray | None):
    """Coverage grid at ``altitude`` [m above datum] for a UAV flying the start-goal bearing."""
    from uav_penetration_env.render import coverage_grid

    sx, sy = (start[0], start[1]) if start is not None else model.start[0]
    heading = math.atan2(model.goal[0, 1] - sy, model.goal[0, 0] - sx)  # the start-goal bearing
    return coverage_grid(model, altitude, heading)


BEST_KNOWN_STYLE = {"color": "black", "linestyle": (0, (4, 2)), "linewidth": 1.8, "zorder": 5}


def best_known_track(inp: FigureInput) -> tuple[str, np.ndarray] | None:
    """The legend label and (K + 1, 3) positions [km, km, m] of the scenario's best-known track.

    ``None`` for a suite (no single scenario), a scenario without a record, or a record that no
    longer replays (its scenario's content changed; ``uav-bench best-known verify`` says so).
    """
    if inp.model is None:
        return None
    from uav_penetration_env.benchmark.bestknown import RecordError, load_record, replay_record

    try:
        record = load_record(inp.group.scenario_hash)
        if record is None:
            return None
        positions = replay_record(record).positions
    except (RecordError, RuntimeError):
        return None
    track = positions / np.array([1000.0, 1000.0, 1.0])
    return f"best known (J* = {record.total_cost:.4g})", track


def _seed_inputs(inp: FigureInput):
    """The track seed, each policy's rows on it, and its start state."""
    seed = track_seed(inp.group.episodes, inp.steps)
    tracks = seed_tracks(inp.group.episodes, inp.steps, seed) if seed is not None else {}
    start = start_state(inp.group.episodes, inp.starts, seed) if seed is not None else None
    return seed, tracks, start


def draw_map(ax, model, start: np.ndarray | None) -> None:
    """Hillshaded terrain with height contours, radars, goal and start on a top-view axes [km]."""
    from matplotlib.colors import LightSource

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
    _scenario_markers(ax, model, start, three_d=False)
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])


def draw_coverage(ax, coverage, altitude: float) -> list[Any]:
    """The shaded region where the coverage level is at least :data:`COVERAGE_LEVEL`, and its edge.

    Args:
        ax: a top-view axes [km].
        coverage: ``(xs [km], ys [km], level (nx, ny))`` from :func:`coverage_at`.
        altitude: the altitude of ``coverage`` [m above datum] (for the legend entry).

    Returns:
        The artists drawn (to remove them when the altitude changes).
    """
    from matplotlib.patches import Rectangle

    xs, ys, threat = coverage
    artists: list[Any] = []
    if threat.max() >= COVERAGE_LEVEL:
        artists.append(
            ax.contourf(
                xs,
                ys,
                threat.T,
                levels=[COVERAGE_LEVEL, max(1.0, float(threat.max())) + 1e-9],
                colors=["red"],
                alpha=0.15,
            )
        )
    if threat.max() > COVERAGE_LEVEL > threat.min():
        artists.append(ax.contour(xs, ys, threat.T, levels=[COVERAGE_LEVEL], colors="red", linewidths=1.0))
    label = f"P_d ≥ {COVERAGE_LEVEL} at {altitude:.0f} m"
    artists.append(
        ax.add_patch(Rectangle((0, 0), 0, 0, facecolor="red", alpha=0.15, edgecolor="red", label=label))
    )
    return artists


def _coverage_title(altitude: float, reason: str) -> str:
    # Two short lines: one long line is wider than the axes and runs under the legend.
    return f"radar coverage P_d ≥ {COVERAGE_LEVEL} at {altitude:.0f} m above datum\n({reason})"


def plot_tracks_top(inp: FigureInput):
    """Top view: hillshaded terrain, radar coverage at a stated altitude, every planner's track.

    One panel per family when there are many policies (:func:`~.common.family_figure`); every
    panel shows the same terrain, coverage, radars and start.
    """
    seed, tracks, start = _seed_inputs(inp)
    figure, panels = family_figure(list(tracks), 7.0, 6.2)
    model = inp.model
    best = best_known_track(inp)
    title = f"{inp.group.name}: tracks, seed {seed}"
    coverage, altitude = None, None
    if model is None:
        title += "\n(scenario not in the store: no terrain, radars or coverage)"
    elif tracks:
        altitude, reason = coverage_altitude(tracks, inp.styles, inp.altitude)
        coverage = coverage_at(model, altitude, start)
        title += "\n" + _coverage_title(altitude, reason)
    for family, container, members in panels:
        ax = container.add_subplot()
        if model is not None:
            draw_map(ax, model, start)
            if coverage is not None:
                draw_coverage(ax, coverage, altitude)
        for label in members:
            x, y, _ = _with_start(tracks[label], start)
            ax.plot(
                x,
                y,
                **inp.styles[label].line(),
                linewidth=1.6,
                marker="o",
                markersize=2.2,
                label=label,
                zorder=4,
            )
        if best is not None:
            ax.plot(best[1][:, 0], best[1][:, 1], label=best[0], **BEST_KNOWN_STYLE)
        ax.set_aspect("equal")
        _finish_map_panel(ax, container, family, empty=not tracks)
    figure_title(figure, title)
    return figure


def _finish_map_panel(ax, container, family: str | None, *, empty: bool) -> None:
    """Label a map panel's x and y axes in km, then :func:`finish_panel` it."""
    ax.set_xlabel("x [km]")
    ax.set_ylabel("y [km]")
    finish_panel(ax, container, family, empty=empty)


def _terrain_colormap():
    """The ``terrain`` colormap without its sea blues (heights here are land above a datum)."""
    from matplotlib import colormaps
    from matplotlib.colors import ListedColormap

    return ListedColormap(colormaps["terrain"](np.linspace(0.25, 0.95, 256)))


def plot_tracks_3d(inp: FigureInput):
    """3-D view: terrain surface, radars, the coverage contour at a stated altitude, the tracks."""
    seed, tracks, start = _seed_inputs(inp)
    figure, panels = family_figure(list(tracks), 7.5, 6.2)
    model = inp.model
    best = best_known_track(inp)
    title = f"{inp.group.name}: tracks, seed {seed}"
    top = max((float(rows["z_m"].max()) for rows in tracks.values()), default=0.0)
    coverage, altitude = None, None
    if model is not None and tracks:
        altitude, reason = coverage_altitude(tracks, inp.styles, inp.altitude)
        coverage = coverage_at(model, altitude, start)
        title += "\n" + _coverage_title(altitude, reason).replace("P_d", "contour P_d")
    # the terrain surface's x and y range [km]: the box the tracks are held in (no map: unbounded)
    extent = ((-math.inf, math.inf), (-math.inf, math.inf))
    if model is not None:
        grid = model.built[0].grid
        top = max(top, float(model.built[0].terrain.max()))
        extent = ((float(grid.x_nodes[0]) / 1000.0, float(grid.x_nodes[-1]) / 1000.0),
                  (float(grid.y_nodes[0]) / 1000.0, float(grid.y_nodes[-1]) / 1000.0))  # fmt: skip
    ceiling = max(top * 1.3, 1.0)
    for family, container, members in panels:
        ax = container.add_subplot(projection="3d")
        if model is not None:
            built = model.built[0]
            stride = max(1, math.ceil(max(built.grid.nx, built.grid.ny) / SURFACE_NODES))
            x = built.grid.x_nodes[::stride] / 1000.0
            y = built.grid.y_nodes[::stride] / 1000.0
            gx, gy = np.meshgrid(x, y, indexing="ij")
            heights = built.terrain[::stride, ::stride]
            ax.plot_surface(
                gx, gy, heights, cmap=_terrain_colormap(), linewidth=0, antialiased=False, alpha=0.6
            )
            if coverage is not None:
                xs, ys, threat = coverage
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
        for label in members:
            x, y, z = _with_start(tracks[label], start)
            x, y, z, moved = clip_to_box(x, y, z, (*extent, (0.0, ceiling)))
            ax.plot(x, y, z, **inp.styles[label].line(), linewidth=1.6, label=label)
            if moved.any():  # a crash below ground or a point past the edge, drawn on the box with a cross
                ax.plot(x[moved], y[moved], z[moved], linestyle="none", marker="x", markersize=6,
                        markeredgewidth=1.6, color=inp.styles[label].colour)  # fmt: skip
        if best is not None:
            ax.plot(best[1][:, 0], best[1][:, 1], best[1][:, 2], label=best[0], **BEST_KNOWN_STYLE)
        if not tracks:  # a 3-D axes writes in axes coordinates with text2D
            ax.text2D(0.5, 0.5, NO_STEPS, transform=ax.transAxes, ha="center")
        ax.set_zlim(0.0, ceiling)
        ax.view_init(elev=35, azim=-60)
        ax.set_zlabel("z [m]")
        _finish_map_panel(ax, container, family, empty=False)
    figure_title(figure, title)
    return figure


def plot_timeline(inp: FigureInput):
    """Altitude above ground and detection probability per step, one line per planner, the track seed.

    A step that ends below the ground (a collision) is drawn at 0 m with a cross in the policy's
    colour: its depth below ground says nothing, and would squeeze every other altitude.
    """
    seed, tracks, _ = _seed_inputs(inp)
    figure, panels = family_figure(list(tracks), 7.0, 5.0)
    title = f"{inp.group.name}: altitude and detection, seed {seed}"
    for family, container, members in panels:
        altitude_ax, detection_ax = container.subplots(2, 1, sharex=True)
        for label in members:
            rows = tracks[label]
            k = rows["step"].to_numpy(dtype=int)
            style = {**inp.styles[label].line(), "marker": "o", "markersize": 2.5, "linewidth": 1.3}
            agl = rows["altitude_agl"].to_numpy(dtype=np.float64)
            below = agl < 0.0  # the step that hit the ground: drawn at 0 m with a cross, not hundreds of m down
            altitude_ax.plot(k, np.maximum(agl, 0.0), label=label, **style)
            if below.any():
                altitude_ax.plot(k[below], np.zeros(int(below.sum())), linestyle="none", marker="x",
                                 markersize=7, markeredgewidth=1.8, color=inp.styles[label].colour)  # fmt: skip
            detection_ax.plot(k, rows["detection_prob"].to_numpy(dtype=np.float64), **style)
        altitude_ax.set_ylabel("altitude AGL [m] (x: below ground)")
        detection_ax.set_ylabel("detection probability")
        detection_ax.set_ylim(-0.02, 1.02)
        detection_ax.set_xlabel("track point k")
        finish_panel(altitude_ax, container, family, empty=not tracks)
    figure_title(figure, title)
    return figure
