"""An animation of one stored episode: the UAV, its track, the radars' coverage at its altitude, the cost.

:func:`find_episode` picks the episode of (policy, seed[, scenario]) in a results store and
:func:`animate_episode` writes it as a GIF (Pillow) or an MP4 (ffmpeg), one frame per track point
from the start state on. Frames are drawn from the stored rows only; the scenario's model, built
from the stored YAML, gives the terrain, the radars and the coverage (api.md §4.6).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark.store import ResultsStore
from uav_penetration_env.suggest import did_you_mean

FORMATS = (".gif", ".mp4")


class ReplayError(ValueError):
    """No such episode, or nothing to draw it with; the message names the argument and what exists."""


@dataclass(frozen=True)
class StoredEpisode:
    """One stored episode: its row, its track points from step 0, and its scenario's YAML."""

    episode: pd.Series
    steps: pd.DataFrame
    yaml_text: str | None


def _require_stored(value: str, column: pd.Series, problem: str) -> None:
    """Raise ReplayError(``problem``, a suggestion and the stored names) unless ``value`` is in ``column``."""
    stored = sorted(column.unique())
    if value not in stored:
        raise ReplayError(f"{problem} — {did_you_mean(value, stored)}stored: {', '.join(stored) or 'none'}")


def find_episode(store: ResultsStore, policy: str, seed: int, scenario: str | None = None) -> StoredEpisode:
    """The finished episode of ``policy`` on ``seed`` (and ``scenario``, needed when several fit).

    When the store holds several configurations of one policy name on that seed, the newest
    episode is taken.

    Raises:
        ReplayError: an unknown policy, scenario or seed (with what the store holds), several
            scenarios without ``scenario``, or an episode that ended in an error.
    """
    episodes = store.episodes()
    _require_stored(policy, episodes["policy"], f"--policy: {policy!r} is not in the store")
    rows = episodes[episodes["policy"] == policy]
    if scenario is not None:
        _require_stored(scenario, rows["scenario"], f"--scenario: {policy!r} has no episode on {scenario!r}")
        rows = rows[rows["scenario"] == scenario]
    seeds = sorted(int(s) for s in rows["seed"].unique())
    rows = rows[rows["seed"] == seed]
    if rows.empty:
        raise ReplayError(f"--seed: {policy!r} has no episode with seed {seed}; stored seeds: {seeds}")
    if rows["scenario_hash"].nunique() > 1:
        raise ReplayError(
            f"--scenario: {policy!r} flew seed {seed} on several scenarios "
            f"({', '.join(sorted(rows['scenario'].unique()))}); name one"
        )
    episode = rows.sort_values("episode_id").iloc[-1]
    if str(episode["error"] or ""):
        raise ReplayError(
            f"--seed: the episode of {policy!r} on seed {seed} ended in an error "
            f"({str(episode['error']).splitlines()[0]}); nothing to replay"
        )
    steps = store.steps([int(episode["episode_id"])], include_start=True).sort_values("step")
    _, yaml_text = store.scenarios().get(episode["scenario_hash"], (None, None))
    return StoredEpisode(episode, steps.reset_index(drop=True), yaml_text)


def animate_episode(stored: StoredEpisode, out: str | Path, *, fps: float = 4.0) -> Path:
    """Write the animation of a stored episode: GIF by Pillow, MP4 by ffmpeg.

    Left: the map (hillshade, radars, goal, start), the track so far, the UAV, and the radar
    coverage at the UAV's altitude and heading. Right: the running cost ΣJ up to each point, the
    detection probability below it.

    Args:
        stored: the episode (:func:`find_episode`).
        out: ``FILE.gif`` or ``FILE.mp4``.
        fps: frames (track points) per second.

    Returns:
        The written path.

    Raises:
        ReplayError: another suffix, an MP4 without ffmpeg, or a scenario that cannot be built.
    """
    from matplotlib import animation

    from uav_penetration_env.benchmark.figures.common import new_figure
    from uav_penetration_env.benchmark.figures.tracks import draw_coverage, draw_map, scenario_model
    from uav_penetration_env.render import coverage_grid

    out = Path(out)
    writer = _writer(out, fps)
    model = scenario_model(stored.yaml_text)
    if model is None:
        raise ReplayError(
            "--store: the episode's scenario is not stored (or cannot be built); nothing to draw"
        )
    steps = stored.steps
    x, y, z = (steps[c].to_numpy(dtype=np.float64) for c in ("x_km", "y_km", "z_m"))
    heading = steps["heading"].to_numpy(dtype=np.float64)
    cost = np.cumsum(np.nan_to_num(steps["J"].to_numpy(dtype=np.float64)))
    detection = steps["detection_prob"].to_numpy(dtype=np.float64)
    k = steps["step"].to_numpy(dtype=int)

    figure = new_figure(10.0, 4.8)
    map_ax, (cost_ax, detection_ax) = _layout(figure)
    start = np.array([x[0] * 1000.0, y[0] * 1000.0, z[0]])
    draw_map(map_ax, model, start)
    map_ax.set_aspect("equal")
    map_ax.set_xlabel("x [km]")
    map_ax.set_ylabel("y [km]")
    (track,) = map_ax.plot([], [], color="black", linewidth=1.5, zorder=6)
    (uav,) = map_ax.plot([], [], marker="o", color="black", markersize=6, linestyle="none", zorder=7)
    cost_ax.plot(k, cost, color="0.8", linewidth=1.0)
    (cost_line,) = cost_ax.plot([], [], color="tab:blue", linewidth=1.6)
    cost_ax.set_ylabel("running cost ΣJ")
    detection_ax.plot(k, detection, color="0.8", linewidth=1.0)
    (detection_line,) = detection_ax.plot([], [], color="tab:red", linewidth=1.4)
    detection_ax.set_ylim(-0.02, 1.02)
    detection_ax.set_ylabel("P_d")
    detection_ax.set_xlabel("track point k")
    coverage: list[Any] = []
    label = f"{stored.episode['policy']} on {stored.episode['scenario']}, seed {int(stored.episode['seed'])}"

    def frame(i: int) -> list[Any]:
        for artist in coverage:
            artist.remove()
        coverage.clear()
        coverage.extend(draw_coverage(map_ax, coverage_grid(model, z[i], heading[i]), z[i]))
        track.set_data(x[: i + 1], y[: i + 1])
        uav.set_data([x[i]], [y[i]])
        cost_line.set_data(k[: i + 1], cost[: i + 1])
        detection_line.set_data(k[: i + 1], detection[: i + 1])
        map_ax.set_title(
            f"{label}\nk = {k[i]}: z = {z[i]:.0f} m, coverage P_d ≥ 0.5 at that altitude (red)", fontsize=8
        )
        cost_ax.set_title(f"ΣJ = {cost[i]:.4g}, P_d = {detection[i]:.2f}", fontsize=8)
        return [track, uav, cost_line, detection_line, *coverage]

    movie = animation.FuncAnimation(figure, frame, frames=len(steps), blit=False, repeat=False)
    movie.save(out, writer=writer)
    return out


def _layout(figure):
    grid = figure.add_gridspec(2, 2, width_ratios=[1.3, 1.0], height_ratios=[2, 1])
    map_ax = figure.add_subplot(grid[:, 0])
    cost_ax = figure.add_subplot(grid[0, 1])
    detection_ax = figure.add_subplot(grid[1, 1], sharex=cost_ax)
    return map_ax, (cost_ax, detection_ax)


def _writer(out: Path, fps: float):
    from matplotlib import animation

    if out.suffix not in FORMATS:
        raise ReplayError(f"--out: got {str(out)!r}, expected a file ending in {' or '.join(FORMATS)}")
    if out.suffix == ".gif":
        return animation.PillowWriter(fps=fps)
    if not animation.writers.is_available("ffmpeg"):
        raise ReplayError(
            f"--out: {out} needs ffmpeg on the PATH to write MP4 (not found); install ffmpeg or write a .gif"
        )
    return animation.FFMpegWriter(fps=fps)
