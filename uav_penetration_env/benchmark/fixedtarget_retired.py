"""The retired pairing rule of leaderboards v2 and v3's fixed-target pages, kept to rebuild them.

DECISION (api.md §4.8): leaderboards v2 and v3 compared two optimisers per (window, seed) at the
worse of the pair's two final costs. That target is set by the pair itself, so it favours
whichever optimiser stops earlier: when the early stopper finishes worse, the other reaches that
target sooner by a few evaluations; when the other finishes worse, its count is the time of its own
last small gain, near the budget (the v3 review, docs/publishing.md §6). The rule is no longer
the default (:func:`~.fixedtarget.window_comparisons` sets targets per window, apart from the
pair); ``uav-bench leaderboard --fixed-target-rule worse-final`` keeps it so the published v2 and
v3 pages still rebuild from their rows byte for byte.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark import stats
from uav_penetration_env.benchmark.runtimes import (
    WINDOW_KEY,
    _number,
    _parsed,
    runtime_to_target,
    value_at_budget,
)


def _paired_test(a: np.ndarray, b: np.ndarray) -> dict[str, float]:
    """Median of a − b, wins, and the two-sided Wilcoxon signed-rank test (stats.wilcoxon_vs_reference)."""
    finite = np.isfinite(a) & np.isfinite(b)
    test = stats.wilcoxon_vs_reference(
        pd.DataFrame({"other": b[finite], "reference": a[finite]}), "reference"
    )
    row = test.loc["other"]
    return {
        "pairs": int(finite.sum()),
        "reference_better": int(np.sum(a[finite] < b[finite])),
        "other_better": int(np.sum(a[finite] > b[finite])),
        "median_difference": float(row["median_difference"]),
        "wilcoxon_statistic": float(row["statistic"]),
        "pvalue": float(row["pvalue"]),
    }


def paired_table(rows: pd.DataFrame, reference: str) -> pd.DataFrame:
    """Fixed-budget and fixed-target comparisons of every other optimiser with ``reference``, per (window, seed).

    Returns:
        One row per (other optimiser, comparison): ``comparison`` is ``fixed budget: J`` (the
        other's J at the reference's ``nfev`` minus the reference's final J) or ``fixed target:
        evaluations`` (to the worse of the two final costs, other minus reference), with
        ``reference_median``, ``other_median``, and the columns of the paired test (``pairs``,
        ``reference_better``, ``other_better``, ``median_difference`` other − reference,
        ``wilcoxon_statistic``, ``pvalue``). Empty when ``reference`` has no rows.
    """
    frame = _parsed(rows)
    keyed = frame.set_index([*WINDOW_KEY, "seed"])
    ref = keyed[keyed["optimizer"] == reference]
    out = []
    for other in sorted(set(frame["optimizer"]) - {reference}):
        mine = keyed[keyed["optimizer"] == other]
        shared = ref.index.intersection(mine.index)
        if len(shared) == 0:
            continue
        a_final = ref.loc[shared, "fun"].to_numpy(dtype=np.float64)
        budgets = ref.loc[shared, "nfev"].to_numpy(dtype=np.float64)
        b_budget = np.array(
            [
                value_at_budget(h, n, budget)
                for h, n, budget in zip(
                    mine.loc[shared, "history"], mine.loc[shared, "history_nfev"], budgets, strict=True
                )
            ]
        )
        b_final = mine.loc[shared, "fun"].to_numpy(dtype=np.float64)
        targets = np.maximum(a_final, b_final)
        a_evals = np.array(
            [
                runtime_to_target(h, n, t)
                for h, n, t in zip(
                    ref.loc[shared, "history"], ref.loc[shared, "history_nfev"], targets, strict=True
                )
            ]
        )
        b_evals = np.array(
            [
                runtime_to_target(h, n, t)
                for h, n, t in zip(
                    mine.loc[shared, "history"], mine.loc[shared, "history_nfev"], targets, strict=True
                )
            ]
        )
        for comparison, a, b in (
            ("fixed budget: J", a_final, b_budget),
            ("fixed target: evaluations", a_evals, b_evals),
        ):
            out.append(
                {
                    "reference": reference,
                    "other": other,
                    "comparison": comparison,
                    "reference_median": float(np.median(a[np.isfinite(a)]))
                    if np.isfinite(a).any()
                    else np.nan,
                    "other_median": float(np.median(b[np.isfinite(b)])) if np.isfinite(b).any() else np.nan,
                    **_paired_test(a, b),
                }
            )
    return pd.DataFrame(out)



def paired_lines(paired: pd.DataFrame, ref: str) -> list[str]:
    """The paired fixed-budget and fixed-target section (none without pairs)."""
    from uav_penetration_env.benchmark.leaderboard.formatting import format_pvalue, markdown_section

    if paired.empty:
        return []
    text = (
        f"Fixed budget: the other optimiser's best-so-far J at {ref}'s evaluation count of the same run, "
        f"against {ref}'s final J. Fixed target: evaluations each needed to reach the worse of the two final "
        "costs. Δ = other − reference (positive: the other is costlier / slower); two-sided Wilcoxon "
        "signed-rank test."
    )
    body = [
        [str(r.comparison), str(r.other), _number(r.reference_median, 6), _number(r.other_median, 6),
         _number(r.median_difference, 4), f"{r.reference_better} / {r.other_better} of {r.pairs}", format_pvalue(r.pvalue)]
        for r in paired.itertuples()
    ]  # fmt: skip
    header = ["comparison", "other", f"{ref} median", "other median", "median Δ", f"{ref} better / other better", "p"]
    align = ["l", "l", "r", "r", "r", "r", "r"]
    return markdown_section(f"Paired per (window, seed) against {ref}", text, header, body, align)




def paired_frame(paired: pd.DataFrame, ref: str) -> pd.DataFrame:
    """The retired pairing's display table (the HTML report of a v2 or v3 store)."""
    from uav_penetration_env.benchmark.leaderboard.formatting import format_pvalue

    return pd.DataFrame(
        [
            {
                "comparison": r.comparison,
                "other": r.other,
                f"{ref} median": _number(r.reference_median, 6),
                "other median": _number(r.other_median, 6),
                "median Δ (other − ref)": _number(r.median_difference, 4),
                f"{ref} better / other better": f"{r.reference_better} / {r.other_better} of {r.pairs}",
                "p": format_pvalue(r.pvalue),
            }
            for r in paired.itertuples()
        ]
    )
