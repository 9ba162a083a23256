"""The contract (test_contract.py, optimizers.md §11.1 C1-C9) under every other boundary rule.

``test_contract.py`` checks every registered optimiser with its defaults (``absorb`` for the swarms).
Here the checks a boundary rule can change run again with ``boundary`` set to each other rule: the
module's ``get_optimizer`` is replaced, for one test, by one that adds the rule.

The rules live in the shared swarm loop (optimizers/swarm.py), so each rule is checked once per
optimiser family (one registered name per swarm class), not for every configuration of a class:
a configuration changes parameters, not where positions are put back into the box. The checks
that cannot depend on the rule (C8's argument errors and C9's bounds forms, both decided before
the first move) are not repeated.
"""

from __future__ import annotations

import pytest

from optimizers import get_optimizer
from optimizers.swarm import BOUNDARY_RULES, SwarmOptimizer
from tests.optimizers import test_contract as contract

SWARMS = [name for name in contract.NAMES if isinstance(get_optimizer(name), SwarmOptimizer)]
# The first registered name of each swarm class (the registry is sorted): one per family.
FAMILIES = list({type(get_optimizer(name)): name for name in reversed(SWARMS)}.values())[::-1]
OTHER_RULES = [rule for rule in BOUNDARY_RULES if rule != "absorb"]


@pytest.fixture(params=OTHER_RULES)
def rule(request, monkeypatch):
    """Make the contract module build every optimiser with this boundary rule."""

    def with_rule(name, **params):
        return get_optimizer(name, boundary=request.param, **params)

    monkeypatch.setattr(contract, "get_optimizer", with_rule)
    return request.param


def test_the_swarms_are_every_name_but_the_references():
    builtin = {n for n in contract.NAMES if type(get_optimizer(n)).__module__.startswith("optimizers.")}
    assert set(SWARMS) == builtin - contract.REFERENCES


def test_the_fixture_sets_the_rule(rule):
    assert contract.get_optimizer("pso").boundary == rule


def test_one_name_per_swarm_class():
    classes = [type(get_optimizer(name)) for name in FAMILIES]
    assert len(set(classes)) == len(classes) == len({type(get_optimizer(n)) for n in SWARMS})
    assert {"pso", "ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism"} == set(FAMILIES)


ONE_ARGUMENT_CHECKS = [
    "test_c1_in_bounds",
    "test_c3_result_consistency",
    "test_c4_determinism",
    "test_c6_nan_handling",
    "test_c7_warm_start",
]
RULE_INDEPENDENT = {"test_c8_bad_input", "test_c9_bounds_forms", "test_c5_exemptions_are_registered", "test_c8_registry_errors"}


@pytest.mark.parametrize("name", FAMILIES)
@pytest.mark.parametrize("check", ONE_ARGUMENT_CHECKS)
def test_contract(rule, check, name):
    getattr(contract, check)(name)


@pytest.mark.parametrize("name", FAMILIES)
def test_c2_budget(rule, name):
    contract.test_c2_budget(name, 1_050)  # a truncated last iteration: the rule acts on a partial batch


@pytest.mark.parametrize("name", [n for n in FAMILIES if n not in contract.C5_EXEMPT])
def test_c5_convergence(rule, name):
    contract.test_c5_convergence(name)


def test_every_contract_check_runs_here_or_cannot_depend_on_the_rule():
    checks = {n for n in dir(contract) if n.startswith("test_c") and callable(getattr(contract, n))}
    covered = set(ONE_ARGUMENT_CHECKS) | {"test_c2_budget", "test_c5_convergence"}
    assert checks - covered == RULE_INDEPENDENT
