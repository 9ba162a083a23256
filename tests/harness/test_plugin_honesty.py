"""The harness trusts no plug-in's word: it counts the evaluations itself and refuses a plan outside the box."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from conftest import tiny_scenario

from optimizers import OptimizeResult
from uav_penetration_env.benchmark import MPCPolicy, evaluate
from uav_penetration_env.benchmark.policies import CountedObjective, PlanError, checked_result
from uav_penetration_env.mpc import MPCSettings, Terminal

SETTINGS = MPCSettings(horizon=2, max_evals=60, terminal=Terminal("none"))


@dataclass(frozen=True)
class Liar:
    """Spends ``spend`` x its budget (or returns a plan scaled by ``scale``) and reports nfev = max_evals."""

    spend: int = 1
    scale: float = 1.0

    def minimize(self, fun, bounds, *, rng=None, max_evals=10_000):
        rng = np.random.default_rng(rng)
        xs = rng.uniform(bounds.lb, bounds.ub, size=(max_evals * self.spend, bounds.lb.size))
        fs = np.concatenate([fun(chunk) for chunk in np.array_split(xs, self.spend)])
        i = int(np.argmin(fs))
        return OptimizeResult(x=xs[i] * self.scale, fun=float(fs[i]), nfev=max_evals, nit=0,
                              history=np.array([fs[i]]), history_nfev=np.array([max_evals]), message="done")  # fmt: skip


def episode(optimizer) -> dict:
    frame = evaluate({"p": MPCPolicy(optimizer, SETTINGS)}, [tiny_scenario(time={"max_steps": 4})], [0], progress=False)
    return frame.iloc[0].to_dict()


def test_an_honest_plugin_is_stored_with_the_harness_count():
    row = episode(Liar())
    assert row["error"] == "" and row["nfev_per_step"] == SETTINGS.max_evals


def test_a_plugin_that_overspends_gets_an_error_row_naming_its_real_count():
    row = episode(Liar(spend=20))
    assert "evaluated 1200 control sequences, over its budget max_evals=60 (it reported nfev=60)" in row["error"]
    assert row["outcome"] == "error"


def test_a_plan_outside_the_box_is_an_error_row_not_a_clipped_flight():
    row = episode(Liar(scale=1e6))
    assert row["outcome"] == "error" and "outside the action box" in row["error"]


def test_checked_result_counts_rows_and_allows_rounding_at_the_walls():
    from scipy.optimize import Bounds

    bounds = Bounds(np.array([-1.0, -2.0]), np.array([1.0, 2.0]))
    counted = CountedObjective(lambda x: x.sum(axis=1))
    counted(np.zeros((3, 2)))
    counted(np.zeros((4, 2)))
    at_wall = OptimizeResult(x=np.array([1.0 + 1e-12, -2.0]), fun=0.0, nfev=99, nit=0,
                             history=np.zeros(1), history_nfev=np.zeros(1, int), message="")  # fmt: skip
    assert checked_result(at_wall, counted, bounds, 7, "x") == 7  # its own count, not the claimed 99
    with pytest.raises(PlanError, match=r"x: evaluated 7 control sequences, over its budget max_evals=6"):
        checked_result(at_wall, counted, bounds, 6, "x")
    wrong_shape = OptimizeResult(x=np.zeros(3), fun=0.0, nfev=7, nit=0, history=np.zeros(1),
                                 history_nfev=np.zeros(1, int), message="")  # fmt: skip
    with pytest.raises(PlanError, match=r"shape \(3,\); expected shape \(2,\)"):
        checked_result(wrong_shape, counted, bounds, 7, "x")
    no_plan = OptimizeResult(x=np.full(2, 1e9), fun=np.inf, nfev=7, nit=0, history=np.zeros(1),
                             history_nfev=np.zeros(1, int), message="no finite cost")  # fmt: skip
    assert checked_result(no_plan, counted, bounds, 7, "x") == 7  # no finite plan: nothing is flown from it


@dataclass(frozen=True)
class Quitter:
    """Calls sys.exit(0) mid-run, as a careless script-style plug-in does."""

    def minimize(self, fun, bounds, *, rng=None, max_evals=10_000):
        raise SystemExit(0)


def test_a_plugin_that_exits_is_an_error_row_and_the_other_episodes_are_kept(tmp_path):
    from uav_penetration_env.benchmark import GreedyPolicy

    frame = evaluate({"quitter": MPCPolicy(Quitter(), SETTINGS), "greedy": GreedyPolicy()},
                     [tiny_scenario(time={"max_steps": 4})], [0, 1], progress=False, store=tmp_path / "s.sqlite")  # fmt: skip
    by_policy = frame.groupby("policy")["outcome"].apply(set).to_dict()
    assert by_policy["quitter"] == {"error"} and "error" not in by_policy["greedy"]
    assert frame.loc[frame["policy"] == "quitter", "error"].str.startswith("SystemExit: 0").all()


def _library_call(x):
    raise ValueError("setting an array element with a sequence (inside the library)")


@dataclass(frozen=True)
class LibraryWrapper:
    """Wraps a 'library' that raises its own exception mid-run (docs/plugins.md §7)."""

    def minimize(self, fun, bounds, *, rng=None, max_evals=10_000):
        fun(np.zeros((2, bounds.lb.size)))
        return _library_call(bounds.lb)


def test_a_librarys_own_exception_names_itself_in_the_row_and_the_summary(tmp_path, capsys):
    from uav_penetration_env.benchmark.commands.run import print_outcome

    frame = evaluate({"wrapped": MPCPolicy(LibraryWrapper(), SETTINGS)}, [tiny_scenario(time={"max_steps": 4})], [0],
                     progress=False)  # fmt: skip
    error = frame.iloc[0]["error"]
    assert error.startswith("ValueError: setting an array element with a sequence (inside the library)\n")
    assert "_library_call" in error  # the library's frame is in the stored traceback
    assert print_outcome(frame, tmp_path / "s.sqlite") == 1
    assert "first error (wrapped, seed 0): ValueError: setting an array element" in capsys.readouterr().err
