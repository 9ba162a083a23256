"""A publication's declared protocol (docs/publishing.md §6): parsing, the answers, the success bar, the command."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from uav_penetration_env.benchmark import cli, stats
from uav_penetration_env.benchmark.protocol import (
    ProtocolError,
    load_protocol,
    parse_protocol,
    primary_answers,
    success_bar,
)

ROOT = Path(__file__).resolve().parents[2]
PROTOCOLS = sorted((ROOT / "leaderboards" / "protocols").glob("*.yaml"))

BASE = {
    "publication": "t",
    "declared": "2026-12-07",
    "alpha": 0.05,
    "bootstrap": {"resamples": 500, "seed": 1},
    "seed_sets": {"six": "0:6", "three": "0:3"},
    "success": {
        "bound": 0.99,
        "confidence": 0.95,
        "tables": [{"table": "s", "seeds": "six"}],
        "planners": ["a", "b"],
    },
    "families": [
        {
            "name": "main",
            "question": "Is a cheaper than b?",
            "primary": True,
            "correction": "holm",
            "comparisons": [
                {"id": "c1", "table": "s", "measure": "total_cost", "unit": "seed", "other": "a",
                 "reference": "b", "seeds": "six"},
            ],
        }
    ],
}


def protocol(**changes):
    data = copy.deepcopy(BASE)
    data.update(changes)
    return data


def episodes(rows):
    """(policy, scenario, seed, total_cost[, outcome]) tuples as episode rows."""
    frame = pd.DataFrame([r if len(r) == 5 else (*r, "success") for r in rows],
                         columns=["policy", "scenario", "seed", "total_cost", "outcome"])  # fmt: skip
    return frame


def test_the_committed_protocols_parse_and_declare_a_primary_family():
    assert {p.stem for p in PROTOCOLS} >= {"v4", "v3-reread"}
    for path in PROTOCOLS:
        declared = load_protocol(path)
        assert any(f.primary for f in declared.families) and declared.comparisons
        for c in declared.comparisons:  # every comparison's seeds come from a declared set
            assert c.seeds in declared.seed_sets.values()


@pytest.mark.parametrize(
    ("change", "field"),
    [
        (lambda d: d.update(colour="red"), "t.colour: unknown key"),
        (lambda d: d["families"][0]["comparisons"][0].update(measure="speed"), "comparisons[0].measure: got 'speed'"),
        (lambda d: d["families"][0]["comparisons"][0].update(unit="window"), "comparisons[0].unit: got 'window' for measure total_cost"),
        (lambda d: d["families"][0]["comparisons"][0].update(seeds="ten"), "comparisons[0].seeds: got 'ten', expected the name of a seed set"),
        (lambda d: d["families"][0]["comparisons"][0].update(other="b"), "comparisons[0].other: got 'b', the reference itself"),
        (lambda d: d["families"][0]["comparisons"][0].update(measure="fixed_target", unit="window"), "comparisons[0].precision: got None"),
        (lambda d: d["families"][0].update(primary=False), "t.families: no family is primary"),
        (lambda d: d["families"][0]["comparisons"].append(dict(d["families"][0]["comparisons"][0])), "comparisons[].id: 'c1' appears twice"),
        (lambda d: d["seed_sets"].update(six="6:0"), "t.seed_sets.six: got '6:0'"),
        (lambda d: d.update(alpha=1.5), "t.alpha: got 1.5, expected a number in (0, 1)"),
        (lambda d: d["success"]["tables"][0].pop("seeds"), "success.tables[0].seeds: missing"),
    ],
)  # fmt: skip
def test_a_broken_protocol_is_refused_in_one_line_naming_the_field(change, field):
    data = protocol()
    change(data)
    with pytest.raises(ProtocolError) as error:
        parse_protocol(data, source="t")
    message = str(error.value)
    assert field in message and "\n" not in message


def test_an_answer_by_hand_and_holm_within_the_family_only():
    # a − b = −1 … −6 over six seeds: median −3.5, all one sign, exact two-sided p = 2 / 2**6.
    rows = [("a", "s", s, 10.0 - (s + 1)) for s in range(6)] + [("b", "s", s, 10.0) for s in range(6)]
    one = primary_answers(parse_protocol(protocol()), episodes(rows)).iloc[0]
    assert one["units"] == 6 and one["median"] == -3.5 and one["other_better"] == 6
    assert one["pvalue"] == pytest.approx(2 / 2**6) and one["pvalue_adjusted"] == pytest.approx(2 / 2**6)
    assert one["verdict"] == "a better" and one["ci_low"] <= -3.5 <= one["ci_high"]
    # A second primary comparison in the same family (c identical to b: p = 1) doubles the smaller p...
    same_family = protocol()
    same_family["families"][0]["comparisons"].append(
        {"id": "c2", "table": "s", "measure": "total_cost", "unit": "seed", "other": "c", "reference": "b", "seeds": "six"}
    )
    rows_c = rows + [("c", "s", s, 10.0) for s in range(6)]
    two = primary_answers(parse_protocol(same_family), episodes(rows_c)).set_index("id")
    assert two.loc["c1", "pvalue_adjusted"] == pytest.approx(2 * 2 / 2**6)
    assert two.loc["c1", "verdict"] == "no significant difference" and two.loc["c2", "verdict"] == "no significant difference"
    # ... while the same comparison in a family of its own, or beside an unflown one, keeps its p.
    other_family = protocol()
    other_family["families"].append(
        {"name": "more", "question": "q", "primary": False, "correction": "holm",
         "comparisons": [dict(same_family["families"][0]["comparisons"][1])]}
    )  # fmt: skip
    apart = primary_answers(parse_protocol(other_family), episodes(rows_c)).set_index("id")
    assert apart.loc["c1", "pvalue_adjusted"] == pytest.approx(2 / 2**6)
    unflown = primary_answers(parse_protocol(same_family), episodes(rows)).set_index("id")
    assert unflown.loc["c2", "verdict"] == "not flown" and unflown.loc["c2", "units"] == 0
    assert unflown.loc["c1", "pvalue_adjusted"] == pytest.approx(2 / 2**6)  # NaN p is not in the family


def test_member_units_average_each_policys_declared_seeds_first():
    from uav_penetration_env.suites import load_suite

    members = [m.scenario for m in load_suite("uavpen-heldout-v1").members][:4]
    data = protocol()
    data["families"][0]["comparisons"][0].update(table="uavpen-heldout-v1", unit="member", seeds="three")
    rows = []
    for i, member in enumerate(members):
        rows += [("b", member, s, 5.0 + s) for s in range(3)]  # mean 6.0 on every member
        # a: seeds 0-2 with mean 6 − (i + 1) on the first three members; seed 0 alone on the last one.
        seeds = range(3) if i < 3 else range(1)
        rows += [("a", member, s, 5.0 + s - (i + 1) if i < 3 else 2.0) for s in seeds]
    rows.append(("a", members[0], 7, -100.0))  # a seed outside the declared set never counts
    answer = primary_answers(parse_protocol(data), episodes(rows)).iloc[0]
    # Differences per member: −1, −2, −3 and 2.0 − 6.0 = −4 → median −2.5 over 4 members.
    assert answer["units"] == 4 and answer["median"] == -2.5


def test_the_success_bar_counts_the_declared_seeds_with_wilson_intervals():
    rows = [("a", "s", s, 1.0, "success") for s in range(6)] + [("b", "s", s, 1.0, "crash" if s == 2 else "success")
                                                              for s in range(6)]  # fmt: skip
    rows.append(("b", "s", 99, 1.0, "crash"))  # outside the declared seeds
    bar = success_bar(parse_protocol(protocol()), episodes(rows)).set_index("planner")
    assert (bar.loc["a", "successes"], bar.loc["a", "episodes"], bar.loc["a", "meets"]) == (6, 6, True)
    assert (bar.loc["b", "successes"], bar.loc["b", "episodes"], bar.loc["b", "meets"]) == (5, 6, False)
    assert (bar.loc["b", "wilson_low"], bar.loc["b", "wilson_high"]) == pytest.approx(stats.wilson_interval(5, 6))


def test_extended_median_and_unit_comparison_with_infinities():
    assert stats.extended_median([1.0, math.inf]) == math.inf
    assert stats.extended_median([-math.inf, math.inf]) == 0.0
    assert stats.extended_median([3.0, -1.0, 2.0]) == 2.0
    with pytest.raises(ValueError, match="values: got NaN"):
        stats.extended_median([1.0, math.nan])
    # An infinite difference ranks above every finite one: [−∞, −1, 2] ranks as [−3, −1, 2] would.
    with_inf = stats.unit_comparison([-math.inf, -1.0, 2.0, math.nan], seed=0, n_resamples=200)
    capped = stats.unit_comparison([-3.0, -1.0, 2.0], seed=0, n_resamples=200)
    assert with_inf["pvalue"] == capped["pvalue"] and with_inf["statistic"] == capped["statistic"]
    assert (with_inf["units"], with_inf["undefined"], with_inf["other_better"]) == (3, 1, 2)
    assert with_inf["median"] == -1.0 and with_inf["ci_low"] == -math.inf
    assert stats.unit_comparison([0.0, 0.0], seed=0)["pvalue"] == 1.0


def test_the_command_prints_and_writes_the_answers(tmp_path, capsys):
    stem = tmp_path / "rows"
    rows = episodes([("a", "s", s, 10.0 - (s + 1)) for s in range(6)] + [("b", "s", s, 10.0) for s in range(6)])
    full = rows.assign(episode_id=np.arange(len(rows)) + 1, scenario_hash="ab", policy_hash="p", run_id=1)
    full.to_csv(f"{stem}-episodes.csv", index=False)
    pd.DataFrame(columns=["run_id"]).to_csv(f"{stem}-runs.csv", index=False)
    path = tmp_path / "p.yaml"
    path.write_text(yaml.safe_dump(protocol()))
    assert cli.main(["protocol", str(path), "--rows", str(stem), "--out", str(tmp_path / "out")]) == 0
    assert "| c1 " in capsys.readouterr().out
    written = pd.read_csv(tmp_path / "out" / "protocol-answers.csv")
    assert written.loc[0, "verdict"] == "a better"
    broken = tmp_path / "broken.yaml"
    broken.write_text("publication: [\n")
    assert cli.main(["protocol", str(broken), "--rows", str(stem)]) == 2
    assert "not valid YAML" in capsys.readouterr().err


# --- fuzzing: any mutation of a valid protocol is a ProtocolError or a protocol, never another exception ---

JUNK = [None, True, 0, -1, 1.5, float("nan"), "", "x", "0:0", "5:1", [], {}, [1, "a"], {"a": 1}, "paper", "holm"]


def _mutations():
    from hypothesis import strategies as st

    def paths(node, prefix=()):
        yield prefix
        if isinstance(node, dict):
            for key, value in node.items():
                yield from paths(value, (*prefix, key))
        elif isinstance(node, list):
            for i, value in enumerate(node):
                yield from paths(value, (*prefix, i))

    data = yaml.safe_load((ROOT / "leaderboards" / "protocols" / "v4.yaml").read_text())
    return data, st.lists(st.tuples(st.sampled_from(list(paths(data))[1:]), st.sampled_from([*JUNK, "DELETE"])), min_size=1, max_size=3)


def _fuzz(examples):
    from hypothesis import HealthCheck, given, settings

    data, mutations = _mutations()

    @settings(max_examples=examples, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(mutations)
    def check(changes):
        mutated = copy.deepcopy(data)
        for path, value in changes:
            node = mutated
            try:
                for key in path[:-1]:
                    node = node[key]
                if value == "DELETE":
                    del node[path[-1]]
                else:
                    node[path[-1]] = value
            except (KeyError, IndexError, TypeError):
                continue  # an earlier change removed or replaced this path
        try:
            parse_protocol(mutated, source="fuzz")
        except ProtocolError as error:
            assert "\n" not in str(error) and str(error).startswith("fuzz")

    check()


def test_mutated_protocols_are_refused_in_one_line_or_accepted():
    _fuzz(300)


@pytest.mark.slow
def test_five_thousand_mutated_protocols():
    _fuzz(5_000)
