"""What every figure shares: an Agg canvas, saving, a colour per policy, mean bands, step selection.

matplotlib is used through :class:`matplotlib.figure.Figure` and the Agg canvas only, never
pyplot, so nothing touches global state and figures can be drawn in any thread or process.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats as scipy_stats

from uav_penetration_env.atomic import atomic_path
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


def finished_steps(group: ScenarioGroup, steps: pd.DataFrame) -> dict[str, list[pd.DataFrame]]:
    """The step rows of each finished episode, per policy label (sorted labels, episodes by seed)."""
    valid = group.episodes[~group.episodes["is_error"]].sort_values(["label", "seed"], kind="mergesort")
    by_episode = dict(tuple(steps.groupby("episode_id", sort=True)))
    result: dict[str, list[pd.DataFrame]] = {}
    for label, episode_id in zip(valid["label"], valid["episode_id"], strict=True):
        if episode_id in by_episode:
            result.setdefault(label, []).append(by_episode[episode_id].sort_values("step", kind="mergesort"))
    return result
