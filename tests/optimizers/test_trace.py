"""``OptimizeResult.trace``: the state machine of the optimisers with phases (docs/swarm.md §6)."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

import optimizers.ihpso as ihpso_module
from optimizers import BudgetedObjective, OptimizeResult, get_optimizer


def sphere(x):
    return (x * x).sum(axis=1)


BOUNDS = [(-1.0, 1.0)] * 3


def test_trace_is_read_only_and_empty_by_default():
    objective = BudgetedObjective(sphere, 3, 10)
    objective(np.zeros((2, 3)))
    objective.record()
    res = objective.result(0, "done")
    assert isinstance(res, OptimizeResult) and dict(res.trace) == {}
    with pytest.raises(TypeError):
        res.trace["mode"] = ()  # type: ignore[index]
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.trace = {}  # type: ignore[misc]
    ihpso = get_optimizer("ihpso").minimize(sphere, BOUNDS, rng=0, max_evals=500)
    again = pickle.loads(pickle.dumps(ihpso))  # results travel between worker processes
    assert dict(again.trace) == dict(ihpso.trace) and len(ihpso.trace) == 8
    for name in ("pso", "cem", "mcpso", "ccpso-ism"):  # no phases
        assert dict(get_optimizer(name).minimize(sphere, BOUNDS, rng=0, max_evals=500).trace) == {}


def test_hpso_stage_boundary_and_regroupings():
    # 1,100 evaluations, N = 100: T = 10 planned iterations, n1 = floor(0.8 * 10 + 0.5) = 8, so stage 2
    # starts at iteration 9. With T_r = 3 the groups are redrawn when 3 iterations have passed since the
    # last grouping: at the start of iterations 4 and 7 (10 would be, but it is in stage 2).
    res = get_optimizer("hpso", regroup_period=3).minimize(sphere, BOUNDS, rng=0, max_evals=1_100)
    assert res.nit == 10
    assert dict(res.trace) == {"stage1_iterations": 8, "stage2_start": 9, "regroup_iterations": (4, 7)}


def test_hpso_run_that_ends_in_stage_1():
    # 300 evaluations: T = 2, n1 = floor(1.6 + 0.5) = 2, and the run has exactly 2 iterations.
    res = get_optimizer("hpso").minimize(sphere, BOUNDS, rng=0, max_evals=300)
    assert res.nit == 2 and res.trace["stage1_iterations"] == 2 and res.trace["stage2_start"] is None


def test_lpso_global_best_from():
    # 2,100 evaluations: T = 20; frac(l) = (3 l + 0.6 T) / T exceeds 0.9 once 3 l > 6, i.e. l = 3, t = 4.
    res = get_optimizer("lpso").minimize(sphere, BOUNDS, rng=0, max_evals=2_100)
    assert res.trace["global_best_from"] == 4


def test_ps2o_extinctions_on_a_plateau():
    # A constant objective: no species ever improves after initialisation. With patience 30 every species
    # but species 0 (which holds the global best: all costs tie, the lowest index wins) dies at iteration
    # 31; re-seeded species improve once (their pbest cost restarts at +inf) and die again 31 later.
    res = get_optimizer("ps2o").minimize(lambda x: np.ones(len(x)), BOUNDS, rng=0, max_evals=7_100)
    assert res.nit == 70
    assert res.trace["extinctions"] == ((31, (1, 2, 3, 4)), (62, (1, 2, 3, 4)))
    noext = get_optimizer("ps2o-noext").minimize(lambda x: np.ones(len(x)), BOUNDS, rng=0, max_evals=7_100)
    assert noext.trace["extinctions"] == ()


def scripted_ihpso(monkeypatch, switch_at, zero_slopes, converged):
    """Replace IHPSO's three decisions by scripts: switch at these iterations, and the next answers."""
    zero_slopes, converged = iter(zero_slopes), iter(converged)
    monkeypatch.setattr(ihpso_module, "switch_due", lambda slopes, t, *args: t in switch_at)
    monkeypatch.setattr(ihpso_module, "slope_is_zero", lambda *args: next(zero_slopes))
    monkeypatch.setattr(ihpso_module, "spreads_converge", lambda *args: next(converged))


def test_ihpso_trace_of_a_scripted_run(monkeypatch):
    # Broad 1-3, switch after 3; accurate 4-5, zero slope at 5 with eq. 33 false: reverse switch after 5;
    # broad 6-7, switch after 7; accurate 8, zero slope and eq. 33 true: stop after iteration 8.
    scripted_ihpso(monkeypatch, switch_at={3, 7}, zero_slopes=[False, True, True], converged=[False, True])
    res = get_optimizer("ihpso").minimize(sphere, BOUNDS, rng=0, max_evals=5_000)
    assert res.nit == 8 and res.message == "adaptive termination (eqs. 29-33)"
    assert dict(res.trace) == {
        "mode": ("broad",) * 3 + ("accurate",) * 2 + ("broad",) * 2 + ("accurate",),
        "switch_iterations": (3, 7),
        "reverse_switch_iterations": (5,),
        "termination_tests": ((5, False), (8, True)),
        "locked_at": None,
        "termination_spreads": res.trace["termination_spreads"],
        "levels": res.trace["levels"],
        "stopped_by": "termination",
    }
    assert len(res.trace["levels"]) == res.nit + 1  # J(0) .. J(nit)


def test_ihpso_noterm_trace_locks(monkeypatch):
    # Same script, but without termination: accurate mode is locked at 8 and the budget runs out:
    # 1,500 evaluations = initialisation + 14 iterations.
    scripted_ihpso(monkeypatch, switch_at={3, 7}, zero_slopes=[False, True, True], converged=[False, True])
    res = get_optimizer("ihpso-noterm").minimize(sphere, BOUNDS, rng=0, max_evals=1_500)
    assert res.nit == 14 and res.message == "max_evals reached"
    assert res.trace["mode"] == ("broad",) * 3 + ("accurate",) * 2 + ("broad",) * 2 + ("accurate",) * 7
    assert res.trace["locked_at"] == 8 and res.trace["stopped_by"] == "max_evals"
    assert res.trace["termination_tests"] == ((5, False), (8, True))


@pytest.mark.parametrize("seed", [0, 1])
def test_ihpso_trace_agrees_with_the_run(seed):
    res = get_optimizer("ihpso").minimize(sphere, BOUNDS, rng=seed, max_evals=10_000)
    trace = res.trace
    modes = trace["mode"]
    assert len(modes) == res.nit
    # A switch after iteration t is a change broad -> accurate between iterations t and t + 1.
    changes_up = tuple(t for t in range(1, res.nit) if modes[t - 1] == "broad" and modes[t] == "accurate")
    changes_down = tuple(t for t in range(1, res.nit) if modes[t - 1] == "accurate" and modes[t] == "broad")
    assert trace["switch_iterations"][: len(changes_up)] == changes_up
    assert trace["reverse_switch_iterations"][: len(changes_down)] == changes_down
    stopped = trace["stopped_by"] == "termination"
    assert stopped == (res.message == "adaptive termination (eqs. 29-33)")
    if stopped:
        assert trace["termination_tests"][-1] == (res.nit, True)
    assert all(not passed for _, passed in trace["termination_tests"][:-1])
