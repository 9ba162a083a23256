"""Learning curves of trained agents: evaluation cost against timesteps, mean and spread over seeds.

``uav-bench plot --models DIR`` (a plug-in extension of ``plot``, :mod:`baselines.plugin`) draws them.

Reads the ``<model>.evaluations.csv`` files and ``<model>.json`` sidecars that :func:`train_agent`
writes (no torch needed) and draws one panel per training regime (the env id and scenario the
agents trained on) with one line per run group (the model name without its training-seed suffix
``-sN``, e.g. ``ppo-paper-zoo``: one algorithm with one hyper-parameter set, as the RL table groups
agents): the mean over training seeds of the mean evaluation cost (-return = sum of J plus any
failure penalty; lower is better) and the band between the best and worst seed.
"""

from __future__ import annotations

import argparse
import json
import re
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from uav_penetration_env.atomic import atomic_path

if TYPE_CHECKING:
    import pandas as pd

TRAINING_SEED = re.compile(r"-s\d+$")  # as the RL table's groups (leaderboard/rl.py)


def load_curves(models: str | Path) -> pd.DataFrame:
    """All evaluation rows of the models in a folder, with their algorithm, regime and seed.

    Returns:
        Columns ``algorithm, group, regime, seed, model, timesteps, mean_cost, success_rate``.
    """
    import pandas as pd  # here, so that `uav-bench plot --help` does not load it

    rows = []
    for sidecar in sorted(Path(models).glob("*.json")):
        csv = sidecar.with_suffix(".evaluations.csv")
        if not csv.exists():
            continue
        meta = json.loads(sidecar.read_text())
        if "algorithm" not in meta or "env_id" not in meta:
            continue
        frame = pd.read_csv(csv)
        frame["algorithm"] = meta["algorithm"]
        frame["regime"] = regime_label(meta)
        frame["seed"] = int(meta.get("seed", 0))
        frame["model"] = sidecar.stem
        frame["group"] = TRAINING_SEED.sub("", sidecar.stem)
        rows.append(frame)
    if not rows:
        return pd.DataFrame(
            columns=[
                "algorithm",
                "group",
                "regime",
                "seed",
                "model",
                "timesteps",
                "mean_cost",
                "success_rate",
            ]
        )
    return pd.concat(rows, ignore_index=True)


def regime_label(meta: Mapping) -> str:
    """Where an agent trained: ``UAVPenetration-v0 / paper-2022-sec5`` or ``UAVPenetrationRandom-v0 (d=0.5)``."""
    scenario = meta.get("scenario") or {}
    if isinstance(scenario, Mapping) and scenario.get("name"):
        return f"{meta['env_id']} / {scenario['name']}"
    difficulty = (meta.get("env_kwargs") or {}).get("difficulty")
    return f"{meta['env_id']}" + (f" (difficulty {difficulty:g})" if difficulty is not None else "")


def _curve(group: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """Mean, min and max over seeds on the timesteps every seed evaluated (held between evaluations)."""
    grid = np.unique(group["timesteps"].to_numpy())
    per_seed = []
    for _, seed_rows in group.groupby("seed", sort=True):
        seed_rows = seed_rows.sort_values("timesteps")
        steps, cost = seed_rows["timesteps"].to_numpy(), seed_rows["mean_cost"].to_numpy()
        index = np.searchsorted(steps, grid, side="right") - 1
        values = np.where(index >= 0, cost[np.clip(index, 0, None)], np.nan)
        per_seed.append(values)
    stack = np.vstack(per_seed)
    complete = ~np.isnan(stack).any(axis=0)
    stack = stack[:, complete]
    return grid[complete], stack.mean(axis=0), stack.min(axis=0), stack.max(axis=0), len(per_seed)


def write_learning_curves(
    models: str | Path,
    out_dir: str | Path,
    *,
    references: Mapping[str, float] | None = None,
    formats: tuple[str, ...] = ("png", "pdf"),
) -> list[Path]:
    """Draw ``learning-curves.{png,pdf}`` from a folder of trained models.

    Args:
        models: folder holding ``*.json`` sidecars and ``*.evaluations.csv`` files.
        out_dir: where to write the figure.
        references: optional horizontal reference costs (e.g. the greedy floor's and an MPC
            planner's mean total J on the training scenario), drawn on the panels whose regime
            names that scenario.
        formats: file formats.

    Returns:
        The written files (none when the folder holds no evaluations).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    curves = load_curves(models)
    if curves.empty:
        return []
    regimes = sorted(curves["regime"].unique())
    figure = Figure(figsize=(6.5 * len(regimes), 4.8), dpi=100)
    FigureCanvasAgg(figure)
    axes = figure.subplots(1, len(regimes), squeeze=False)[0]
    for ax, regime in zip(axes, regimes, strict=True):
        subset = curves[curves["regime"] == regime]
        for name, group in subset.groupby("group", sort=True):
            steps, mean, low, high, seeds = _curve(group)
            (line,) = ax.plot(steps, mean, label=f"{name} (mean of {seeds} seed{'s' if seeds > 1 else ''})")
            ax.fill_between(steps, low, high, color=line.get_color(), alpha=0.2, linewidth=0)
        for name, value in (references or {}).items():
            if name.split(":", 1)[0] in regime:
                ax.axhline(value, linestyle="--", linewidth=1, color="grey")
                ax.annotate(
                    name.split(":", 1)[-1],
                    (ax.get_xlim()[1], value),
                    ha="right",
                    va="bottom",
                    fontsize=8,
                    color="grey",
                )
        ax.set_title(f"trained on {regime}", fontsize=10)
        ax.set_xlabel("environment steps")
        ax.set_ylabel("evaluation cost = -return (lower is better)\nmean over seeds, band = best..worst seed")
        ax.set_yscale("log")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    figure.tight_layout()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for fmt in formats:
        path = out / f"learning-curves.{fmt}"
        with atomic_path(path) as temporary:
            figure.savefig(temporary, format=fmt, metadata={"CreationDate": None} if fmt == "pdf" else None)
        written.append(path)
    return written


# --- `uav-bench plot --models` ----------------------------------------------------------------------


def add_curve_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags ``--models`` and ``--reference-line`` of ``uav-bench plot``."""
    parser.add_argument("--models", help="instead: learning curves of the trained models in this folder")
    parser.add_argument(
        "--reference-line",
        dest="reference_line",
        action="append",
        help="with --models: SCENARIO:LABEL=VALUE dashed line (repeatable)",
    )


def parse_reference(text: str) -> tuple[str, float]:
    """``SCENARIO:LABEL=VALUE`` (a dashed reference line on learning-curve panels of that scenario).

    Raises:
        CLIError: another form.
    """
    from uav_penetration_env.benchmark.commands.common import CLIError

    try:
        key, value = text.rsplit("=", 1)
        return key, float(value)
    except ValueError:
        raise CLIError(
            f"--reference-line: got {text!r}, expected SCENARIO:LABEL=VALUE, e.g. paper-2022-sec5:greedy=17.2"
        ) from None


def curves_command(args: argparse.Namespace) -> int:
    """Draw ``learning-curves.{png,pdf}`` from ``--models`` into ``--out`` and print the paths.

    Raises:
        CLIError: ``--models`` is not a folder or holds no evaluations, a bad ``--reference-line``,
            an unwritable ``--out``.
    """
    from uav_penetration_env.benchmark.commands.common import CLIError, check_writable_folder

    check_writable_folder(Path(args.out), "--out")
    if not Path(args.models).is_dir():
        raise CLIError(f"--models: {args.models} is not a folder of trained models")
    references = dict(parse_reference(r) for r in args.reference_line or [])
    written = write_learning_curves(args.models, Path(args.out), references=references)
    if not written:
        raise CLIError(f"--models: no *.evaluations.csv with a .json sidecar in {args.models}")
    for path in written:
        print(path)
    return 0
