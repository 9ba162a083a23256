"""The first run compiles the physics once, up front, and says so; `uav-bench compile` does it on demand."""

from __future__ import annotations

from conftest import tiny_scenario

from uav_penetration_env import compile_cache, warmup
from uav_penetration_env.benchmark import GreedyPolicy, cli, evaluate


def test_an_empty_cache_folder_is_cold_and_a_filled_one_is_not(tmp_path, monkeypatch):
    warmup.compile_physics()  # the package's own folder now holds every kernel
    assert not warmup.is_cold() and warmup.cache_size_bytes() > 0
    monkeypatch.setattr(compile_cache, "COMPILE_CACHE_DIR", str(tmp_path))
    assert warmup.is_cold() and warmup.cache_size_bytes() == 0


def test_a_cold_run_says_it_is_compiling_before_the_episodes(monkeypatch, capsys):
    calls = []
    monkeypatch.setattr(warmup, "_loaded", True)  # this process's kernels are loaded (load_once: nothing)
    monkeypatch.setattr(warmup, "is_cold", lambda: True)
    monkeypatch.setattr(warmup, "compile_physics", lambda: calls.append("compiled") or 12.0)
    evaluate({"greedy": GreedyPolicy()}, [tiny_scenario()], [0], progress=True)
    err = capsys.readouterr().err
    assert calls == ["compiled"]
    assert "compiling the physics (first run only" in err and "compiled in 12 s" in err
    assert err.index("compiling the physics") < err.index("episodes")


def test_a_warm_run_compiles_nothing_first(monkeypatch, capsys):
    monkeypatch.setattr(warmup, "_loaded", True)
    monkeypatch.setattr(warmup, "is_cold", lambda: False)
    monkeypatch.setattr(warmup, "compile_physics", lambda: (_ for _ in ()).throw(AssertionError("compiled")))
    evaluate({"greedy": GreedyPolicy()}, [tiny_scenario()], [0], progress=False)
    assert "compiling" not in capsys.readouterr().err


def test_an_episode_clock_starts_after_its_process_loaded_the_compiled_code(monkeypatch):
    """A fresh worker loads the machine code (3 s on 2 cores) before timing its first episode, so the
    first ETA is not priced from a load-inflated episode (it came out 9x too high); once per process."""
    import importlib

    evaluate_module = importlib.import_module("uav_penetration_env.benchmark.evaluate")  # not the function
    events = []

    def load():
        events.append("load")
        warmup._loaded = True
        return 3.0

    class Clock:
        @staticmethod
        def perf_counter():
            events.append("clock")
            return float(len(events))

    monkeypatch.setattr(warmup, "_loaded", False)  # as in a fresh worker process
    monkeypatch.setattr(warmup, "compile_physics", load)
    monkeypatch.setattr(evaluate_module, "time", Clock)
    task = evaluate_module.EpisodeTask("greedy", GreedyPolicy(), "h", tiny_scenario(time={"max_steps": 3}), 0)
    evaluate_module.run_episode(task)
    evaluate_module.run_episode(task)
    assert events.count("load") == 1 and events.index("load") < events.index("clock")


def test_the_compile_message_states_its_conditions():
    import importlib

    COMPILE_MESSAGE = importlib.import_module("uav_penetration_env.benchmark.evaluate").COMPILE_MESSAGE

    assert "idle" in COMPILE_MESSAGE and "busy" in COMPILE_MESSAGE


def test_the_compile_command_reports_the_folder_and_its_size(capsys):
    assert cli.main(["compile"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("uav-bench compile: ") and compile_cache.COMPILE_CACHE_DIR in out and " MB" in out


def test_threads_sets_the_compiled_threads_of_each_episode_and_changes_no_result(tmp_path, capsys):
    import numba
    import pytest

    from uav_penetration_env.kernels import limit_worker_threads

    before = numba.get_num_threads()
    try:
        assert limit_worker_threads(1) == 1
        assert limit_worker_threads(10_000) == numba.config.NUMBA_NUM_THREADS  # capped at the known cores
        scenario = tiny_scenario(time={"max_steps": 6})
        one = evaluate({"greedy": GreedyPolicy()}, [scenario], [0], progress=False, threads=1)
        every = evaluate({"greedy": GreedyPolicy()}, [scenario], [0], progress=False, threads=numba.config.NUMBA_NUM_THREADS)
        assert one["total_cost"].tolist() == every["total_cost"].tolist()
        with pytest.raises(ValueError, match=r"threads: got 0, expected None or an integer >= 1"):
            evaluate({"greedy": GreedyPolicy()}, [scenario], [0], progress=False, threads=0)
        assert cli.main(["run", "--threads", "0", "--policies", "greedy", "--store", str(tmp_path / "s.sqlite")]) == 2
        assert "--threads: got 0, expected an integer >= 1" in capsys.readouterr().err
    finally:
        numba.set_num_threads(before)


COVERAGE = """
import sys, importlib
import numba
from numba.core.registry import CPUDispatcher
from uav_penetration_env import warmup

def signatures():
    counts = {}
    for name, module in list(sys.modules.items()):
        if name.startswith("uav_penetration_env") and module is not None:
            for attribute, value in vars(module).items():
                if isinstance(value, CPUDispatcher):
                    counts[f"{name}.{attribute}"] = len(value.signatures)
    return counts

warmup.compile_physics()
evaluate = importlib.import_module("uav_penetration_env.benchmark.evaluate")
from uav_penetration_env.benchmark.policies import make_policy
from uav_penetration_env.scenario import paper_scenario
before = signatures()
for name in ("greedy", "pso"):
    task = evaluate.EpisodeTask(name, make_policy(name, max_evals=200), "h", paper_scenario(), 0)
    row, _ = evaluate.run_episode(task)
    assert not row["error"], row["error"]
after = signatures()
print(sorted(k for k in after if after[k] != before.get(k, 0)))
"""


def test_the_warm_up_covers_what_an_episode_compiles():
    """After compile_physics a fresh process's greedy and MPC episodes add no compiled signature: a
    worker's first episode loads nothing in its clock (the env's own calls were missing: 20-34 s)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    done = subprocess.run([sys.executable, "-c", COVERAGE], capture_output=True, text=True, timeout=900,
                          env=dict(os.environ, PYTHONPATH=str(root)))  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip().splitlines()[-1] == "[]", done.stdout
