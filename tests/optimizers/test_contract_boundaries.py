"""The contract (test_contract.py, optimizers.md §11.1 C1-C9) under every other boundary rule.

``test_contract.py`` checks every registered optimiser with its defaults (``absorb`` for the swarms).
Here the same test functions run again for every swarm optimiser with ``boundary`` set to each other
rule: the module's ``get_optimizer`` is replaced, for one test, by one that adds the rule.
"""

from __future__ import annotations

import pytest

from optimizers import get_optimizer
from optimizers.swarm import BOUNDARY_RULES, SwarmOptimizer
from tests.optimizers import test_contract as contract

SWARMS = [name for name in contract.NAMES if isinstance(get_optimizer(name), SwarmOptimizer)]
OTHER_RULES = [rule for rule in BOUNDARY_RULES if rule != "absorb"]


@pytest.fixture(params=OTHER_RULES)
def rule(request, monkeypatch):
    """Make the contract module build every optimiser with this boundary rule."""

    def with_rule(name, **params):
        return get_optimizer(name, boundary=request.param, **params)

    monkeypatch.setattr(contract, "get_optimizer", with_rule)
    return request.param


def test_the_swarms_are_every_name_but_the_references():
    assert set(SWARMS) == set(contract.NAMES) - contract.REFERENCES


def test_the_fixture_sets_the_rule(rule):
    assert contract.get_optimizer("pso").boundary == rule


@pytest.mark.parametrize("name", SWARMS)
def test_c1_in_bounds(rule, name):
    contract.test_c1_in_bounds(name)


@pytest.mark.parametrize("name", SWARMS)
@pytest.mark.parametrize("max_evals", [7, 1_000, 1_050])
def test_c2_budget(rule, name, max_evals):
    contract.test_c2_budget(name, max_evals)


@pytest.mark.parametrize("name", SWARMS)
def test_c3_result_consistency(rule, name):
    contract.test_c3_result_consistency(name)


@pytest.mark.parametrize("name", SWARMS)
def test_c4_determinism(rule, name):
    contract.test_c4_determinism(name)


@pytest.mark.parametrize("name", [n for n in SWARMS if n not in contract.C5_EXEMPT])
def test_c5_convergence(rule, name):
    contract.test_c5_convergence(name)


@pytest.mark.parametrize("name", SWARMS)
def test_c6_nan_handling(rule, name):
    contract.test_c6_nan_handling(name)


@pytest.mark.parametrize("name", SWARMS)
def test_c7_warm_start(rule, name):
    contract.test_c7_warm_start(name)


@pytest.mark.parametrize("name", SWARMS)
def test_c8_bad_input(rule, name):
    contract.test_c8_bad_input(name)


@pytest.mark.parametrize("name", SWARMS)
def test_c9_bounds_forms(rule, name):
    contract.test_c9_bounds_forms(name)
