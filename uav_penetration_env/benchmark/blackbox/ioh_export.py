"""Stored window runs in IOHprofiler's file format, written by ioh's own logger (docs/blackbox.md §3).

:func:`export_window_runs` reads a results store's ``window_runs`` rows (``uav-bench windows``,
api.md §4.8) and writes them as IOHexperimenter writes a benchmark: one folder per optimiser
configuration, each holding one ``IOHprofiler_f<id>_<name>.json`` per window and its ``.dat``
file of (evaluations, best-so-far cost) lines, which IOHanalyzer and iohinspector read. The files
are written by ``ioh.logger.Analyzer``, the logger IOHexperimenter uses, so their layout is
IOH's own: each run's history is replayed through an IOH problem that returns, at each
evaluation, the cost that makes the logger see the stored best-so-far trace.

DECISION (docs/blackbox.md §3, what is replayed): a run's history holds its best-so-far cost after
each iteration and the evaluations spent by then, not the cost of each evaluation; the export
places each improvement at the last evaluation of the iteration that made it (the earliest count
at which the run is known to have reached it), so the fixed-target runtimes it gives are upper
bounds by less than one iteration's evaluations. Evaluations before the first finite best-so-far
cost are replayed before the logger is attached (IOH logs nothing of them), and a run that never
found a finite cost is logged once, at its last evaluation, with the largest float64 (1.797e308):
it reaches no target and counts its whole budget, as a run that failed. The stores keep no positions, so the ``x`` that
IOH writes beside each run's best is the centre of the box, not the run's point.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from uav_penetration_env.benchmark.blackbox.adapters import _require
from uav_penetration_env.benchmark.plugins import Needs

IOH = Needs(
    modules=("ioh",),
    install="the blackbox extra: pip install -e '.[blackbox]' in a checkout, or pip install 'uav-penetration[blackbox]'",
)
UNREACHED = float(np.finfo(np.float64).max)  # the logged cost of a run that never found a finite one
WINDOW_KEY = ("scenario", "scenario_hash", "source_policy", "episode_seed", "step", "horizon")


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.-]", "_", text)


def window_function_name(row: Any) -> str:
    """The IOH function name of a window run's window (scenario, source policy, episode seed, step, H)."""
    return _slug(
        f"uavpen_window_{row['scenario']}_{row['scenario_hash'][:8]}_{row['source_policy']}"
        f"_s{int(row['episode_seed'])}_k{int(row['step'])}_H{int(row['horizon'])}"
    )


def replay_costs(history: Sequence[float], history_nfev: Sequence[int]) -> tuple[int, np.ndarray]:
    """The costs to return at each evaluation so that IOH's logger sees a stored run.

    Args:
        history: the best-so-far cost after each iteration.
        history_nfev: the evaluations spent by then (non-decreasing, >= 1).

    Returns:
        ``(unlogged, costs)``: the number of leading evaluations to replay before the logger is
        attached, and the costs of all ``history_nfev[-1]`` evaluations (DECISION docs/blackbox.md §3).

    Raises:
        ValueError: histories of different lengths, an empty one, or evaluation counts that are
            not positive and non-decreasing.
    """
    best = np.asarray(history, dtype=np.float64)
    nfev = np.asarray(history_nfev, dtype=np.int64)
    if best.shape != nfev.shape or best.ndim != 1 or best.size == 0:
        raise ValueError(
            f"history: got {best.size} costs and {nfev.size} evaluation counts, expected equal non-zero lengths"
        )
    if nfev[0] < 1 or np.any(np.diff(nfev) < 0):
        raise ValueError(f"history_nfev: got {nfev.tolist()[:6]}..., expected positive non-decreasing counts")
    costs = np.full(int(nfev[-1]), np.inf)  # the unlogged evaluations: never a best the logger sees
    finite = np.flatnonzero(np.isfinite(best))
    if finite.size == 0:
        costs[-1] = UNREACHED
        return int(nfev[-1]) - 1, costs
    first = int(finite[0])
    previous, start = np.inf, int(nfev[first]) - 1
    for cost, spent in zip(best[first:], nfev[first:], strict=True):
        if spent > start:  # an iteration that evaluated nothing cannot have improved
            costs[start : spent - 1] = previous
            costs[spent - 1] = min(previous, float(cost))
            previous, start = float(costs[spent - 1]), int(spent)
    return int(nfev[first]) - 1, costs


def export_window_runs(store: Any, out: str | Path, *, optimizers: Sequence[str] | None = None) -> list[Path]:
    """Write a store's window runs as IOHprofiler data, one folder per optimiser configuration.

    Args:
        store: an open :class:`~uav_penetration_env.benchmark.store.ResultsStore`.
        out: a new folder (it must not exist, or be empty); written whole or not at all.
        optimizers: the optimiser names to export (default: every one stored).

    Returns:
        The ``.json`` files written (one per optimiser configuration and window).

    Raises:
        ValueError: ``out`` is a non-empty folder or a file, the store holds no window runs (of
            ``optimizers``), or a stored history is malformed (naming the run).
        ImportError: ioh is not installed (with the install line).
    """
    ioh = _require("ioh")
    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ValueError(f"out: {out} exists and is not an empty folder; expected a new folder")
    runs = store.window_runs()
    if optimizers:
        runs = runs[runs["optimizer"].astype(str).isin(list(optimizers))]
    if runs.empty:
        wanted = f" of {', '.join(optimizers)}" if optimizers else ""
        raise ValueError(
            f"store: no window runs{wanted} in {store.path}; expected rows of `uav-bench windows`"
        )
    runs = runs.sort_values(["optimizer", "optimizer_hash", *WINDOW_KEY, "seed"], kind="stable")
    hashes = runs.groupby("optimizer")["optimizer_hash"].nunique()
    out.parent.mkdir(parents=True, exist_ok=True)
    temporary = Path(tempfile.mkdtemp(prefix=f".{out.name}-", dir=out.parent))
    try:
        feed: dict[str, Any] = {}
        problems: dict[str, Any] = {}
        for (name, config), group in runs.groupby(["optimizer", "optimizer_hash"], sort=False):
            algorithm = str(name) if hashes[name] == 1 else f"{name}@{str(config)[:8]}"
            logger = ioh.logger.Analyzer(
                root=str(temporary),
                folder_name=_slug(algorithm),
                algorithm_name=algorithm,
                algorithm_info=f"optimizer_hash {config}; max_evals {int(group['max_evals'].iloc[0])}",
            )
            for _, row in group.iterrows():
                _replay_run(ioh, row, problems, feed, logger)
            logger.close()
        if out.exists():
            out.rmdir()
        os.replace(temporary, out)
    finally:
        shutil.rmtree(temporary, ignore_errors=True)
    return sorted(out.glob("*/IOHprofiler_f*.json"))


def _replay_run(ioh: Any, row: Any, problems: dict[str, Any], feed: dict[str, Any], logger: Any) -> None:
    """Replay one stored run through its window's IOH problem with ``logger`` attached after the unlogged part."""
    function = window_function_name(row)
    dimension = 3 * int(row["horizon"])
    if function not in problems:
        # One IOH problem per window, registered once: every optimiser's logger sees the same function id.
        problems[function] = ioh.wrap_problem(
            lambda x, f=function: next(feed[f]),
            name=function,
            dimension=dimension,
            instance=1,
            lb=-1.0,
            ub=1.0,
        )
    problem = problems[function]
    try:
        unlogged, costs = replay_costs(json.loads(row["history"]), json.loads(row["history_nfev"]))
    except (ValueError, TypeError) as error:
        raise ValueError(f"window run {int(row['window_run_id'])} ({row['optimizer']}): {error}") from None
    feed[function] = iter(costs.tolist())
    centre = np.zeros(dimension)
    problem.reset()
    for _ in range(unlogged):
        problem(centre)
    problem.attach_logger(logger)
    for _ in range(costs.size - unlogged):
        problem(centre)
    problem.detach_logger()
    problem.reset()
