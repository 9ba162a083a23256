"""Golden values: results that refactors must keep bit-identical (issue 9).

The JSON files beside this test were written by ``golden_cases.write()`` before the architecture
refactor; these tests recompute each case and compare exactly (floats as hex). The planner episodes
of seed 1 and of the reference optimisers are marked slow; seed 0 of every planner runs by default.
"""

from __future__ import annotations

import json

import pytest

from tests.golden import golden_cases as cases

OPTIMIZERS = json.loads(cases.OPTIMIZER_FILE.read_text())
PLANNERS = json.loads(cases.PLANNER_FILE.read_text())
SCENARIOS = json.loads(cases.SCENARIO_FILE.read_text())


def test_golden_files_cover_every_registered_optimizer():
    from optimizers import available_optimizers

    names = {key.split("/")[0] for key in OPTIMIZERS}
    assert names == set(available_optimizers())
    assert {key.split("/")[0] for key in PLANNERS} == set(cases.planner_names())


@pytest.mark.parametrize("key", sorted(OPTIMIZERS))
def test_optimizer_golden(key):
    name, function, seed = key.split("/")
    assert cases.optimizer_case(name, function, int(seed)) == OPTIMIZERS[key]


def _planner_param(key: str):
    slow = key.endswith("/1")
    return pytest.param(key, marks=pytest.mark.slow) if slow else key


@pytest.mark.parametrize("key", [_planner_param(k) for k in sorted(PLANNERS)])
def test_planner_golden(key):
    name, seed = key.split("/")
    assert cases.planner_case(name, int(seed)) == PLANNERS[key]


def test_scenario_hashes_pinned():
    """The scenario hash seeds every episode: an accidental change would re-seed every stored result."""
    assert cases.scenario_hashes() == SCENARIOS
