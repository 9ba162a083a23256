"""Smoke tests: the env and harness benchmark scripts run end to end with their quick settings."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def load(name: str):
    spec = importlib.util.spec_from_file_location(name, BENCHMARKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
    finally:
        sys.modules.pop(spec.name, None)
    return module


def test_bench_env_quick_run_reports_every_figure(capsys):
    results = load("bench_env").main(["--quick"])
    out = capsys.readouterr().out
    for header in ("build times", "single env", "native vector env", "rollout_cost"):
        assert header in out
    assert results["single_env_steps_per_s"] > 0 and results["rollout_vs_env"] > 1
    assert {"vector_1", "vector_16", "vector_256", "vector_1024"} <= set(results)


@pytest.mark.slow
def test_bench_harness_full_settings_run():
    results = load("bench_harness").main(["--steps", "3", "--max-evals", "2000", "--sweep-max-evals", "1000"])
    assert 0.0 < results["pso_share"] <= 1.0


def test_bench_harness_quick_run(capsys):
    results = load("bench_harness").main(["--quick"])
    out = capsys.readouterr().out
    assert "planning per MPC step" in out and "8-episode sweep" in out
    assert all(0.0 < results[f"{name}_share"] <= 1.0 for name in ("ihpso", "pso", "cem", "cmaes"))
    assert results["speedup"] > 0


def test_bench_checks_quick_run_reports_every_entry_point(capsys):
    results = load("bench_checks").main(["--quick"])
    out = capsys.readouterr().out
    for name in ("step, 1 row", "observe, 1 row", "rollout_cost", "height"):
        assert name in out
    assert len(results) == 5 and all(value > 0 for value in results.values())


def test_bench_suite_quick_run_reports_every_figure(capsys):
    results = load("bench_suite").main(["--quick"])
    out = capsys.readouterr().out
    assert "suite uavpen-v1, 3 members" in out and "run --suite --policies greedy --seeds 1" in out
    assert set(results) == {"verify_warm_s", "verify_cold_s", "run_greedy_s"}
    assert all(value > 0 for value in results.values())
