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
    monkeypatch.setattr(warmup, "is_cold", lambda: True)
    monkeypatch.setattr(warmup, "compile_physics", lambda: calls.append("compiled") or 12.0)
    evaluate({"greedy": GreedyPolicy()}, [tiny_scenario()], [0], progress=True)
    err = capsys.readouterr().err
    assert calls == ["compiled"]
    assert "compiling the physics (first run only" in err and "compiled in 12 s" in err
    assert err.index("compiling the physics") < err.index("episodes")


def test_a_warm_run_compiles_nothing_first(monkeypatch, capsys):
    monkeypatch.setattr(warmup, "is_cold", lambda: False)
    monkeypatch.setattr(warmup, "compile_physics", lambda: (_ for _ in ()).throw(AssertionError("compiled")))
    evaluate({"greedy": GreedyPolicy()}, [tiny_scenario()], [0], progress=False)
    assert "compiling" not in capsys.readouterr().err


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
