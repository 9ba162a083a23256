"""The optimiser examples of docs/plugins.md: through the interface, and through the page's CLI line."""

from __future__ import annotations

import importlib.util
import re
import shlex
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import tiny_scenario
from scipy.optimize import Bounds

from optimizers import OptimizeResult, get_optimizer, normalize_bounds, registry
from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.store import ResultsStore

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "plugins.md"
NEVERGRAD = importlib.util.find_spec("nevergrad") is not None
MODULES = ("examples.random_search", "examples.nevergrad_de")
EXAMPLES_EXTRA = "the nevergrad example needs the examples extra: pip install -e '.[examples]'"

EXAMPLES = [
    pytest.param("examples.random_search", "random-search", id="random-search"),
    pytest.param(
        "examples.nevergrad_de", "ng-twopointsde", id="ng-twopointsde",
        marks=pytest.mark.skipif(not NEVERGRAD, reason=EXAMPLES_EXTRA),
    ),
]  # fmt: skip


@pytest.fixture(autouse=True)
def own_registry(monkeypatch):
    """Each test imports the examples afresh into a copy of the registry, so their names do not leak.

    Importing an example registers its name for good; another test (or a second import) registering
    the same name would then be refused as a duplicate.
    """
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    for module in MODULES:
        monkeypatch.delitem(sys.modules, module, raising=False)
    yield
    for module in MODULES:
        sys.modules.pop(module, None)


def sphere(X: np.ndarray) -> np.ndarray:
    return np.sum((X - 0.25) ** 2, axis=1)


def optimizer(module: str, name: str):
    importlib.import_module(module)  # importing registers the name
    return get_optimizer(name)


@pytest.mark.parametrize(("module", "name"), EXAMPLES)
def test_an_example_keeps_the_interface(module, name):
    """Budget kept, answer inside the box, best-so-far history, a seed replays, on the planner's Bounds."""
    opt = optimizer(module, name)
    bounds = Bounds(-np.ones(6), np.ones(6))
    calls: list[int] = []

    def counted(X):
        calls.append(len(X))
        return sphere(X)

    result = opt.minimize(counted, bounds, rng=np.random.default_rng(3), max_evals=300)
    assert isinstance(result, OptimizeResult)
    assert sum(calls) == result.nfev <= 300 and result.nfev == result.history_nfev[-1]
    assert (
        np.all(result.x >= -1)
        and np.all(result.x <= 1)
        and result.fun == pytest.approx(sphere(result.x[None])[0])
    )
    assert np.all(np.diff(result.history) <= 0) and result.history[-1] == result.fun
    assert result.fun < sphere(np.zeros((1, 6)))[0]  # it found something better than the box's centre
    again = opt.minimize(sphere, bounds, rng=np.random.default_rng(3), max_evals=300)
    assert np.array_equal(again.x, result.x) and again.fun == result.fun


@pytest.mark.parametrize(("module", "name"), EXAMPLES)
def test_an_example_takes_every_bounds_form_and_a_warm_start(module, name):
    opt = optimizer(module, name)
    pairs = [(-1.0, 1.0)] * 3
    by_pairs = opt.minimize(sphere, pairs, rng=0, max_evals=40)
    by_arrays = opt.minimize(sphere, (np.full(3, -1.0), np.full(3, 1.0)), rng=0, max_evals=40)
    assert np.array_equal(by_pairs.x, by_arrays.x)
    warm = opt.minimize(sphere, pairs, rng=0, max_evals=1, x0=np.full(3, 0.25))
    assert warm.nfev == 1 and warm.fun == pytest.approx(0.0)  # the warm start is the first point tried
    with pytest.raises(ValueError, match=r"bounds\[1\]: got lower=1.0, upper=1.0"):
        opt.minimize(sphere, [(-1, 1), (1, 1)], rng=0, max_evals=10)


def test_normalize_bounds_is_public_and_reads_the_planners_bounds():
    lo, hi = normalize_bounds(Bounds(-np.array([2.0, 0.5]), np.array([2.0, 0.5])))
    assert lo.tolist() == [-2.0, -0.5] and hi.tolist() == [2.0, 0.5]


def page_commands() -> list[list[str]]:
    """The ``uav-bench run`` lines of the page's shell blocks, as argv lists."""
    blocks = re.findall(r"^```bash\n(.*?)^```", PAGE.read_text(encoding="utf-8"), flags=re.M | re.S)
    lines = [shlex.split(line) for block in blocks for line in block.splitlines()]
    return [words[1:] for words in lines if words[:2] == ["uav-bench", "run"]]


def test_the_pages_cli_line_runs_as_printed(tmp_path, monkeypatch):
    """The first ``uav-bench run`` of docs/plugins.md §5, on the tests' tiny scenario, into tmp_path."""
    argv = page_commands()[0]
    assert argv[:3] == ["run", "--import", "examples.random_search"]
    monkeypatch.chdir(ROOT)  # --import finds examples/ under the current folder, as the page says
    scenario = tiny_scenario(time={"max_steps": 8}).to_yaml(tmp_path / "tiny.yaml")
    store = tmp_path / "plugins.sqlite"
    extra = [
        "--scenarios",
        str(scenario),
        "--seeds",
        "1",
        "--store",
        str(store),
        "--no-report",
        "--no-progress",
    ]
    assert "random-search" not in registry._REGISTRY  # the page's --import is what registers it
    assert cli.main([*argv, *extra]) == 0
    with ResultsStore(store) as results:
        rows = results.episodes()
    assert sorted(rows["policy"]) == ["greedy", "random-search"] and (rows["error"] == "").all()
    assert (rows.loc[rows["policy"] == "random-search", "nfev"] > 0).all()


def test_every_run_line_of_the_page_parses():
    commands = page_commands()
    assert len(commands) == 2
    for argv in commands:
        cli.build_parser().parse_args(argv)


def test_the_page_prints_each_example_file_exactly():
    """docs/plugins.md shows the examples inline (GitHub renders no include), and they cannot drift."""
    blocks = re.findall(r"^```python\n(.*?)^```", PAGE.read_text(), flags=re.M | re.S)
    for name in ("random_search.py", "nevergrad_de.py"):
        assert (ROOT / "examples" / name).read_text() in blocks, (
            f"docs/plugins.md no longer shows examples/{name}"
        )


@pytest.mark.parametrize(("module", "name"), EXAMPLES)
def test_an_example_calls_fun_through_the_packages_budgeted_objective(module, name):
    """The examples use optimizers.BudgetedObjective: its checks and its result, not a loop of their own."""
    opt = optimizer(module, name)
    with pytest.raises(ValueError, match=r"objective returned shape \(\d+, 2\), expected \(\d+,\)"):
        opt.minimize(lambda X: np.column_stack([sphere(X)] * 2), [(-1.0, 1.0)] * 3, rng=0, max_evals=40)
    with pytest.raises(ValueError, match=r"max_evals: got 0, expected an integer >= 1"):
        opt.minimize(sphere, [(-1.0, 1.0)] * 3, rng=0, max_evals=0)
    nothing = opt.minimize(lambda X: np.full(len(X), np.nan), [(-1.0, 1.0)] * 3, rng=0, max_evals=40)
    assert nothing.fun == np.inf and nothing.message.endswith("no finite cost found") and nothing.nfev == 40
