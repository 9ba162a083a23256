"""Golden values: results that refactors must keep bit-identical.

The JSON files beside this test were written by ``golden_cases.write()`` before the architecture
refactor; these tests recompute each case and compare exactly (floats as hex), except for the
optimisers in ``golden_cases.PLATFORM_DEPENDENT``, whose results depend on the platform's linear
algebra and are checked at the outcome level. The planner episodes
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
    got = cases.optimizer_case(name, function, int(seed))
    want = OPTIMIZERS[key]
    if name not in cases.PLATFORM_DEPENDENT:
        assert got == want
        return
    # Outcome level (decisions.md 'Reproducibility'): the same budget spent, and a final value
    # within 1 % of the pinned one (measured across two machines: at most 1e-3 apart).
    assert got["nfev"] == want["nfev"]
    fun, pinned = float.fromhex(got["fun"]), float.fromhex(want["fun"])
    assert abs(fun - pinned) <= 1e-2 * (1.0 + abs(pinned))


def _planner_param(key: str):
    slow = key.endswith("/1")
    return pytest.param(key, marks=pytest.mark.slow) if slow else key


@pytest.mark.parametrize("key", [_planner_param(k) for k in sorted(PLANNERS)])
def test_planner_golden(key):
    name, seed = key.split("/")
    got = cases.planner_case(name, int(seed))
    if name not in cases.PLATFORM_DEPENDENT:
        assert got == PLANNERS[key]
        return
    # A CMA-ES episode amplifies the platform's last digits into another track (measured: the same
    # seed succeeds on one machine and collides on another), so only what holds everywhere is
    # checked: a complete episode, and the same numbers when flown again on this machine.
    assert got["outcome"] in {"success", "collided", "out_of_area", "truncated"}
    assert 1 <= got["steps"] <= 150 and got["nfev"] == got["steps"] * cases.PLANNER_BUDGET
    assert cases.planner_case(name, int(seed)) == got


def test_scenario_hashes_pinned():
    """The scenario hash seeds every episode: an accidental change would re-seed every stored result."""
    assert cases.scenario_hashes() == SCENARIOS
