"""A publication's declared protocol: its primary comparisons, their tests and families, its seeds and success bar.

A protocol (docs/publishing.md §6) is a YAML file committed before any episode of the publication
is flown. It says which comparisons answer the publication's questions (the *primary* ones), the
statistic and test of each, the family each is corrected over, the seed sets, and the success
bound. Everything else a results page shows is exploratory. :func:`load_protocol` reads and checks
the file; :func:`primary_answers` computes every declared comparison from a publication's rows,
and :func:`success_bar` the success rates with their Wilson intervals.

A comparison pairs two policies on *units of replication*: the seeds of one scenario, the members
of a suite (a member's episodes averaged over its declared seeds first, so a member flown with 3
seeds weighs as one), or the windows of a window study (api.md §4.8). Per unit the difference is
``other − reference`` (a cost: negative means the other is cheaper); the statistic is the median
over units with its percentile-bootstrap interval, the test the two-sided Wilcoxon signed-rank test
over units (:func:`~.stats.unit_comparison`), and the p values are Holm-corrected within the
family, which holds the primary comparisons alone, never every policy a table ranks.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from uav_penetration_env.benchmark import stats

MEASURES = ("total_cost", "fixed_target", "fixed_budget")
UNITS = ("seed", "member", "window")
CORRECTIONS = ("holm",)
PROTOCOL_KEYS = ("publication", "declared", "alpha", "bootstrap", "seed_sets", "success", "families")
FAMILY_KEYS = ("name", "question", "primary", "correction", "comparisons")
COMPARISON_KEYS = ("id", "table", "measure", "unit", "other", "reference", "seeds", "precision")
SUCCESS_KEYS = ("bound", "confidence", "tables", "planners")


class ProtocolError(ValueError):
    """A protocol file or field that cannot be used; the message names the field and what was expected."""


def _keys(
    mapping: Any, allowed: Sequence[str], where: str, required: Sequence[str] = ()
) -> Mapping[str, Any]:
    if not isinstance(mapping, Mapping):
        raise ProtocolError(f"{where}: got {type(mapping).__name__}, expected a mapping")
    unknown = sorted(set(map(str, mapping)) - set(allowed))
    if unknown:
        raise ProtocolError(f"{where}.{unknown[0]}: unknown key, expected one of {', '.join(allowed)}")
    missing = [k for k in required if k not in mapping]
    if missing:
        raise ProtocolError(f"{where}.{missing[0]}: missing, expected a value")
    return mapping


def _seeds(value: Any, where: str) -> tuple[int, ...]:
    """``START:STOP`` (half-open) or a list of non-negative integers."""
    if isinstance(value, str) and ":" in value:
        try:
            start, stop = (int(part) for part in value.split(":", 1))
        except ValueError:
            raise ProtocolError(f"{where}: got {value!r}, expected START:STOP or a list of seeds") from None
        seeds = tuple(range(start, stop))
    elif isinstance(value, list) and all(isinstance(v, int) and not isinstance(v, bool) for v in value):
        seeds = tuple(value)
    else:
        raise ProtocolError(f"{where}: got {value!r}, expected START:STOP or a list of seeds")
    if not seeds or min(seeds) < 0 or len(set(seeds)) != len(seeds):
        raise ProtocolError(f"{where}: got {value!r}, expected at least one distinct seed >= 0")
    return seeds


def _seed_set(name: Any, seed_sets: Mapping[str, tuple[int, ...]], where: str) -> tuple[int, ...]:
    """The seeds of a declared seed set, by name."""
    if not isinstance(name, str) or name not in seed_sets:
        raise ProtocolError(
            f"{where}: got {name!r}, expected the name of a seed set ({', '.join(seed_sets)})"
        )
    return seed_sets[name]


def _fraction(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 < float(value) < 1.0:
        raise ProtocolError(f"{where}: got {value!r}, expected a number in (0, 1)")
    return float(value)


def _name(value: Any, where: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise ProtocolError(f"{where}: got {value!r}, expected a non-empty name")
    return value


@dataclass(frozen=True)
class Comparison:
    """One declared comparison: ``other`` against ``reference`` on ``table``'s units.

    Attributes:
        id: unique within the protocol.
        table: a scenario name (units: seeds) or a frozen suite's name (units: members); for the
            window measures, the scenario of the window study.
        measure: ``total_cost`` (the episode's total J with its failure penalty), ``fixed_target``
            (per window log10 ERT ratio at ``precision``) or ``fixed_budget`` (per window J gap at
            the reference's evaluations), api.md §4.8.
        unit: ``seed``, ``member`` or ``window`` (the window measures).
        other, reference: policy names as stored (window measures: optimiser names).
        seeds: the episode seeds that count (a member's are averaged), or the window-run seeds.
        precision: the target precision Δ of ``fixed_target``.
    """

    id: str
    table: str
    measure: str
    unit: str
    other: str
    reference: str
    seeds: tuple[int, ...]
    precision: float | None = None

    @classmethod
    def from_mapping(cls, data: Any, where: str, seed_sets: Mapping[str, tuple[int, ...]]) -> Comparison:
        """Parse and check one comparison entry; its ``seeds`` names one of ``seed_sets``.

        Raises:
            ProtocolError: an unknown or missing key, or a value outside its domain.
        """
        data = _keys(
            data,
            COMPARISON_KEYS,
            where,
            required=("id", "table", "measure", "unit", "other", "reference", "seeds"),
        )
        measure, unit = data["measure"], data["unit"]
        if measure not in MEASURES:
            raise ProtocolError(f"{where}.measure: got {measure!r}, expected one of {', '.join(MEASURES)}")
        if unit not in UNITS:
            raise ProtocolError(f"{where}.unit: got {unit!r}, expected one of {', '.join(UNITS)}")
        if (measure == "total_cost") == (unit == "window"):
            expected = "seed or member" if measure == "total_cost" else "window"
            raise ProtocolError(f"{where}.unit: got {unit!r} for measure {measure}, expected {expected}")
        precision = data.get("precision")
        if measure == "fixed_target":
            if (
                isinstance(precision, bool)
                or not isinstance(precision, (int, float))
                or not 0 < precision < 1
            ):
                raise ProtocolError(
                    f"{where}.precision: got {precision!r}, expected a target precision Δ in (0, 1)"
                )
            precision = float(precision)
        elif precision is not None:
            raise ProtocolError(
                f"{where}.precision: given for measure {measure}, expected only with fixed_target"
            )
        other, reference = (
            _name(data["other"], f"{where}.other"),
            _name(data["reference"], f"{where}.reference"),
        )
        if other == reference:
            raise ProtocolError(
                f"{where}.other: got {other!r}, the reference itself; expected another policy"
            )
        return cls(
            id=_name(data["id"], f"{where}.id"),
            table=_name(data["table"], f"{where}.table"),
            measure=measure,
            unit=unit,
            other=other,
            reference=reference,
            seeds=_seed_set(data["seeds"], seed_sets, f"{where}.seeds"),
            precision=precision,
        )


@dataclass(frozen=True)
class Family:
    """Comparisons corrected together (Holm): a question's primary answers, or an exploratory set.

    Attributes:
        name: unique within the protocol.
        question: the question the family answers, in words.
        primary: whether its comparisons are primary answers (False: exploratory, still corrected
            within the family).
        correction: ``holm``.
        comparisons: the family's comparisons.
    """

    name: str
    question: str
    primary: bool
    correction: str
    comparisons: tuple[Comparison, ...]


@dataclass(frozen=True)
class SuccessBar:
    """The success bound every declared planner must clear on every declared table.

    Attributes:
        bound: the share of episodes reaching the goal (0.99).
        confidence: the Wilson interval's level printed beside each rate.
        tables: (scenario or suite name, the episode seeds that count there) pairs.
        planners: the policy names held to the bar.
    """

    bound: float
    confidence: float
    tables: tuple[tuple[str, tuple[int, ...]], ...]
    planners: tuple[str, ...]


@dataclass(frozen=True)
class Protocol:
    """A publication's declared protocol (docs/publishing.md §6).

    Attributes:
        publication: the publication's name (``v4``).
        declared: the date it was declared (ISO), before any of its episodes was flown.
        alpha: the significance level of every test after correction.
        bootstrap_resamples, bootstrap_seed: every interval's resamples and base seed.
        seed_sets: the declared seed sets by name, which comparisons and the bar refer to.
        success: the success bar.
        families: the families, each corrected on its own.
    """

    publication: str
    declared: str
    alpha: float
    bootstrap_resamples: int
    bootstrap_seed: int
    seed_sets: Mapping[str, tuple[int, ...]]
    success: SuccessBar
    families: tuple[Family, ...]

    @property
    def comparisons(self) -> tuple[Comparison, ...]:
        """Every comparison, family by family, in the file's order."""
        return tuple(c for family in self.families for c in family.comparisons)


def _bootstrap(data: Any, where: str) -> tuple[int, int]:
    """(resamples, seed) of the ``bootstrap`` block."""
    boot = _keys(data, ("resamples", "seed"), where, required=("resamples", "seed"))
    out = []
    for key, least in (("resamples", 100), ("seed", 0)):
        value = boot[key]
        if isinstance(value, bool) or not isinstance(value, int) or value < least:
            raise ProtocolError(f"{where}.{key}: got {value!r}, expected an integer >= {least}")
        out.append(int(value))
    return out[0], out[1]


def _success(data: Any, seed_sets: Mapping[str, tuple[int, ...]], where: str) -> SuccessBar:
    """The ``success`` block."""
    bar = _keys(data, SUCCESS_KEYS, where, required=SUCCESS_KEYS)
    for key in ("tables", "planners"):
        if not isinstance(bar[key], list) or not bar[key]:
            raise ProtocolError(f"{where}.{key}: got {bar[key]!r}, expected a non-empty list")
    tables = []
    for i, entry in enumerate(bar["tables"]):
        at = f"{where}.tables[{i}]"
        entry = _keys(entry, ("table", "seeds"), at, required=("table", "seeds"))
        tables.append((_name(entry["table"], f"{at}.table"), _seed_set(entry["seeds"], seed_sets, f"{at}.seeds")))
    return SuccessBar(
        bound=_fraction(bar["bound"], f"{where}.bound"),
        confidence=_fraction(bar["confidence"], f"{where}.confidence"),
        tables=tuple(tables),
        planners=tuple(_name(p, f"{where}.planners") for p in bar["planners"]),
    )


def _family(raw: Any, seed_sets: Mapping[str, tuple[int, ...]], where: str) -> Family:
    """One entry of ``families``."""
    raw = _keys(raw, FAMILY_KEYS, where, required=FAMILY_KEYS)
    if raw["correction"] not in CORRECTIONS:
        raise ProtocolError(f"{where}.correction: got {raw['correction']!r}, expected one of {', '.join(CORRECTIONS)}")
    if not isinstance(raw["primary"], bool):
        raise ProtocolError(f"{where}.primary: got {raw['primary']!r}, expected true or false")
    if not isinstance(raw["comparisons"], list) or not raw["comparisons"]:
        raise ProtocolError(f"{where}.comparisons: got {raw['comparisons']!r}, expected a non-empty list")
    comparisons = tuple(
        Comparison.from_mapping(c, f"{where}.comparisons[{j}]", seed_sets) for j, c in enumerate(raw["comparisons"])
    )
    return Family(
        _name(raw["name"], f"{where}.name"), _name(raw["question"], f"{where}.question"), raw["primary"],
        raw["correction"], comparisons,
    )  # fmt: skip


def parse_protocol(data: Any, source: str = "protocol") -> Protocol:
    """Check a protocol's content (the YAML file's mapping) and build it.

    Raises:
        ProtocolError: one line naming the first field that is wrong and what was expected.
    """
    data = _keys(data, PROTOCOL_KEYS, source, required=PROTOCOL_KEYS)
    resamples, seed = _bootstrap(data["bootstrap"], f"{source}.bootstrap")
    raw_sets = data["seed_sets"]
    if not isinstance(raw_sets, Mapping) or not raw_sets:
        raise ProtocolError(f"{source}.seed_sets: got {raw_sets!r}, expected a mapping of NAME: START:STOP")
    seed_sets = {str(k): _seeds(v, f"{source}.seed_sets.{k}") for k, v in raw_sets.items()}
    success = _success(data["success"], seed_sets, f"{source}.success")
    if not isinstance(data["families"], list) or not data["families"]:
        raise ProtocolError(f"{source}.families: got {data['families']!r}, expected a non-empty list")
    families = [_family(raw, seed_sets, f"{source}.families[{i}]") for i, raw in enumerate(data["families"])]
    for what, names in (
        ("families[].name", [f.name for f in families]),
        ("comparisons[].id", [c.id for f in families for c in f.comparisons]),
    ):
        duplicated = sorted({n for n in names if names.count(n) > 1})
        if duplicated:
            raise ProtocolError(f"{source}.{what}: {duplicated[0]!r} appears twice, expected unique names")
    if not any(f.primary for f in families):
        raise ProtocolError(f"{source}.families: no family is primary, expected at least one with primary: true")
    return Protocol(
        publication=_name(data["publication"], f"{source}.publication"),
        declared=_name(str(data["declared"]), f"{source}.declared"),
        alpha=_fraction(data["alpha"], f"{source}.alpha"),
        bootstrap_resamples=resamples,
        bootstrap_seed=seed,
        seed_sets=seed_sets,
        success=success,
        families=tuple(families),
    )


def load_protocol(path: str | Path) -> Protocol:
    """Read and check a protocol file.

    Raises:
        ProtocolError: unreadable, not YAML, or any field wrong (one line naming it).
    """
    import yaml

    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise ProtocolError(
            f"protocol {path}: cannot be read ({error.__class__.__name__}); expected a YAML file"
        ) from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise ProtocolError(f"protocol {path}: not valid YAML{where}") from None
    return parse_protocol(data, source=path.name)


# --- computing the answers ----------------------------------------------------------------------


ANSWER_COLUMNS = [
    "family",
    "primary",
    "id",
    "table",
    "measure",
    "unit",
    "other",
    "reference",
    "units",
    "median",
    "ci_low",
    "ci_high",
    "other_better",
    "reference_better",
    "undefined",
    "statistic",
    "pvalue",
    "pvalue_adjusted",
    "verdict",
]


def unit_costs(episodes: pd.DataFrame, comparison: Comparison) -> pd.DataFrame:
    """Per unit, the two policies' costs: rows = units, columns ``other`` and ``reference``.

    ``seed`` units: the episodes of ``table`` (a scenario) with the declared seeds; a seed counts
    when both policies flew it. ``member`` units: the members of ``table`` (a frozen suite) by
    scenario name, each policy's mean over the declared seeds it flew there; a member counts when
    both policies flew at least one of them (a suite's seed rule flies a deterministic policy once
    on a fixed start, where every seed would repeat its episode, docs/suite.md §4).
    """
    wanted = episodes[
        episodes["policy"].isin([comparison.other, comparison.reference])
        & episodes["seed"].isin(comparison.seeds)
    ]
    if comparison.unit == "seed":
        rows = wanted[wanted["scenario"] == comparison.table]
        table = rows.pivot_table(index="seed", columns="policy", values="total_cost", aggfunc="mean")
    else:
        from uav_penetration_env.suites import load_suite

        members = {m.scenario for m in load_suite(comparison.table).members}
        rows = wanted[wanted["scenario"].isin(members)]
        table = rows.pivot_table(index="scenario", columns="policy", values="total_cost", aggfunc="mean")
    table = table.reindex(columns=[comparison.other, comparison.reference])
    table.columns = ["other", "reference"]
    return table.dropna(axis=0, how="any")


def _window_answer(window_runs: pd.DataFrame, comparison: Comparison, protocol: Protocol) -> dict[str, float]:
    """A window measure's summary over windows (:func:`~.fixedtarget.window_comparisons`)."""
    from uav_penetration_env.benchmark import fixedtarget

    rows = window_runs[
        (window_runs["scenario"] == comparison.table)
        & window_runs["seed"].isin(comparison.seeds)
        & window_runs["optimizer"].isin([comparison.other, comparison.reference])
    ]
    if rows.empty:
        return {}
    # f_best comes from every run on the window, the long searches included, not the compared two alone.
    f_best = fixedtarget.window_best(window_runs[window_runs["scenario"] == comparison.table])
    table = fixedtarget.window_comparisons(
        rows,
        comparison.reference,
        f_best=f_best,
        precisions=(comparison.precision,) if comparison.precision else fixedtarget.TARGET_PRECISIONS[:1],
        seed=protocol.bootstrap_seed,
        n_resamples=protocol.bootstrap_resamples,
    )
    kind = fixedtarget.FIXED_TARGET if comparison.measure == "fixed_target" else fixedtarget.FIXED_BUDGET
    row = table[(table["other"] == comparison.other) & (table["comparison"] == kind)]
    return {} if row.empty else row.iloc[0][list(stats.unit_comparison([0.0], seed=0))].to_dict()


def _verdict(median: float, p_adjusted: float, alpha: float, other: str, reference: str) -> str:
    """The words of one answer: the cheaper (or faster) side where the corrected test rejects, else none."""
    if (
        p_adjusted is None
        or math.isnan(p_adjusted)
        or p_adjusted >= alpha
        or median == 0
        or math.isnan(median)
    ):
        return "no significant difference"
    return f"{other} better" if median < 0 else f"{reference} better"


def primary_answers(
    protocol: Protocol, episodes: pd.DataFrame, window_runs: pd.DataFrame | None = None
) -> pd.DataFrame:
    """Every declared comparison computed from the rows, Holm-corrected within its family.

    Args:
        protocol: the declared protocol.
        episodes: episode rows (``policy``, ``scenario``, ``seed``, ``total_cost``).
        window_runs: window-run rows, for the window measures.

    Returns:
        One row per comparison (:data:`ANSWER_COLUMNS`): ``median`` and its interval are of
        ``other − reference`` over units (negative: the other is cheaper or needs fewer
        evaluations), ``pvalue`` the raw two-sided Wilcoxon p over units, ``pvalue_adjusted`` Holm's
        within the family (a comparison with no data is NaN and does not count in the family),
        ``verdict`` the words at the protocol's alpha. A comparison whose rows are absent has
        ``units`` 0 and the verdict ``not flown``.
    """
    out = []
    for family in protocol.families:
        rows = []
        for c in family.comparisons:
            seed = stats.label_seed(protocol.bootstrap_seed, f"{protocol.publication}|{c.id}", 30)
            if c.unit == "window":
                summary = _window_answer(
                    window_runs
                    if window_runs is not None
                    else pd.DataFrame(columns=["scenario", "seed", "optimizer"]),
                    c,
                    protocol,
                )
            else:
                costs = unit_costs(episodes, c)
                summary = (
                    stats.unit_comparison(
                        costs["other"] - costs["reference"],
                        seed=seed,
                        n_resamples=protocol.bootstrap_resamples,
                    )
                    if len(costs)
                    else {}
                )
            rows.append(
                {
                    "family": family.name,
                    "primary": family.primary,
                    "id": c.id,
                    "table": c.table,
                    "measure": c.measure
                    if c.measure != "fixed_target"
                    else f"fixed_target Δ={c.precision:g}",
                    "unit": c.unit,
                    "other": c.other,
                    "reference": c.reference,
                    **{k: summary.get(k, math.nan) for k in ANSWER_COLUMNS[8:17]},
                }
            )
        adjusted = stats.holm([r["pvalue"] for r in rows])
        for row, p in zip(rows, adjusted, strict=True):
            row["units"] = int(0 if math.isnan(row["units"]) else row["units"])
            row["pvalue_adjusted"] = float(p)
            row["verdict"] = (
                "not flown"
                if row["units"] == 0
                else _verdict(row["median"], p, protocol.alpha, row["other"], row["reference"])
            )
        out += rows
    return pd.DataFrame(out, columns=ANSWER_COLUMNS)


def success_bar(protocol: Protocol, episodes: pd.DataFrame) -> pd.DataFrame:
    """Per declared table and planner: episodes, successes, the rate, its Wilson interval, the bar.

    A suite's episodes are its members' (by scenario name); only the table's declared seeds count.

    Returns:
        Columns ``table``, ``planner``, ``episodes``, ``successes``, ``rate``, ``wilson_low``,
        ``wilson_high``, ``meets`` (rate >= bound; NaN rate: not flown) and ``bound``.
    """
    from uav_penetration_env.suites import SuiteError, load_suite

    bar = protocol.success
    rows = []
    for table, seeds in bar.tables:
        try:
            scenarios = {m.scenario for m in load_suite(table).members}
        except SuiteError:
            scenarios = {table}
        for planner in bar.planners:
            mine = episodes[
                (episodes["policy"] == planner)
                & episodes["scenario"].isin(scenarios)
                & episodes["seed"].isin(seeds)
            ]
            n, k = len(mine), int((mine["outcome"] == "success").sum())
            low, high = stats.wilson_interval(k, n, bar.confidence)
            rate = k / n if n else math.nan
            rows.append(
                {
                    "table": table,
                    "planner": planner,
                    "episodes": n,
                    "successes": k,
                    "rate": rate,
                    "wilson_low": low,
                    "wilson_high": high,
                    "meets": bool(rate >= bar.bound) if n else None,
                    "bound": bar.bound,
                }
            )
    return pd.DataFrame(rows)


__all__ = [
    "Comparison",
    "Family",
    "Protocol",
    "ProtocolError",
    "SuccessBar",
    "load_protocol",
    "parse_protocol",
    "primary_answers",
    "success_bar",
    "unit_costs",
]
