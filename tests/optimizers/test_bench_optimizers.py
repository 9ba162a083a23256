"""Smoke test: the benchmark script runs end to end with its smallest settings (so it cannot rot)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_optimizers.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_optimizers", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the class is created
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        sys.modules.pop(spec.name, None)


def test_benchmark_functions_have_their_minimum_at_zero(bench):
    import numpy as np

    for problem in bench.PROBLEMS:
        x_star = np.full((1, 7), 1.0 if problem.name == "rosenbrock" else bench.SHIFT)
        assert abs(problem.fun(x_star)[0]) < 1e-12, problem.name
        assert problem.fun(x_star + 0.3)[0] > 1e-3, problem.name


def test_quick_run_prints_both_tables(bench, capsys, tmp_path):
    out_csv = tmp_path / "runs.csv"
    status = bench.main(["--quick", "--dims", "2", "--optimizers", "ihpso", "pso", "cem", "--n-jobs", "1",
                         "--csv", str(out_csv)])  # d = 2: bounds must not be read as (lower, upper) pairs
    assert status == 0
    text = capsys.readouterr().out
    assert "median final error" in text and "ms/iteration" in text
    for name in ("ihpso", "pso", "cem"):
        assert sum(line.startswith(name + " ") for line in text.splitlines()) == 2  # results + overhead
    assert len(out_csv.read_text().splitlines()) == 1 + 3 * 5 * 2


def test_unknown_optimizer_is_rejected(bench):
    with pytest.raises(KeyError, match="did you mean 'ihpso'"):
        bench.main(["--quick", "--optimizers", "ihspo", "--n-jobs", "1"])


def test_biased_case_prints_every_rule(bench, capsys, tmp_path):
    out_csv = tmp_path / "biased.csv"
    status = bench.main(["--biased", "--quick", "--dims", "3", "--optimizers", "pso", "lpso", "cem",
                         "--n-jobs", "1", "--csv", str(out_csv)])
    assert status == 0
    lines = capsys.readouterr().out.splitlines()
    header = next(line for line in lines if line.startswith("optimizer"))
    assert header.split() == ["optimizer", "absorb", "reflect", "damp", "random"]
    rows = [line.split() for line in lines if line.startswith(("pso ", "lpso ", "cem "))]
    assert [row[0] for row in rows] == ["pso", "lpso"]  # cem has no boundary rule: left out
    assert all(row[2::2] and all(cell.endswith("/2") for cell in row[2::2]) for row in rows)
    assert len(out_csv.read_text().splitlines()) == 1 + 2 * 4 * 2


def test_biased_run_counts_a_coordinate_on_a_wall_as_stuck(bench):
    row = bench.run_biased("pso", "absorb", 2, 0, 200)
    assert row["boundary"] == "absorb" and row["nfev"] == 200
    assert isinstance(row["stuck"], bool) and row["error"] >= 0
