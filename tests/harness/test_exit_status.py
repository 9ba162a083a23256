"""Exit status tells the truth: 0 all done, 1 some work failed, 2 bad input."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import tiny_scenario

from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.store import ResultsStore

HERE = Path(__file__).parent


def run_cli(*argv: object) -> int:
    return cli.main([str(a) for a in argv])


@pytest.fixture
def tiny_yaml(tmp_path) -> Path:
    return tiny_scenario(time={"max_steps": 8}).to_yaml(tmp_path / "tiny.yaml")


def test_help_documents_the_exit_statuses(capsys):
    with pytest.raises(SystemExit) as exited:
        cli.main(["--help"])
    assert exited.value.code == 0
    text = capsys.readouterr().out
    for line in ("0    all the work was done", "1    some work failed", "2    bad arguments or inputs"):
        assert line in text


def test_run_with_failed_episodes_says_so_and_exits_1(tiny_yaml, tmp_path, capsys, monkeypatch):
    monkeypatch.syspath_prepend(str(HERE))
    store = tmp_path / "s.sqlite"
    argv = ["run", "--import", "exploding_optimizer", "--policies", "greedy,test-exploding", "--scenarios",
            tiny_yaml, "--seeds", 2, "--max-evals", 50, "--jobs", 1, "--store", store, "--no-report",
            "--no-progress"]  # fmt: skip
    assert run_cli(*argv) == 1
    captured = capsys.readouterr()
    summary = [line for line in captured.out.splitlines() if line.startswith("results: ")]
    assert summary == [f"results: {store} (4 episodes, 2 errors; 2 of 4 episodes FAILED, exit status 1)"]
    assert "planned failure" in captured.err
    with ResultsStore(store) as results:
        assert len(results.done_keys()) == 2  # greedy's two episodes are kept and skipped on rerun


def test_run_with_every_episode_done_exits_0(tiny_yaml, tmp_path, capsys):
    store = tmp_path / "s.sqlite"
    argv = ["run", "--policies", "greedy", "--scenarios", tiny_yaml, "--seeds", 2, "--store", store,
            "--no-report", "--no-progress"]  # fmt: skip
    assert run_cli(*argv) == 0
    assert f"results: {store} (2 episodes, 0 errors)" in capsys.readouterr().out


def test_calibrate_with_failed_episodes_exits_1_and_writes_nothing(tiny_yaml, tmp_path, capsys, monkeypatch):
    monkeypatch.syspath_prepend(str(HERE))
    out = tmp_path / "calibrated.yaml"
    argv = ["calibrate", "--import", "exploding_optimizer", "--optimizer", "test-exploding", "--scenario",
            tiny_yaml, "--runs", 1, "--max-evals", 20, "--horizon", 2, "--jobs", 1, "--out", out]  # fmt: skip
    assert run_cli(*argv) == 1
    err = capsys.readouterr().err
    assert "uav-bench calibrate: FAILED, no scenario written: 1 of 1 calibration episodes failed" in err
    assert not out.exists()
