"""Rendering of the 3-D scene: terrain, radars and their coverage at the UAV's altitude, the track.

matplotlib is imported here only (lazily, with the Agg backend for ``rgb_array``), so the
physics never depends on it. The static scene (terrain surface, radars, start, goal) is drawn
once per model; each frame redraws only the track, the UAV and the detection envelope.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from uav_penetration_env.kinematics import HEADING
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.types import FloatArray

FRAME_PIXELS = 640  # square frames, >= 400 x 400 (model.md §7a)
FRAME_DPI = 100
COVERAGE_LEVEL = 0.5  # the envelope is drawn where the network detection probability crosses 0.5
COVERAGE_NODES = 60  # per axis, for the coverage evaluation grid


def _new_figure(human: bool):
    """A figure: pyplot's (a window) for ``human``, else a plain Agg figure with no global state."""
    size = FRAME_PIXELS / FRAME_DPI
    try:
        if human:
            import matplotlib.pyplot as plt

            return plt.figure(figsize=(size, size), dpi=FRAME_DPI)
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as error:  # a core-only install (matplotlib is in the harness extra)
        raise ImportError(
            "rendering needs matplotlib: pip install matplotlib, or the harness extra (pip install -e '.[harness]')"
        ) from error
    figure = Figure(figsize=(size, size), dpi=FRAME_DPI)
    FigureCanvasAgg(figure)
    return figure


def coverage_grid(
    model: PenetrationModel, altitude_m: float, heading: float, nodes: int = COVERAGE_NODES
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Network threat on a horizontal grid at one altitude, for a UAV flying level at ``heading``.

    Returns:
        x [km] (n,), y [km] (n,), the model's coverage level in [0, 1] (n, n) indexed [ix, iy]
        (:meth:`PenetrationModel.coverage_level`).
    """
    low_x, high_x, low_y, high_y = model.bounds
    xs = np.linspace(low_x, high_x, nodes)
    ys = np.linspace(low_y, high_y, nodes)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    states = np.zeros((gx.size, 6))
    states[:, 0], states[:, 1], states[:, 2] = gx.ravel(), gy.ravel(), altitude_m
    states[:, 3], states[:, HEADING] = model.limits.speed_max, heading
    threat = model.coverage_level(states)
    return xs / 1000.0, ys / 1000.0, threat.reshape(gx.shape)


def scatter_radars_3d(ax: Any, radar_xyz: np.ndarray, *, size: float, **style: Any) -> None:
    """Draw radar sites as red triangles on a 3-D axes.

    Args:
        ax: A matplotlib 3-D axes.
        radar_xyz: (n, 3) radar positions [x, y, z] in m; drawn as x, y in km and z in m.
        size: Marker area [points^2].
        **style: Further ``Axes3D.scatter`` keywords (``zorder``, ``edgecolors``...).
    """
    ax.scatter(
        radar_xyz[:, 0] / 1000.0,
        radar_xyz[:, 1] / 1000.0,
        radar_xyz[:, 2],
        c="red",
        marker="^",
        s=size,
        depthshade=False,
        label="radars",
        **style,
    )


class SceneRenderer:
    """Draws frames of one scenario's scene."""

    def __init__(self, model: PenetrationModel, human: bool = False) -> None:
        self.model = model
        self.human = human
        self.figure = _new_figure(human)
        # Fixed draw order: markers and the track stay visible in front of the terrain surface.
        self.axes = self.figure.add_subplot(projection="3d", computed_zorder=False)
        self._dynamic: list = []
        self._draw_static()

    def _draw_static(self) -> None:
        model, ax = self.model, self.axes
        built = model.built[0]
        grid = built.grid
        stride = max(1, grid.nx // 75)
        x = grid.x_nodes[::stride] / 1000.0
        y = grid.y_nodes[::stride] / 1000.0
        heights = built.terrain[::stride, ::stride]
        gx, gy = np.meshgrid(x, y, indexing="ij")
        ax.plot_surface(
            gx,
            gy,
            heights,
            cmap="terrain",
            linewidth=0,
            antialiased=False,
            alpha=0.85,
            rstride=1,
            cstride=1,
            zorder=1,
        )
        if len(built.radar_xyz):
            scatter_radars_3d(ax, built.radar_xyz, size=50, zorder=5)
        start = model.initial_state()
        goal = model.goal[0]
        ax.scatter(
            [start[0] / 1000.0],
            [start[1] / 1000.0],
            [start[2]],
            c="blue",
            marker="o",
            s=40,
            depthshade=False,
            label="start",
        )
        goal_z = float(model.height(goal[:1], goal[1:2])[0])
        ax.scatter(
            [goal[0] / 1000.0],
            [goal[1] / 1000.0],
            [goal_z],
            c="gold",
            marker="*",
            s=120,
            depthshade=False,
            label="goal",
        )
        ax.set_xlabel("x [km]")
        ax.set_ylabel("y [km]")
        ax.set_zlabel("z [m]")
        ax.set_zlim(0.0, max(float(built.terrain.max()) * 1.5, 1000.0))
        ax.set_title(model.scenario.name)
        ax.legend(loc="upper left", fontsize=8)

    def draw(self, track: FloatArray, state: FloatArray) -> np.ndarray:
        """Render one frame: the flown ``track`` (K, 6) and the detection envelope at ``state``'s altitude.

        Returns:
            (H, W, 3) uint8 image.
        """
        for artist in self._dynamic:
            artist.remove()
        self._dynamic = []
        ax = self.axes
        altitude = float(state[2])
        xs, ys, threat = coverage_grid(self.model, altitude, float(state[HEADING]))
        if threat.max() > COVERAGE_LEVEL > threat.min():
            gx, gy = np.meshgrid(xs, ys, indexing="ij")
            contour = ax.contour(
                gx, gy, threat, levels=[COVERAGE_LEVEL], offset=altitude, colors="red", linewidths=1.0
            )
            self._dynamic.append(contour)
        track = np.atleast_2d(track)
        (line,) = ax.plot(
            track[:, 0] / 1000.0, track[:, 1] / 1000.0, track[:, 2], color="black", linewidth=1.5
        )
        self._dynamic.append(line)
        marker = ax.scatter(
            [state[0] / 1000.0], [state[1] / 1000.0], [state[2]], c="black", s=25, depthshade=False
        )
        self._dynamic.append(marker)
        self.figure.canvas.draw()
        frame = np.asarray(self.figure.canvas.buffer_rgba())[..., :3].copy()
        if self.human:
            import matplotlib.pyplot as plt

            plt.pause(0.001)
        return frame

    def close(self) -> None:
        """Close the figure."""
        if self.human:
            import matplotlib.pyplot as plt

            plt.close(self.figure)
