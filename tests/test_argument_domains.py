"""Every public entry point refuses out-of-domain arguments clearly.

Hypothesis draws one bad argument at a time (the others valid) for ``Optimizer.minimize`` (every
registered optimiser), the harness's ``evaluate``, and the ``uav-bench`` command line, and checks
the answer: a ``ValueError``/``TypeError`` whose message starts with the argument's name and says
what was expected, never an ``IndexError`` from deep inside or a result; for the CLI, exit status
2 and one line ``uav-bench: error: ...`` with no traceback. The default suite runs a deterministic
sample (the ``ci`` profile); ``-m slow`` runs at least 10 000 generated cases in all.
"""

from __future__ import annotations

import contextlib
import io
import math
import os

import numpy as np
import pytest
from conftest import tiny_scenario
from hypothesis import given, settings
from hypothesis import strategies as st

from optimizers import available_optimizers, get_optimizer
from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.evaluate import evaluate
from uav_penetration_env.benchmark.policies import GreedyPolicy
from uav_penetration_env.terminal_kernels import NO_TERMINAL_COST

SLOW = settings(max_examples=2_500, deadline=None, derandomize=True)

# --- values that belong to no numeric domain, or to the wrong one ---------------------------------------

NOT_A_NUMBER = st.sampled_from(["ten", "", None, [], {}, object(), b"1", "1.5x", (1, 2)])
NON_FINITE = st.sampled_from([math.nan, math.inf, -math.inf])
BOOLS = st.sampled_from([True, False, np.bool_(True)])
NEGATIVE_INTS = st.integers(max_value=-1)
FRACTIONAL = st.floats(allow_nan=False, allow_infinity=False).filter(lambda v: not float(v).is_integer())


def message_names(error: BaseException, argument: str) -> None:
    text = str(error)
    assert text.startswith(argument) or f" {argument}" in text or f"{argument}[" in text, text
    assert "expected" in text, text


# --- Optimizer.minimize ----------------------------------------------------------------------------------


def sphere(x: np.ndarray) -> np.ndarray:
    return np.sum(x * x, axis=1)


GOOD = {"bounds": [(-1.0, 1.0), (-2.0, 2.0)], "rng": 0, "max_evals": 30, "x0": None}

BAD_BOUNDS = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False).map(lambda lo: [(lo, lo)]),  # lower == upper
    st.tuples(st.floats(-1e9, 1e9), st.floats(0.0, 1e9, exclude_min=True)).map(  # lower > upper
        lambda p: [(p[0] + p[1], p[0])]
    ),
    NON_FINITE.map(lambda v: [(v, 1.0)]),
    NON_FINITE.map(lambda v: [(0.0, v)]),
    st.just([(-1e308, 1e308)]),  # a width that overflows
    st.just([]),
    st.just([[0.0, 1.0, 2.0]]),
    st.just("bounds"),
    st.just(None),
    st.just(np.zeros((2, 3, 2))),
)
BAD_MAX_EVALS = st.one_of(st.integers(max_value=0), FRACTIONAL, NON_FINITE, BOOLS, NOT_A_NUMBER)
BAD_X0 = st.one_of(
    NON_FINITE.map(lambda v: [v, 0.0]),
    st.just([0.0]),
    st.just([[0.0, 0.0]]),
    st.just([0.0, 0.0, 0.0]),
    st.just("x0"),
)
BAD_RNG = st.one_of(NEGATIVE_INTS, FRACTIONAL, NON_FINITE, BOOLS, st.just("seed"), st.just(object()))

OPTIMIZER_CASES = st.one_of(
    st.tuples(st.just("bounds"), BAD_BOUNDS),
    st.tuples(st.just("max_evals"), BAD_MAX_EVALS),
    st.tuples(st.just("x0"), BAD_X0),
    st.tuples(st.just("rng"), BAD_RNG),
    st.tuples(st.just("fun"), st.sampled_from([None, 3, "sphere"])),
)


def check_optimizer_case(name: str, argument: str, value: object) -> None:
    kwargs = dict(GOOD)
    fun = sphere
    if argument == "fun":
        fun = value
    else:
        kwargs[argument] = value
    bounds = kwargs.pop("bounds")
    with pytest.raises((ValueError, TypeError)) as raised:
        get_optimizer(name).minimize(fun, bounds, **kwargs)
    message_names(raised.value, argument if argument != "x0" else "x0")


@pytest.mark.parametrize("name", available_optimizers())
@given(case=OPTIMIZER_CASES)
def test_minimize_refuses_out_of_domain_arguments(name, case):
    check_optimizer_case(name, *case)


@pytest.mark.slow
@SLOW
@given(name=st.sampled_from(available_optimizers()), case=OPTIMIZER_CASES)
def test_minimize_refuses_out_of_domain_arguments_many(name, case):
    check_optimizer_case(name, *case)


# --- the harness's evaluate ------------------------------------------------------------------------------

TINY = tiny_scenario(time={"max_steps": 3})

EVALUATE_CASES = st.one_of(
    st.tuples(st.just("policies"), st.sampled_from([{}, [], None, "greedy", {"": GreedyPolicy()}])),
    st.tuples(st.just("policies"), st.sampled_from([{"x": 3}, {"x": "greedy"}, {"x": object()}])),
    st.tuples(st.just("scenarios"), st.sampled_from([[], TINY, "paper", None, 5])),
    st.tuples(st.just("seeds"), st.lists(st.one_of(NEGATIVE_INTS, FRACTIONAL, BOOLS, NOT_A_NUMBER), min_size=1)),
    st.tuples(st.just("seeds"), st.sampled_from([[], "012", 3, None])),
    st.tuples(st.just("n_jobs"), st.one_of(FRACTIONAL, BOOLS, st.just("all"))),
    st.tuples(st.just("backend"), st.text(max_size=8).filter(lambda b: b not in ("loky", "dask", "sequential"))),
    st.tuples(st.just("store"), st.sampled_from([3, object(), ["a.sqlite"]])),
)  # fmt: skip


def check_evaluate_case(argument: str, value: object) -> None:
    kwargs = {"policies": {"greedy": GreedyPolicy()}, "scenarios": [TINY], "seeds": [0], "progress": False}
    kwargs[argument] = value
    with pytest.raises((ValueError, TypeError)) as raised:
        evaluate(**kwargs)
    message_names(raised.value, argument)


@given(case=EVALUATE_CASES)
def test_evaluate_refuses_out_of_domain_arguments(case):
    check_evaluate_case(*case)


@pytest.mark.slow
@SLOW
@given(case=EVALUATE_CASES)
def test_evaluate_refuses_out_of_domain_arguments_many(case):
    check_evaluate_case(*case)


# --- the command line --------------------------------------------------------------------------------------

JUNK = st.one_of(
    st.sampled_from(
        ["", "x", "-", "--", "nan", "inf", "-inf", "1e999", "-1", "0", "1.5", "NaN", "2**8", "☃"]
    ),
    st.text(alphabet="abc-:,._/0", min_size=1, max_size=6).filter(lambda t: not t.lstrip("-").isdigit()),
)


def bad_value_for(flag: str) -> st.SearchStrategy[list[str]]:
    """A value that ``flag`` must refuse (before any work starts)."""
    numbers = {
        "--max-evals": st.one_of(
            st.integers(max_value=0).map(str), JUNK.filter(lambda t: t not in ("1e999",))
        ),
        "--horizon": st.one_of(st.integers(max_value=0).map(str), JUNK),
        "--discount": st.one_of(
            st.floats(allow_nan=False).filter(lambda v: not 0.0 < v <= 1.0).map(repr),
            st.sampled_from(["nan", "x"]),
        ),
        "--terminal-cost": st.one_of(
            st.floats(max_value=0.0, exclude_max=True).map(repr), st.sampled_from(["nan", "inf", "x"])
        ),
        "--difficulty": st.one_of(
            st.floats(allow_nan=False).filter(lambda v: not 0.0 <= v <= 1.0).map(repr), st.just("nan")
        ),
        "--seeds": st.one_of(
            st.integers(max_value=0).map(str),
            st.tuples(st.integers(0, 50), st.integers(0, 50))
            .filter(lambda p: p[1] <= p[0])
            .map(lambda p: f"{p[0]}:{p[1]}"),
            JUNK.filter(lambda t: not t.isdigit()),
        ),
        "--jobs": JUNK.filter(lambda t: t not in ("-1", "0")),
        "--weights": st.one_of(JUNK, st.just("1,2"), st.just("0.5,0.5,nan"), st.just("1,1,1")),
        "--backend": JUNK,
        "--profile": JUNK,
        "--policies": JUNK.filter(lambda t: t not in ("random", "greedy")),
        "--scenarios": JUNK,
    }
    return numbers[flag].map(lambda value: [flag, value])


RUN_FLAGS = ["--max-evals", "--horizon", "--discount", "--terminal-cost", "--difficulty", "--seeds", "--jobs",
             "--weights", "--backend", "--profile", "--policies", "--scenarios"]  # fmt: skip

CLI_CASES = st.one_of(
    st.sampled_from(RUN_FLAGS).flatmap(bad_value_for).map(lambda bad: ["run", *bad]),
    st.sampled_from(["--max-evals", "--runs", "--horizon"]).flatmap(
        lambda flag: st.one_of(st.integers(max_value=0).map(str), JUNK).map(lambda v: [flag, v])
    ).map(lambda bad: ["calibrate", "--optimizer", "pso", "--out", "calibrated.yaml", *bad]),
    st.tuples(st.sampled_from(["leaderboard", "plot", "export --format csv"]), JUNK).map(
        lambda c: [*c[0].split(), "--store", f"missing-{c[1]}.sqlite"]
    ),
    st.tuples(st.sampled_from(["run", "leaderboard", "plot", "export", "scenario", "calibrate"]), JUNK).map(
        lambda c: [c[0], f"--no-such-flag-{c[1]}"]
    ),
    JUNK.map(lambda name: ["scenario", "show", f"no-such-scenario-{name}"]),
    JUNK.map(lambda name: [f"no-such-command-{name}"]),
    st.sampled_from([["export", "--format", "xml"], ["leaderboard", "--suite"], [], ["run", "--seeds"]]),
)  # fmt: skip


def check_cli_case(argv: list[str]) -> None:
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = cli.main(argv)
    lines = err.getvalue().strip().splitlines()
    assert code == 2, (argv, code, err.getvalue())
    assert len(lines) == 1 and lines[0].startswith("uav-bench: error: "), (argv, lines)
    assert "Traceback" not in err.getvalue()


@pytest.fixture(scope="module", autouse=True)
def in_tmp(tmp_path_factory):
    # Nothing may be written for a refused command; a private folder keeps any mistake visible.
    folder = tmp_path_factory.mktemp("cwd")
    previous = os.getcwd()
    os.chdir(folder)
    yield folder
    os.chdir(previous)
    assert sorted(p.name for p in folder.iterdir()) == []


@given(argv=CLI_CASES)
def test_the_cli_refuses_bad_arguments_in_one_line(argv):
    check_cli_case(argv)


@pytest.mark.slow
@settings(max_examples=3_000, deadline=None, derandomize=True)
@given(argv=CLI_CASES)
def test_the_cli_refuses_bad_arguments_in_one_line_many(argv):
    check_cli_case(argv)


# --- PenetrationModel ------------------------------------------------------------------------------------

MODEL_SCENARIO = tiny_scenario(time={"max_steps": 12})


@pytest.fixture(scope="module")
def model():
    from uav_penetration_env import PenetrationModel

    return PenetrationModel(MODEL_SCENARIO)


K_MAX = MODEL_SCENARIO.time.max_steps


def bad_batch(width: int) -> st.SearchStrategy[object]:
    """(B, width) arrays that are not: NaN/inf entries, other shapes, no numbers at all."""
    with_non_finite = st.tuples(st.integers(1, 4), st.integers(0, 3 * width), NON_FINITE).map(
        lambda c: np.where(np.arange(c[0] * width).reshape(c[0], width) == c[1] % (c[0] * width), c[2], 1.0)
    )
    return st.one_of(
        with_non_finite,
        st.sampled_from([np.zeros(width), np.zeros((2, width + 1)), np.zeros((1, 1, width)), np.zeros(())]),
        st.sampled_from(["states", None, [["a"] * width], object()]),
    )


BAD_STEP = st.one_of(
    NEGATIVE_INTS, st.integers(min_value=K_MAX), FRACTIONAL, st.just(1.0), BOOLS, NOT_A_NUMBER,
    st.just(np.array([0, K_MAX + 5])), st.just(np.array([0.0])),
)  # fmt: skip
BAD_POOL_INDEX = st.one_of(
    st.integers(min_value=1), NEGATIVE_INTS, st.just(0.0), st.just(np.array([0.5])), st.just("0")
)


def model_cases(model_step_name: str = "step") -> st.SearchStrategy[tuple[str, str, object]]:
    return st.one_of(
        st.tuples(st.just("step"), st.just("states"), bad_batch(6)),
        st.tuples(st.just("step"), st.just("controls"), bad_batch(3)),
        st.tuples(st.just("step"), st.just("step_index"), BAD_STEP),
        st.tuples(st.just("step"), st.just("scenario_index"), BAD_POOL_INDEX),
        st.tuples(st.just("costs"), st.just("next_states"), bad_batch(6)),
        st.tuples(st.just("costs"), st.just("step_index"), BAD_STEP),
        st.tuples(st.just("rollout_cost"), st.just("state"), st.one_of(
            st.tuples(st.integers(0, 5), NON_FINITE).map(lambda c: np.where(np.arange(6) == c[0], c[1], 0.0)),
            st.sampled_from([np.zeros(5), np.zeros((1, 6)), "state", None]))),
        st.tuples(st.just("rollout_cost"), st.just("controls"), st.one_of(
            NON_FINITE.map(lambda v: np.full((3, 2, 3), v)), st.just(np.zeros((3, 0, 3))),
            st.just(np.zeros((3, 3))), st.just("controls"))),
        st.tuples(st.just("rollout_cost"), st.just("step"), st.one_of(
            NEGATIVE_INTS, st.integers(min_value=K_MAX + 1), FRACTIONAL, BOOLS, st.just(2.0))),
        st.tuples(st.just("rollout_cost"), st.just("discount"), st.one_of(
            st.floats().filter(lambda v: not 0.0 < v <= 1.0), BOOLS, NOT_A_NUMBER)),
        st.tuples(st.just("rollout_cost"), st.just("terminal_cost"), st.one_of(  # never a bare number
            st.floats(), NON_FINITE, BOOLS, NOT_A_NUMBER, st.just(0.06))),
        st.tuples(st.just("rollout_cost"), st.just("scenario_index"), BAD_POOL_INDEX),
        st.tuples(st.just("height"), st.just("x_m"), st.one_of(
            NON_FINITE, NON_FINITE.map(lambda v: np.array([0.0, v])), st.just("x"), st.just(np.zeros(3)))),
        st.tuples(st.just("height"), st.just("scenario_index"), BAD_POOL_INDEX),
        st.tuples(st.just("observe"), st.just("states"), bad_batch(6)),
        st.tuples(st.just("observe"), st.just("step_index"), st.one_of(
            NEGATIVE_INTS, st.integers(min_value=K_MAX + 1), FRACTIONAL, BOOLS)),
        st.tuples(st.just("observe"), st.just("result"), st.sampled_from([3, "result", object()])),
    )  # fmt: skip


def call_model(model, method: str, argument: str, value: object) -> None:
    state = model.initial_state()
    kwargs: dict[str, object]
    if method in ("step", "costs"):
        second = "controls" if method == "step" else "next_states"
        kwargs = {"states": state[None], second: state[None] if method == "costs" else np.zeros((1, 3)),
                  "step_index": 0, "scenario_index": None}  # fmt: skip
    elif method == "rollout_cost":
        kwargs = {"state": state, "controls": np.zeros((4, 3, 3)), "step": 0, "discount": 0.9,
                  "terminal_cost": NO_TERMINAL_COST, "scenario_index": 0}  # fmt: skip
    elif method == "height":
        kwargs = {"x_m": np.array([0.0, 1000.0]), "y_m": np.array([0.0, 500.0]), "scenario_index": None}
    else:
        kwargs = {"states": state[None], "step_index": 0, "result": None, "scenario_index": None}
    if argument == "x_m" and np.shape(value) == (3,):
        kwargs["y_m"] = np.zeros(2)  # shapes that do not broadcast
    kwargs[argument] = value
    with pytest.raises((ValueError, TypeError)) as raised:
        getattr(model, method)(**kwargs)
    expected_name = "x_m, y_m" if argument == "x_m" and np.shape(value) == (3,) else argument
    message_names(raised.value, expected_name)


@given(case=model_cases())
def test_model_entry_points_refuse_out_of_domain_arguments(model, case):
    call_model(model, *case)


@pytest.mark.slow
@settings(max_examples=3_000, deadline=None, derandomize=True)
@given(case=model_cases())
def test_model_entry_points_refuse_out_of_domain_arguments_many(model, case):
    call_model(model, *case)


def test_the_domains_edges_are_accepted(model):
    state = model.initial_state()
    last = model.step(state[None], np.zeros((1, 3)), K_MAX - 1)
    assert last.step_index.tolist() == [K_MAX] and bool(last.truncated[0] or last.terminated[0])
    assert model.observe(last.state, K_MAX, last).shape == (1, 67)
    assert model.rollout_cost(state, np.zeros((2, 3, 3)), step=K_MAX).tolist() == [0.0, 0.0]
    assert model.step(state[None], np.zeros((1, 3)), np.int64(0)).step_index.tolist() == [1]
    assert model.height(0.0, 0.0).shape == ()


def test_complex_input_is_refused_not_silently_made_real():
    import numpy as np

    from optimizers import get_optimizer
    from uav_penetration_env import PenetrationModel

    model = PenetrationModel(TINY)
    state = model.initial_state()
    with pytest.raises(TypeError, match=r"controls: got complex values, expected .*\(real numbers\)"):
        model.rollout_cost(state, np.zeros((1, 2, 3), complex) + 1j, step=0)
    with pytest.raises(ValueError, match=r"objective returned complex values, expected an \(\d+,\) array of real costs"):
        get_optimizer("pso").minimize(lambda x: x.sum(axis=1) * (1 + 1j), [(-1, 1)] * 2, rng=0, max_evals=50)
