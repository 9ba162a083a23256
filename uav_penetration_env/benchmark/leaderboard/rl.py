"""RL statistics of a scenario group: agents grouped over training seeds, and the compute axis.

docs/rl-statistics.md §2. A *method* is what a row or a point stands for:

* an **RL group**: every RL agent (a plug-in policy, family "RL agents", hybrids included) whose
  label differs only in its training-seed suffix ``-sN`` (``sb3:ppo-paper-s0``, ``-s1``, ... form
  ``sb3:ppo-paper``). Its runs are the training seeds, each scored per scenario by the agent's
  mean over its episodes there;
* any **other policy** (a planner, a floor): its runs are its episode seeds.

The paper scenario's start is fixed, so a deterministic agent (or the greedy floor) flies the same
episode for every evaluation seed: there the variation that counts is across training seeds, and
across scenarios on a suite (the strata of the bootstrap, :mod:`~uav_penetration_env.benchmark.rl_stats`).

DECISION (docs/rl-statistics.md §2): the group of an agent is read from its label, the file-name
convention of ``uav-bench train`` (``ALGO-REGIME-sSEED``), rather than from the store's
configuration, which holds file hashes but neither the regime nor the training seed; an agent
whose label has no ``-sN`` is a group of one.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark import rl_stats
from uav_penetration_env.benchmark.columns import RL_GROUP
from uav_penetration_env.benchmark.families import FAMILIES, MPC_FAMILIES, policy_family
from uav_penetration_env.benchmark.leaderboard.formatting import (
    format_interval,
    format_number,
    markdown_table,
)
from uav_penetration_env.benchmark.leaderboard.groups import prepare_episodes
from uav_penetration_env.benchmark.leaderboard.table import relative_gaps
from uav_penetration_env.benchmark.stats import label_seed

TRAINING_SEED = re.compile(r"-s\d+$")
SWARM_FAMILY = "paper planners (MPC)"
RL_FAMILY = "RL agents"
CONFIDENCE = 0.95
TABLE_NOTE = (
    "Runs are training seeds for RL groups (each scored by its mean total J over the evaluation "
    "episodes of a scenario) and episode seeds for reference policies. On a scenario with a fixed "
    "start (the paper's) a deterministic agent flies the same episode for every evaluation seed, so "
    "the variation that counts is across training seeds; intervals are stratified bootstraps over "
    "runs within scenarios (Agarwal et al. 2021). Lower total J is better: P(< Y) is the chance that "
    "a run of the row is cheaper than a run of Y."
)


def rl_group_label(label: str) -> str:
    """An RL agent's group: its label without the training-seed suffix (``sb3:ppo-paper-s0`` -> ``sb3:ppo-paper``)."""
    return TRAINING_SEED.sub("", label)


@dataclass(frozen=True)
class Method:
    """One row of the RL table or one point of the compute figure.

    Attributes:
        label: the group's or the policy's label.
        members: the policy labels it pools (one for a plain policy).
        grouped: True for an RL group (runs = members), False for a policy (runs = episode seeds).
        family: its policy family (:data:`~uav_penetration_env.benchmark.families.FAMILIES`).
    """

    label: str
    members: tuple[str, ...]
    grouped: bool
    family: str


def methods(episodes: pd.DataFrame) -> list[Method]:
    """The methods of a group's episodes: RL agents pooled by group, every other policy alone.

    Returns:
        Methods sorted by family order, then label.
    """
    frame = episodes if "is_error" in episodes else prepare_episodes(episodes)
    labels = sorted(frame.loc[~frame["is_error"], "label"].astype(str).unique())
    groups: dict[str, list[str]] = {}
    found = []
    for label in labels:
        family = policy_family(label)
        if family == RL_FAMILY:
            groups.setdefault(rl_group_label(label), []).append(label)
        else:
            found.append(Method(label, (label,), False, family))
    found += [Method(group, tuple(members), True, RL_FAMILY) for group, members in groups.items()]
    return sorted(found, key=lambda m: (FAMILIES.index(m.family), m.label))


def _task_column(frame: pd.DataFrame) -> str:
    return "episode_scenario_hash" if "episode_scenario_hash" in frame else "scenario_hash"


def _seed_column(frame: pd.DataFrame) -> str:
    return "episode_seed" if "episode_seed" in frame else "seed"


def run_scores(episodes: pd.DataFrame, method: Method, column: str = "total_cost") -> pd.DataFrame:
    """The (runs x tasks) scores of a method: one row per run, one column per scenario.

    An RL group's runs are its members, each scored by its mean over its finished episodes of the
    scenario; a scenario some member did not finish is left out (the group keeps all its training
    seeds). A policy's runs are its episode seeds; a seed missing on some scenario is left out.

    Args:
        episodes: the group's prepared episode rows.
        method: the method.
        column: the episode column scored (default: total J incl. penalty).

    Returns:
        A DataFrame of finite values, index = runs, columns = scenario hashes (may be empty).
    """
    task = _task_column(episodes)
    rows = episodes[~episodes["is_error"] & episodes["label"].isin(method.members)]
    rows = rows[np.isfinite(rows[column].to_numpy(dtype=np.float64))]
    run = "label" if method.grouped else _seed_column(rows)
    table = rows.groupby([run, task])[column].mean().unstack(task).sort_index()
    return table.dropna(axis=1 if method.grouped else 0, how="any")


def _estimate(table: pd.DataFrame, statistic: str, seed: np.random.SeedSequence, n: int) -> rl_stats.Estimate:
    if table.empty:
        return rl_stats.Estimate(np.nan, np.nan, np.nan)
    return rl_stats.interval_estimate(table.to_numpy(), statistic, seed=seed, n_resamples=n)


def _improvement(x: pd.DataFrame, y: pd.DataFrame, seed: np.random.SeedSequence, n: int) -> rl_stats.Estimate:
    tasks = [t for t in x.columns if t in y.columns]
    if x.empty or y.empty or not tasks:
        return rl_stats.Estimate(np.nan, np.nan, np.nan)
    return rl_stats.probability_of_improvement(
        x[tasks].to_numpy(), y[tasks].to_numpy(), seed=seed, n_resamples=n
    )


def _difference(x: pd.DataFrame, y: pd.DataFrame, seed: np.random.SeedSequence, n: int) -> rl_stats.Estimate:
    tasks = [t for t in x.columns if t in y.columns]
    if x.empty or y.empty or not tasks:
        return rl_stats.Estimate(np.nan, np.nan, np.nan)
    return rl_stats.mean_difference(x[tasks].to_numpy(), y[tasks].to_numpy(), seed=seed, n_resamples=n)


def best_planner(episodes: pd.DataFrame, found: Sequence[Method]) -> Method | None:
    """The swarm planner (family "paper planners (MPC)") with the lowest mean total J, ties by label.

    DECISION (docs/rl-statistics.md §2): "best" by the mean total J incl. penalty over finished
    episodes, the leaderboard's headline; with no paper planner in the group, the best MPC
    planner of any family.
    """
    candidates = [m for m in found if m.family == SWARM_FAMILY] or [
        m for m in found if m.family in MPC_FAMILIES
    ]
    valid = episodes[~episodes["is_error"]]
    means = {m.label: float(valid.loc[valid["label"] == m.label, "total_cost"].mean()) for m in candidates}
    ranked = sorted((v, k) for k, v in means.items() if np.isfinite(v))
    return next((m for m in candidates if m.label == ranked[0][1]), None) if ranked else None


def rl_table(episodes: pd.DataFrame, *, seed: int = 0, n_resamples: int = 10_000) -> pd.DataFrame:
    """The RL table of one scenario (or suite) group: RL groups and the reference policies.

    Rows: every RL group, sorted by IQM (lower first), then the greedy floor and the best swarm
    planner as ``reference`` rows; empty when the group has no RL agent. Columns: those of
    :data:`~uav_penetration_env.benchmark.columns.RL_GROUP` (their CSV names). Every bootstrap is
    seeded from ``(seed, row label)``.

    Args:
        episodes: the group's episode rows.
        seed: seed of every bootstrap.
        n_resamples: bootstrap resamples of the IQM and mean (the probabilities of improvement use
            a fifth of them, at least 500: each resample compares every pair of runs).

    Returns:
        The table (``attrs``: ``best_planner``, ``n_resamples``).
    """
    frame = episodes if "is_error" in episodes else prepare_episodes(episodes)
    found = methods(frame)
    groups = [m for m in found if m.grouped]
    columns = [name for column in RL_GROUP for name in column.csv]
    planner = best_planner(frame, found)
    greedy = next((m for m in found if m.label == "greedy"), None)
    if not groups:
        table = pd.DataFrame(columns=columns)
        table.attrs.update(best_planner=None if planner is None else planner.label, n_resamples=n_resamples)
        return table
    references = [m for m in (greedy, planner) if m is not None]
    scores = {m.label: run_scores(frame, m) for m in [*groups, *references]}
    poi_resamples = max(500, n_resamples // 5)
    rows = [
        _method_row(frame, method, scores, greedy, planner, seed, n_resamples, poi_resamples)
        for method in [*groups, *references]
    ]
    table = pd.DataFrame(rows, columns=columns)
    grouped = table[table["kind"] == "RL group"].sort_values(
        ["iqm", "group"], kind="mergesort", na_position="last"
    )
    table = pd.concat([grouped, table[table["kind"] == "reference"]], ignore_index=True)
    table.attrs.update(best_planner=None if planner is None else planner.label, n_resamples=n_resamples)
    return table


def _method_row(
    frame: pd.DataFrame,
    method: Any,
    scores: dict[str, pd.DataFrame],
    greedy: Any,
    planner: Any,
    seed: int,
    n_resamples: int,
    poi_resamples: int,
) -> dict[str, Any]:
    """One row of the RL table: a group's (or reference's) IQM, mean, improvement over greedy and the planner, gap, compute."""
    table = scores[method.label]
    valid = frame[~frame["is_error"] & frame["label"].isin(method.members)]
    iqm = _estimate(table, "iqm", label_seed(seed, method.label, 10), n_resamples)
    mean = _estimate(table, "mean", label_seed(seed, method.label, 11), n_resamples)
    row: dict[str, Any] = {
        "group": method.label,
        "kind": "RL group" if method.grouped else "reference",
        "members": " ".join(method.members),
        "runs": len(table),
        "tasks": table.shape[1],
        "episodes": len(valid),
        "iqm": iqm.value,
        "iqm_ci_low": iqm.low,
        "iqm_ci_high": iqm.high,
        "mean": mean.value,
        "mean_ci_low": mean.low,
        "mean_ci_high": mean.high,
        "best_planner": None if planner is None else planner.label,
    }
    none = rl_stats.Estimate(np.nan, np.nan, np.nan)
    for key, versus, purpose in (("poi_greedy", greedy, 12), ("poi_planner", planner, 13)):
        poi = (
            none
            if versus is None or versus is method
            else _improvement(table, scores[versus.label], label_seed(seed, method.label, purpose), poi_resamples)
        )
        row.update({key: poi.value, f"{key}_ci_low": poi.low, f"{key}_ci_high": poi.high})
    delta = (
        none
        if greedy is None or greedy is method
        else _difference(table, scores[greedy.label], label_seed(seed, method.label, 14), n_resamples)
    )
    row.update({"delta_greedy": delta.value, "delta_greedy_ci_low": delta.low, "delta_greedy_ci_high": delta.high})
    gaps = relative_gaps(valid).to_numpy(dtype=np.float64) if len(valid) else np.array([])
    gaps = gaps[np.isfinite(gaps)]
    row["gap"] = float(gaps.mean()) if len(gaps) else np.nan
    row["decision_seconds"] = float(valid["planning_seconds"].mean()) if len(valid) else np.nan
    for budget in ("train_timesteps", "train_seconds"):
        values = valid[budget].dropna() if budget in valid else pd.Series(dtype=float)
        row[budget] = float(values.mean()) if len(values) else np.nan
    return row


def _cell(name: str, r: Any) -> str:
    if name == "group":
        return f"{r['group']} (reference)" if r["kind"] == "reference" else str(r["group"])
    if name in ("runs", "tasks", "episodes"):
        return f"{int(r[name])}"
    if name in ("iqm", "mean"):
        return format_interval(r[name], r[f"{name}_ci_low"], r[f"{name}_ci_high"])
    if name == "delta_greedy":
        return format_interval(r[name], r[f"{name}_ci_low"], r[f"{name}_ci_high"], 3)
    if name.startswith("poi_"):
        return format_interval(r[name], r[f"{name}_ci_low"], r[f"{name}_ci_high"], 3)
    if name == "gap":
        return f"{100.0 * r[name]:.2f}%" if np.isfinite(r[name]) else ""
    if name == "train_timesteps":
        return f"{int(r[name]):,}" if np.isfinite(r[name]) else ""
    return format_number(r[name], 3 if name == "decision_seconds" else 4)


def _best_planner(table: pd.DataFrame) -> str:
    """The best swarm planner an RL table compares with (its attrs, else its CSV column)."""
    if table.attrs.get("best_planner"):
        return str(table.attrs["best_planner"])
    named = table["best_planner"].dropna() if "best_planner" in table else pd.Series(dtype=object)
    return str(named.iloc[0]) if len(named) else "best planner"


def rl_rows(table: pd.DataFrame) -> tuple[list[str], list[list[str]]]:
    """The header and cell texts of an :func:`rl_table` (or of its CSV read back by pandas)."""
    planner = _best_planner(table)
    header = [column.board.header.format(planner=planner) for column in RL_GROUP]
    return header, [[_cell(column.name, r) for column in RL_GROUP] for _, r in table.iterrows()]


def rl_markdown(table: pd.DataFrame) -> str:
    """The "RL agents over training seeds" section of a leaderboard's Markdown file (empty without agents)."""
    if table.empty:
        return ""
    planner = _best_planner(table)
    header, rows = rl_rows(table)
    resamples = f"{int(table.attrs.get('n_resamples', 10_000)):,}"
    legend = [
        f"- **{column.board.header.format(planner=planner)}**: {column.board.legend.format(resamples=resamples)}."
        for column in RL_GROUP
    ]
    return "\n".join(
        [
            "## RL agents over training seeds",
            "",
            TABLE_NOTE,
            "",
            markdown_table(header, rows, ["l", *(["r"] * (len(header) - 1))]),
            "",
            *legend,
            "",
        ]
    )


# --- the compute axis -----------------------------------------------------------------------------------


def compute_points(episodes: pd.DataFrame, *, seed: int = 0, n_resamples: int = 2_000) -> pd.DataFrame:
    """Per method: mean decision time per step and mean total J, each with a stratified-bootstrap interval.

    docs/rl-statistics.md §2: RL agents are pooled by group (runs = training seeds), other
    policies stand alone (runs = episode seeds); both quantities are means over runs x scenarios
    and their intervals resample runs within scenarios. The decision time is the episodes'
    ``planning_seconds``: wall-clock seconds per action as the evaluator measured them (MPC
    planning, network inference, the greedy rule alike).

    Args:
        episodes: one scenario (or suite) group's episode rows.
        seed: seed of the bootstraps.
        n_resamples: bootstrap resamples.

    Returns:
        One row per method with a finite score: ``method``, ``family``, ``members``, ``runs``,
        ``decision_seconds`` (+ ``_ci_low``/``_ci_high``), ``total_cost`` (+ interval),
        ``train_timesteps``, ``train_seconds`` (NaN for methods that do not train).
    """
    frame = episodes if "is_error" in episodes else prepare_episodes(episodes)
    rows = []
    for method in methods(frame):
        cost = run_scores(frame, method)
        time = run_scores(frame, method, "planning_seconds")
        if cost.empty:
            continue
        valid = frame[~frame["is_error"] & frame["label"].isin(method.members)]
        row: dict[str, Any] = {
            "method": method.label,
            "family": method.family,
            "members": " ".join(method.members),
            "runs": len(cost),
        }
        for name, table, purpose in (("decision_seconds", time, 20), ("total_cost", cost, 21)):
            estimate = _estimate(table, "mean", label_seed(seed, method.label, purpose), n_resamples)
            row.update(
                {name: estimate.value, f"{name}_ci_low": estimate.low, f"{name}_ci_high": estimate.high}
            )
        for budget in ("train_timesteps", "train_seconds"):
            values = valid[budget].dropna() if budget in valid else pd.Series(dtype=float)
            row[budget] = float(values.mean()) if len(values) else np.nan
        rows.append(row)
    return pd.DataFrame(rows)


__all__ = [
    "TABLE_NOTE",
    "Method",
    "best_planner",
    "compute_points",
    "label_seed",
    "methods",
    "rl_group_label",
    "rl_markdown",
    "rl_table",
    "run_scores",
]
