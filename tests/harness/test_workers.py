"""A worker process that dies costs its episode an error row, not the run (loky and dask)."""

from __future__ import annotations

import re
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import tiny_scenario

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
    import time

    scenario = tiny_scenario().to_yaml(tmp_path / "tiny.yaml")
    store = tmp_path / "interrupted.sqlite"
    command = [sys.executable, "-m", "uav_penetration_env.benchmark.cli", "run", "--scenarios", str(scenario),
               "--policies", "pso", "greedy", "--seeds", "8", "--max-evals", "1500", "--jobs", "2",
               "--no-report", "--no-progress", "--store", str(store)]  # fmt: skip
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE.parent.parent), os.environ.get("PYTHONPATH", "")]))
    process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)  # fmt: skip
    stored, deadline = 0, time.monotonic() + 300  # a bound on the wait, not an assertion on speed
    while time.monotonic() < deadline and process.poll() is None and stored < 2:
        if store.exists():
            try:
                with sqlite3.connect(store, timeout=1) as connection:
                    stored = connection.execute("SELECT COUNT(*) FROM episodes").fetchone()[0]
            except sqlite3.OperationalError:
                stored = 0
        time.sleep(0.05)
    assert process.poll() is None, f"the run ended before the interruption: {process.stderr.read()[-500:]}"
    os.killpg(process.pid, signal.SIGINT)
    _, stderr = process.communicate(timeout=300)
    assert process.returncode == 130, stderr
    assert "Traceback" not in stderr, stderr
    lines = [line for line in stderr.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("interrupted: "), stderr
    with sqlite3.connect(store) as connection:
        assert connection.execute("SELECT COUNT(*) FROM episodes").fetchone()[0] >= stored
