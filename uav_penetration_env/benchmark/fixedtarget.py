"""Fixed-target and fixed-budget comparison of optimisers on identical MPC windows (api.md §4.8).

The COCO view of "fewer iterations": on each window (a stored MPC state, ``window_runs`` rows of
``uav-bench windows``) the reference cost f_best is the best cost any run of any optimiser found,
at any budget (:func:`window_best`); the targets are f_best + Δ·|f_best| (:data:`TARGET_PRECISIONS`). A run's *runtime* for a target is the number
of evaluations at the first ``history`` entry at or below it (from ``history_nfev``), infinite if it
never got there. Per optimiser and target:

* the expected running time ERT = (Σ runtimes of the successful runs + Σ ``nfev`` of the others) /
  successes (Hansen et al., COCO; infinite without a success), :func:`ert`;
* the runtime ECDF: the share of (run, target) pairs solved within x evaluations,
  :func:`runtime_ecdf`, which ends at the success share.

Each other optimiser against a reference (IHPSO by default), with the window as the unit of
replication (:func:`window_comparisons`): the per-window log10 ERT ratio at each target and the
per-window fixed-budget J difference, each summarised by its median over windows, a bootstrap
interval over windows and the Wilcoxon signed-rank test over windows. The targets come from every
run on the window (a dedicated long search included), never from the compared pair alone; the
retired v2/v3 rule (the worse of a pair's two finals) lives in :mod:`~.fixedtarget_retired`.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark import stats
from uav_penetration_env.benchmark.rows import ResultTables, store_tables
from uav_penetration_env.benchmark.runtimes import (
    WINDOW_KEY,
    _number,
    _parsed,
    ert,
    runtime_ecdf,
    runtime_to_target,
    value_at_budget,
)

TARGET_PRECISIONS = (1e-1, 1e-2, 1e-3, 1e-4)  # Δ: targets f_best + Δ |f_best| (DECISION api.md §4.8)
def window_best(rows: pd.DataFrame) -> pd.Series:
    """f_best per window: the best ``fun`` any run of any optimiser, at any budget, found on it.

    A dedicated long search (``uav-bench windows --optimizers cma-es --max-evals 200000`` on the
    same windows) lowers it for every optimiser alike, so no compared pair sets its own targets.

    Returns:
        Indexed by :data:`WINDOW_KEY`.
    """
    return pd.to_numeric(rows["fun"]).astype(np.float64).groupby([rows[k] for k in WINDOW_KEY]).min()


def compared_runs(rows: pd.DataFrame, reference: str) -> tuple[pd.DataFrame, int]:
    """The runs a study compares: those at the reference's budget (``max_evals``), and that budget.

    DECISION (api.md §4.8): runs at any other budget (a long search for f_best, a longer study)
    enter f_best only; the compared optimisers share one budget, so an ERT is never pooled over
    runs that could spend different amounts. Without the reference, the most common budget.
    """
    budgets = pd.to_numeric(rows["max_evals"]).astype(np.int64)
    mine = budgets[rows["optimizer"] == reference]
    if rows.empty:
        return rows, 0
    budget = int((mine if not mine.empty else budgets).mode().min())
    return rows[budgets == budget], budget


def target_runs(
    rows: pd.DataFrame, precisions: Sequence[float] = TARGET_PRECISIONS, *, f_best: pd.Series | None = None
) -> pd.DataFrame:
    """The runtime of every window run for every target.

    One row per (window run, target): ``optimizer``, the window key, ``seed``, ``precision``,
    ``target``, ``runtime`` (``inf``: not reached) and ``nfev``.

    Args:
        rows: ``window_runs`` rows (one scenario, one budget).
        precisions: the Δ of the targets f_best + Δ|f_best|.
        f_best: per window (:func:`window_best`), when it comes from more runs than ``rows`` (a
            long search); default: the best ``fun`` of the window over ``rows``.
    """
    frame = _parsed(rows)
    best = (window_best(frame) if f_best is None else f_best).rename("f_best")
    keyed = frame.join(best, on=WINDOW_KEY)
    out = []
    for run in keyed.itertuples(index=False):
        for precision in precisions:
            target = run.f_best + precision * abs(run.f_best)
            out.append(
                {
                    "optimizer": run.optimizer,
                    **{key: getattr(run, key) for key in WINDOW_KEY},
                    "seed": int(run.seed),
                    "precision": precision,
                    "target": target,
                    "runtime": runtime_to_target(run.history, run.history_nfev, target),
                    "nfev": run.nfev,
                }
            )
    return pd.DataFrame(out)


def window_ert_table(targets: pd.DataFrame) -> pd.DataFrame:
    """ERT per (optimiser, window, target precision) over the window's seeds, from :func:`target_runs`.

    Returns:
        Columns ``optimizer``, the window key, ``precision``, ``runs``, ``successes``, ``ert``.
    """
    rows = []
    for key, group in targets.groupby(["optimizer", *WINDOW_KEY, "precision"], sort=True):
        rows.append(
            {
                **dict(zip(["optimizer", *WINDOW_KEY, "precision"], key, strict=True)),
                "runs": len(group),
                "successes": int(np.isfinite(group["runtime"]).sum()),
                "ert": ert(group["runtime"], group["nfev"]),
            }
        )
    return pd.DataFrame(rows)


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


def window_comparisons(
    rows: pd.DataFrame,
    reference: str,
    precisions: Sequence[float] = TARGET_PRECISIONS,
    *,
    f_best: pd.Series | None = None,
    seed: int = 0,
    n_resamples: int = 10_000,
) -> pd.DataFrame:
    """Every other optimiser against ``reference`` with windows as the unit of replication (api.md §4.8).

    Per window (a stored MPC state, every seed of it pooled):

    * fixed target, per Δ: d = log10(ERT_other / ERT_ref) at the target f_best + Δ|f_best| of the
      window (:func:`window_ert_table`); ``+inf`` when only the reference reached it, ``-inf`` when
      only the other did, undefined (left out, counted) when neither did;
    * fixed budget: d = the mean over seeds of the other's best-so-far J at the reference run's
      evaluation count of the same seed, minus the reference's final J.

    Each set of per-window values is summarised by :func:`~..stats.unit_comparison`: the median
    over windows with its percentile-bootstrap interval (resampling windows) and the two-sided
    Wilcoxon signed-rank test over windows. The p values are raw: the correction belongs to the
    family a publication's protocol declares (docs/publishing.md §6).

    Args:
        rows: ``window_runs`` rows of one scenario (every budget: runs at another budget than the
            reference's, e.g. a dedicated long search, only lower f_best).
        reference: the optimiser the others are compared with.
        precisions: the Δ of the targets.
        f_best: per window (:func:`window_best`), when more runs than ``rows`` set it (default:
            every row of ``rows``).
        seed: the bootstraps' base seed (each comparison draws from :func:`~..stats.label_seed`).
        n_resamples: bootstrap resamples.

    Returns:
        One row per (other, comparison, Δ): ``reference``, ``other``, ``comparison`` (``fixed
        target: log10 ERT ratio`` or ``fixed budget: J``), ``precision`` (NaN for the budget),
        ``budget``, then :func:`~..stats.unit_comparison`'s columns (``units`` = windows,
        ``median``, ``ci_low``, ``ci_high``, ``other_better``, ``reference_better``,
        ``undefined``, ``statistic``, ``pvalue``). Empty when the reference has no rows.
    """
    frame = _parsed(rows)
    compared, budget = compared_runs(frame, reference)
    if compared.empty:
        return pd.DataFrame(columns=COMPARISON_COLUMNS)
    best = window_best(frame) if f_best is None else f_best
    per_window = window_ert_table(target_runs(compared, precisions, f_best=best))
    ert = per_window.set_index(["optimizer", *WINDOW_KEY, "precision"])["ert"]
    out = []
    for other in sorted(set(compared["optimizer"]) - {reference}):
        windows = _shared_windows(compared, reference, other)
        if not windows:
            continue
        for precision in precisions:
            mine = np.array([ert.loc[(other, *w, precision)] for w in windows])
            theirs = np.array([ert.loc[(reference, *w, precision)] for w in windows])
            label = f"{reference}|{other}|target|{precision!r}"
            summary = stats.unit_comparison(
                _log_ratio(mine, theirs), seed=stats.label_seed(seed, label, 20), n_resamples=n_resamples
            )
            out.append(_comparison_row(reference, other, FIXED_TARGET, precision, budget, summary))
        differences = _budget_differences(compared, reference, other, windows)
        summary = stats.unit_comparison(
            differences, seed=stats.label_seed(seed, f"{reference}|{other}|budget", 21), n_resamples=n_resamples
        )
        out.append(_comparison_row(reference, other, FIXED_BUDGET, math.nan, budget, summary))
    return pd.DataFrame(out, columns=COMPARISON_COLUMNS)


FIXED_TARGET = "fixed target: log10 ERT ratio"
FIXED_BUDGET = "fixed budget: J"
COMPARISON_COLUMNS = [
    "reference", "other", "comparison", "precision", "budget", "units", "median", "ci_low", "ci_high",
    "other_better", "reference_better", "undefined", "statistic", "pvalue",
]  # fmt: skip


def _comparison_row(
    reference: str, other: str, comparison: str, precision: float, budget: int, summary: dict[str, float]
) -> dict[str, Any]:
    return {
        "reference": reference, "other": other, "comparison": comparison, "precision": precision,
        "budget": budget, **summary,
    }  # fmt: skip


def _log_ratio(mine: np.ndarray, theirs: np.ndarray) -> np.ndarray:
    """log10(mine / theirs) over the extended reals; NaN where both are infinite (neither solved)."""
    out = np.full(mine.shape, np.nan)
    both = np.isfinite(mine) & np.isfinite(theirs)
    out[both] = np.log10(mine[both] / theirs[both])
    out[np.isinf(mine) & np.isfinite(theirs)] = math.inf  # only the reference solved: the other is slower
    out[np.isfinite(mine) & np.isinf(theirs)] = -math.inf
    return out


def _shared_windows(frame: pd.DataFrame, reference: str, other: str) -> list[tuple[Any, ...]]:
    """The windows both optimisers ran on, in a fixed order."""
    keys = [
        set(map(tuple, frame.loc[frame["optimizer"] == name, WINDOW_KEY].itertuples(index=False)))
        for name in (reference, other)
    ]
    return sorted(keys[0] & keys[1])


def _budget_differences(
    frame: pd.DataFrame, reference: str, other: str, windows: list[tuple[Any, ...]]
) -> np.ndarray:
    """Per window: mean over shared seeds of (other's J at the reference run's nfev − reference's final J)."""
    keyed = frame.set_index([*WINDOW_KEY, "seed"])
    ref, mine = keyed[keyed["optimizer"] == reference], keyed[keyed["optimizer"] == other]
    out = []
    for window in windows:
        a, b = ref.loc[window], mine.loc[window]
        seeds = a.index.intersection(b.index)
        gaps = [
            value_at_budget(b.loc[s, "history"], b.loc[s, "history_nfev"], a.loc[s, "nfev"]) - a.loc[s, "fun"]
            for s in seeds
        ]
        out.append(float(np.mean(gaps)) if gaps else math.nan)
    return np.asarray(out, dtype=np.float64)


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


FIXED_TARGET_RULES = ("coco", "worse-final")  # the default first; worse-final: v2/v3 only (fixedtarget_retired)


def _comparisons(rows: pd.DataFrame, reference: str, rule: str) -> pd.DataFrame:
    """The comparison rows of ``rule``: :func:`window_comparisons`, or the retired pairing."""
    if rule not in FIXED_TARGET_RULES:
        raise ValueError(f"rule: got {rule!r}, expected one of {', '.join(FIXED_TARGET_RULES)}")
    if rule == "worse-final":
        from uav_penetration_env.benchmark.fixedtarget_retired import paired_table

        return paired_table(rows, reference)
    return window_comparisons(rows, reference)


def _study(rows: pd.DataFrame, reference: str) -> tuple[str, pd.DataFrame, pd.DataFrame]:
    """The reference used, the pooled ERT table and the trace table of the compared runs."""
    ref = reference if reference in set(rows["optimizer"]) else sorted(set(rows["optimizer"]))[0]
    frame = _parsed(rows)
    compared, _ = compared_runs(frame, ref)
    table = ert_table(target_runs(compared, f_best=window_best(frame)), ref)
    return ref, table, trace_table(compared)


def fixed_target_frames(
    rows: pd.DataFrame, reference: str, rule: str = "coco"
) -> tuple[str, dict[str, pd.DataFrame]]:
    """The three tables of one scenario's window runs, formatted for display (the HTML report).

    The content of :func:`fixed_target_markdown`'s tables: the ERT per target precision, the
    comparisons with the reference (windows as units, or the retired pairing) and the evaluations
    and state machines per optimiser.

    Args:
        rows: the scenario's ``window_runs`` rows.
        reference: the optimiser the others are compared with (the first name if it has no rows).
        rule: ``coco`` (default) or ``worse-final`` (:data:`FIXED_TARGET_RULES`).

    Returns:
        (the reference used, {title: DataFrame of display strings}); the comparison table is empty
        when no other optimiser shares a window with the reference.
    """
    ref, ert, traces = _study(rows, reference)
    comparisons = _comparisons(rows, ref, rule)
    ert_frame = pd.DataFrame(
        {
            "Δ": [f"{value:.0e}" for value in ert["precision"]],
            "optimizer": ert["optimizer"].astype(str),
            "solved": [f"{s}/{r}" for s, r in zip(ert["successes"], ert["runs"], strict=True)],
            "ERT [evals]": [_number(value) for value in ert["ert"]],
            f"ERT / {ref}": [_number(value, 3) for value in ert["ert_ratio"]],
        }
    )
    if rule == "worse-final":
        from uav_penetration_env.benchmark.fixedtarget_retired import paired_frame

        title, compared = f"Paired per (window, seed) against {ref}", paired_frame(comparisons, ref)
    else:
        title, compared = f"Windows as units, against {ref}", _comparison_frame(comparisons, ref)
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
        title: compared,
        "Evaluations and the optimisers' state machines": trace_frame,
    }


def _comparison_cells(r: Any) -> list[str]:
    """One comparison row's display cells (:data:`COMPARISON_HEADER`)."""
    from uav_penetration_env.benchmark.leaderboard.formatting import format_pvalue

    what = f"fixed target Δ={r.precision:.0e}" if r.comparison == FIXED_TARGET else "fixed budget"
    statistic = "log10 ERT ratio" if r.comparison == FIXED_TARGET else "J at ref's evaluations − ref's J"
    return [
        what, str(r.other), statistic, _number(r.median, 4), f"[{_number(r.ci_low, 4)}, {_number(r.ci_high, 4)}]",
        f"{r.other_better} / {r.reference_better} of {r.units}" + (f" ({r.undefined} unsolved by both)" if r.undefined else ""),
        format_pvalue(r.pvalue),
    ]  # fmt: skip


COMPARISON_HEADER = ["comparison", "other", "per-window statistic", "median", "95 % CI", "other better / ref better", "p"]


def _comparison_frame(comparisons: pd.DataFrame, ref: str) -> pd.DataFrame:
    return pd.DataFrame([_comparison_cells(r) for r in comparisons.itertuples()], columns=COMPARISON_HEADER)


def _comparison_lines(comparisons: pd.DataFrame, ref: str) -> list[str]:
    """The windows-as-units section (none without a shared window)."""
    from uav_penetration_env.benchmark.leaderboard.formatting import markdown_section

    if comparisons.empty:
        return []
    text = (
        "Each window (one MPC state, all its seeds) is one unit of replication. Fixed target: per window, "
        f"log10(ERT of the other / ERT of {ref}) at f_best + Δ|f_best| (+∞: only {ref} reached it, −∞: only the "
        "other; a window neither reached is left out and counted). Fixed budget: per window, the mean over seeds "
        f"of the other's best-so-far J at {ref}'s evaluation count of the same seed, minus {ref}'s final J. "
        "Median over windows, percentile-bootstrap 95 % interval over windows, two-sided Wilcoxon signed-rank "
        "test over windows; p values are raw (a publication's protocol declares its family and correction). "
        "Negative: the other is faster / cheaper."
    )
    body = [_comparison_cells(r) for r in comparisons.itertuples()]
    align = ["l", "l", "l", "r", "r", "r", "r"]
    return markdown_section(f"Windows as units, against {ref}", text, COMPARISON_HEADER, body, align)


def fixed_target_markdown(
    rows: pd.DataFrame, reference: str, name: str, command: str, date: str = "", rule: str = "coco"
) -> tuple[str, dict[str, pd.DataFrame]]:
    """The Markdown page and the CSV tables of one scenario's window runs.

    Args:
        rows: the scenario's ``window_runs`` rows.
        reference: the optimiser the others are compared with (the first name if it has no rows).
        name: the scenario's name (the page's title).
        command: the command line recorded in the page.
        date: the page's date.
        rule: ``coco`` (default: targets per window, windows as units) or ``worse-final`` (the
            retired pairing of v2 and v3, :mod:`~.fixedtarget_retired`).

    Returns:
        (the page, {CSV file suffix: table}): ``""`` the pooled ERT rows (:func:`ert_table`); under
        ``coco`` ``"-windows"`` the comparisons (:func:`window_comparisons`) and ``"-window-ert"``
        the ERT per (optimiser, window, Δ) (:func:`window_ert_table`); under ``worse-final``
        ``"-paired"``; and ``"-traces"`` the evaluations and state machines (:func:`trace_table`).
        A comparison table is empty without a shared window.

    The page's date line (``- Date: DATE, by `COMMAND```) is its only line that depends on when and
    from which source (store or exported rows) it was built.
    """
    ref, table, traces = _study(rows, reference)
    comparisons = _comparisons(rows, ref, rule)
    windows = rows.drop_duplicates(WINDOW_KEY)
    budgets = sorted(set(pd.to_numeric(rows["max_evals"]).astype(int)))
    best = "f*" if rule == "worse-final" else "f_best"
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
        f"## Expected running time (ERT) to the targets {best} + Δ|{best}|",
        "",
        f"{best} is the best cost any run found on the window"
        + ("" if rule == "worse-final" else " (every optimiser and budget, long searches included)")
        + ". ERT = (evaluations of the successful runs to the "
        "target + evaluations of the unsuccessful runs) / successes, over every window and seed; ∞: no run "
        f"reached it. Ratio: ERT / {ref}'s ERT.",
        "",
    ]
    if rule == "worse-final":
        from uav_penetration_env.benchmark.fixedtarget_retired import paired_lines

        lines += _ert_lines(table) + paired_lines(comparisons, ref) + _trace_lines(traces)
        return "\n".join(lines), {"": table, "-paired": comparisons, "-traces": traces}
    frame = _parsed(rows)
    compared, _ = compared_runs(frame, ref)
    per_window = window_ert_table(target_runs(compared, f_best=window_best(frame)))
    lines += _ert_lines(table) + _comparison_lines(comparisons, ref) + _trace_lines(traces)
    return "\n".join(lines), {"": table, "-windows": comparisons, "-window-ert": per_window, "-traces": traces}


def _ert_lines(table: pd.DataFrame) -> list[str]:
    """The ERT table's Markdown (its heading and explanation precede it on the page)."""
    from uav_penetration_env.benchmark.leaderboard.formatting import markdown_table

    body = [
        [f"{row.precision:.0e}", str(row.optimizer), f"{row.successes}/{row.runs}", _number(row.ert), _number(row.ert_ratio, 3)]
        for row in table.itertuples()
    ]
    return [markdown_table(["Δ", "optimizer", "solved", "ERT [evals]", "ratio"], body, ["r", "l", "r", "r", "r"]), ""]


def _trace_lines(traces: pd.DataFrame) -> list[str]:
    """The evaluations and state-machine section."""
    from uav_penetration_env.benchmark.leaderboard.formatting import markdown_section

    body = [
        [str(r.optimizer), str(r.runs), _number(r.nfev_mean), _number(r.stopped_early_share, 3),
         _number(r.switches_mean, 3), _number(r.reverse_switches_mean, 3), _number(r.fun_median, 6)]
        for r in traces.itertuples()
    ]  # fmt: skip
    header = ["optimizer", "runs", "evals/run", "stopped early", "switches/run", "reverse/run", "median J"]
    align = ["l", "r", "r", "r", "r", "r", "r"]
    return markdown_section("Evaluations and the optimisers' state machines", "", header, body, align)



def write_fixed_target(
    store_path: str | Path | ResultTables,
    out_dir: str | Path,
    *,
    reference: str = "ihpso",
    command: str = "",
    rule: str = "coco",
) -> list[Path]:
    """Write a scenario's fixed-target page and its tables, per scenario whose window runs the store holds.

    Per scenario: ``<stem>-fixed-target.md`` (the page), ``<stem>-fixed-target.csv`` (pooled ERT
    per optimiser and target precision, :func:`ert_table`), ``<stem>-fixed-target-windows.csv``
    (the comparisons with windows as units, :func:`window_comparisons`; absent when no other
    optimiser shares a window with the reference), ``<stem>-fixed-target-window-ert.csv`` (ERT per
    optimiser, window and Δ, :func:`window_ert_table`) and ``<stem>-fixed-target-traces.csv``
    (evaluations and state machines per optimiser, :func:`trace_table`), so every number on the page
    is also a row a script can read. Under ``rule="worse-final"`` (v2 and v3 only) the comparisons
    are the retired ``-fixed-target-paired.csv`` and there is no per-window ERT file.

    The stem is the scenario's leaderboard stem (:func:`~.leaderboard.scenario_groups`), or its
    sanitised name when the store has no episodes of that scenario hash.

    Args:
        store_path: the SQLite results store, or its row tables (:func:`~.rows.read_rows`).
        out_dir: output folder (created if needed).
        reference: the optimiser the others are paired with (default IHPSO; the first name if absent).
        command: the command line recorded in the page.
        rule: ``coco`` or ``worse-final`` (:data:`FIXED_TARGET_RULES`).

    Returns:
        The written paths (per scenario, sorted by stem: the Markdown, then the CSVs); none without
        window runs.
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
            group, reference, str(group["scenario"].iloc[0]), command, date, rule=rule
        )
        written.append(write_text_atomic(out_dir / f"{stem}-fixed-target.md", markdown))
        for suffix, frame in csv_tables.items():
            if frame.empty:
                continue
            # whole or not at all, formula-like names neutralised (api.md §4.7)
            written.append(write_csv_table(frame, out_dir / f"{stem}-fixed-target{suffix}.csv"))
    return written


__all__ = [
    "FIXED_BUDGET", "FIXED_TARGET", "FIXED_TARGET_RULES", "TARGET_PRECISIONS", "WINDOW_KEY", "compared_runs",
    "ert", "ert_table", "fixed_target_frames", "fixed_target_markdown", "runtime_ecdf", "runtime_to_target",
    "target_runs", "trace_table", "value_at_budget", "window_best", "window_comparisons", "window_ert_table",
    "write_fixed_target",
]  # fmt: skip
