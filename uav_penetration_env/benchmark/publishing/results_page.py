"""Write the published results page, ``docs/results.md``, and the README's headline from the tables.

The results page answers the testbed's two questions from leaderboard v3's folder
(``leaderboards/v3`` by default) alone, on its first screen:

1. Does IHPSO's adaptivity help? IHPSO against HPSO per table (the table's CSV: success, mean,
   IQM, the paired Δ with its interval and Holm-corrected Wilcoxon p, evaluations per step), the
   same pairing recomputed under every terminal-cost form from the episode rows (robust or not),
   and the identical-window studies (``*-fixed-target-paired.csv``).
2. Learned planners against swarm planners, on cost and on decision time: per table the cheapest
   distilled network, the cheapest RL agent group, the best of the paper's swarm planners and
   IHPSO, then each learned planner paired with that swarm planner under every terminal-cost form.

Then the 99 % bar (every MPC planner reaches the goal in at least 99 % of episodes and no failure
is a goal pass) and every section of ``benchmarks/headline.py`` (the full tables).

Every number is computed here from a table or from the episode rows; the prose between them holds
no number, and a sentence whose direction depends on the data is chosen here from the data. The
episode rows are ``FOLDER/rows/leaderboard-episodes.parquet`` (a rebuilt or provisional folder) or
the checkpoint chunks of ``FOLDER-checkpoint`` (the published layout, docs/publishing.md §5.2);
the per-form pairings reuse ``benchmarks/terminal_cost_table.py``'s ``read_part``, ``within``
and ``paired``.

Usage::

    python benchmarks/results_page.py                 # rewrite docs/results.md and the README's headline
    python benchmarks/results_page.py --check         # exit 1 when either is not what the tables give
    python benchmarks/results_page.py --folder DIR --out /tmp/results.md --readme /tmp/README.md
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from uav_penetration_env.benchmark.families import MPC_FAMILIES, PAPER_PLANNERS, policy_family
from uav_penetration_env.benchmark.publishing import headline as hl
from uav_penetration_env.benchmark.publishing import repository
from uav_penetration_env.benchmark.publishing import terminal_cost_table as ctg

ROOT = repository()

ALPHA = 0.05
SUCCESS_BAR = ctg.SUCCESS_BAR  # the bar: every MPC planner reaches the goal in >= 99 % of episodes
DEFAULT_FOLDER = ROOT / "leaderboards" / "v3"
ADAPTIVITY_TABLES = ("paper-2022-sec5", "paper-2022-sec5-w2", "uavpen-v1", "uavpen-heldout-v1")
LEARNED_TABLES = ("paper-2022-sec5", "uavpen-v1", "uavpen-heldout-v1")
IMITATION = "imitation (distilled)"
README_START = "<!-- headline: written by benchmarks/results_page.py -->"
README_END = "<!-- /headline -->"
OTHER_FORMS = tuple(f for f in ctg.FORMS if f != "value")
# v3's rows re-read under the rules v4 declares (docs/publishing.md §6): the headline's answers.
REREAD = ROOT / "leaderboards" / "protocols" / "v3-reread.yaml"


# --- reading ------------------------------------------------------------------------------------


def episode_paths(folder: Path, rows: Path | None = None) -> list[Path]:
    """The episode files behind ``folder``: ``rows`` where given, else its exported rows, else its checkpoint's chunks.

    ``rows`` is an export stem or a checkpoint folder (as ``uav-bench leaderboard --rows`` takes it),
    for a folder rebuilt elsewhere (``--rows`` of this script).

    A rebuilt or provisional folder holds ``rows/leaderboard-episodes.parquet``; the published v3
    folder does not, and its rows are the chunks of ``<folder>-checkpoint`` beside it (the chunks
    its manifest names, in order).

    Raises:
        SystemExit: neither exists (one line naming both paths).
    """
    from uav_penetration_env.benchmark.rows import ROW_FORMATS, checkpoint_stems, row_path

    if rows is not None:
        given = [row_path(s, "episodes", ext) for s in checkpoint_stems(rows) for ext in ROW_FORMATS]
        if not any(p.is_file() for p in given):
            raise SystemExit(f"--rows {rows}: no episodes table; expected an export stem or a checkpoint folder")
        return [p for p in given if p.is_file()]
    exported = folder / "rows" / "leaderboard-episodes.parquet"
    if exported.is_file():
        return [exported]
    checkpoint = folder.parent / f"{folder.name}-checkpoint"
    if (checkpoint / "manifest.json").is_file():
        stems = checkpoint_stems(checkpoint)
        paths = [row_path(s, "episodes", ext) for s in stems for ext in ROW_FORMATS]
        return [p for p in paths if p.is_file()]
    raise SystemExit(f"{folder}: no episode rows; expected {exported} or a checkpoint folder {checkpoint}/manifest.json")


def episode_rows(folder: Path, rows: Path | None = None) -> pd.DataFrame:
    """The episodes behind ``folder`` with ``planner`` and ``form`` columns (``ctg.read_part``; bare = ``value``).

    Raises:
        SystemExit: no episode rows (:func:`episode_paths`).
    """
    return ctg.read_part(episode_paths(folder, rows), "value")


def selection(episodes: pd.DataFrame, stem: str) -> pd.DataFrame:
    """The episodes a table counts: a suite's members by its seed rule or one scenario (``ctg.within``).

    DECISION (docs/publishing.md §5.5): a table whose name is neither a suite nor a scenario of the rows gets no episodes
    (its pairings read "-"), rather than stopping the page.
    """
    try:
        return ctg.within(episodes, stem)
    except SystemExit:
        return episodes.iloc[0:0]


# --- small helpers --------------------------------------------------------------------------------


def names(items: Sequence[str]) -> str:
    """Back-quoted, comma-separated names; ``none`` for none."""
    return ", ".join(f"`{i}`" for i in items) if items else "none"


def signed(value: float, digits: int = 3) -> str:
    """``value`` with an explicit sign (``+0.12``, ``-0.3``) and ``digits`` significant digits."""
    text = hl.number(value, digits)
    return text if text == "-" or text.startswith("-") else f"+{text}"


def interval(value: float, low: float, high: float, digits: int = 3) -> str:
    """``value [low, high]`` with signs."""
    return f"{signed(value, digits)} [{signed(low, digits)}, {signed(high, digits)}]"


def direction(median: float, p: float) -> int:
    """-1 when the first of a pair is significantly cheaper, +1 when costlier, 0 otherwise.

    DECISION (docs/publishing.md §5.5): the direction is the paired median difference's, as the signed-rank test is about
    the typical pair (one member where a planner loiters can move the mean against most pairs).
    """
    if p is None or math.isnan(p) or p >= ALPHA or median == 0 or math.isnan(median):
        return 0
    return -1 if median < 0 else 1


def verdict(sign: int, first: str, second: str) -> str:
    """The words for :func:`direction`'s answer about ``first`` - ``second``."""
    return {-1: f"{first} cheaper", 1: f"{second} cheaper", 0: "no significant difference"}[sign]


def flown(pair: dict | None, units: int) -> bool:
    """Whether a form's pairing covers the table: at least half of the value form's ``units``.

    DECISION (docs/publishing.md §5.5): a form flown on at least half of the table's pairing units counts (its coverage is
    printed beside it, so a publication still missing a few episodes shows them); below half it
    was flown for another selection (the suite's five seeds of a fixed member, seen from that
    member's own 20-seed table) and the table is "value form only".
    """
    return pair is not None and 2 * pair["n"] >= units


# --- 1. IHPSO against HPSO ------------------------------------------------------------------------


def ihpso_vs_hpso(table: pd.DataFrame) -> dict | None:
    """IHPSO against HPSO from one scenario table (indexed by policy); None if either is missing.

    The table's ``delta_mean``, its interval and ``median_difference`` are policy - IHPSO, so
    HPSO's row gives HPSO - IHPSO: negated here and the bounds swapped, every value reads
    IHPSO - HPSO. ``p`` is HPSO's Holm-corrected Wilcoxon p; ``sign`` is :func:`direction`'s.
    """
    if not {hl.REFERENCE, hl.BASELINE} <= set(table.index):
        return None
    r, b = table.loc[hl.REFERENCE], table.loc[hl.BASELINE]
    out = {"ihpso_success": r["success_rate"], "hpso_success": b["success_rate"],
           "ihpso_mean": r["total_cost_mean"], "ihpso_iqm": r["total_cost_iqm"],
           "hpso_mean": b["total_cost_mean"], "hpso_iqm": b["total_cost_iqm"],
           "delta": -b["delta_mean"], "low": -b["delta_mean_ci_high"], "high": -b["delta_mean_ci_low"],
           "median": -b["median_difference"], "p": b["pvalue_holm"],
           "evals_share": r["nfev_per_step"] / b["nfev_per_step"]}  # fmt: skip
    out["sign"] = direction(out["median"], out["p"])
    return out


def pairs_by_form(episodes: pd.DataFrame, a: str, b: str) -> dict[str, dict]:
    """``a - b`` paired under every terminal-cost form flown (``ctg.paired``: per seed or per member).

    A policy without a terminal cost (form ``-``: a learned or classical planner) is paired with
    ``b`` under each form of ``b``.
    """
    out = {}
    for form in ctg.FORMS:
        rows = episodes[episodes["planner"].isin([a, b]) & episodes["form"].isin([form, "-"])]
        pair = ctg.paired(rows.assign(form=form), form, a, b)
        if pair is not None:
            out[form] = pair
    return out


def value_sign(pairs: dict[str, dict]) -> int:
    """The value form's own paired verdict (:func:`direction`, unadjusted p), 0 without a value pairing.

    DECISION (docs/publishing.md §5.5): a claim is marked robust by the per-form pairings alone,
    each tested the same way (one pair, unadjusted Wilcoxon p), so the value form is compared with
    the other forms like with like. The table's Holm-corrected verdict (over all its policies) is
    printed beside it and is the stricter one; on the paper scenario the two can differ.
    """
    value = pairs.get("value")
    return 0 if value is None else direction(value["median"], value["p"])


def robustness(sign: int, pairs: dict[str, dict]) -> str:
    """``**robust**`` when every other form gives the value form's verdict ``sign`` (p < ALPHA, or none).

    ``value form only`` where another form was not flown on the table (:func:`flown`); ``-``
    without a value-form pairing.
    """
    value = pairs.get("value")
    if value is None:
        return "-"
    if not all(flown(pairs.get(f), value["n"]) for f in OTHER_FORMS):
        return "value form only"
    held = all(direction(pairs[f]["median"], pairs[f]["p"]) == sign for f in OTHER_FORMS)
    return "**robust**" if held else "not robust"


def robustness_cell(pairs: dict[str, dict], first: str, second: str) -> str:
    """:func:`robustness` with the verdict that holds, e.g. ``**robust**: HPSO cheaper under every form``."""
    sign = value_sign(pairs)
    mark = robustness(sign, pairs)
    if mark == "**robust**":
        return f"{mark}: {verdict(sign, first, second)} under every form"
    if mark == "not robust":
        return f"{mark} (value form: {verdict(sign, first, second)})"
    return mark


def form_medians(pairs: dict[str, dict]) -> str:
    """Per form: the paired median and Wilcoxon p, with the coverage where short of the value form's."""
    units = pairs["value"]["n"] if "value" in pairs else 0
    cells = []
    for form, p in pairs.items():
        short = f", {p['n']} of {units} {p['unit']}s" if p["n"] < units else ""
        cells.append(f"{form} {signed(p['median'], 2)} (p {hl.pvalue(p['p'])}{short})")
    return "; ".join(cells) or "-"


def adaptivity_table(rows: dict[str, tuple[dict, dict[str, dict]]]) -> list[str]:
    """The first screen's table: per scenario table, IHPSO against HPSO and its robustness.

    Args:
        rows: table stem -> (:func:`ihpso_vs_hpso`'s dict, :func:`pairs_by_form`'s dict).
    """
    header = ["table", "success IHPSO / HPSO", "mean (IQM) IHPSO", "mean (IQM) HPSO",
              "Δ IHPSO − HPSO [95 % CI]", "Holm p", "verdict", "IHPSO evals / HPSO's",
              "same paired verdict under every terminal cost", "median Δ per form (Wilcoxon p, unadjusted)"]  # fmt: skip
    body = []
    for stem, (r, pairs) in rows.items():
        body.append([f"`{stem}`", f"{hl.percent(r['ihpso_success'])} / {hl.percent(r['hpso_success'])}",
                     f"{hl.number(r['ihpso_mean'], 4)} ({hl.number(r['ihpso_iqm'], 4)})",
                     f"{hl.number(r['hpso_mean'], 4)} ({hl.number(r['hpso_iqm'], 4)})",
                     interval(r["delta"], r["low"], r["high"]), hl.pvalue(r["p"]),
                     verdict(r["sign"], "IHPSO", "HPSO"), hl.percent(r["evals_share"]),
                     robustness_cell(pairs, "IHPSO", "HPSO"), form_medians(pairs)])  # fmt: skip
    return [hl.markdown(header, body)]


def window_studies(folder: Path) -> dict[str, pd.DataFrame]:
    """Each identical-window study's IHPSO-vs-HPSO rows (``*-fixed-target-paired.csv``), by stem."""
    out = {}
    for path in sorted(folder.glob("*-fixed-target-paired.csv")):
        paired = pd.read_csv(path)
        paired = paired[(paired["reference"] == hl.REFERENCE) & (paired["other"] == hl.BASELINE)]
        if not paired.empty:
            out[path.name.removesuffix("-fixed-target-paired.csv")] = paired.set_index("comparison")
    return out


def window_verdict(row: pd.Series) -> int:
    """-1 when IHPSO is significantly better on the comparison, +1 when HPSO is, 0 otherwise.

    DECISION (docs/publishing.md §5.5): the direction is the paired median difference's (``median_difference``
    is HPSO − IHPSO, so a positive one favours IHPSO), as for the episode tables; where that median is 0
    (a fixed-target comparison ties on many windows), the side winning more pairs.
    """
    if math.isnan(row["pvalue"]) or row["pvalue"] >= ALPHA:
        return 0
    if row["median_difference"] != 0:
        return -1 if row["median_difference"] > 0 else 1
    if row["reference_better"] == row["other_better"]:
        return 0
    return -1 if row["reference_better"] > row["other_better"] else 1


def window_counts(studies: dict[str, pd.DataFrame]) -> tuple[int, int, int]:
    """How many studies favour IHPSO on evaluations and how many find no difference in J.

    Returns:
        (studies where IHPSO needs significantly fewer evaluations to the target, studies with no
        significant difference in J at the fixed budget, studies).
    """
    fewer = sum(1 for s in studies.values() if "fixed target: evaluations" in s.index
                and window_verdict(s.loc["fixed target: evaluations"]) == -1)  # fmt: skip
    same_j = sum(1 for s in studies.values() if "fixed budget: J" in s.index
                 and window_verdict(s.loc["fixed budget: J"]) == 0)  # fmt: skip
    return fewer, same_j, len(studies)


def window_lines(studies: dict[str, pd.DataFrame], link: str) -> list[str]:
    """The identical-window table, its two counts as sentences, and the links to the tolerance tables.

    Args:
        studies: :func:`window_studies`'s frames.
        link: the folder's path as the page links it (``../leaderboards/v3``).
    """
    if not studies:
        return ["No identical-window study in this folder.", ""]
    words = {-1: "IHPSO better", 1: "HPSO better", 0: "no significant difference"}
    body = []
    for stem, s in studies.items():
        cells = [f"`{stem}`"]
        for comparison in ("fixed budget: J", "fixed target: evaluations"):
            if comparison not in s.index:
                cells.append("-")
                continue
            r = s.loc[comparison]
            cells.append(f"{words[window_verdict(r)]}: medians {hl.number(r['reference_median'], 5)} vs "
                         f"{hl.number(r['other_median'], 5)}, paired median HPSO − IHPSO "
                         f"{signed(r['median_difference'], 3)}, pairs won {int(r['reference_better'])} vs "
                         f"{int(r['other_better'])}, p {hl.pvalue(r['pvalue'])}, {int(r['pairs'])} pairs")  # fmt: skip
        body.append(cells)
    fewer, same_j, n = window_counts(studies)
    tolerance = ", ".join(f"[{stem}]({link}/{stem}-fixed-target.md)" for stem in studies)
    return [hl.markdown(["study", "fixed budget (J; IHPSO vs HPSO)", "fixed target (evaluations; IHPSO vs HPSO)"], body),
            "", f"IHPSO needs significantly fewer evaluations to the same target in {fewer} of {n} studies; "
            f"there is no significant difference in J at the same budget in {same_j} of {n}. "
            f"The tolerance tables (ERT per target): {tolerance}.", ""]  # fmt: skip


# --- 2. learned planners against swarm planners ---------------------------------------------------


def complete(table: pd.DataFrame) -> pd.DataFrame:
    """The rows of ``table`` that cover every member of a suite table (all rows of a one-scenario table)."""
    return table if "members" not in table else table[table["members"] == table["members"].max()]


def cheapest(table: pd.DataFrame, candidates: Sequence[str]) -> str | None:
    """The candidate with the lowest IQM total cost among those covering every member; None if none."""
    pool = complete(table)
    pool = pool[pool.index.isin(list(candidates))]
    return None if pool.empty else str(pool["total_cost_iqm"].idxmin())


def best_rl_group(rl: pd.DataFrame | None) -> pd.Series | None:
    """The RL agent group (``sb3:``) with the lowest IQM among those flown on every member; None if none.

    The RL table's ``tasks`` is the members a group's episodes cover; its most is the suite's.
    """
    if rl is None:
        return None
    groups = rl[(rl["kind"] == "RL group") & rl["group"].str.startswith("sb3:")]
    groups = groups[groups["tasks"] == rl["tasks"].max()]
    return None if groups.empty else groups.sort_values("iqm").iloc[0]


def planner_entry(table: pd.DataFrame, name: str, role: str) -> dict:
    """One policy's row for the learned-planner table, from the scenario table (Δ vs IHPSO where it has one)."""
    r = table.loc[name]
    return {"role": role, "name": name, "success": r["success_rate"], "iqm": r["total_cost_iqm"],
            "low": r["total_cost_iqm_ci_low"], "high": r["total_cost_iqm_ci_high"],
            "ms": 1000 * r["planning_seconds"], "delta": r["delta_mean"], "dlow": r["delta_mean_ci_low"],
            "dhigh": r["delta_mean_ci_high"], "median": r["median_difference"], "p": r["pvalue_holm"]}  # fmt: skip


def group_entry(table: pd.DataFrame, group: pd.Series) -> dict:
    """An RL group's row: IQM and decision time from the RL table, success summed over its runs' policies.

    The scenario table has a Δ vs IHPSO per run, not per group: left out.
    """
    runs = table.loc[table.index.intersection(str(group["members"]).split())]
    success = runs["successes"].sum() / runs["episodes"].sum() if len(runs) else math.nan
    return {"role": "RL agent group", "name": str(group["group"]), "success": success, "iqm": group["iqm"],
            "low": group["iqm_ci_low"], "high": group["iqm_ci_high"], "ms": 1000 * group["decision_seconds"],
            "delta": math.nan, "dlow": math.nan, "dhigh": math.nan, "median": math.nan, "p": math.nan}  # fmt: skip


def learned_entries(table: pd.DataFrame, rl: pd.DataFrame | None) -> list[dict]:
    """The cheapest distilled network, the cheapest RL group, the best paper swarm planner and IHPSO.

    DECISION (docs/publishing.md §5.5): "cheapest" and "best" are by IQM total cost (robust to the odd failed episode), among
    the policies covering every member of a suite table; decision time is milliseconds per step
    (the tables' ``planning_seconds`` and the RL table's ``decision_seconds`` are both the mean
    wall clock per action).
    """
    out = []
    imitation = cheapest(table, [p for p in table.index if policy_family(str(p)) == IMITATION])
    if imitation is not None:
        out.append(planner_entry(table, imitation, "distilled network"))
    group = best_rl_group(rl)
    if group is not None:
        out.append(group_entry(table, group))
    swarm = cheapest(table, PAPER_PLANNERS)
    if swarm is not None:
        out.append(planner_entry(table, swarm, "best swarm planner"))
    if hl.REFERENCE in table.index and swarm != hl.REFERENCE:
        out.append(planner_entry(table, hl.REFERENCE, "IHPSO"))
    return out


def learned_table(entries: dict[str, list[dict]]) -> list[str]:
    """The learned-planner table: per scenario table, each entry's success, IQM, decision time and Δ vs IHPSO."""
    header = ["table", "role", "policy", "success", "IQM [95 % CI]", "decision [ms/step]",
              "Δ vs IHPSO: mean [95 % CI]", "median", "Holm p", "verdict vs IHPSO"]  # fmt: skip
    body = []
    for stem, rows in entries.items():
        for r in rows:
            compared = not math.isnan(r["delta"])
            delta = interval(r["delta"], r["dlow"], r["dhigh"]) if compared else "-"
            sign = direction(r["median"], r["p"]) if compared else 0
            body.append([f"`{stem}`", r["role"], f"`{r['name']}`", hl.percent(r["success"]),
                         f"{hl.number(r['iqm'], 4)} [{hl.number(r['low'], 4)}, {hl.number(r['high'], 4)}]",
                         hl.number(r["ms"], 3), delta, signed(r["median"], 3) if compared else "-",
                         hl.pvalue(r["p"]), verdict(sign, r["role"], "IHPSO") if compared else "-"])  # fmt: skip
    return [hl.markdown(header, body)]


def relabel_group(episodes: pd.DataFrame, group: pd.Series | None) -> pd.DataFrame:
    """``episodes`` with the RL group's run policies labelled by the group (paired as one planner).

    DECISION (docs/publishing.md §5.5): a group's cost on a seed is the mean over its runs (``ctg.paired``'s pivot averages them).
    """
    if group is None:
        return episodes
    runs = str(group["members"]).split()
    return episodes.assign(planner=episodes["planner"].where(~episodes["policy"].isin(runs), str(group["group"])))


def learned_pair_table(pairs: dict[tuple[str, str, str], dict[str, dict]]) -> list[str]:
    """Each learned planner against the best swarm planner under each form, with its robustness.

    Args:
        pairs: (table, learned planner, swarm planner) -> :func:`pairs_by_form`'s dict.
    """
    header = ["table", "learned − swarm", *(f"{f}: mean [95 % CI], median, p" for f in ctg.FORMS),
              "verdict (value)", "under every terminal cost"]  # fmt: skip
    body = []
    for (stem, learned, swarm), by_form in pairs.items():
        cells = [f"`{stem}`", f"`{learned}` − `{swarm}`"]
        for form in ctg.FORMS:
            p = by_form.get(form)
            cells.append("-" if p is None else f"{interval(p['mean'], p['low'], p['high'])}, "
                         f"{signed(p['median'], 2)}, {hl.pvalue(p['p'])} ({p['n']} {p['unit']}s)")  # fmt: skip
        value = by_form.get("value")
        sign = 0 if value is None else direction(value["median"], value["p"])
        cells += ["-" if value is None else verdict(sign, "learned", "swarm"), robustness_cell(by_form, "learned", "swarm")]
        body.append(cells)
    return [hl.markdown(header, body)]


# --- 3. the 99 % bar ------------------------------------------------------------------------------


def is_variant(name: str) -> bool:
    """Whether ``name`` is a formulation variant (``-eq37``, ``-ctg-*``), not a planner of the bar."""
    return name.endswith("-eq37") or "-ctg-" in name


def goal_passes(folder: Path, stem: str, table: pd.DataFrame) -> pd.Series:
    """Per policy of ``table``, the failures that passed the goal (``fail_goal_pass``).

    A suite table lacks the failure kinds; they are summed from ``<suite>-members.csv`` (every
    member's row, or a difficulty level's members for ``<suite>-<level>``). NaN where neither has them.
    """
    if "fail_goal_pass" in table:
        return table["fail_goal_pass"]
    for suite, level in ((stem, None), (stem.rsplit("-", 1)[0], stem.rsplit("-", 1)[-1])):
        path = folder / f"{suite}-members.csv"
        if path.is_file():
            members = pd.read_csv(path)
            if level is not None:
                members = members[members["member_group"] == level]
            if not members.empty:
                return members.groupby("policy")["fail_goal_pass"].sum().reindex(table.index)
    return pd.Series(math.nan, index=table.index)


def success_bar(table: pd.DataFrame, passes: pd.Series) -> tuple[list[str], list[str], int, int]:
    """The MPC planners below the bar or with a goal pass, and the formulation variants likewise.

    Returns:
        (planners' "name successes/episodes, k goal passes" texts, variants' texts, planners, variants).
    """
    mpc = [str(p) for p in table.index if policy_family(str(p)) in MPC_FAMILIES]
    def failing(names: list[str]) -> list[str]:
        out = []
        for name in names:
            r, k = table.loc[name], passes.get(name, math.nan)
            if r["success_rate"] < SUCCESS_BAR or (not math.isnan(k) and k > 0):
                goal = "" if math.isnan(k) else f", {int(k)} goal pass{'es' if int(k) != 1 else ''}"
                out.append(f"`{name}` {int(r['successes'])}/{int(r['episodes'])}{goal}")
        return out

    planners = [n for n in mpc if not is_variant(n)]
    variants = [n for n in mpc if is_variant(n)]
    return failing(planners), failing(variants), len(planners), len(variants)


def bar_lines(results: dict[str, tuple[list[str], list[str], int, int]]) -> list[str]:
    """One line per table for the MPC planners, one for the formulation variants (not held to the bar)."""
    lines = []
    for stem, (planners, variants, n_planners, n_variants) in results.items():
        state = "every one clears it" if not planners else f"{len(planners)} {'does' if len(planners) == 1 else 'do'} not: {'; '.join(planners)}"
        lines.append(f"- `{stem}`, {n_planners} MPC planners: {state}.")
        if n_variants:
            lines.append(f"  Formulation variants (not held to the bar): {len(variants)} of {n_variants} below "
                         f"it or with a goal pass{': ' + '; '.join(variants) if variants else ''}.")  # fmt: skip
    return lines


# --- the page -------------------------------------------------------------------------------------


def collect(folder: Path, rows: Path | None = None) -> dict:
    """Everything the page and the headline print, read and computed once from ``folder``.

    Raises:
        SystemExit: ``folder`` holds none of the scenario tables, or no episode rows.
    """
    tables = hl.read_tables(folder, hl.TABLES)
    if not tables:
        raise SystemExit(f"{folder}: none of the tables {', '.join(f'{s}.csv' for s in hl.TABLES)}; "
                         "expected a leaderboard folder")  # fmt: skip
    episodes = episode_rows(folder, rows)
    adaptivity = {}
    for stem in ADAPTIVITY_TABLES:
        r = ihpso_vs_hpso(tables[stem]) if stem in tables else None
        if r is not None:
            adaptivity[stem] = (r, pairs_by_form(selection(episodes, stem), hl.REFERENCE, hl.BASELINE))
    learned, learned_pairs = {}, {}
    for stem in LEARNED_TABLES:
        if stem not in tables:
            continue
        rl_path = folder / f"{stem}-rl.csv"
        rl = pd.read_csv(rl_path) if rl_path.is_file() else None
        entries = learned_entries(tables[stem], rl)
        learned[stem] = entries
        swarm = next((e["name"] for e in entries if e["role"] == "best swarm planner"), None)
        chosen = relabel_group(selection(episodes, stem), best_rl_group(rl))
        for e in entries:
            if swarm is not None and e["role"] in ("distilled network", "RL agent group"):
                learned_pairs[(stem, e["name"], swarm)] = pairs_by_form(chosen, e["name"], swarm)
    bar = {stem: success_bar(t, goal_passes(folder, stem, t)) for stem, t in tables.items()}
    return {"tables": tables, "adaptivity": adaptivity, "windows": window_studies(folder),
            "learned": learned, "learned_pairs": learned_pairs, "bar": bar,
            "reread": reread(folder, rows)}  # fmt: skip


def window_rows(folder: Path, rows: Path | None = None) -> pd.DataFrame:
    """The window runs behind ``folder``, from the same source as :func:`episode_paths` (none: empty)."""
    from uav_penetration_env.benchmark.rows import checkpoint_stems, concat_pieces, read_table

    if rows is not None:
        stems = checkpoint_stems(rows)
    elif (folder / "rows" / "leaderboard-episodes.parquet").is_file():
        stems = [folder / "rows" / "leaderboard"]
    else:
        stems = checkpoint_stems(folder.parent / f"{folder.name}-checkpoint")
    pieces = [t for t in (read_table(s, "window_runs") for s in stems) if t is not None]
    return concat_pieces(pieces) if pieces else pd.DataFrame(columns=["scenario", "seed", "optimizer"])


def reread(folder: Path, rows: Path | None = None) -> pd.DataFrame:
    """The answers of :data:`REREAD` (v3's rows under the rules v4 declares, post hoc) from ``folder``'s rows."""
    from uav_penetration_env.benchmark.protocol import load_protocol, primary_answers

    episodes = episode_rows(folder, rows)
    return primary_answers(load_protocol(REREAD), episodes, window_rows(folder, rows))


def count_signs(signs: Sequence[int]) -> tuple[int, int, int]:
    """(how many are -1, +1, 0)."""
    return sum(s == -1 for s in signs), sum(s == 1 for s in signs), sum(s == 0 for s in signs)


def tally(signs: Sequence[int], first: str, second: str) -> str:
    """``"FIRST is significantly cheaper than SECOND on k, significantly costlier on m and neither on j of n tables"``.

    Args:
        signs: one :func:`direction` per table, of ``first`` - ``second``.
        first: the planner the sentence is about.
        second: the planner it is compared with.
    """
    a, b, neither = count_signs(signs)
    return (f"{first} is significantly cheaper than {second} on {a}, significantly costlier on {b} and "
            f"neither on {neither} of {len(signs)} tables")  # fmt: skip


def pace(ratios: Sequence[float]) -> str:
    """``decides A to B times faster`` (or slower) for the swarm planner's over the learned planner's decision times."""
    low, high = min(ratios), max(ratios)
    if low >= 1:
        return f"decides {hl.number(low, 2)} to {hl.number(high, 2)} times faster"
    if high <= 1:
        return f"decides {hl.number(1 / high, 2)} to {hl.number(1 / low, 2)} times slower"
    return f"decides between {hl.number(1 / low, 2)} times slower and {hl.number(high, 2)} times faster"


def _difference(row: pd.Series) -> str:
    """``+0.256 [−0.085, +0.523], Holm p 0.097`` of one protocol answer."""
    if not row["units"]:
        return "not flown"
    p = row["pvalue_adjusted"]
    text = "<0.001" if p < 0.001 else f"{p:.3g}"  # three digits: 0.0498 must not read as 0.05
    return f"{interval(row['median'], row['ci_low'], row['ci_high'])}, Holm p {text}"


def _part(row: pd.Series) -> str:
    """One answer as ``TABLE +0.26 [...], Holm p 0.097 (verdict)``, or ``TABLE not flown``."""
    if not row["units"]:
        return f"`{row['table']}` not flown"
    verdict = str(row["verdict"]).replace(" better", " cheaper") if row["measure"] == "total_cost" else row["verdict"]
    return f"`{row['table']}` {_difference(row)} ({verdict})"


def robustness_sentence(answers: pd.DataFrame) -> str:
    """The exploratory per-form family in one sentence: the tables where every form gives HPSO cheaper.

    DECISION (docs/publishing.md §6): a table's adaptivity answer is robust to the terminal cost when
    each form's comparison, on the same units as the primary answer and Holm-corrected over forms x
    tables, gives the same verdict; it is exploratory (the family is ``adaptivity-by-terminal-cost``).
    """
    family = answers[(answers["family"] == "adaptivity-by-terminal-cost") & (answers["units"] > 0)]
    if family.empty:
        return ""
    family = family.assign(table_id=family["id"].str.split("-", n=2).str[2])
    verdicts = family.groupby("table_id", sort=False)["verdict"].agg(list)
    robust = [t for t, v in verdicts.items() if all(x.startswith("hpso") and x.endswith("better") for x in v)]
    tables = dict(zip(family["table_id"], family["table"], strict=False))
    named = ", ".join(f"`{tables[t]}`" for t in robust) or "no table"
    return (f" Exploratory, under each of the {family['id'].str.split('-').str[1].nunique()} terminal costs "
            f"(Holm over forms x tables): HPSO is cheaper under every form on {named}, of the "
            f"{len(verdicts)} tables; elsewhere at least one form shows no significant difference.")


def readme_headline(found: dict) -> str:
    """The README's headline: one short paragraph per question, each claim with its number, interval and test.

    DECISION (docs/publishing.md §6): the headline quotes the declared comparisons of
    ``leaderboards/protocols/v3-reread.yaml`` computed from v3's rows (post hoc: v3 was flown before
    the rules were declared), never the exploratory tables below it; it quotes no speed ratio, since
    v3's decision times were measured in different runs without the per-map setup.
    """
    answers = found["reread"].set_index("id")
    tables = [a for a in answers.index if a.startswith("adaptivity-")]
    windows = answers[answers.index.str.startswith("evaluations-")]
    parts = "; ".join(_part(answers.loc[a]) for a in tables)
    first = (f"**Does IHPSO's adaptivity help?** Not on v3's rows, re-read under the rules v4 declares "
             f"(post hoc; docs/publishing.md §6). IHPSO − HPSO in total cost, median "
             f"paired difference [95 % CI] over seeds or members, Wilcoxon signed-rank with Holm over the "
             f"declared comparisons: {parts}.")  # fmt: skip
    paper = found["adaptivity"].get(ADAPTIVITY_TABLES[0])
    if paper is not None:
        first += (f" IHPSO spends {hl.percent(paper[0]['evals_share'])} of HPSO's evaluations per step on the paper "
                  "scenario, because its termination rule stops early.")  # fmt: skip
    windows = windows[windows["units"] > 0]
    if len(windows):
        hpso_first = int((windows["reference_better"] > windows["other_better"]).sum())
        significant = int((windows["verdict"] == "hpso better").sum())
        first += (f" On identical MPC windows, with targets f_best + 10⁻³|f_best| set per window and windows as units, "
                  f"HPSO reaches the target with fewer evaluations on most windows in {hpso_first} of {len(windows)} "
                  f"studies (significantly after Holm in {significant}; Holm p "
                  f"{', '.join(f'{p:.3g}' for p in windows['pvalue_adjusted'])}).")  # fmt: skip
    first += robustness_sentence(found["reread"])
    learned = [a for a in answers.index if a.startswith("learned-")]
    if not learned:
        return first
    parts = "; ".join(_part(answers.loc[a]) for a in learned)
    name = answers.loc[learned[0], "other"]
    second = (f"**Learned against swarm planners.** The published shielded network `{name}`, trained and designed "
              f"on these maps (in sample), against PS2O, network − PS2O: {parts}. Its decision times in the rows "
              "were measured in other runs than PS2O's and leave out the per-map build of the value function both "
              "read, so v3 makes no speed claim; v4's interleaved timing command will.")  # fmt: skip
    return f"{first}\n\n{second}"


def link_base(folder: Path) -> str:
    """``folder`` as docs/results.md links it: relative to the repository when inside it."""
    try:
        return "../" + folder.resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return folder.as_posix()


INTRO = """\
# Results

Written by `python benchmarks/results_page.py` from leaderboard v3's tables and episode rows (the
lattice value function as the MPC terminal cost, docs/model.md §7e); every number is computed from
them, and `--check` verifies the page is current. Leaderboard v2's tables stay at the top of
`leaderboards/`.
"""

REPRODUCE = """\
## Reproduce

```bash
uav-bench leaderboard --rows leaderboards/v3-checkpoint --out /tmp/rebuilt --fixed-target-rule worse-final   # the tables from the committed rows alone
uav-bench protocol leaderboards/protocols/v3-reread.yaml --rows leaderboards/v3-checkpoint   # the declared comparisons
python benchmarks/results_page.py --check          # this page and the README's headline against the tables
cp leaderboards/v3/compute.jsonl /tmp/rebuilt/     # this page's numbers from the rebuilt tables (links aside)
python benchmarks/results_page.py --folder /tmp/rebuilt --rows leaderboards/v3-checkpoint --out /tmp/results.md --readme /tmp/README.md
```

docs/publishing.md §5 describes the v3 publication; `benchmarks/reproduce_published.py STORE` (as of f860dda, since removed)
compares a re-run with the published episodes.
"""

EXPLORATORY_NOTE = (
    "The sections below are v3's tables as published. Their Holm corrections run over every policy of a table, "
    "their robustness marks are uncorrected, the identical-window verdicts use the retired pairing rule (the "
    "worse of a pair's two finals as the target, which favours whoever stops early; api.md §4.8), the learned "
    "planners were trained and designed on these maps, and the decision times come from different runs without "
    "per-map setup. They are exploratory; the answers above are the declared ones."
)


def reread_lines(answers: pd.DataFrame) -> list[str]:
    """The declared comparisons' table (v3 re-read), one row per answer."""
    header = ["comparison", "table", "measure", "units", "other − reference: median [95 % CI]",
              "other / reference better", "Holm p", "verdict"]  # fmt: skip
    body = [[f"`{r.id}`", f"`{r.table}`", str(r.measure), f"{int(r.units)} {r.unit}s",
             f"`{r.other}` − `{r.reference}`: {interval(r.median, r.ci_low, r.ci_high)}",
             f"{int(r.other_better)} / {int(r.reference_better)}" if r.units else "-", hl.pvalue(r.pvalue_adjusted),
             str(r.verdict) + ("" if r.primary else " (exploratory)")]
            for r in answers.itertuples()]  # fmt: skip
    return ["### The declared comparisons, on v3's rows", "",
            "`uav-bench protocol leaderboards/protocols/v3-reread.yaml --rows leaderboards/v3-checkpoint` (docs/publishing.md "
            "§6): every comparison of the file, Holm within its family; the fixed-target rows are log10 ERT ratios "
            "(+∞: only the reference reached the window's target).", "", hl.markdown(header, body), ""]  # fmt: skip


ADAPTIVITY_NOTE = (
    "Δ, its bootstrap interval and the Holm-corrected Wilcoxon p are the table's (paired per seed, per member "
    "on a suite); the verdict is the median difference's direction where p < {alpha:g}. *Under every terminal "
    "cost*: the same pair recomputed from the episode rows (a suite's members by its seed rule, as the terminal-cost "
    "table counts them) under each form (`value`, the default; `NAME-ctg-dubins`; "
    "`NAME-ctg-distance`), each tested alike (unadjusted Wilcoxon p): **robust** when every form gives the value "
    "form's verdict (the same direction at p < {alpha:g}, or no difference under each), *value form only* where "
    "the other forms were not flown on the table. The Holm verdict, corrected over every policy of the table, is "
    "the stricter of the two, so a table can read *no significant difference* and **robust** at once."
)


def page(folder: Path, found: dict | None = None) -> str:
    """The whole results page for the leaderboard folder ``folder`` (Markdown).

    Raises:
        SystemExit: ``folder`` holds none of the scenario tables, or no episode rows.
    """
    found = collect(folder) if found is None else found
    link = link_base(folder)
    lines = [INTRO, "## In short", "", readme_headline(found), "", *reread_lines(found["reread"]),
             "## 1. Does IHPSO's adaptivity help? (exploratory, as published in v3)", "", EXPLORATORY_NOTE, ""]
    lines += [*adaptivity_table(found["adaptivity"]), "", ADAPTIVITY_NOTE.format(alpha=ALPHA), ""]
    lines += ["### Identical MPC windows (fixed budget and fixed target)", ""]
    lines += window_lines(found["windows"], link)
    lines += ["## 2. Learned planners against swarm planners, on cost and on decision time (exploratory)", ""]
    lines += [*learned_table(found["learned"]), ""]
    lines += ["The best swarm planner is the paper planner with the lowest IQM among those covering every member "
              "(the RL tables of §4 name the one with the lowest mean, docs/rl-statistics.md §2, which can differ). "
              "The verdict vs IHPSO is the paired median's direction at Holm p < 0.05 (the mean can point the other "
              "way when one failed episode pulls it).", "",
              "Each learned planner paired with the table's best swarm planner (per seed, per member on a suite; "
              "bootstrap 95 % interval of the mean difference, Wilcoxon p), under each terminal cost of the swarm "
              "planner; a learned planner has none.", ""]  # fmt: skip
    lines += [*learned_pair_table(found["learned_pairs"]), ""]
    lines += [f"## 3. The {SUCCESS_BAR:.0%} bar", "",
              f"The MPC planners (paper planners, reference optimisers, IHPSO ablations; value terminal cost) "
              f"that reach the goal in fewer than {SUCCESS_BAR:.0%} of a table's episodes or pass the goal in a failure:", ""]  # fmt: skip
    lines += [*bar_lines(found["bar"]), ""]
    lines += [f"The terminal-cost study: [ctg-sensitivity/sensitivity.md]({link}/ctg-sensitivity/sensitivity.md).", ""]
    # headline.py's own title names the folder's path, which differs between checkouts: replaced.
    details = hl.headline(folder, list(found["tables"])).split("\n", 1)[1]
    lines += ["## 4. The tables behind the findings", details.replace("\n## ", "\n### "), "", REPRODUCE]
    return "\n".join(lines)


def with_headline(readme: str, paragraph: str) -> str:
    """``readme`` with the text between the headline markers replaced by ``paragraph``."""
    start, end = readme.find(README_START), readme.find(README_END)
    if start < 0 or end < start:
        raise SystemExit(f"README: no {README_START!r} ... {README_END!r} block to write the headline into")
    return readme[: start + len(README_START)] + "\n" + paragraph + "\n" + readme[end:]


def main(argv: Sequence[str] | None = None) -> int:
    """Write the results page and the README's headline, or ``--check`` them (exit 1 when stale)."""
    parser = argparse.ArgumentParser(prog="python benchmarks/results_page.py", description=__doc__.splitlines()[0])
    parser.add_argument("--folder", type=Path, default=DEFAULT_FOLDER, help="leaderboard v3 folder")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "results.md", help="the results page")
    parser.add_argument("--readme", type=Path, default=ROOT / "README.md", help="the README holding the headline")
    parser.add_argument("--check", action="store_true", help="compare instead of writing; exit 1 on a difference")
    parser.add_argument("--rows", type=Path, default=None,
                        help="the episode rows (export stem or checkpoint folder) of a folder rebuilt elsewhere")  # fmt: skip
    args = parser.parse_args(argv)
    found = collect(args.folder, args.rows)
    text = page(args.folder, found) + "\n"
    readme = with_headline(args.readme.read_text(), readme_headline(found))
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
