"""A protocol's answers as Markdown and CSV: the primary answers, the exploratory ones, the success bar.

:func:`answers_markdown` renders :func:`~.protocol.primary_answers` and :func:`~.protocol.success_bar`
(docs/publishing.md §6); :func:`answer_sentence` is one answer in plain words with its number,
interval and test, the form the results page and the README's headline quote.
"""

from __future__ import annotations

import math

import pandas as pd

from uav_penetration_env.benchmark.leaderboard.formatting import format_number, format_pvalue, markdown_table
from uav_penetration_env.benchmark.protocol import Protocol

MEASURE_WORDS = {
    "total_cost": "total cost (J with the failure penalty), other − reference",
    "fixed_target": "log10 of the ERT ratio other / reference to the window's target",
    "fixed_budget": "J at the reference's evaluation count, other − reference",
}


def _number(value: float, digits: int = 3) -> str:
    if isinstance(value, float) and math.isinf(value):
        return "+∞" if value > 0 else "−∞"
    return format_number(value, digits)


def interval_text(row: pd.Series) -> str:
    """``median [low, high]`` of one answer."""
    return f"{_number(row['median'])} [{_number(row['ci_low'])}, {_number(row['ci_high'])}]"


def answer_sentence(row: pd.Series) -> str:
    """One answer in words: the verdict, the statistic with its interval, the units and the corrected test."""
    units = {"seed": "seeds", "member": "members", "window": "windows"}[str(row["unit"])]
    if row["verdict"] == "not flown":
        return f"{row['other']} vs {row['reference']} on {row['table']}: not flown."
    measure = str(row["measure"]).split(" ")[0]
    what = {
        "total_cost": "median paired difference in total cost",
        "fixed_target": "median log10 ERT ratio",
        "fixed_budget": "median J difference at equal evaluations",
    }[measure]
    return (
        f"{row['verdict']} ({what} {interval_text(row)} over {int(row['units'])} {units}, "
        f"Wilcoxon signed-rank, Holm p {format_pvalue(row['pvalue_adjusted'])})"
    )


def answers_markdown(protocol: Protocol, answers: pd.DataFrame, success: pd.DataFrame, source: str) -> str:
    """The protocol's answers page: one table per family, then the success bar.

    Args:
        protocol: the protocol the answers were computed under.
        answers: :func:`~.protocol.primary_answers`'s frame.
        success: :func:`~.protocol.success_bar`'s frame.
        source: where the rows came from (printed under the title).
    """
    lines = [
        f"# Protocol {protocol.publication}: the declared comparisons",
        "",
        f"Computed by `uav-bench protocol` from {source} under the protocol declared on {protocol.declared} "
        f"(docs/publishing.md §6). α = {protocol.alpha:g} after Holm's correction within each family; "
        "the statistic is the median over units of other − reference (negative: the other is cheaper or "
        f"faster) with a percentile-bootstrap 95 % interval over units ({protocol.bootstrap_resamples} "
        "resamples); the test is the two-sided Wilcoxon signed-rank test over units.",
        "",
    ]
    header = ["comparison", "table", "measure", "units", "other", "reference", "median [95 % CI]",
              "other / ref better", "p", "Holm p", "verdict"]  # fmt: skip
    for family in protocol.families:
        rows = answers[answers["family"] == family.name]
        kind = "primary" if family.primary else "exploratory"
        lines += [f"## {family.name} ({kind})", "", family.question, ""]
        body = [
            [str(r.id), str(r.table), str(r.measure), f"{int(r.units)} {r.unit}s", str(r.other), str(r.reference),
             interval_text(pd.Series(r._asdict())) if r.units else "-",
             f"{int(r.other_better)} / {int(r.reference_better)}" if r.units else "-",
             format_pvalue(r.pvalue), format_pvalue(r.pvalue_adjusted), str(r.verdict)]
            for r in rows.itertuples()
        ]  # fmt: skip
        lines += [markdown_table(header, body, ["l", "l", "l", "r", "l", "l", "r", "r", "r", "r", "l"]), ""]
    lines += [
        f"## The success bar ({protocol.success.bound:.0%})",
        "",
        f"Share of episodes reaching the goal, with its Wilson {protocol.success.confidence:.0%} interval; "
        f"a planner meets the bar when the share is at least {protocol.success.bound:.0%}.",
        "",
    ]
    body = [
        [str(r.table), str(r.planner), f"{int(r.successes)}/{int(r.episodes)}",
         "-" if not r.episodes else f"{r.rate:.1%}",
         "-" if not r.episodes else f"[{r.wilson_low:.1%}, {r.wilson_high:.1%}]",
         "not flown" if r.meets is None else ("yes" if r.meets else "**no**")]
        for r in success.itertuples()
    ]  # fmt: skip
    lines += [markdown_table(["table", "planner", "reached", "share", "Wilson interval", "meets"], body,
                             ["l", "l", "r", "r", "r", "l"]), ""]  # fmt: skip
    return "\n".join(lines)


__all__ = ["MEASURE_WORDS", "answer_sentence", "answers_markdown", "interval_text"]
