"""Policy names read once (api.md §4.1): the grammar, the published names as aliases, errors, quoting."""

from __future__ import annotations

import pytest
from fake_policy_kind import fake_kind
from hypothesis import given
from hypothesis import strategies as st

from uav_penetration_env.benchmark import plugins
from uav_penetration_env.benchmark.policies import (
    LatticePolicy,
    MPCPolicy,
    ValueGreedyPolicy,
    make_policy,
    parse_policy,
    policy_label,
    unknown_policy,
)
from uav_penetration_env.benchmark.policy_names import ClearanceParams, PlannerParams
from uav_penetration_env.benchmark.policy_spec import (
    PolicyValueError,
    Term,
    UnknownPolicyError,
    format_term,
    parse_terms,
    quote,
)
from uav_penetration_env.mpc import Terminal


@pytest.fixture
def fake(monkeypatch):
    """Plug-in discovery answers with the fake kind alone (``fake[path=PATH]``, published ``fake:PATH``)."""
    loaded: list[str] = []
    kind = fake_kind(loaded, hybrid=lambda params, planner: planner)
    found = {plugins.POLICY_GROUP: {"fake": plugins.Plugin("fake", kind)}, plugins.COMMAND_GROUP: {}}
    monkeypatch.setattr(plugins, "discover", lambda group: found[group])
    return loaded


# Every published form of the built-in kinds, its bracket form written by hand, and its parameters.
PUBLISHED = [
    ("ihpso", "ihpso", PlannerParams()),
    ("ihpso-eq37", "ihpso[terminal=none]", PlannerParams("none")),
    ("ihpso-ctg-value", "ihpso[terminal=value]", PlannerParams("value")),
    ("hpso-ctg-distance", "hpso[terminal=distance]", PlannerParams("distance")),
    ("ccpso-ism-ctg-dubins", "ccpso-ism[terminal=dubins]", PlannerParams("dubins")),
    ("ihpso-noterm-eq37", "ihpso-noterm[terminal=none]", PlannerParams("none")),
    ("lattice", "lattice", ClearanceParams()),
    ("lattice-c40", "lattice[clearance=40]", ClearanceParams(40)),
    ("lattice-c60", "lattice[clearance=60]", ClearanceParams(60)),
    ("value-greedy-c40", "value-greedy[clearance=40]", ClearanceParams(40)),
    ("greedy", "greedy", None),
    ("random", "random", None),
]


@pytest.mark.parametrize("name, canonical, params", PUBLISHED)
def test_a_published_name_reads_as_its_bracket_form_and_keeps_its_label(name, canonical, params, fake):
    spec = parse_policy(name)
    assert spec.canonical() == canonical and spec.label == name
    if params is not None:
        assert spec.params == params
    again = parse_policy(canonical)
    assert again == spec and again.label == name  # the label of the new spelling is the published name


@pytest.mark.parametrize(
    "published, bracket, label, path",
    [
        ("fake:dir/agent.zip", "fake[path=dir/agent.zip]", "fake:agent", "dir/agent.zip"),
        (
            "fake:dir/a+b.zip",
            "fake[path=dir/a+b.zip]",
            "fake:a+b",
            "dir/a+b.zip",
        ),  # '+' after ':' is the path's
        ("fake:dir/a,b=c.zip", 'fake[path="dir/a,b=c.zip"]', "fake:a,b=c", "dir/a,b=c.zip"),
    ],
)
def test_a_plugin_form_reads_as_its_bracket_form(published, bracket, label, path, fake):
    spec = parse_policy(published)
    assert (spec.kind, spec.family, spec.params.path, spec.label) == ("fake", "plugin", path, label)
    assert spec.canonical() == bracket and parse_policy(bracket) == spec


def test_hybrids_read_alike_in_both_grammars(fake):
    published = parse_policy("ihpso-eq37+fake:dir/agent.zip")
    for text in (
        "ihpso[terminal=none]+fake[path=dir/agent.zip]",
        "ihpso-eq37+fake[path=dir/agent.zip]",
        "ihpso[terminal=none]+fake:dir/agent.zip",
    ):
        assert parse_policy(text) == published, text
    assert published.label == "ihpso-eq37+fake:agent" and published.base_label == "ihpso-eq37"
    assert published.canonical() == "ihpso[terminal=none]+fake[path=dir/agent.zip]"
    assert published.warm_start is not None and published.warm_start.params.path == "dir/agent.zip"


def test_new_and_published_spellings_build_the_same_policy(fake):
    pairs = [
        ("lattice[clearance=60]", "lattice-c60"),
        ("value-greedy[clearance=40]", "value-greedy-c40"),
        ("ihpso[terminal=none]", "ihpso-eq37"),
        ("hpso[terminal=distance]", "hpso-ctg-distance"),
    ]
    for new, published in pairs:
        a, b = make_policy(new, max_evals=50), make_policy(published, max_evals=50)
        assert type(a) is type(b) and a.config() == b.config(), new
        assert policy_label(new) == policy_label(published) == published
    lattice = make_policy("lattice[clearance=60]")
    assert isinstance(lattice, LatticePolicy) and lattice.guidance.clearance_m == 60.0
    assert isinstance(make_policy("value-greedy"), ValueGreedyPolicy)
    planner = make_policy("hpso[terminal=distance]", terminal_cost=0.3)
    assert isinstance(planner, MPCPolicy) and planner.settings.terminal == Terminal("distance", 0.3)
    assert planner.name == "hpso-ctg-distance"
    hybrid = make_policy("ihpso[terminal=none]+fake[path=m.zip]", horizon=3, max_evals=40)
    assert isinstance(hybrid, MPCPolicy) and hybrid.name == "ihpso-eq37" and hybrid.settings.horizon == 3
    make_policy("fake[path=dir/a.zip]")
    assert fake == ["dir/a.zip"]


@pytest.mark.parametrize(
    "text, error, message",
    [
        ("ihspo", UnknownPolicyError, "unknown policy 'ihspo' — did you mean 'ihpso'"),
        ("ihspo[terminal=none]", UnknownPolicyError, "did you mean 'ihpso'"),
        (
            "fakee:x",
            UnknownPolicyError,
            "no installed plug-in provides the kind 'fakee' (entry points "
            "uav_penetration.policies); did you mean 'fake'?",
        ),
        (
            "lattice[clearence=60]",
            PolicyValueError,
            "unknown parameter 'clearence' of the kind 'lattice' — did you mean 'clearance'? its parameters: clearance",
        ),
        (
            "lattice[clearance=5]",
            PolicyValueError,
            "clearance: got '5', expected an integer number of metres in [10, 1000]",
        ),
        (
            "lattice[clearance=60.5]",
            PolicyValueError,
            "clearance: got '60.5', expected an integer number of metres",
        ),
        (
            "lattice-c2000",
            PolicyValueError,
            "clearance: got '2000', expected an integer number of metres in [10, 1000]",
        ),
        (
            "ihpso[terminal=eq37]",
            PolicyValueError,
            "terminal: got 'eq37', expected one of none, distance, dubins, value",
        ),
        ("greedy[terminal=none]", PolicyValueError, "unknown parameter 'terminal' of the kind 'greedy'"),
        ("fake", PolicyValueError, "the kind 'fake' needs the parameter 'path' (a path)"),
        ("fake[path=]", PolicyValueError, "at character 11, expected a value (quote one that is empty"),
        ('fake[path=""]', PolicyValueError, "path: got '', expected a path"),
        ("lattice[clearance=60", PolicyValueError, "at character 21, expected ',' or ']', got the end"),
        ("lattice[clearance=60,clearance=70]", PolicyValueError, "parameter 'clearance' given twice"),
        (
            "lattice[clearance=60]x",
            PolicyValueError,
            "at character 22, expected '+', '[' or the end, got 'x'",
        ),
        (
            'fake[path="a\\qb"]',
            PolicyValueError,
            'at character 13, expected an escape \\" or \\\\ inside quotes',
        ),
        ('fake[path="ab]', PolicyValueError, "expected the closing '\"', got the end"),
        ("greedy+fake:m.zip", UnknownPolicyError, "a hybrid is PLANNER+AGENT with an MPC planner"),
        ("ihpso+lattice", UnknownPolicyError, "the kind 'lattice' cannot warm-start a planner"),
        ("ihpso+fake:a+fake:b", PolicyValueError, None),  # the path of the second term is 'a+fake:b': fine
        ("ihpso+fake[path=a]+fake[path=b]", PolicyValueError, "expected the end (a hybrid has one '+')"),
    ],
)
def test_a_bad_name_is_one_line_naming_the_parameter_and_the_expected_value(text, error, message, fake):
    if message is None:
        assert parse_policy(text).warm_start.params.path == "a+fake:b"
        return
    with pytest.raises(error) as raised:
        parse_policy(text)
    assert message in str(raised.value) and "\n" not in str(raised.value)
    assert str(raised.value).startswith(("unknown policy", f"policy {text!r}: "))
    assert unknown_policy(text) == str(raised.value)  # the fast refusal says the same


@pytest.mark.parametrize(
    "value, written",
    [
        ("dir/agent.zip", "dir/agent.zip"),
        ("C:\\models\\a b.zip", "C:\\models\\a b.zip"),  # a bare value keeps backslashes and spaces
        ("a,b", '"a,b"'),
        ("a]b", '"a]b"'),
        ("a[b", '"a[b"'),
        ("k=v", '"k=v"'),
        ('say "hi"', '"say \\"hi\\""'),
        ('back\\slash,"', '"back\\\\slash,\\""'),  # quoted: a backslash is written twice
        ("", '""'),
    ],
)
def test_values_holding_special_characters_are_quoted_and_read_back(value, written, fake):
    assert quote(value) == written
    text = format_term("fake", [("path", value)])
    assert text == f"fake[path={written}]"
    term, warm = parse_terms(text)
    assert term.params == (("path", value),) and warm is None
    if value:
        assert parse_policy(text).params.path == value and parse_policy(text).canonical() == text


def test_every_published_name_of_the_v3_tables_is_its_own_label(fake):
    """The rows' labels stay the store keys: each built-in label of the published tables reads back to itself."""
    from pathlib import Path

    import pandas as pd

    table = Path(__file__).resolve().parents[2] / "leaderboards" / "v3" / "paper-2022-sec5.csv"
    labels = sorted(set(pd.read_csv(table)["policy"].astype(str)))
    builtin = [label for label in labels if ":" not in label]
    assert {"ihpso-eq37", "lattice-c40", "ihpso-ctg-dubins", "greedy"} <= set(builtin)
    for label in builtin:
        assert policy_label(label) == label
        assert policy_label(parse_policy(label).canonical()) == label


@given(st.text(min_size=1))
def test_any_value_reads_back_from_its_written_form(value):
    """Quoting is lossless: every non-empty text, written by ``quote``, parses back to itself."""
    term, warm = parse_terms(format_term("fake", [("path", value), ("other", value)]))
    assert term == Term("fake", params=(("path", value), ("other", value))) and warm is None
