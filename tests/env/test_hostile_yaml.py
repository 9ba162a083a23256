"""Scenario files PyYAML would accept but that hang, crash or silently drop what was written."""

from __future__ import annotations

import time

import pytest

from uav_penetration_env import ScenarioError, load_scenario
from uav_penetration_env.scenario.files import MAX_DEPTH, MAX_NODES, load_yaml_text


def test_a_duplicate_key_is_refused_naming_it_and_its_line():
    with pytest.raises(ScenarioError, match=r"duplicate key 'time' \(each key may appear once\) at line 3"):
        load_yaml_text("time: {max_steps: 5}\nname: x\ntime: {max_steps: 6}\n", "f.yaml")


def test_a_merge_key_may_be_overridden_as_yaml_says():
    data = load_yaml_text("base: &b {a: 1, b: 2}\nmine:\n  <<: *b\n  b: 3\n", "f.yaml")
    assert data["mine"] == {"a": 1, "b": 3}


def test_nesting_deeper_than_the_limit_is_refused_at_once():
    start = time.perf_counter()
    with pytest.raises(ScenarioError, match=f"nested deeper than {MAX_DEPTH} levels"):
        load_yaml_text("x: " + "[" * 5000 + "]" * 5000, "f.yaml")
    assert load_yaml_text("x: " + "[" * (MAX_DEPTH - 2) + "]" * (MAX_DEPTH - 2), "f.yaml")
    assert time.perf_counter() - start < 30  # generous: the unguarded loader recursed for ~40 s


def test_an_alias_bomb_is_counted_not_built():
    anchors = "{a: &a [x,x,x,x,x,x,x,x,x], " + ", ".join(
        f"{c}: &{c} [{','.join(['*' + p] * 9)}]" for p, c in zip("abcdefgh", "bcdefghi", strict=True)
    ) + "}"
    with pytest.raises(ScenarioError, match=f"at most {MAX_NODES:,} YAML nodes"):
        load_yaml_text(f"bomb: {anchors}\n", "f.yaml")
    assert load_yaml_text("a: &a [1, 2]\nb: *a\n", "f.yaml") == {"a": [1, 2], "b": [1, 2]}


def test_a_key_that_is_not_a_plain_value_is_refused():
    with pytest.raises(ScenarioError, match=r"a key that is not a plain value \(list\)"):
        load_yaml_text("? [1, 2]\n: x\n", "f.yaml")


def test_a_file_that_is_not_utf8_is_a_scenario_error(tmp_path):
    path = tmp_path / "latin1.yaml"
    path.write_bytes("name: caf\xe9\n".encode("latin-1"))
    with pytest.raises(ScenarioError, match=r"expected a UTF-8 text file \(byte 9 is not UTF-8\)"):
        load_scenario(path)
