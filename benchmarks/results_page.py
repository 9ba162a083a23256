"""Write the published results page, ``docs/results.md``, and the README's headline from the tables.

The results page answers the testbed's two questions, does IHPSO's adaptivity help and how do
learned planners compare with swarm planners on cost and on compute, from the published
leaderboard folder alone. Every number on it is computed here from a committed table:

- the scenario tables ``<stem>.csv`` and their RL tables ``<stem>-rl.csv``;
- the window studies' ``<stem>-fixed-target-paired.csv``;
- the terminal-cost study's episode rows under ``ctg-sensitivity/`` (re-analysed with
  ``benchmarks/terminal_cost_table.py``'s functions, so its conclusions are recomputed, not read);
- then every section of ``benchmarks/headline.py`` (the full tables behind each finding).

The prose between the numbers is fixed text without numbers; a sentence whose direction depends
on the data (cheaper or costlier, beats the floor or not) is chosen here from the data.

Usage::

    python benchmarks/results_page.py                 # rewrite docs/results.md and the README's headline
    python benchmarks/results_page.py --check         # exit 1 when either is not what the tables give
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
for path in (ROOT, HERE):  # run as a script from anywhere: this checkout's package and scripts
    if str(path) not in sys.path:
        sys.path.insert(0, str(path))

import headline as hl  # noqa: E402
import terminal_cost_table as ctg  # noqa: E402

from uav_penetration_env.benchmark.families import MPC_FAMILIES, policy_family  # noqa: E402

ALPHA = 0.05
EPISODE_TABLES = ("paper-2022-sec5", "paper-2022-sec5-w2", "uavpen-heldout-v1")
RL_TABLES = ("paper-2022-sec5", "uavpen-heldout-v1")
COMPARED_FAMILIES = (*MPC_FAMILIES[:2], "floors")  # the planners and floors a finding names (no ablations, agents)
# The terminal-cost study's committed episodes (benchmarks/terminal_cost_table.py's usage).
CTG_PARTS = {
    "paper scenario": ("paper-episodes.csv",),
    "suite uavpen-v1": ("suite-value-rows/suite-value-4256938-episodes.parquet",
                        "suite-forms-rows/suite-forms-4256938-episodes.parquet"),
}  # fmt: skip
CTG_WINDOWS = "ctg-sensitivity/windows"  # the window study flown again with the value terminal cost
README_START = "<!-- headline: written by benchmarks/results_page.py -->"
README_END = "<!-- /headline -->"


def names(items: Sequence[str]) -> str:
    return ", ".join(f"`{i}`" for i in items) if items else "none"


def versus_ihpso(table: pd.DataFrame) -> tuple[list[str], list[str]]:
    """The planners and floors significantly cheaper and costlier than IHPSO (Holm-corrected Wilcoxon).

    The direction is the paired median difference's, as the signed-rank test is about the typical pair.
    """
    compared = table[[policy_family(str(p)) in COMPARED_FAMILIES for p in table.index]]
    significant = compared[compared["pvalue_holm"] < ALPHA]
    cheaper = significant[significant["median_difference"] < 0].sort_values("total_cost_iqm")
    costlier = significant[significant["median_difference"] > 0].sort_values("total_cost_iqm")
    return list(cheaper.index), list(costlier.index)


def episode_findings(tables: dict[str, pd.DataFrame]) -> list[str]:
    """One line per episode table: IHPSO's success and rank, who is cheaper and who costlier."""
    lines = []
    for stem in EPISODE_TABLES:
        table = tables.get(stem)
        if table is None or hl.REFERENCE not in table.index:
            continue
        r = table.loc[hl.REFERENCE]
        cheaper, costlier = versus_ihpso(table)
        lines.append(
            f"- `{stem}`: IHPSO reaches the goal in {hl.percent(r['success_rate'])} of {int(r['episodes'])} episodes, "
            f"IQM {hl.number(r['total_cost_iqm'], 4)}, Friedman rank {hl.number(r['friedman_rank'], 3)} of {len(table)}. "
            f"Significantly cheaper than IHPSO: {names(cheaper)}; significantly costlier: {names(costlier)}."
        )
    return lines


def evaluation_findings(tables: dict[str, pd.DataFrame], folder: Path) -> list[str]:
    """IHPSO's evaluation share in the episodes and its paired comparisons on identical windows."""
    lines = []
    table = tables.get(EPISODE_TABLES[0])
    if table is not None and {hl.REFERENCE, hl.BASELINE} <= set(table.index):
        r, base = table.loc[hl.REFERENCE], table.loc[hl.BASELINE]
        lines.append(
            f"- In the `{EPISODE_TABLES[0]}` episodes IHPSO spends {hl.percent(r['nfev_per_step'] / base['nfev_per_step'])} "
            f"of HPSO's evaluations per MPC step and its adaptive termination stops "
            f"{hl.percent(r['stopped_early_share'])} of steps early (the paper reports 78 % of HPSO's iterations)."
        )
    studies = [(p, "") for p in sorted(folder.glob("*-fixed-target-paired.csv"))]
    studies += [(p, ", `value` terminal cost") for p in sorted((folder / CTG_WINDOWS).glob("*-fixed-target-paired.csv"))]
    for path, form in studies:
        stem = path.name.removesuffix("-fixed-target-paired.csv")
        paired = pd.read_csv(path)
        paired = paired[(paired["reference"] == hl.REFERENCE) & (paired["other"] == hl.BASELINE)]
        if paired.empty:
            continue
        parts = []
        for r in paired.itertuples():
            if r.pvalue >= ALPHA:
                verdict = "no significant difference"
            else:
                # "better" counts the pairs each side wins; the one winning more pairs is the faster/cheaper
                verdict = f"{'IHPSO' if r.reference_better > r.other_better else 'HPSO'} is better"
            parts.append(f"{r.comparison}: {verdict} (medians IHPSO {hl.number(r.reference_median, 5)}, "
                         f"HPSO {hl.number(r.other_median, 5)}; p {hl.pvalue(r.pvalue)}, {r.pairs} pairs)")  # fmt: skip
        lines.append(f"- Identical MPC windows of `{stem}`{form}: " + "; ".join(parts) + ".")
    return lines


def terminal_cost_findings(folder: Path) -> list[str]:
    """The terminal-cost study's conclusions, recomputed from its committed episodes."""
    lines = []
    for part, files in CTG_PARTS.items():
        paths = [folder / "ctg-sensitivity" / f for f in files]
        if not all(p.is_file() for p in paths):
            continue
        episodes = ctg.read_part(paths, "value")
        table = ctg.planner_table(episodes)
        pairs = [p for p in (ctg.paired(episodes, f) for f in ctg.FORMS) if p is not None]
        claims = ctg.conclusions(table, pairs)
        every = [text for text, truth, _ in claims if truth and all(truth.values())]
        depends = [text for text, truth, _ in claims if any(truth.values()) and not all(truth.values())]
        lines.append(f"- {part}, under the forms {', '.join(ctg.FORMS)}: holds under every form: "
                     f"{'; '.join(every) or 'nothing'}. Depends on the form: {'; '.join(depends) or 'nothing'}.")  # fmt: skip
    return lines


def rl_findings(folder: Path) -> list[str]:
    """Per RL table: how many agent groups beat the greedy floor, the best group, and the decision-time ratio."""
    lines = []
    for stem in RL_TABLES:
        path = folder / f"{stem}-rl.csv"
        if not path.is_file():
            continue
        table = pd.read_csv(path)
        groups = table[table["kind"] == "RL group"]
        agents = groups[groups["group"].str.startswith("sb3:")]
        hybrids = groups[~groups["group"].str.startswith("sb3:")]
        planner = table[(table["kind"] == "reference") & (table["group"] != "greedy")]
        if agents.empty or planner.empty:
            continue
        beat = int((agents["delta_greedy_ci_high"] < 0).sum())
        worse = int((agents["delta_greedy_ci_low"] > 0).sum())
        best = agents.sort_values("iqm").iloc[0]
        p = planner.iloc[0]
        text = (f"- `{stem}`: of {len(agents)} agent groups, {beat} beat the greedy floor and {worse} are costlier "
                f"(paired Δ's 95 % interval below or above zero). The best, `{best['group']}`, has IQM "
                f"{hl.number(best['iqm'], 4)} [{hl.number(best['iqm_ci_low'], 4)}, {hl.number(best['iqm_ci_high'], 4)}], "
                f"Δ vs greedy {hl.number(best['delta_greedy'], 3)}; the best of the paper's swarm planners, `{p['group']}`, "
                f"{hl.number(p['iqm'], 4)}. The agents decide "
                f"{hl.number(p['decision_seconds'] / agents['decision_seconds'].median(), 2)} times faster than it "
                "(median over groups, seconds per step on the same machine).")  # fmt: skip
        if not hybrids.empty:
            h = hybrids.sort_values("iqm").iloc[0]
            text += (f" IHPSO warm-started by an agent (`{h['group']}`): IQM {hl.number(h['iqm'], 4)}, "
                     f"Δ vs greedy {hl.number(h['delta_greedy'], 3)} [{hl.number(h['delta_greedy_ci_low'], 3)}, "
                     f"{hl.number(h['delta_greedy_ci_high'], 3)}].")  # fmt: skip
        lines.append(text)
    return lines


def readme_headline(tables: dict[str, pd.DataFrame], folder: Path) -> str:
    """The README's short headline paragraph: the answer to each question in one sentence, with its numbers."""
    stem = EPISODE_TABLES[0]
    table = tables[stem]
    r, base = table.loc[hl.REFERENCE], table.loc[hl.BASELINE]
    cheaper, _ = versus_ihpso(table)
    first = (f"On the paper's scenario, {len(cheaper)} planners are significantly cheaper than IHPSO "
             f"({names(cheaper)}), while IHPSO spends {hl.percent(r['nfev_per_step'] / base['nfev_per_step'])} "
             "of HPSO's evaluations.")  # fmt: skip
    rl = pd.read_csv(folder / f"{stem}-rl.csv") if (folder / f"{stem}-rl.csv").is_file() else None
    if rl is None:
        return first
    agents = rl[(rl["kind"] == "RL group") & rl["group"].str.startswith("sb3:")]
    beat = int((agents["delta_greedy_ci_high"] < 0).sum())
    planner = rl[(rl["kind"] == "reference") & (rl["group"] != "greedy")].iloc[0]
    count = f"None of the {len(agents)} RL agent groups beats" if beat == 0 else f"{beat} of {len(agents)} RL agent groups beat"
    second = (f"{count} the greedy floor (trained on this scenario or on random ones); they decide about "
              f"{hl.number(planner['decision_seconds'] / agents['decision_seconds'].median(), 2)} times faster "
              f"than the best of the paper's swarm planners, `{planner['group']}`.")  # fmt: skip
    return f"{first} {second}"


INTRO = """\
# Results

This page is written by `python benchmarks/results_page.py` from the published leaderboard's CSV
tables in `leaderboards/` (every number below is computed from them; `--check` verifies the page is
current). The tables rebuild from the committed rows alone (docs/publishing.md §3).

**Which version.** These are leaderboard v2's tables. Its MPC planners priced the end of each
window with the straight-line `distance` terminal cost; the default is now the lattice value
function (docs/model.md §7e), and leaderboard v3 flies every part again with it. The
terminal-cost study below checks which conclusions survive that choice.
"""

REPRODUCE = """\
## Reproduce

```bash
python benchmarks/publish.py --from-published      # a fresh clone: the store and compute log back from leaderboards/
python benchmarks/publish.py --dry-run             # every command of the publication, and whether it is done
uav-bench leaderboard --rows leaderboards/rows/leaderboard --out /tmp/rebuilt   # the tables from the rows alone
python benchmarks/results_page.py --check          # this page against the tables
```

docs/publishing.md describes the driver; `benchmarks/reproduce_published.py STORE` compares a re-run
with the published episodes.
"""


def page(folder: Path) -> str:
    """The whole results page for the leaderboard folder ``folder`` (Markdown).

    Raises:
        SystemExit: ``folder`` holds none of the scenario tables.
    """
    tables = hl.read_tables(folder, hl.TABLES)
    if not tables:
        raise SystemExit(f"{folder}: none of the tables {', '.join(f'{s}.csv' for s in hl.TABLES)}; "
                         "expected a leaderboard folder")  # fmt: skip
    lines = [INTRO, "## Does IHPSO's adaptivity help?", ""]
    lines += episode_findings(tables) + evaluation_findings(tables, folder)
    lines += ["", "### Under each terminal cost", ""]
    lines += terminal_cost_findings(folder)
    lines += ["", "The full study: [leaderboards/ctg-sensitivity/sensitivity.md](../leaderboards/ctg-sensitivity/sensitivity.md).", ""]
    lines += ["## Learned planners against swarm planners, on cost and on compute", ""]
    lines += [*rl_findings(folder), ""]
    # headline.py's own title names the folder's path, which differs between checkouts: replaced.
    details = hl.headline(folder, list(tables)).split("\n", 1)[1]
    lines += ["## The tables behind the findings", details.replace("\n## ", "\n### "), "", REPRODUCE]
    return "\n".join(lines)


def with_headline(readme: str, paragraph: str) -> str:
    """``readme`` with the text between the headline markers replaced by ``paragraph``."""
    start, end = readme.find(README_START), readme.find(README_END)
    if start < 0 or end < start:
        raise SystemExit(f"README: no {README_START!r} ... {README_END!r} block to write the headline into")
    return readme[: start + len(README_START)] + "\n" + paragraph + "\n" + readme[end:]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python benchmarks/results_page.py", description=__doc__.splitlines()[0])
    parser.add_argument("--folder", type=Path, default=ROOT / "leaderboards", help="leaderboard folder")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "results.md", help="the results page")
    parser.add_argument("--readme", type=Path, default=ROOT / "README.md", help="the README holding the headline")
    parser.add_argument("--check", action="store_true", help="compare instead of writing; exit 1 on a difference")
    args = parser.parse_args(argv)
    text = page(args.folder) + "\n"
    readme = with_headline(args.readme.read_text(), readme_headline(hl.read_tables(args.folder, hl.TABLES), args.folder))
    stale = [p for p, new in ((args.out, text), (args.readme, readme)) if not p.is_file() or p.read_text() != new]
    if args.check:
        for p in stale:
            print(f"{p}: not what the tables in {args.folder} give; run python benchmarks/results_page.py", file=sys.stderr)
        return 1 if stale else 0
    from uav_penetration_env.atomic import write_text_atomic

    for p, new in ((args.out, text), (args.readme, readme)):
        write_text_atomic(p, new)
    print(f"wrote {args.out} and the headline of {args.readme}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
