"""A worker process that dies costs its episode an error row, not the run (loky and dask)."""

from __future__ import annotations

import re
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import tiny_scenario, wait_for_episodes

from uav_penetration_env.benchmark import workers

HERE = Path(__file__).parent


@pytest.fixture
def dying(monkeypatch):
    monkeypatch.syspath_prepend(str(HERE))  # the loky workers import it from the same path
    import dying_tasks

    return dying_tasks


def test_a_task_that_kills_its_worker_gets_the_death_and_the_others_their_results(dying):
    tasks = [1, -1, 2, 3, 4, -2, 5]
    results = [row for row, _ in workers.loky_results(tasks, 2, dying.fly, dying.died)]
    assert sorted(row["task"] for row in results) == sorted(tasks)  # each task once
    dead = {row["task"]: row["died"] for row in results if "died" in row}
    assert dead == {-1: "worker died (exit code 3)", -2: "worker died (exit code 3)"}


def test_death_reason_reads_loky_exit_codes():
    assert workers.death_reason(RuntimeError("The exit codes of the workers are {EXIT(3)}")) == (
        "worker died (exit code 3)"
    )
    assert workers.death_reason(RuntimeError("... are {SIGSEGV(-11)}")) == "worker died (exit code -11, SIGSEGV)"
    assert workers.death_reason(RuntimeError("pool broke\nmore")) == "worker died (pool broke)"


def bench(*argv: object, cwd: Path) -> subprocess.CompletedProcess:
    env_path = f"{HERE}:{HERE.parent.parent}"
    return subprocess.run(
        [sys.executable, "-m", "uav_penetration_env.benchmark.cli", *map(str, argv)],
        capture_output=True, text=True, cwd=cwd, env={**__import__("os").environ, "PYTHONPATH": env_path},
    )  # fmt: skip


def stored(store: Path) -> list[tuple[str, int, str, str]]:
    with sqlite3.connect(store) as connection:
        rows = connection.execute("SELECT policy, seed, outcome, error FROM episodes ORDER BY policy, seed")
        return [(p, s, o, e.splitlines()[0] if e else "") for p, s, o, e in rows]


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["loky", "dask"])
def test_run_with_a_dying_worker_stores_an_error_row_exits_1_and_a_rerun_continues(tmp_path, backend):
    if backend == "dask":
        pytest.importorskip("dask.distributed")
    scenario = tiny_scenario(time={"max_steps": 8}).to_yaml(tmp_path / "tiny.yaml")
    store = tmp_path / "s.sqlite"
    argv = ["run", "--import", "dying_optimizer", "--policies", "greedy", "test-dying", "--scenarios", scenario,
            "--seeds", 2, "--max-evals", 50, "--horizon", 1, "--jobs", 2, "--backend", backend,
            "--no-report", "--no-progress", "--store", store]  # fmt: skip
    for _ in range(2):  # the rerun flies the error rows again, and ends the same way
        done = bench(*argv, cwd=tmp_path)
        assert done.returncode == 1, done.stderr[-800:]
        assert "Traceback" not in done.stderr
        assert re.fullmatch(r"first error \(test-dying, seed [01]\): worker died.*", done.stderr.strip().splitlines()[-1])
        rows = stored(store)
        assert [(p, s, o == "error") for p, s, o, _ in rows] == [
            ("greedy", 0, False), ("greedy", 1, False), ("test-dying", 0, True), ("test-dying", 1, True)
        ]  # fmt: skip
        if backend == "loky":
            assert rows[2][3] == rows[3][3] == "worker died (exit code 3)"


def test_loky_workers_leave_ctrl_c_to_the_parent():
    """A terminal's Ctrl-C reaches every process of the group: the workers ignore it (api.md §4.7)."""
    import signal

    executor = workers._executor(1)
    try:
        assert executor.submit(signal.getsignal, signal.SIGINT).result() == signal.SIG_IGN
    finally:
        executor.shutdown(wait=True, kill_workers=True)


def test_ctrl_c_during_a_run_prints_one_line_and_keeps_the_finished_episodes(tmp_path):
    """SIGINT to the run's whole process group, as a terminal sends it: exit 130, one line, no traceback."""
    import os
    import signal

    scenario = tiny_scenario().to_yaml(tmp_path / "tiny.yaml")
    store = tmp_path / "interrupted.sqlite"
    command = [sys.executable, "-m", "uav_penetration_env.benchmark.cli", "run", "--scenarios", str(scenario),
               "--policies", "test-slow", "greedy", "--seeds", "24", "--jobs", "2", "--import", "slow_optimizer",
               "--no-report", "--no-progress", "--store", str(store)]  # fmt: skip
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE.parent.parent), str(HERE), os.environ.get("PYTHONPATH", "")]))
    # A shell's background job (`cmd &` without job control, as CI scripts and nohup start them) runs
    # with SIGINT ignored, and a child inherits that: the run would then rightly ignore the Ctrl-C.
    # The child gets the default handling, as a process started from a terminal has it.
    process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                               start_new_session=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # fmt: skip
    # The slow planner takes 0.2 s a step (24 episodes, seconds each), so the run outlasts the poll that
    # waits for 2 stored episodes on any machine: a run of fast episodes could end in that gap and exit
    # 0 (seen under two busy processes with 128 tiny pso episodes, issue 42).
    stored = wait_for_episodes(store, process, at_least=2, seconds=300, poll_s=0.05)
    assert process.poll() is None, f"the run ended before the interruption: {process.stderr.read()[-500:]}"
    os.killpg(process.pid, signal.SIGINT)
    _, stderr = process.communicate(timeout=300)
    assert process.returncode == 130, stderr
    assert "Traceback" not in stderr, stderr
    lines = [line for line in stderr.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("interrupted: "), stderr
    with sqlite3.connect(store) as connection:
        assert connection.execute("SELECT COUNT(*) FROM episodes").fetchone()[0] >= stored


def test_an_unreachable_scheduler_is_refused_in_one_line(tmp_path, capsys, monkeypatch):
    pytest.importorskip("dask.distributed")
    from uav_penetration_env.benchmark import cli

    monkeypatch.setattr(workers, "CONNECT_SECONDS", 2)  # nothing listens there: no need to wait long
    scenario = tiny_scenario(time={"max_steps": 3}).to_yaml(tmp_path / "tiny.yaml")
    status = cli.main(["run", "--backend", "dask", "--scheduler", "tcp://127.0.0.1:9", "--policies", "greedy",
                       "--scenarios", str(scenario), "--seeds", "1", "--no-report", "--no-progress",
                       "--store", str(tmp_path / "s.sqlite")])  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1, err
    assert err[0].startswith("uav-bench: error: --scheduler tcp://127.0.0.1:9: cannot connect"), err


PLUGIN = '''
from dataclasses import dataclass

import numpy as np

from optimizers import OptimizeResult, register_optimizer


@register_optimizer("test-shipped-search")
@dataclass(frozen=True)
class ShippedSearch:
    def minimize(self, fun, bounds, *, rng=None, max_evals=10_000):
        rng = np.random.default_rng(rng)
        lo, hi = np.asarray(bounds.lb, float), np.asarray(bounds.ub, float)
        xs = rng.uniform(lo, hi, size=(min(max_evals, 20), lo.size))
        fs = np.asarray(fun(xs), float)
        i = int(np.argmin(fs))
        return OptimizeResult(x=xs[i], fun=float(fs[i]), nfev=len(xs), nit=1, message="done",
                              history=[float(fs[i])], history_nfev=[len(xs)])
'''


@pytest.fixture
def external_cluster(tmp_path):
    """A dask scheduler and one worker started apart, as on another machine: their own folder and path."""
    pytest.importorskip("dask.distributed")
    import os
    import time

    folder = tmp_path / "cluster"
    folder.mkdir()
    address_file = folder / "scheduler.json"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(HERE.parent.parent)  # the project, not the plug-in's folder
    common = dict(cwd=folder, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--no-dashboard",
                                  "--port", "0", "--scheduler-file", str(address_file)], **common)  # fmt: skip
    worker = None
    try:
        deadline = time.monotonic() + 120  # a bound on the start, not an assertion on speed
        while not address_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", "--no-dashboard",
                                   "--nworkers", "1", "--nthreads", "1", "--scheduler-file", str(address_file)],
                                  **common)  # fmt: skip
        import json

        from dask.distributed import Client

        address = json.loads(address_file.read_text())["address"]
        with Client(address, timeout=60) as client:
            client.wait_for_workers(1, timeout=120)
        yield address
    finally:
        for process in (worker, scheduler):
            if process is not None:
                process.terminate()
                process.wait(timeout=60)


def test_an_imported_single_file_plugin_reaches_an_external_clusters_workers(tmp_path, external_cluster, capsys,
                                                                           monkeypatch):  # fmt: skip
    """--import of a module beside the user, with a cluster that lacks it: the module is sent to the
    workers (client.upload_file) and every episode flies (before: each failed to unpickle its policy)."""
    from uav_penetration_env.benchmark import cli

    here = tmp_path / "user"
    here.mkdir()
    (here / "shipped_plugin.py").write_text(PLUGIN)
    monkeypatch.chdir(here)
    monkeypatch.syspath_prepend(str(here))
    scenario = tiny_scenario(time={"max_steps": 4}).to_yaml(tmp_path / "tiny.yaml")
    store = tmp_path / "s.sqlite"
    status = cli.main(["run", "--backend", "dask", "--scheduler", external_cluster, "--import", "shipped_plugin",
                       "--policies", "test-shipped-search", "--scenarios", str(scenario), "--seeds", "2",
                       "--max-evals", "40", "--no-report", "--no-progress", "--store", str(store)])  # fmt: skip
    captured = capsys.readouterr()
    assert status == 0, captured.err[-2000:]
    with sqlite3.connect(store) as connection:
        errors = [row[0] for row in connection.execute("SELECT error FROM episodes")]
    assert len(errors) == 2 and all(not e for e in errors), errors


def test_a_package_the_workers_lack_is_refused_in_one_line(tmp_path, external_cluster, capsys, monkeypatch):
    from uav_penetration_env.benchmark import cli

    here = tmp_path / "user"
    (here / "shipped_package").mkdir(parents=True)
    (here / "shipped_package" / "__init__.py").write_text(PLUGIN.replace("test-shipped-search", "test-shipped-package"))
    monkeypatch.chdir(here)
    monkeypatch.syspath_prepend(str(here))
    scenario = tiny_scenario(time={"max_steps": 4}).to_yaml(tmp_path / "tiny.yaml")
    status = cli.main(["run", "--backend", "dask", "--scheduler", external_cluster, "--import", "shipped_package",
                       "--policies", "test-shipped-package", "--scenarios", str(scenario), "--seeds", "1",
                       "--no-report", "--no-progress", "--store", str(tmp_path / "s.sqlite")])  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1, err
    assert "--import shipped_package: 1 of the 1 dask workers" in err[0] and "installed on every worker" in err[0]
