"""Print the tables behind the published findings, read from the leaderboard's CSV tables alone.

The results page (docs/results.md, written by ``benchmarks/results_page.py``, which embeds these
tables) answers four questions from the leaderboard: does IHPSO beat the other PSO variants; with how many evaluations relative to HPSO (the paper's
78 % claim); how far each family is from the best known; where RL stands against the swarm planners
on cost and on decision time; plus what the frozen suite shows by difficulty, and what the
regeneration cost. This script prints every one of those numbers from the CSV tables of a
leaderboard folder (the published ``leaderboards/`` or the folder ``uav-bench leaderboard --rows``
rebuilds from the committed rows), so the headline can be checked line by line against a rebuild.

It reads, when present:

- the scenario tables ``<stem>.csv`` (default stems: the paper scenario in both weightings, the
  suite and its three difficulty levels, the held-out suite ``uavpen-heldout-v1``; ``--tables``
  to choose others);
- their RL tables ``<stem>-rl.csv``;
- every fixed-target study in the folder: ``<stem>-fixed-target.csv`` (ERT),
  ``-fixed-target-windows.csv`` (``-fixed-target-paired.csv`` in v2 and v3) and ``-fixed-target-traces.csv``;
- ``compute.jsonl``, the publication driver's log of every attempt, with the exported rows
  (``rows/leaderboard-*``) and the RL programme's snapshot (``rl/``) for its compute table
  (docs/publishing.md §2).

Usage: ``python benchmarks/headline.py [DIR] [--tables STEM ...]`` (DIR defaults to leaderboards).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from uav_penetration_env.benchmark.families import FAMILIES, PAPER_PLANNERS, policy_family
from uav_penetration_env.benchmark.publishing import repository

ROOT = repository()

TABLES = (
    "paper-2022-sec5",
    "paper-2022-sec5-w2",
    "uavpen-v1",
    "uavpen-v1-d0.25",
    "uavpen-v1-d0.50",
    "uavpen-v1-d0.75",
    "uavpen-heldout-v1",
)
PSO_VARIANTS = (*PAPER_PLANNERS, "pso")
REFERENCE = "ihpso"
BASELINE = "hpso"  # the paper's claim: IHPSO needs 78 % of HPSO's iterations


def number(value: float, digits: int = 3) -> str:
    """``value`` with ``digits`` significant digits; ``-`` for a missing value."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if math.isinf(value):
        return "∞" if value > 0 else "-∞"
    if abs(value) >= 10 ** digits:  # 10000 evaluations, not 1e+04
        return f"{value:.0f}"
    return f"{value:.{digits}g}"


def pvalue(value: float) -> str:
    """A p-value as printed: 3 significant digits, ``-`` when missing."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return "<0.001" if value < 0.001 else f"{value:.2g}"


def percent(value: float, digits: int = 3) -> str:
    """A fraction as a percentage of ``digits`` significant digits, ``-`` when missing."""
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{100 * value:.{digits}g}%"


def markdown(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A Markdown table of ``header`` and ``rows`` (strings)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def partial(table: pd.DataFrame, name: str) -> str:
    """``*`` when ``name`` finished fewer members of a suite table than the table's most (else ``""``).

    Such a policy's means cover other members than the rest (a policy flown on the paper members
    only, in the whole-suite table): the mark keeps it from being read as a suite-wide result.
    """
    if "members" not in table or name not in table.index:
        return ""
    return "*" if table.loc[name, "members"] < table["members"].max() else ""


PARTIAL_NOTE = "`*`: the policy finished fewer of the suite's members than the table's others (its mean covers other members)."


def read_tables(folder: Path, stems: Sequence[str]) -> dict[str, pd.DataFrame]:
    """The scenario tables of ``stems`` that exist, indexed by policy."""
    return {stem: pd.read_csv(folder / f"{stem}.csv").set_index("policy") for stem in stems if (folder / f"{stem}.csv").is_file()}


def pso_section(tables: dict[str, pd.DataFrame]) -> list[str]:
    """Mean total J, rank and the paired difference to IHPSO of each PSO variant, per table."""
    rows = []
    for name in PSO_VARIANTS:
        cells = [name]
        for table in tables.values():
            if name not in table.index:
                cells.append("-")
                continue
            r = table.loc[name]
            cell = (f"{number(r['total_cost_mean'], 4)}{partial(table, name)}, IQM {number(r['total_cost_iqm'], 4)} "
                    f"(rank {number(r['friedman_rank'], 3)}")  # fmt: skip
            if name != REFERENCE and not math.isnan(r["delta_mean"]):
                cell += f"; Δ {number(r['delta_mean'], 2)}, p {pvalue(r['pvalue_holm'])}"
            cells.append(cell + ")")
        rows.append(cells)
    best = ["best policy"]
    for table in tables.values():
        winner = table["total_cost_mean"].idxmin()
        best.append(f"{winner} {number(table.loc[winner, 'total_cost_mean'], 4)} (of {len(table)})")
    rows.append(best)
    return [
        "## 1. IHPSO against the other PSO variants",
        "",
        "Mean and IQM of total J (incl. the failure penalty), Friedman rank among every policy of the table, and the "
        f"paired difference to {REFERENCE} (Δ = policy − {REFERENCE}, Holm-corrected Wilcoxon p).",
        "",
        markdown(["policy", *tables], rows),
        "",
        PARTIAL_NOTE,
        "",
    ]


def evaluations_section(tables: dict[str, pd.DataFrame], folder: Path) -> list[str]:
    """IHPSO's evaluations against HPSO's: in the episodes, and in every fixed-target study."""
    lines = ["## 2. IHPSO's evaluations against HPSO's (the paper's 78 % claim)", ""]
    rows = []
    for stem, table in tables.items():
        if REFERENCE in table.index and BASELINE in table.index:
            r, base = table.loc[REFERENCE], table.loc[BASELINE]
            # Tables written before the state-machine columns existed (version 1) lack them: "-".
            rows.append([stem, number(r["nfev_per_step"], 4), number(base["nfev_per_step"], 4),
                         percent(r["nfev_per_step"] / base["nfev_per_step"]), percent(r.get("stopped_early_share")),
                         number(r.get("switches_per_step")), number(r.get("reverse_switches_per_step"))])  # fmt: skip
    if rows:
        lines += ["Episodes (per MPC step):", ""]
        header = ["table", f"{REFERENCE} evals", f"{BASELINE} evals", "ratio", "stopped early", "switches", "reverse"]
        lines += [markdown(header, rows), ""]
    for traces_path in sorted(folder.glob("*-fixed-target-traces.csv")):
        stem = traces_path.name.removesuffix("-fixed-target-traces.csv")
        traces = pd.read_csv(traces_path).set_index("optimizer")
        if REFERENCE not in traces.index:
            continue
        lines += [f"Window study `{stem}` (fixed-target pages, api.md §4.8):", ""]
        base_evals = traces.loc[BASELINE, "nfev_mean"] if BASELINE in traces.index else math.nan
        rows = [
            [name, str(int(r["runs"])), number(r["nfev_mean"], 4), percent(r["nfev_mean"] / base_evals),
             percent(r["stopped_early_share"]), number(r["switches_mean"]), number(r["reverse_switches_mean"]),
             number(r["fun_median"], 6)]
            for name, r in traces.iterrows()
        ]  # fmt: skip
        header = ["optimizer", "runs", "evals/run", f"of {BASELINE}'s", "stopped early", "switches/run",
                  "reverse/run", "median J"]  # fmt: skip
        lines += [markdown(header, rows), ""]
        windows_path = folder / f"{stem}-fixed-target-windows.csv"
        paired_path = folder / f"{stem}-fixed-target-paired.csv"  # v2 and v3: the retired pairing
        if windows_path.is_file():
            compared = pd.read_csv(windows_path)
            for r in compared[compared["other"] == BASELINE].itertuples():
                target = f" Δ={r.precision:g}" if r.comparison.startswith("fixed target") else ""
                lines.append(f"- {r.comparison}{target}, {r.other} vs {r.reference}: median {number(r.median, 4)} "
                             f"[{number(r.ci_low, 4)}, {number(r.ci_high, 4)}] over {r.units} windows, {r.other} "
                             f"better on {r.other_better} and {r.reference} on {r.reference_better}, p {pvalue(r.pvalue)}")  # fmt: skip
        elif paired_path.is_file():
            paired = pd.read_csv(paired_path)
            paired = paired[paired["other"] == BASELINE]
            for r in paired.itertuples():
                lines.append(f"- {r.comparison}, {r.reference} vs {r.other}: medians {number(r.reference_median, 6)} vs "
                             f"{number(r.other_median, 6)}, {r.reference} better in {r.reference_better} and "
                             f"{r.other} in {r.other_better} of {r.pairs} pairs, p {pvalue(r.pvalue)}")  # fmt: skip
        ert_path = folder / f"{stem}-fixed-target.csv"
        if ert_path.is_file():
            ert = pd.read_csv(ert_path)
            ert = ert[ert["optimizer"].isin([REFERENCE, BASELINE])]
            for precision, group in ert.groupby("precision", sort=False):
                cells = [f"{r.optimizer} {r.successes}/{r.runs} (ERT {number(r.ert, 4)})" for r in group.itertuples()]
                lines.append(f"- target f* + {precision:g}|f*|: " + ", ".join(cells))
        lines.append("")
    return lines


def gap_section(tables: dict[str, pd.DataFrame]) -> list[str]:
    """Per family and table: the member closest to the best known, and the family's median gap (IQM)."""
    header = "## 3. Distance from the best known, per family"
    if not any("gap_iqm" in table for table in tables.values()):
        return [header, "", "No best-known record covers these tables (docs/best-known.md).", ""]
    rows = []
    for family in FAMILIES:
        cells = [family]
        for table in tables.values():
            if "gap_iqm" not in table:
                cells.append("-")
                continue
            members = table[[policy_family(str(p)) == family for p in table.index]]["gap_iqm"].dropna()
            if members.empty:
                cells.append("-")
                continue
            closest = members.idxmin()
            mark = partial(table, closest)
            cells.append(f"{closest}{mark} {percent(members[closest])}; median {percent(members.median())}")
        if any(cell != "-" for cell in cells[1:]):  # a family no table holds gets no row
            rows.append(cells)
    return [
        header,
        "",
        "Gap to the best-known total J (IQM over episodes; docs/best-known.md): the family's closest member "
        "and the median over its members.",
        "",
        markdown(["family", *tables], rows),
        "",
        PARTIAL_NOTE,
        "",
    ]


def rl_section(folder: Path, stems: Sequence[str]) -> list[str]:
    """Every RL group's IQM, its paired difference to greedy, its probabilities of improvement and decision time."""
    lines = ["## 4. RL agents against the swarm planners", ""]
    found = False
    for stem in stems:
        path = folder / f"{stem}-rl.csv"
        if not path.is_file():
            continue
        found = True
        table = pd.read_csv(path)
        references = table[table["kind"] == "reference"]
        planner = references[references["group"] != "greedy"]
        planner_seconds = float(planner["decision_seconds"].iloc[0]) if len(planner) else math.nan
        def delta(r) -> str:  # tables written before the column existed lack it
            if not hasattr(r, "delta_greedy"):
                return "-"
            return f"{number(r.delta_greedy, 3)} [{number(r.delta_greedy_ci_low, 3)}, {number(r.delta_greedy_ci_high, 3)}]"

        rows = [
            [str(r.group), str(r.kind), str(r.runs), f"{number(r.iqm, 4)} [{number(r.iqm_ci_low, 4)}, {number(r.iqm_ci_high, 4)}]",
             number(r.mean, 4), delta(r), number(r.poi_greedy, 2), number(r.poi_planner, 2), number(r.decision_seconds, 3),
             number(planner_seconds / r.decision_seconds, 3) if r.decision_seconds else "-"]
            for r in table.itertuples()
        ]  # fmt: skip
        header = ["group", "kind", "runs", "IQM [95% CI]", "mean", "Δ vs greedy [95% CI]", "P(better than greedy)",
                  "P(better than best planner)", "decision [s/step]", "planner's time / this"]  # fmt: skip
        lines += [f"`{stem}` (best planner: {planner['group'].iloc[0] if len(planner) else '-'}):", "",
                  markdown(header, rows), ""]  # fmt: skip
    if not found:
        lines += ["No RL table in this folder.", ""]
    return lines


def suite_section(tables: dict[str, pd.DataFrame]) -> list[str]:
    """Per difficulty level: success, the cheapest policy, IHPSO's rank, the floors' gaps."""
    levels = {stem: table for stem, table in tables.items() if stem.startswith("uavpen-v1-d0.")}
    if not levels:
        return []
    rows = []
    for stem, table in levels.items():
        winner = table["total_cost_mean"].idxmin()
        ihpso = table.loc[REFERENCE] if REFERENCE in table.index else None
        greedy = table.loc["greedy"] if "greedy" in table.index else None
        planners = table[[policy_family(str(p)).endswith("(MPC)") for p in table.index]]
        rows.append([
            stem, str(int(table["members"].max())) if "members" in table else "-",
            f"{winner} {number(table.loc[winner, 'total_cost_mean'], 4)}",
            "-" if ihpso is None else f"{number(ihpso['friedman_rank'], 3)} of {len(table)}",
            f"{percent(planners['success_rate'].min())}-{percent(planners['success_rate'].max())}",
            "-" if greedy is None else percent(greedy.get("gap_iqm")),
        ])  # fmt: skip
    header = ["level", "members", "cheapest (mean total J)", "IHPSO rank", "MPC success range", "greedy gap (IQM)"]
    return ["## 5. The frozen suite by difficulty", "", markdown(header, rows), ""]


def compute_section(folder: Path) -> list[str]:
    """The campaign's compute table (docs/publishing.md §2) from the folder's log and rows.

    The campaign is v3's (``leaderboards/campaigns/v3.yaml``) when the log has its terminal-cost
    part, else v2's: its parts' order and the training it publishes.
    """
    log = folder / "compute.jsonl"
    if not log.is_file():
        return []
    from uav_penetration_env.benchmark.campaign.carry import MANIFEST
    from uav_penetration_env.benchmark.campaign.compute import compute_table, worker_seconds
    from uav_penetration_env.benchmark.campaign.log import read_log
    from uav_penetration_env.benchmark.campaign.spec import load_campaign_file
    from uav_penetration_env.benchmark.rows import read_chunks

    # The rows the compute is read from: an export in the folder (v2, a rebuilt folder), else the
    # publication's committed checkpoint beside it (v3: leaderboards/v3 -> leaderboards/v3-checkpoint).
    exported, checkpoint = folder / "rows" / "leaderboard", folder.with_name(f"{folder.name}-checkpoint")
    worker = {}
    if exported.with_name("leaderboard-runs.parquet").is_file():
        worker = worker_seconds(read_chunks([exported]))
    elif (checkpoint / MANIFEST).is_file():
        worker = worker_seconds(read_chunks([checkpoint]))
    attempts = read_log(log)
    # v3's log has its terminal-cost part, and v3 publishes the distilled planners (publishing.md §5.1).
    v3 = any(a.get("part") == "ctg-sensitivity" for a in attempts)
    spec = load_campaign_file(ROOT / "leaderboards" / "campaigns" / ("v3.yaml" if v3 else "v2.yaml"))
    rl_root = folder / "rl" if (folder / "rl").is_dir() else folder.parent / "rl"
    distill = spec.compute.distill_root
    table = compute_table(attempts, spec.order, worker, rl_root=rl_root,
                          distill_root=ROOT / distill if distill is not None else None,
                          distill_names=spec.compute.distill_names)  # v3's own networks, not those trained since  # fmt: skip
    return ["## 6. Compute of the regeneration", "", table, ""]


def headline(folder: Path, stems: Sequence[str] = TABLES) -> str:
    """The headline numbers of the leaderboard folder ``folder`` as Markdown.

    Raises:
        SystemExit: ``folder`` holds none of the scenario tables ``stems``.
    """
    tables = read_tables(folder, stems)
    if not tables:
        raise SystemExit(f"{folder}: none of the tables {', '.join(f'{s}.csv' for s in stems)}; "
                         "expected a leaderboard folder (leaderboards/ or the output of uav-bench leaderboard)")  # fmt: skip
    lines = [f"# Headline numbers from `{folder}`", ""]
    lines += pso_section(tables)
    lines += evaluations_section(tables, folder)
    lines += gap_section(tables)
    lines += rl_section(folder, list(tables))
    lines += suite_section(tables)
    lines += compute_section(folder)
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """Print the headline numbers of a leaderboard folder."""
    parser = argparse.ArgumentParser(prog="python benchmarks/headline.py", description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", default=str(ROOT / "leaderboards"), help="leaderboard folder")
    parser.add_argument("--tables", nargs="+", default=TABLES, metavar="STEM", help="scenario tables to read")
    args = parser.parse_args(argv)
    print(headline(Path(args.folder), args.tables))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
