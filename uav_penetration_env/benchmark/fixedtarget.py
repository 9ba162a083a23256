"""Fixed-target and fixed-budget comparison of optimisers on identical MPC windows (api.md §4.8).

The COCO view of "fewer iterations": on each window (a stored MPC state, ``window_runs`` rows of
``uav-bench windows``) the reference cost f* is the best cost any run of any optimiser found; the
targets are f* + Δ·|f*| (:data:`TARGET_PRECISIONS`). A run's *runtime* for a target is the number
of evaluations at the first ``history`` entry at or below it (from ``history_nfev``), infinite if it
never got there. Per optimiser and target:

* the expected running time ERT = (Σ runtimes of the successful runs + Σ ``nfev`` of the others) /
  successes (Hansen et al., COCO; infinite without a success), :func:`ert`;
* the runtime ECDF: the share of (run, target) pairs solved within x evaluations,
  :func:`runtime_ecdf`, which ends at the success share.

Paired per (window, seed), each other optimiser against a reference (IHPSO by default):

* fixed budget: its J at the reference's evaluation count (:func:`value_at_budget`) against the
  reference's final J;
* fixed target: the evaluations each needed to reach the worse of the two final costs.

Both are tested with the two-sided Wilcoxon signed-rank test (:mod:`~uav_penetration_env.benchmark.stats`).
"""

from __future__ import annotations

import datetime as dt
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark import stats
from uav_penetration_env.benchmark.rows import ResultTables, store_tables
from uav_penetration_env.types import FloatArray

TARGET_PRECISIONS = (1e-1, 1e-2, 1e-3, 1e-4)  # Δ: targets f* + Δ |f*| (DECISION api.md §4.8)
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


def target_runs(rows: pd.DataFrame, precisions: Sequence[float] = TARGET_PRECISIONS) -> pd.DataFrame:
    """The runtime of every window run for every target.

    One row per (window run, target): ``optimizer``, the window key, ``seed``, ``precision``,
    ``target``, ``runtime`` (``inf``: not reached) and ``nfev``.

    Args:
        rows: ``window_runs`` rows (one scenario, one budget).
        precisions: the Δ of the targets f* + Δ|f*|, f* the best ``fun`` of the window over every row.
    """
    frame = _parsed(rows)
    best = frame.groupby(WINDOW_KEY)["fun"].transform("min")
    out = []
    for (_, run), f_star in zip(frame.iterrows(), best, strict=True):
        for precision in precisions:
            target = f_star + precision * abs(f_star)
            out.append(
                {
                    "optimizer": run["optimizer"],
                    **{key: run[key] for key in WINDOW_KEY},
                    "seed": int(run["seed"]),
                    "precision": precision,
                    "target": target,
                    "runtime": runtime_to_target(run["history"], run["history_nfev"], target),
                    "nfev": run["nfev"],
                }
            )
    return pd.DataFrame(out)


def ert_table(targets: pd.DataFrame, reference: str | None = None) -> pd.DataFrame:
    """ERT per (optimiser, target precision) over every window and seed, from :func:`target_runs`.

    Returns:
        Columns ``optimizer``, ``precision``, ``runs``, ``successes``, ``ert`` and ``ert_ratio``
        (ERT / the reference's ERT at the same precision; NaN without a reference or where either
        ERT is infinite).
    """
    rows = []
    for (optimizer, precision), group in targets.groupby(["optimizer", "precision"], sort=True):
        rows.append(
            {
                "optimizer": optimizer,
                "precision": precision,
                "runs": len(group),
                "successes": int(np.isfinite(group["runtime"]).sum()),
                "ert": ert(group["runtime"], group["nfev"]),
            }
        )
    table = pd.DataFrame(rows).sort_values(
        ["precision", "optimizer"], ascending=[False, True], kind="mergesort"
    )
    table["ert_ratio"] = np.nan
    if reference is not None and reference in set(table["optimizer"]):
        base = table[table["optimizer"] == reference].set_index("precision")["ert"]
        mine, theirs = table["ert"].to_numpy(), base.reindex(table["precision"]).to_numpy()
        both = np.isfinite(mine) & np.isfinite(theirs)  # a ratio with an infinite ERT says nothing
        table["ert_ratio"] = np.where(both, mine / np.where(both, theirs, 1.0), np.nan)
    return table.reset_index(drop=True)


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


def trace_table(rows: pd.DataFrame) -> pd.DataFrame:
    """Per optimiser: runs, evaluations used (mean), share stopped early, switches and reverse switches per run."""
    frame = rows.copy()
    for column in ("nfev", "stopped_early", "switches", "reverse_switches", "fun"):
        frame[column] = pd.to_numeric(frame[column], errors="coerce").astype(np.float64)
    return (
        frame.groupby("optimizer", sort=True)
        .agg(
            runs=("nfev", "size"),
            nfev_mean=("nfev", "mean"),
            stopped_early_share=("stopped_early", "mean"),
            switches_mean=("switches", "mean"),
            reverse_switches_mean=("reverse_switches", "mean"),
            fun_median=("fun", "median"),
        )
        .reset_index()
    )


def _number(value: Any, digits: int = 4) -> str:
    from uav_penetration_env.benchmark.leaderboard.formatting import format_number

    if isinstance(value, float) and math.isinf(value):
        return "∞"
    return format_number(value, digits)


def fixed_target_frames(rows: pd.DataFrame, reference: str) -> tuple[str, dict[str, pd.DataFrame]]:
    """The three tables of one scenario's window runs, formatted for display (the HTML report).

    The content of :func:`fixed_target_markdown`'s tables: the ERT per target precision, the paired
    fixed-budget and fixed-target comparisons with the reference, and the evaluations and state
    machines per optimiser.

    Args:
        rows: the scenario's ``window_runs`` rows.
        reference: the optimiser the others are paired with (the first name if it has no rows).

    Returns:
        (the reference used, {title: DataFrame of display strings}); the paired table is empty when
        no other optimiser shares a (window, seed) with the reference.
    """
    from uav_penetration_env.benchmark.leaderboard.formatting import format_pvalue

    ref = reference if reference in set(rows["optimizer"]) else sorted(set(rows["optimizer"]))[0]
    ert = ert_table(target_runs(rows), ref)
    paired = paired_table(rows, ref)
    traces = trace_table(rows)
    ert_frame = pd.DataFrame(
        {
            "Δ": [f"{value:.0e}" for value in ert["precision"]],
            "optimizer": ert["optimizer"].astype(str),
            "solved": [f"{s}/{r}" for s, r in zip(ert["successes"], ert["runs"], strict=True)],
            "ERT [evals]": [_number(value) for value in ert["ert"]],
            f"ERT / {ref}": [_number(value, 3) for value in ert["ert_ratio"]],
        }
    )
    paired_frame = pd.DataFrame(
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
    trace_frame = pd.DataFrame(
        {
            "optimizer": traces["optimizer"].astype(str),
            "runs": traces["runs"],
            "evals/run": [_number(value) for value in traces["nfev_mean"]],
            "stopped early": [_number(value, 3) for value in traces["stopped_early_share"]],
            "switches/run": [_number(value, 3) for value in traces["switches_mean"]],
            "reverse/run": [_number(value, 3) for value in traces["reverse_switches_mean"]],
            "median J": [_number(value, 6) for value in traces["fun_median"]],
        }
    )
    return ref, {
        "Expected running time (ERT) to the targets f* + Δ|f*|": ert_frame,
        f"Paired per (window, seed) against {ref}": paired_frame,
        "Evaluations and the optimisers' state machines": trace_frame,
    }


def fixed_target_markdown(
    rows: pd.DataFrame, reference: str, name: str, command: str, date: str = ""
) -> tuple[str, dict[str, pd.DataFrame]]:
    """The Markdown page and the CSV tables of one scenario's window runs.

    Returns:
        (the page, {CSV file suffix: table}): ``""`` the ERT rows (:func:`ert_table`),
        ``"-paired"`` the paired comparisons (:func:`paired_table`, empty without pairs) and
        ``"-traces"`` the evaluations and state machines (:func:`trace_table`).

    The page's date line (``- Date: DATE, by `COMMAND```) is its only line that depends on when and
    from which source (store or exported rows) it was built.
    """
    ref = reference if reference in set(rows["optimizer"]) else sorted(set(rows["optimizer"]))[0]
    targets = target_runs(rows)
    table = ert_table(targets, ref)
    paired = paired_table(rows, ref)
    traces = trace_table(rows)
    windows = rows.drop_duplicates(WINDOW_KEY)
    budgets = sorted(set(pd.to_numeric(rows["max_evals"]).astype(int)))
    lines = [
        f"# Fixed-target and fixed-budget comparison: {name}",
        "",
        "Generated by `uav-bench leaderboard` from the window runs of a results store or of its exported "
        "rows (api.md §4.8); do not edit.",
        "",
        f"- Date: {date}, by `{command}`",
        "",
        f"{len(windows)} window states (source {', '.join(sorted(set(rows['source_policy'].astype(str))))}, "
        f"episode seeds {', '.join(map(str, sorted(set(windows['episode_seed'].astype(int)))))}, steps "
        f"{', '.join(map(str, sorted(set(windows['step'].astype(int)))))}), "
        f"{rows['seed'].nunique()} seeds, budget {', '.join(f'{b:,}' for b in budgets)} evaluations; reference {ref}.",
        "",
        "## Expected running time (ERT) to the targets f* + Δ|f*|",
        "",
        "f* is the best cost any run found on the window. ERT = (evaluations of the successful runs to the "
        "target + evaluations of the unsuccessful runs) / successes, over every window and seed; ∞: no run "
        f"reached it. Ratio: ERT / {ref}'s ERT.",
        "",
    ]
    lines += _ert_lines(table) + _paired_lines(paired, ref) + _trace_lines(traces)
    return "\n".join(lines), {"": table, "-paired": paired, "-traces": traces}

def _ert_lines(table: pd.DataFrame) -> list[str]:
    """The ERT table's Markdown (its heading and explanation precede it on the page)."""
    from uav_penetration_env.benchmark.leaderboard.formatting import markdown_table

    body = [
        [f"{row.precision:.0e}", str(row.optimizer), f"{row.successes}/{row.runs}", _number(row.ert), _number(row.ert_ratio, 3)]
        for row in table.itertuples()
    ]
    return [markdown_table(["Δ", "optimizer", "solved", "ERT [evals]", "ratio"], body, ["r", "l", "r", "r", "r"]), ""]


def _paired_lines(paired: pd.DataFrame, ref: str) -> list[str]:
    """The paired fixed-budget and fixed-target section (none without pairs)."""
    from uav_penetration_env.benchmark.leaderboard.formatting import format_pvalue, markdown_table

    if paired.empty:
        return []
    lines = [
        f"## Paired per (window, seed) against {ref}",
        "",
        f"Fixed budget: the other optimiser's best-so-far J at {ref}'s evaluation count of the same run, "
        f"against {ref}'s final J. Fixed target: evaluations each needed to reach the worse of the two final "
        "costs. Δ = other − reference (positive: the other is costlier / slower); two-sided Wilcoxon "
        "signed-rank test.",
        "",
    ]
    body = [
        [str(r.comparison), str(r.other), _number(r.reference_median, 6), _number(r.other_median, 6),
         _number(r.median_difference, 4), f"{r.reference_better} / {r.other_better} of {r.pairs}", format_pvalue(r.pvalue)]
        for r in paired.itertuples()
    ]  # fmt: skip
    header = ["comparison", "other", f"{ref} median", "other median", "median Δ", f"{ref} better / other better", "p"]
    return [*lines, markdown_table(header, body, ["l", "l", "r", "r", "r", "r", "r"]), ""]


def _trace_lines(traces: pd.DataFrame) -> list[str]:
    """The evaluations and state-machine section."""
    from uav_penetration_env.benchmark.leaderboard.formatting import markdown_table

    body = [
        [str(r.optimizer), str(r.runs), _number(r.nfev_mean), _number(r.stopped_early_share, 3),
         _number(r.switches_mean, 3), _number(r.reverse_switches_mean, 3), _number(r.fun_median, 6)]
        for r in traces.itertuples()
    ]  # fmt: skip
    header = ["optimizer", "runs", "evals/run", "stopped early", "switches/run", "reverse/run", "median J"]
    return ["## Evaluations and the optimisers' state machines", "", markdown_table(header, body, ["l", "r", "r", "r", "r", "r", "r"]), ""]



def write_fixed_target(
    store_path: str | Path | ResultTables, out_dir: str | Path, *, reference: str = "ihpso", command: str = ""
) -> list[Path]:
    """Write a scenario's fixed-target page and its tables, per scenario whose window runs the store holds.

    Per scenario: ``<stem>-fixed-target.md`` (the page), ``<stem>-fixed-target.csv`` (ERT per
    optimiser and target precision, :func:`ert_table`), ``<stem>-fixed-target-paired.csv`` (the
    paired fixed-budget and fixed-target comparisons, :func:`paired_table`; absent when no other
    optimiser shares a (window, seed) with the reference) and ``<stem>-fixed-target-traces.csv``
    (evaluations and state machines per optimiser, :func:`trace_table`), so every number on the page
    is also a row a script can read.

    The stem is the scenario's leaderboard stem (:func:`~.leaderboard.scenario_groups`), or its
    sanitised name when the store has no episodes of that scenario hash.

    Args:
        store_path: the SQLite results store, or its row tables (:func:`~.rows.read_rows`).
        out_dir: output folder (created if needed).
        reference: the optimiser the others are paired with (default IHPSO; the first name if absent).
        command: the command line recorded in the page.

    Returns:
        The written paths (per scenario, sorted by stem: the Markdown, then the ERT, paired and
        traces CSVs); none without window runs.
    """
    from uav_penetration_env.atomic import write_text_atomic
    from uav_penetration_env.benchmark.leaderboard.groups import sanitize, scenario_groups
    from uav_penetration_env.benchmark.safe_text import write_csv_table

    out_dir = Path(out_dir)
    tables = store_path if isinstance(store_path, ResultTables) else store_tables(store_path)
    rows, episodes = tables.window_runs, tables.episodes
    written: list[Path] = []
    if rows.empty:
        return written
    stems = {group.scenario_hash: group.stem for group in scenario_groups(episodes)}
    by_stem = sorted(
        (stems.get(h) or sanitize(str(group["scenario"].iloc[0])), group)
        for h, group in rows.groupby("scenario_hash")
    )
    out_dir.mkdir(parents=True, exist_ok=True)
    date = dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat()
    for stem, group in by_stem:
        markdown, csv_tables = fixed_target_markdown(
            group, reference, str(group["scenario"].iloc[0]), command, date
        )
        written.append(write_text_atomic(out_dir / f"{stem}-fixed-target.md", markdown))
        for suffix, frame in csv_tables.items():
            if frame.empty:
                continue
            # whole or not at all, formula-like names neutralised (api.md §4.7)
            written.append(write_csv_table(frame, out_dir / f"{stem}-fixed-target{suffix}.csv"))
    return written
