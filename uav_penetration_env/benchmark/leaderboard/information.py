"""The price of information: each planner on the belief against itself given the truth (docs/dynamic.md §7).

For every policy P flown beside ``oracle:P`` (the same policy planning on the truth) on the same
scenarios and seeds, the price of information is the paired difference of total cost,
``total_cost(P) - total_cost(oracle:P)``, per episode. The table gives, per P: the pairs, the
mean and median difference with a paired bootstrap interval of the mean, Wilcoxon's signed-rank
test of a zero median (two-sided, Holm-corrected over the planners of the table) and the success
rates of both with their Wilson intervals. The same for ``offline:P``, the never-replanning floor,
against P: what replanning on the belief earns.

DECISION (docs/dynamic.md §7): the price is never assumed to be positive (more information need
not lower every rule's cost in every episode, §6); its sign is read from the interval.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats as scipy_stats

from uav_penetration_env.atomic import write_text_atomic
from uav_penetration_env.benchmark import stats
from uav_penetration_env.benchmark.leaderboard.formatting import format_number, markdown_table
from uav_penetration_env.benchmark.leaderboard.registry import TableContext, register_tables
from uav_penetration_env.benchmark.policy_spec import OFFLINE, ORACLE
from uav_penetration_env.benchmark.safe_text import markdown_cell, write_csv_table

PAIRS = {ORACLE: "price of information (P - oracle:P)", OFFLINE: "value of replanning (offline:P - P)"}
COLUMNS = (
    "comparison",
    "policy",
    "pairs",
    "mean_difference",
    "ci_low",
    "ci_high",
    "median_difference",
    "wilcoxon_p",
    "wilcoxon_p_holm",
    "success",
    "success_other",
)


def _pairs(episodes: pd.DataFrame, policy: str, other: str) -> pd.DataFrame:
    """The finished episodes of ``policy`` and ``other`` on the same (scenario, seed), side by side."""
    keys = ["scenario_hash", "seed"]
    done = episodes[episodes["outcome"].notna() & (episodes["outcome"] != "error")]
    a = done[done["policy"] == policy][[*keys, "total_cost", "outcome"]]
    b = done[done["policy"] == other][[*keys, "total_cost", "outcome"]]
    return a.merge(b, on=keys, suffixes=("", "_other"))


def information_table(
    episodes: pd.DataFrame, *, seed: int = 0, n_resamples: int = 10_000, confidence: float = 0.95
) -> pd.DataFrame:
    """One row per (comparison, planner) with a paired partner in ``episodes`` (see the module docstring).

    Args:
        episodes: episode rows (``policy``, ``scenario_hash``, ``seed``, ``outcome``, ``total_cost``).
        seed: bootstrap seed (each row's stream derives from it and the row's label).
        n_resamples: bootstrap resamples.
        confidence: the intervals' level.

    Returns:
        The :data:`COLUMNS` table; empty when no policy has its partner. For ``oracle`` rows the
        difference is P - oracle:P; for ``offline`` rows offline:P - P (positive: replanning helps).
    """
    rows = []
    labels = set(episodes["policy"])
    for mode, comparison in PAIRS.items():
        block = []
        for label in sorted(labels):
            if not label.startswith(f"{mode}:"):
                continue
            inner = label[len(mode) + 1 :]
            if inner not in labels:
                continue
            first, second = (inner, label) if mode == ORACLE else (label, inner)
            pairs = _pairs(episodes, first, second)
            if pairs.empty:
                continue
            difference = pairs["total_cost"].to_numpy(float) - pairs["total_cost_other"].to_numpy(float)
            low, high = (
                stats.paired_difference_ci(
                    pairs["total_cost"], pairs["total_cost_other"], seed=stats.label_seed(seed, f"{mode}:{inner}", 0),
                    n_resamples=n_resamples, confidence=confidence,
                )
                if len(pairs) >= 2 else (np.nan, np.nan)
            )  # fmt: skip
            nonzero = difference[difference != 0.0]
            p = float(scipy_stats.wilcoxon(nonzero).pvalue) if len(nonzero) >= 1 else 1.0
            block.append(
                {
                    "comparison": comparison,
                    "policy": inner,
                    "pairs": len(pairs),
                    "mean_difference": float(difference.mean()),
                    "ci_low": low,
                    "ci_high": high,
                    "median_difference": float(np.median(difference)),
                    "wilcoxon_p": p,
                    "success": float((pairs["outcome"] == "success").mean()),
                    "success_other": float((pairs["outcome_other"] == "success").mean()),
                }
            )
        if block:
            corrected = stats.holm([row["wilcoxon_p"] for row in block])
            for row, p_holm in zip(block, corrected, strict=True):
                row["wilcoxon_p_holm"] = float(p_holm)
            rows += block
    return pd.DataFrame(rows, columns=list(COLUMNS))


@register_tables("information")
def _information_tables(context: TableContext) -> list[Path]:
    """``information.csv`` and ``information.md`` when the store holds a planner beside its oracle or offline floor."""
    table = information_table(context.episodes, seed=context.seed, n_resamples=context.n_resamples)
    if table.empty:
        return []
    csv = write_csv_table(table, context.out_dir / "information.csv")
    cells = [
        [markdown_cell(row["comparison"]), markdown_cell(row["policy"]), str(row["pairs"]),
         *(format_number(row[column]) for column in COLUMNS[3:])]
        for _, row in table.iterrows()
    ]  # fmt: skip
    text = "\n".join(
        [
            "# The price of information (docs/dynamic.md §7)",
            "",
            "Paired per episode (same scenario, same seed). Price of information: the planner's total cost "
            "on the belief minus its own given the truth (`oracle:`). Value of replanning: the never-replanning "
            "floor (`offline:`, its plan on the prior map flown open loop) minus the planner. Intervals: paired "
            "bootstrap of the mean; p: Wilcoxon signed-rank, two-sided, Holm over the planners of each comparison.",
            "",
            markdown_table(list(COLUMNS), cells, ["l", "l", *["r"] * (len(COLUMNS) - 2)]),
            "",
            f"Command: `{context.command}`; {context.date}",
            "",
        ]
    )
    md = write_text_atomic(context.out_dir / "information.md", text)
    return [csv, md]
