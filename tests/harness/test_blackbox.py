"""Black-box problems (docs/blackbox.md): the problems, the IOH and nevergrad adapters, the IOH export."""

from __future__ import annotations

import importlib.util
import json

import numpy as np
import pytest
from conftest import tiny_scenario

from uav_penetration_env.benchmark.bestknown import best_known_total
from uav_penetration_env.benchmark.bestknown.record import replay_controls
from uav_penetration_env.benchmark.blackbox import (
    BlackBoxProblem,
    offline_problem,
    suite_problems,
    window_problem,
)
from uav_penetration_env.benchmark.blackbox.ioh_export import UNREACHED, export_window_runs, replay_costs
from uav_penetration_env.benchmark.policies import mpc_objective
from uav_penetration_env.benchmark.store import ResultsStore
from uav_penetration_env.benchmark.windows import window_at
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.mpc import MPCSettings, Terminal

BLACKBOX = importlib.util.find_spec("ioh") is not None and importlib.util.find_spec("nevergrad") is not None
needs_blackbox = pytest.mark.skipif(not BLACKBOX, reason="the blackbox extra: pip install -e '.[blackbox]'")
TINY = tiny_scenario(time={"max_steps": 6})


# --- the problems -------------------------------------------------------------------------------------------


def test_the_offline_problem_is_the_evaluators_total_cost_of_the_flight():
    problem = offline_problem(TINY)
    assert (problem.kind, problem.name, problem.dimension) == ("offline", "offline/tiny", 3 * 6)
    assert problem.lower.tolist() == [-1.0] * 18 and problem.upper.tolist() == [1.0] * 18
    x = np.random.default_rng(0).uniform(-0.3, 0.3, size=(3, 18))
    high = np.asarray(PenetrationModel(TINY).limits.action_high)
    for row, cost in zip(x, problem(x), strict=True):
        flown = replay_controls(TINY, row.reshape(6, 3) * high)  # the env, step by step, as the evaluator
        assert cost == pytest.approx(flown.total_cost, rel=1e-12)  # only the order of the sum differs
        assert problem(row) == cost  # one point gives a float
    assert problem.optimum is None and problem.optimum_x is None  # the tiny scenario has no record


def test_the_offline_problem_of_a_suite_member_has_its_best_known_value_as_optimum():
    (paper,) = suite_problems("uavpen-v1", members=["uavpen-v1/paper"], verify=False)
    assert (paper.instance, paper.suite_member, paper.scenario) == (1, "uavpen-v1/paper", "paper-2022-sec5")
    assert paper.optimum == best_known_total(paper.scenario_hash)
    assert paper(paper.optimum_x) == pytest.approx(paper.optimum, rel=1e-9)  # the record replays to J*


def test_suite_problems_number_instances_by_the_members_position_in_the_suite():
    from uav_penetration_env.suites import load_suite

    names = [m.name for m in load_suite("uavpen-v1").members]
    chosen = suite_problems(
        "uavpen-v1", "window", members=["uavpen-v1/d0.25/3000[12]"], verify=False, horizon=2
    )
    assert [p.instance for p in chosen] == [names.index(p.suite_member) + 1 for p in chosen]
    assert [p.suite_member for p in chosen] == ["uavpen-v1/d0.25/30001", "uavpen-v1/d0.25/30002"]
    assert all(p.dimension == 6 and p.kind == "window" for p in chosen)
    with pytest.raises(ValueError, match=r"kind: got 'online', expected one of offline, window"):
        suite_problems("uavpen-v1", "online")


def test_the_window_problem_is_the_planners_objective_on_its_box():
    problem = window_problem(TINY, horizon=2, terminal="none")
    model = PenetrationModel(TINY)
    reference = mpc_objective(model, model.initial_state(None), 0, MPCSettings(horizon=2, terminal=Terminal("none")))
    assert problem.dimension == 6 and problem.name == "window/tiny/k0"
    np.testing.assert_array_equal(problem.lower, reference.bounds.lb)
    np.testing.assert_array_equal(problem.upper, reference.bounds.ub)
    x = np.random.default_rng(1).uniform(problem.lower, problem.upper, size=(4, 6))
    np.testing.assert_array_equal(problem(x), reference(x))
    assert problem.optimum is None
    # a stored episode's window keeps its state, step and settings
    window = window_at(
        model, model.initial_state(None), 3, [np.ones(3)], MPCSettings(horizon=3, terminal=Terminal("none"))
    )
    again = window_problem(window)
    assert (again.step, again.dimension, again.name) == (3, 9, "window//k3")
    np.testing.assert_array_equal(
        again(x[:, :3].repeat(3, axis=1)[:, :9]), window.objective(x[:, :3].repeat(3, axis=1)[:, :9])
    )


@pytest.mark.parametrize("bad", [0, -1, 1.5, "1", True])
def test_a_bad_instance_is_refused_naming_the_field(bad):
    with pytest.raises(ValueError, match=rf"instance: got {bad!r}, expected an integer >= 1"):
        window_problem(TINY, instance=bad)


def test_a_point_of_the_wrong_dimension_is_refused():
    problem = window_problem(TINY, horizon=2)
    with pytest.raises(ValueError, match=r"x: got shape \(5,\), expected \(6,\) or \(n, 6\)"):
        problem(np.zeros(5))


# --- the adapters -------------------------------------------------------------------------------------------


@needs_blackbox
def test_the_ioh_problem_maps_the_unit_box_onto_the_problems_box():
    import ioh

    from uav_penetration_env.benchmark.blackbox import ioh_problem

    problem = window_problem(TINY, horizon=2, instance=3)
    wrapped = ioh_problem(problem)
    assert (wrapped.meta_data.name, wrapped.meta_data.instance, wrapped.meta_data.n_variables) == (
        "uavpen_window_tiny_k0", 3, 6,
    )  # fmt: skip
    assert wrapped.bounds.lb.tolist() == [-1.0] * 6 and wrapped.bounds.ub.tolist() == [1.0] * 6
    x = np.array([0.5, -1.0, 1.0, 0.0, 0.25, -0.5])
    assert wrapped(x) == problem(x * problem.upper)  # the box is symmetric: centre 0, half-width = upper
    again = ioh.get_problem("uavpen_window_tiny_k0", 3, 6)  # registered by name
    assert again(x) == wrapped(x)


@needs_blackbox
def test_the_ioh_problem_of_a_suite_member_knows_its_optimum():
    from uav_penetration_env.benchmark.blackbox import ioh_problem

    (paper,) = suite_problems("uavpen-v1", members=["uavpen-v1/paper"], verify=False)
    wrapped = ioh_problem(paper)
    assert wrapped.optimum.y == paper.optimum and wrapped.meta_data.instance == 1
    assert wrapped(paper.optimum_x) == pytest.approx(paper.optimum, rel=1e-9)


@needs_blackbox
def test_the_nevergrad_function_is_named_and_copies():
    import nevergrad as ng

    from uav_penetration_env.benchmark.blackbox import nevergrad_function

    problem = window_problem(TINY, horizon=2)
    function = nevergrad_function(problem)
    assert function.descriptors["name"] == "window/tiny/k0" and function.dimension == 6
    x = np.full(6, 0.1)
    assert function(x) == problem(x) and function.copy()(x) == function(x)
    optimizer = ng.optimizers.RandomSearch(parametrization=function.parametrization.copy(), budget=20)
    best = optimizer.minimize(function)
    assert np.all(best.value >= problem.lower) and np.all(best.value <= problem.upper)


# --- the IOH export -----------------------------------------------------------------------------------------


def test_replay_costs_place_each_best_at_the_end_of_its_iteration():
    unlogged, costs = replay_costs([5.0, 3.0, 3.0, 2.5], [3, 6, 8, 9])
    assert unlogged == 2 and costs.tolist() == [np.inf, np.inf, 5.0, 5.0, 5.0, 3.0, 3.0, 3.0, 2.5]
    unlogged, costs = replay_costs([np.inf, 4.0], [2, 4])  # nothing finite after the first iteration
    assert unlogged == 3 and costs.tolist() == [np.inf, np.inf, np.inf, 4.0]
    unlogged, costs = replay_costs([np.inf, np.inf], [2, 3])  # a run that never found a finite cost
    assert unlogged == 2 and costs.tolist() == [np.inf, np.inf, UNREACHED]
    with pytest.raises(ValueError, match=r"history_nfev: got \[3, 2\]"):
        replay_costs([1.0, 1.0], [3, 2])


def window_run(optimizer, seed, history, nfev, step=2):
    return {
        "scenario": "tiny", "scenario_hash": "abcdef0123456789", "source_policy": "greedy",
        "source_policy_hash": "g" * 16, "episode_seed": 0, "step": step, "state": "[]", "optimizer": optimizer,
        "optimizer_hash": f"{optimizer}-hash", "seed": seed, "max_evals": nfev[-1], "horizon": 2,
        "nfev": nfev[-1], "nit": len(nfev) - 1, "fun": history[-1], "history": json.dumps(history),
        "history_nfev": json.dumps(nfev), "message": "", "seconds": 0.0,
    }  # fmt: skip


def dat_runs(path):
    """The runs of an IOH .dat file: lists of (evaluations, y) after each header line."""
    runs = []
    for line in path.read_text().splitlines():
        if line.startswith("evaluations"):
            runs.append([])
        else:
            evaluations, y = line.split()
            runs[-1].append((int(evaluations), float(y)))
    return runs


@needs_blackbox
def test_the_ioh_export_writes_what_iohexperimenter_writes(tmp_path):
    store_path = tmp_path / "w.sqlite"
    with ResultsStore(store_path) as store:
        store.write_window_runs(
            [
                window_run("pso", 0, [5.0, 3.0, 3.0, 2.5], [3, 6, 8, 9]),
                window_run("pso", 1, [np.inf, 4.0], [2, 4]),
                window_run("cem", 0, [np.inf, np.inf], [2, 3]),
                window_run("cem", 0, [1.5], [5], step=4),
            ]
        )
        written = export_window_runs(store, tmp_path / "ioh")
    assert sorted(p.parent.name for p in written) == ["cem", "cem", "pso"]
    pso = json.loads((tmp_path / "ioh" / "pso" / written[-1].name).read_text())
    assert pso["function_name"] == "uavpen_window_tiny_abcdef01_greedy_s0_k2_H2" and not pso["maximization"]
    assert pso["algorithm"] == {"name": "pso", "info": "optimizer_hash pso-hash; max_evals 9"}
    assert pso["attributes"] == ["evaluations", "raw_y"]
    (scenario,) = pso["scenarios"]
    assert scenario["dimension"] == 6
    assert [(r["evals"], r["best"]["evals"], r["best"]["y"]) for r in scenario["runs"]] == [
        (9, 9, 2.5),
        (4, 4, 4.0),
    ]
    dat = tmp_path / "ioh" / "pso" / scenario["path"]
    assert dat_runs(dat) == [[(3, 5.0), (6, 3.0), (9, 2.5)], [(4, 4.0)]]
    cem_runs = {}
    for path in (tmp_path / "ioh" / "cem").glob("*.json"):
        meta = json.loads(path.read_text())
        cem_runs[meta["function_name"]] = dat_runs(tmp_path / "ioh" / "cem" / meta["scenarios"][0]["path"])
    assert cem_runs["uavpen_window_tiny_abcdef01_greedy_s0_k2_H2"] == [
        [(3, UNREACHED)]
    ]  # never finite: one line
    assert cem_runs["uavpen_window_tiny_abcdef01_greedy_s0_k4_H2"] == [[(5, 1.5)]]
    # the same window is the same IOH function id for every optimiser
    assert len({json.loads(p.read_text())["function_id"] for p in written if "_k2_" in p.name}) == 1
    with (
        ResultsStore(store_path) as store,
        pytest.raises(ValueError, match=r"out: .* exists and is not an empty folder"),
    ):
        export_window_runs(store, tmp_path / "ioh")
    with (
        ResultsStore(store_path) as store,
        pytest.raises(ValueError, match=r"store: no window runs of ihpso"),
    ):
        export_window_runs(store, tmp_path / "other", optimizers=["ihpso"])


def test_a_black_box_problem_is_a_plain_dataclass():
    problem = BlackBoxProblem("x", "window", lambda x: x.sum(axis=1), -np.ones(2), np.ones(2))
    assert problem.dimension == 2 and problem(np.ones(2)) == 2.0


@pytest.mark.parametrize("module", ["ioh", "nevergrad"])
def test_a_missing_library_is_named_with_the_install_line(module, monkeypatch):
    from uav_penetration_env.benchmark.blackbox import ioh_problem, nevergrad_function

    monkeypatch.setitem(__import__("sys").modules, module, None)  # as if not installed
    adapter = ioh_problem if module == "ioh" else nevergrad_function
    with pytest.raises(
        ImportError,
        match=rf"{module} is missing; install the blackbox extra: pip install -e '\.\[blackbox\]'",
    ):
        adapter(BlackBoxProblem("x", "window", lambda x: x.sum(axis=1), -np.ones(2), np.ones(2)))


@needs_blackbox
def test_the_adapters_stay_functions_after_their_first_call():
    """A submodule named like a function of the package would replace it once imported."""
    from uav_penetration_env.benchmark import blackbox

    blackbox.nevergrad_function(window_problem(TINY, horizon=2))
    blackbox.ioh_problem(window_problem(TINY, horizon=2))
    assert callable(blackbox.nevergrad_function) and callable(blackbox.ioh_problem)
    assert callable(blackbox.export_window_runs)


@needs_blackbox
def test_export_ioh_on_the_command_line(tmp_path, capsys):
    from uav_penetration_env.benchmark import cli

    store_path = tmp_path / "w.sqlite"
    with ResultsStore(store_path) as store:
        store.write_window_runs([window_run("pso", 0, [5.0, 3.0], [3, 6]), window_run("cem", 0, [4.0], [6])])
    assert cli.main(["export", "--ioh", "--store", str(store_path)]) == 0  # default --out: STORE-ioh/
    assert sorted(p.name for p in (tmp_path / "w-ioh").iterdir()) == ["cem", "pso"]
    assert "pso: 1 windows" in capsys.readouterr().out
    assert (
        cli.main(
            ["export", "--ioh", "--format", "csv", "--store", str(store_path), "--out", str(tmp_path / "x")]
        )
        == 2
    )
    assert "--format: not an option of --ioh" in capsys.readouterr().err
    with ResultsStore(tmp_path / "empty.sqlite"):
        pass
    assert (
        cli.main(["export", "--ioh", "--store", str(tmp_path / "empty.sqlite"), "--out", str(tmp_path / "y")])
        == 2
    )
    assert "--ioh: store: no window runs in" in capsys.readouterr().err
