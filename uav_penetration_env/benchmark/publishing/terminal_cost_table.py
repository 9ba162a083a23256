r"""The published terminal-cost sensitivity table (model.md §7e.4), written from committed episode rows.

Does a conclusion measure the planners or the terminal cost we chose for them? This script reads
the episodes of the terminal-cost studies (the paper scenario's 20 seeds and the suite, each flown
under every priced form) and writes, per part and form:

- each planner's episodes, success rate, mean and IQM total cost, and mean rank among the seven MPC
  planners (ranked within each scenario and seed that all seven flew);
- IHPSO against HPSO, paired: the mean of IHPSO - HPSO with a seeded 95 % bootstrap interval and
  a Wilcoxon signed-rank p. The unit of pairing is the seed on a one-scenario part and the
  scenario (its seeds' mean difference) on a many-scenario part, so members count equally;
- the conclusions, each checked under every form: "holds under every form" only if it does.

Policy names carry the form (``ihpso-ctg-dubins``); a bare planner name (``ihpso``) was flown with
the default form of its commit, given by ``--bare-form``.

Usage (the committed table):
    python benchmarks/terminal_cost_table.py \
        --part paper=leaderboards/ctg-sensitivity/paper-episodes.csv \
        --part suite=leaderboards/ctg-sensitivity/suite-value-rows/suite-value-4256938-episodes.parquet \
        --part suite=leaderboards/ctg-sensitivity/suite-forms-rows/suite-forms-4256938-episodes.parquet \
        --out /tmp/ctg-table && cp /tmp/ctg-table/* leaderboards/ctg-sensitivity/

From one store's exported rows (leaderboard v3, docs/publishing.md §5), where one episodes file
holds every scenario, ``--within NAME=SELECTION`` keeps a part's episodes on one scenario or on a
frozen suite's members by the suite's seed rule (seeds 0-4 on a fixed member, seed 0 on a
procedural one, docs/suite.md §4), so the suite part counts what ``run --suite`` flies:
    python benchmarks/terminal_cost_table.py \
        --part paper=results/v3/out/rows/leaderboard-episodes.parquet --within paper=paper-2022-sec5 \
        --part suite=results/v3/out/rows/leaderboard-episodes.parquet --within suite=uavpen-v1 \
        --out results/v3/out/ctg-sensitivity
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from uav_penetration_env.benchmark.stats import bootstrap_ci, iqm

PLANNERS = ("ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism", "cmaes")
FORMS = ("value", "dubins", "distance")
SUCCESS_BAR = 0.99  # the bar a published table must clear: every MPC planner reaches the goal in at least 99 % of episodes
ALPHA = 0.05


def read_part(paths: list[Path], bare_form: str) -> pd.DataFrame:
    """The episodes of one part with ``planner`` and ``form`` columns (baselines get form ``-``)."""
    from uav_penetration_env.benchmark.rows import concat_pieces

    frames = [pd.read_parquet(p) if p.suffix == ".parquet" else pd.read_csv(p) for p in paths]
    e = concat_pieces(frames)[["policy", "scenario", "seed", "outcome", "total_cost"]]
    e = e.drop_duplicates(["policy", "scenario", "seed"], keep="last")
    e["form"] = e.policy.str.extract(r"-ctg-(\w+)$")[0]
    e["planner"] = e.policy.str.replace(r"-ctg-\w+$", "", regex=True)
    mpc = e.planner.isin(PLANNERS)
    e.loc[mpc & e.form.isna(), "form"] = bare_form
    e["form"] = e.form.fillna("-")
    return e


def within(e: pd.DataFrame, selection: str) -> pd.DataFrame:
    """The episodes of ``e`` on ``selection``: a frozen suite's members by its seed rule, or one scenario name.

    A suite member is matched by its scenario name (``random-30000``, ``paper-2022-sec5``); a fixed
    member keeps seeds below ``FIXED_MEMBER_SEEDS`` (5), a procedural one below
    ``PROCEDURAL_MEMBER_SEEDS`` (1), which is every seed the rule flies (a deterministic policy's
    single seed 0 included).

    Raises:
        SystemExit: ``selection`` is neither a suite nor a scenario of ``e`` (one line naming it).
    """
    from uav_penetration_env.suites import SuiteError, load_suite
    from uav_penetration_env.suites.schema import FIXED_GROUP
    from uav_penetration_env.suites.seeds import FIXED_MEMBER_SEEDS, PROCEDURAL_MEMBER_SEEDS

    try:
        suite = load_suite(selection)
    except SuiteError:
        if selection not in set(e.scenario):
            raise SystemExit(
                f"--within: {selection!r} is neither a suite nor a scenario of the episodes"
            ) from None
        return e[e.scenario == selection]
    limit = {m.scenario: FIXED_MEMBER_SEEDS if m.group == FIXED_GROUP else PROCEDURAL_MEMBER_SEEDS
             for m in suite.members}  # fmt: skip
    return e[e.scenario.map(limit).gt(e.seed)]


def planner_table(e: pd.DataFrame) -> pd.DataFrame:
    """Per form and planner: episodes, success, mean, IQM and mean rank (among the seven MPC planners)."""
    rows = []
    for (form, planner), g in e.groupby(["form", "planner"], sort=False):
        rows.append({"form": form, "planner": planner, "episodes": len(g),
                     "success": float((g.outcome == "success").mean()), "mean": float(g.total_cost.mean()),
                     "iqm": float(iqm(g.total_cost.to_numpy()))})  # fmt: skip
    table = pd.DataFrame(rows)
    table["mean_rank"] = np.nan
    for form in table.form.unique():
        blocks = e[(e.form == form) & e.planner.isin(PLANNERS)].pivot_table(
            index=["scenario", "seed"], columns="planner", values="total_cost"
        )
        complete = blocks.dropna()
        if complete.shape[1] < 2 or complete.empty:
            continue
        ranks = pd.Series(stats.rankdata(complete.to_numpy(), axis=1).mean(axis=0), index=complete.columns)
        at = table.form == form
        table.loc[at, "mean_rank"] = table.loc[at, "planner"].map(ranks)
    order = {f: i for i, f in enumerate((*FORMS, "-"))}
    return table.sort_values(["form", "mean"], key=lambda c: c.map(order) if c.name == "form" else c)


def paired(e: pd.DataFrame, form: str, a: str = "ihpso", b: str = "hpso") -> dict | None:
    """``a - b`` under ``form``, paired by seed (one scenario) or by scenario (several); None if unpaired."""
    both = e[e.form == form].pivot_table(index=["scenario", "seed"], columns="planner", values="total_cost")
    if not {a, b} <= set(both.columns):
        return None
    d = (both[a] - both[b]).dropna()
    if d.index.get_level_values("scenario").nunique() > 1:
        unit, d = "scenario", d.groupby(level="scenario").mean()
    else:
        unit = "seed"
    x = d.to_numpy()
    if x.size < 2:
        return None
    low, high = bootstrap_ci(x, np.mean, seed=0)
    p = float(stats.wilcoxon(x).pvalue) if np.any(x != 0) else 1.0
    return {"form": form, "unit": unit, "n": int(x.size), "mean": float(x.mean()), "low": low, "high": high,
            "median": float(np.median(x)), "a_cheaper": int((x < 0).sum()), "p": p}  # fmt: skip


def conclusions(table: pd.DataFrame, pairs: list[dict]) -> list[tuple[str, dict[str, bool], str]]:
    """The part's conclusions, each with its truth per form and one line of evidence."""
    mpc = table[table.planner.isin(PLANNERS)]
    forms = [f for f in FORMS if f in set(mpc.form)]
    out = []
    worst = {f: mpc[mpc.form == f].success.min() for f in forms}
    out.append((f"every MPC planner reaches the goal in at least {SUCCESS_BAR:.0%} of episodes",
                {f: bool(worst[f] >= SUCCESS_BAR) for f in forms},
                "; ".join(f"{f}: lowest {worst[f]:.1%}" for f in forms)))  # fmt: skip
    by_form = {p["form"]: p for p in pairs}
    # The direction is the median's: the signed-rank test is about the typical pair, and one member
    # where a planner loiters can move the mean against most pairs (the mean is in the pairs table).
    for text, test in (("HPSO is cheaper than IHPSO (Wilcoxon p < 0.05)", lambda p: p["median"] > 0 and p["p"] < ALPHA),
                       ("IHPSO is cheaper than HPSO (Wilcoxon p < 0.05)", lambda p: p["median"] < 0 and p["p"] < ALPHA)):  # fmt: skip
        truth = {f: bool(f in by_form and test(by_form[f])) for f in forms}
        evidence = "; ".join(f"{f}: median {by_form[f]['median']:+.2f}, p = {by_form[f]['p']:.2g}"
                             for f in forms if f in by_form)
        out.append((text, truth, evidence))
    best = {f: mpc[mpc.form == f].sort_values("mean").planner.iloc[0] for f in forms}
    for planner in sorted(set(best.values())):
        out.append((f"{planner} has the lowest mean total cost", {f: best[f] == planner for f in forms},
                    "; ".join(f"{f}: {best[f]}" for f in forms)))  # fmt: skip
    ranked = {f: mpc[mpc.form == f].sort_values("mean_rank").planner.tolist() for f in forms}
    ihpso_last_half = {f: "ihpso" in r and r.index("ihpso") >= len(r) // 2 for f, r in ranked.items()}
    out.append(("IHPSO ranks in the lower half of the seven MPC planners (mean rank)", ihpso_last_half,
                "; ".join(f"{f}: rank {ranked[f].index('ihpso') + 1} of {len(ranked[f])}" for f in forms
                          if "ihpso" in ranked[f])))  # fmt: skip
    return out


def markdown(parts: dict[str, tuple[pd.DataFrame, list[dict], list]]) -> str:
    """The table's Markdown page: per part, each conclusion under each terminal-cost form."""
    lines = ["# Conclusions under each terminal cost (model.md §7e.4)", "",
             "Generated by `benchmarks/terminal_cost_table.py` from the committed episode rows of this folder.",
             "Forms: `value` (the lattice value function V, the default), `dubins` (c_T from the scenario's",
             "lattice route, Dubins length), `distance` (c_T = 0.06, straight line; the v2 default).", ""]  # fmt: skip
    for part, (table, pairs, claims) in parts.items():
        lines += [f"## {part}", "", "| conclusion | " + " | ".join(FORMS) + " | verdict | evidence |",
                  "|---|" + ":-:|" * len(FORMS) + "---|---|"]  # fmt: skip
        for text, truth, evidence in claims:
            marks = [("yes" if truth[f] else "no") if f in truth else "–" for f in FORMS]
            present = list(truth.values())
            verdict = "holds under every form" if present and all(present) else (
                "holds under none" if not any(present) else "depends on the form")
            lines.append(f"| {text} | " + " | ".join(marks) + f" | {verdict} | {evidence} |")
        lines += ["", "IHPSO − HPSO, paired:", "", "| form | unit | n | mean [95 % CI] | median | IHPSO cheaper | Wilcoxon p |",
                  "|---|---|--:|---|--:|--:|--:|"]  # fmt: skip
        for p in pairs:
            lines.append(f"| {p['form']} | {p['unit']} | {p['n']} | {p['mean']:+.3f} [{p['low']:+.3f}, {p['high']:+.3f}] "
                         f"| {p['median']:+.3f} | {p['a_cheaper']} | {p['p']:.3g} |")  # fmt: skip
        lines += ["", "| form | planner | episodes | success | mean | IQM | mean rank |", "|---|---|--:|--:|--:|--:|--:|"]
        for r in table.itertuples():
            rank = "" if np.isnan(r.mean_rank) else f"{r.mean_rank:.2f}"
            lines.append(f"| {r.form} | {r.planner} | {r.episodes} | {r.success:.1%} | {r.mean:.3f} | {r.iqm:.3f} | {rank} |")
        lines.append("")
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    """The script's flags (tests/test_campaign_runner.py checks v3's tables command against them)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", action="append", required=True, metavar="NAME=PATH",
                        help="episodes (CSV or Parquet) of one part; repeat a NAME to join files")  # fmt: skip
    parser.add_argument("--within", action="append", default=[], metavar="NAME=SELECTION",
                        help="keep part NAME's episodes on one scenario or a frozen suite (its seed rule)")  # fmt: skip
    parser.add_argument("--bare-form", default="value", choices=FORMS, help="the form a bare planner name flew")
    parser.add_argument("--out", type=Path, required=True, help="folder for sensitivity.md and sensitivity.csv")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Write the terminal-cost table (Markdown and CSV) into ``--out``."""
    parser = build_parser()
    args = parser.parse_args(argv)
    files: dict[str, list[Path]] = {}
    for item in args.part:
        name, sep, path = item.partition("=")
        if not sep or not name or not path:
            parser.error(f"--part: got {item!r}, expected NAME=PATH")
        if not Path(path).is_file():
            parser.error(f"--part {name}: no file {path}")
        files.setdefault(name, []).append(Path(path))
    selections: dict[str, str] = {}
    for item in args.within:
        name, sep, selection = item.partition("=")
        if not sep or name not in files or not selection:
            parser.error(f"--within: got {item!r}, expected NAME=SCENARIO|SUITE for a --part NAME")
        selections[name] = selection
    parts, csv_rows = {}, []
    for name, paths in files.items():
        e = read_part(paths, args.bare_form)
        if name in selections:
            e = within(e, selections[name])
        table = planner_table(e)
        pairs = [p for p in (paired(e, f) for f in FORMS) if p is not None]
        parts[name] = (table, pairs, conclusions(table, pairs))
        csv_rows.append(table.assign(part=name))
        for p in pairs:
            print(f"{name:8s} {p['form']:8s} IHPSO - HPSO per {p['unit']} (n={p['n']}): {p['mean']:+.3f} "
                  f"[{p['low']:+.3f}, {p['high']:+.3f}], p = {p['p']:.3g}")  # fmt: skip
    args.out.mkdir(parents=True, exist_ok=True)
    text = markdown(parts)
    (args.out / "sensitivity.md").write_text(text + "\n")
    columns = ["part", "form", "planner", "episodes", "success", "mean", "iqm", "mean_rank"]
    pd.concat(csv_rows)[columns].to_csv(args.out / "sensitivity.csv", index=False, float_format="%.6g")
    print(f"wrote {args.out / 'sensitivity.md'} and sensitivity.csv")
    return 0


if __name__ == "__main__":
    sys.exit(main())
