"""Bounds, warm start, result and the budgeted objective (optimizers.md §1)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.optimize import Bounds

from optimizers import BudgetedObjective, Optimizer, OptimizeResult, get_optimizer
from optimizers.base import check_x0, normalize_bounds


def test_normalize_bounds_forms():
    lo, hi = np.array([-1.0, 0.0, 2.0]), np.array([1.0, 5.0, 3.0])
    for form in (
        [(-1, 1), (0, 5), (2, 3)],
        np.column_stack([lo, hi]),
        (lo, hi),
        [lo.tolist(), hi.tolist()],
        Bounds(lo, hi),
    ):
        a, b = normalize_bounds(form)
        assert a.dtype == b.dtype == np.float64
        assert a.tolist() == lo.tolist() and b.tolist() == hi.tolist()


def test_normalize_bounds_two_by_two_is_pairs():
    lo, hi = normalize_bounds([[0.0, 1.0], [2.0, 3.0]])  # D29: scipy's convention
    assert lo.tolist() == [0.0, 2.0] and hi.tolist() == [1.0, 3.0]
    lo, hi = normalize_bounds(Bounds([0.0, 1.0], [2.0, 3.0]))  # (lower, upper) must come as Bounds
    assert lo.tolist() == [0.0, 1.0] and hi.tolist() == [2.0, 3.0]


def test_normalize_bounds_one_dimension_and_broadcast_bounds():
    assert [a.tolist() for a in normalize_bounds([(-2.0, 2.0)])] == [[-2.0], [2.0]]
    assert [a.tolist() for a in normalize_bounds(([-2.0], [2.0]))] == [[-2.0], [2.0]]
    lo, hi = normalize_bounds(Bounds(-1.0, [1.0, 2.0]))
    assert lo.tolist() == [-1.0, -1.0] and hi.tolist() == [1.0, 2.0]


def test_normalize_bounds_never_aliases_the_input():
    lo, hi = np.array([0.0, 0.0, 0.0]), np.array([1.0, 1.0, 1.0])
    a, _ = normalize_bounds((lo, hi))
    a[0] = 9.0
    assert lo[0] == 0.0
    c, _ = normalize_bounds(Bounds(lo, hi))
    c[0] = 9.0
    assert lo[0] == 0.0


@pytest.mark.parametrize(
    ("bounds", "pattern"),
    [
        ([(0.0, 1.0), (2.0, 2.0)], r"bounds\[1\]: got lower=2\.0, upper=2\.0, expected finite values with lower < upper"),
        ([(0.0, 1.0), (3.0, 2.0)], r"bounds\[1\]"),
        ([(0.0, np.inf)], r"bounds\[0\].*finite"),
        ([(np.nan, 1.0)], r"bounds\[0\]"),
        (np.zeros((3, 3)), r"shape \(3, 3\)"),
        ([1.0, 2.0], r"shape \(2,\)"),
        (Bounds(np.zeros((2, 2)), np.ones((2, 2))), "one-dimensional"),
        ("abc", "bounds"),
        (np.zeros((0, 2)), "zero dimensions"),
    ],
)
def test_normalize_bounds_errors(bounds, pattern):
    with pytest.raises(ValueError, match=pattern):
        normalize_bounds(bounds)


def test_check_x0():
    lo, hi = np.array([0.0, 0.0]), np.array([1.0, 1.0])
    assert check_x0(None, lo, hi) is None
    assert check_x0([2.0, 0.5], lo, hi).tolist() == [1.0, 0.5]
    with pytest.raises(ValueError, match=r"x0: got shape \(3,\), expected \(2,\)"):
        check_x0([0.0, 0.0, 0.0], lo, hi)
    with pytest.raises(ValueError, match=r"x0\[1\]"):
        check_x0([0.0, np.inf], lo, hi)


def sphere(x):
    return (x**2).sum(axis=1)


def test_budgeted_objective_truncates_and_pads():
    calls = []

    def fun(x):
        calls.append(x.shape)
        return sphere(x)

    obj = BudgetedObjective(fun, 2, max_evals=5)
    f = obj(np.ones((3, 2)))
    assert f.tolist() == [2.0, 2.0, 2.0] and obj.nfev == 3 and obj.remaining == 2
    f = obj(np.full((4, 2), 0.5))
    assert f.tolist() == [0.5, 0.5, np.inf, np.inf]
    assert calls == [(3, 2), (2, 2)]
    assert obj.nfev == 5 and obj.remaining == 0
    with pytest.raises(RuntimeError, match="budget"):
        obj(np.ones((1, 2)))
    assert len(calls) == 2


def test_budgeted_objective_checks():
    obj = BudgetedObjective(lambda x: np.zeros((len(x), 1)), 2, max_evals=10)
    with pytest.raises(ValueError, match=r"objective returned shape \(3, 1\), expected \(3,\)"):
        obj(np.ones((3, 2)))
    obj = BudgetedObjective(sphere, 2, max_evals=10)
    with pytest.raises(ValueError, match="expected"):
        obj(np.ones((3, 3)))
    with pytest.raises(ValueError):
        obj(np.ones((0, 2)))
    obj = BudgetedObjective(lambda x: np.array([1.0, -np.inf]), 1, max_evals=10)
    with pytest.raises(ValueError, match="-inf"):
        obj(np.ones((2, 1)))
    obj = BudgetedObjective(lambda x: [1, 2], 1, max_evals=10)  # any array-like, cast to float64
    assert obj(np.ones((2, 1))).dtype == np.float64
    for bad in (0, -3, 2.5, True):
        with pytest.raises(ValueError, match="max_evals"):
            BudgetedObjective(sphere, 1, max_evals=bad)


def test_budgeted_objective_nan_tracker_and_stand_in():
    obj = BudgetedObjective(lambda x: x[:, 0].copy(), 1, max_evals=20)
    assert obj.finite_stand_in() == 1e30
    f = obj(np.array([[np.nan], [3.0], [np.inf], [3.0]]))
    assert f.tolist() == [np.inf, 3.0, np.inf, 3.0]  # NaN -> +inf (D30)
    assert obj.best_f == 3.0 and obj.best_x.tolist() == [3.0]
    assert obj.finite_stand_in() == 30.0
    assert obj.finite_costs(f).tolist() == [30.0, 3.0, 30.0, 3.0]
    obj.record()
    obj(np.array([[2.0], [2.0]]))
    obj.record()
    res = obj.result(1, "done")
    assert res.fun == 2.0 and res.x.tolist() == [2.0] and res.message == "done"
    assert res.history.tolist() == [3.0, 2.0] and res.history_nfev.tolist() == [4, 6]
    with pytest.raises(RuntimeError, match="history"):
        obj.result(3, "done")


def test_finite_stand_in_is_worse_than_nonpositive_costs():
    obj = BudgetedObjective(lambda x: x[:, 0].copy(), 1, max_evals=5)
    obj(np.array([[-4.0], [0.0]]))
    assert obj.finite_stand_in() > 0.0
    obj = BudgetedObjective(lambda x: x[:, 0].copy(), 1, max_evals=5)
    obj(np.array([[-4.0]]))
    assert obj.finite_stand_in() > -4.0


def test_budgeted_objective_first_of_equal_costs_wins_and_copies_are_fresh():
    seen = []

    def fun(x):
        seen.append(x)
        out = np.zeros(len(x))
        x[:] = 99.0  # fun owns its copy
        return out

    obj = BudgetedObjective(fun, 1, max_evals=10)
    X = np.array([[1.0], [2.0]])
    obj(X)
    obj(np.array([[3.0]]))
    assert X.tolist() == [[1.0], [2.0]]
    obj.record()
    res = obj.result(0, "m")
    assert res.x.tolist() == [1.0]


def test_all_infinite_gives_first_row_and_suffix():
    obj = BudgetedObjective(lambda x: np.full(len(x), np.nan), 1, max_evals=3)
    obj(np.array([[0.25], [0.5]]))
    obj.record()
    res = obj.result(0, "max_evals reached")
    assert res.fun == np.inf and res.x.tolist() == [0.25]
    assert res.message == "max_evals reached; no finite cost found"


def test_optimize_result_is_frozen_and_optimizers_satisfy_the_protocol():
    res = get_optimizer("pso").minimize(sphere, [(-1, 1)] * 2, rng=0, max_evals=200)
    assert isinstance(res, OptimizeResult)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.fun = 0.0  # type: ignore[misc]
    assert isinstance(get_optimizer("ihpso"), Optimizer)
