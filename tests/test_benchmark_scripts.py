"""Smoke tests: the env and harness benchmark scripts run end to end with their quick settings."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.script_modules import load_script

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def load(name: str):
    return load_script(BENCHMARKS / f"{name}.py")


def test_bench_env_quick_run_reports_every_figure(capsys):
    results = load("bench_env").main(["--quick"])
    out = capsys.readouterr().out
    for header in ("build times", "single env", "native vector env", "rollout_cost"):
        assert header in out
    assert results["single_env_steps_per_s"] > 0 and results["rollout_vs_env"] > 1
    assert {"vector_1", "vector_16", "vector_256", "vector_1024"} <= set(results)


def test_bench_contention_measures_each_figure_idle_and_loaded(capsys):
    results = load("bench_contention").main(["--seconds", "0.05", "--load", "1"])
    assert list(results) == ["idle, OMP_WAIT_POLICY=PASSIVE", "with 1 busy processes, OMP_WAIT_POLICY=PASSIVE"]
    for ratios in results.values():
        assert {"rollout 100 x 5", "rollout 10000 x 5", "vector env 256", "single env"} <= set(ratios)
        assert all(ratio > 0 for ratio in ratios.values())
    assert "x" in capsys.readouterr().out


def test_bench_vector_breakdown_prints_each_component_and_the_ratio(capsys):
    rows = load("bench_vector_breakdown").main(["--envs", "16", "--repeats", "1", "--steps", "5"])
    out = capsys.readouterr().out
    for part in ("kinematics", "radars (", "terrain patch", "fused step + observe", "reset draws", "ratio x"):
        assert part in out
    assert all(value > 0 for value in rows.values())
    # The whole step costs more than the compiled pass it makes.
    assert rows["vector env step, whole"] > rows["fused step + observe kernel (the vector env's)"]


@pytest.mark.slow
def test_bench_vector_breakdown_compares_two_trees_idle_and_loaded(capsys):
    root = str(BENCHMARKS.parent)
    quick = ["--rounds", "1", "--envs", "16", "--repeats", "1", "--steps", "5", "--load", "1"]
    results = load("bench_vector_breakdown").main(["--compare", root, *quick])
    assert {"idle, speed-up", "with 1 busy processes, speed-up"} <= set(results)
    assert all(value > 0 for value in results.values())
    assert "faster after" in capsys.readouterr().out


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


def test_bench_rl_quick_run_reports_every_case(capsys):
    from conftest import RL_EXTRA

    pytest.importorskip("stable_baselines3", reason=RL_EXTRA)
    bench = load("bench_rl")
    results = bench.main(["--quick"])
    out = capsys.readouterr().out
    assert set(results) == set(bench.CASES) and all(value > 0 for value in results.values())
    assert out.count("steps per CPU-s") == len(bench.CASES)


def test_bench_suite_quick_run_reports_every_figure(capsys):
    results = load("bench_suite").main(["--quick"])
    out = capsys.readouterr().out
    assert "suite uavpen-v1, 3 members" in out and "run --suite --policies greedy --seeds 1" in out
    assert set(results) == {"verify_warm_s", "verify_cold_s", "run_greedy_s"}
    assert all(value > 0 for value in results.values())


def test_the_quick_start_check_runs_the_readmes_own_commands(tmp_path):
    """.ci/quickstart_under_load.py reads the README's quick start, so it runs what a newcomer types."""
    path = Path(__file__).resolve().parents[1] / ".ci" / "quickstart_under_load.py"
    module = load_script(path)
    readme = (path.parents[1] / "README.md").read_text(encoding="utf-8")
    assert module.quick_start_commands(readme) == ['pip install -e ".[dev]"', "uav-bench run && pytest"]
    with pytest.raises(ValueError, match="no ```bash block under '## Set up and run'"):
        module.quick_start_commands("# README\n\n## Set up and run\n\nno block\n\n## Next\n")
    contributing = (path.parents[1] / "CONTRIBUTING.md").read_text(encoding="utf-8")
    assert "python3 .ci/quickstart_under_load.py" in contributing


def test_bench_value_quick_run_times_each_part_and_matches_the_reference(capsys):
    results = load("bench_value").main(["--quick"])
    out = capsys.readouterr().out
    assert list(results) == ["0 busy processes beside it", "1 busy processes beside it"]
    for builds, changes in results.values():
        assert [(row["map"], row["threads"]) for row in builds] == [("random-50000", 1), ("random-50000", 2)]
        assert all(row["difference"] <= 1e-9 for row in builds)
        assert all(row[f"{method}_{part}"] > 0 for row in builds for method in ("reference", "sweeps") for part in ("moves", "costs", "sweeps", "route"))
        assert [row["change"] for row in changes] == ["added", "moved", "removed"]
        assert all(row["difference"] <= 1e-9 and 0 < row["changed_moves"] < row["moves"] for row in changes)
    assert "radar added" in out and "max rel diff" in out
