"""What one optimiser run on one MPC window measured: runtimes to targets, values at budgets, ERT (api.md §4.8).

The per-run readings of COCO's fixed-target view, shared by the comparisons of
:mod:`~.fixedtarget` and the retired pairing of :mod:`~.fixedtarget_retired`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env.types import FloatArray

WINDOW_KEY = ["scenario_hash", "source_policy_hash", "episode_seed", "step"]


def runtime_to_target(history: Sequence[float], history_nfev: Sequence[int], target: float) -> float:
    """Evaluations until the best-so-far first reached ``target``: ``history_nfev`` there, ``inf`` if never.

    Args:
        history: (n,) best-so-far cost after initialisation and after each iteration.
        history_nfev: (n,) evaluations spent at each entry.
        target: the cost to reach (at or below).
    """
    reached = np.flatnonzero(np.asarray(history, dtype=np.float64) <= target)
    return float(np.asarray(history_nfev)[reached[0]]) if reached.size else math.inf


def value_at_budget(history: Sequence[float], history_nfev: Sequence[int], budget: float) -> float:
    """The best-so-far cost with at most ``budget`` evaluations: the last history entry within it.

    ``inf`` when even the first entry (initialisation) needed more than ``budget``.
    """
    within = np.flatnonzero(np.asarray(history_nfev, dtype=np.float64) <= budget)
    return float(np.asarray(history, dtype=np.float64)[within[-1]]) if within.size else math.inf


def ert(runtimes: Sequence[float], spent: Sequence[float]) -> float:
    """Expected running time: (Σ finite runtimes + Σ ``spent`` of the unsuccessful runs) / successes.

    Args:
        runtimes: (n,) per run, evaluations to the target (``inf``: not reached).
        spent: (n,) per run, the evaluations it spent in total.

    Returns:
        The ERT in evaluations; ``inf`` when no run succeeded.
    """
    runtimes, spent = np.asarray(runtimes, dtype=np.float64), np.asarray(spent, dtype=np.float64)
    solved = np.isfinite(runtimes)
    if not solved.any():
        return math.inf
    return float((runtimes[solved].sum() + spent[~solved].sum()) / solved.sum())


def runtime_ecdf(runtimes: Sequence[float], evaluations: Sequence[float]) -> FloatArray:
    """The share of runtimes at or below each of ``evaluations`` (unsolved runtimes are ``inf``).

    Returns:
        (len(evaluations),) non-decreasing in ``evaluations``; at or beyond the largest finite
        runtime it equals the success share.
    """
    runtimes = np.sort(np.asarray(runtimes, dtype=np.float64))
    if runtimes.size == 0:
        return np.full(len(evaluations), np.nan)
    return np.searchsorted(runtimes, np.asarray(evaluations, dtype=np.float64), side="right") / runtimes.size


def _parsed(rows: pd.DataFrame) -> pd.DataFrame:
    frame = rows.copy()
    for column in ("history", "history_nfev"):
        frame[column] = [json.loads(v) if isinstance(v, str) else list(v) for v in frame[column]]
    frame["fun"] = pd.to_numeric(frame["fun"]).astype(np.float64)
    frame["nfev"] = pd.to_numeric(frame["nfev"]).astype(np.float64)
    return frame


def _number(value: Any, digits: int = 4) -> str:
    from uav_penetration_env.benchmark.leaderboard.formatting import format_number

    if isinstance(value, float) and math.isinf(value):
        return "∞"
    return format_number(value, digits)



__all__ = ["WINDOW_KEY", "ert", "runtime_ecdf", "runtime_to_target", "value_at_budget"]
