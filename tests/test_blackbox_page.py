"""docs/blackbox.md runs as printed: its Python blocks in order, its command lines parse (the d3rlpy block: slow)."""

from __future__ import annotations

import importlib.util
import json
import re
import shlex
from pathlib import Path

import pytest

from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.store import ResultsStore

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "blackbox.md"
EXTRAS = all(importlib.util.find_spec(m) is not None for m in ("ioh", "nevergrad", "minari"))
pytestmark = pytest.mark.skipif(not EXTRAS, reason="the page needs the blackbox and offline extras")


def python_blocks() -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", PAGE.read_text(encoding="utf-8"), flags=re.M | re.S)


def command_lines() -> list[list[str]]:
    blocks = re.findall(r"^```bash\n(.*?)^```", PAGE.read_text(encoding="utf-8"), flags=re.M | re.S)
    lines = [shlex.split(line, comments=True) for block in blocks for line in block.splitlines()]
    return [words[1:] for words in lines if words[:1] == ["uav-bench"]]


def window_row(optimizer: str, seed: int, step: int) -> dict:
    """A stored window run as `uav-bench windows` writes it (the page's export reads these)."""
    history, nfev = [9.0 - seed, 7.5 - seed, 7.0 - seed], [100, 200, 300]
    return {
        "scenario": "paper-2022-sec5", "scenario_hash": "cb71b7b881715851", "source_policy": "greedy",
        "source_policy_hash": "0" * 16, "episode_seed": 0, "step": step, "state": "[]", "optimizer": optimizer,
        "optimizer_hash": f"{optimizer}-config", "seed": seed, "max_evals": 300, "horizon": 5, "nfev": 300,
        "nit": 2, "fun": history[-1], "history": json.dumps(history), "history_nfev": json.dumps(nfev),
        "message": "", "seconds": 0.0,
    }  # fmt: skip


@pytest.fixture(scope="module")
def page_folder(tmp_path_factory):
    """A folder holding what the page's shell lines would have made: a store of window runs and a Minari dataset."""
    from uav_penetration_env.benchmark.minari_export import plan_datasets, write_datasets

    folder = tmp_path_factory.mktemp("page")
    results = folder / "results"
    results.mkdir()
    with ResultsStore(results / "windows.sqlite") as store:
        store.write_window_runs(
            [window_row(o, s, k) for o in ("ihpso", "cem") for s in range(3) for k in (4, 10)]
        )
    store_path = results / "paper.sqlite"
    argv = ["run", "--policies", "greedy", "--scenarios", "paper", "--seeds", "1", "--store", str(store_path),
            "--no-report", "--no-progress", "--jobs", "1"]  # fmt: skip
    assert cli.main(argv) == 0
    with ResultsStore(store_path, create=False) as store:
        plans = plan_datasets(store.episodes(), dataset_id="uav-penetration/paper-2022-sec5-ihpso-v0")
        write_datasets(store, plans, results / "paper-minari")
    return folder


def test_every_command_line_of_the_page_parses():
    commands = command_lines()
    assert [c[0] for c in commands] == ["run", "windows", "export", "run", "export"]
    for argv in commands:
        cli.build_parser().parse_args(argv)


def test_the_pages_python_blocks_run_in_order(page_folder, monkeypatch, capsys):
    monkeypatch.chdir(page_folder)
    monkeypatch.delenv("MINARI_DATASETS_PATH", raising=False)
    namespace: dict = {}
    blocks = [b for b in python_blocks() if "import d3rlpy" not in b]
    assert len(blocks) == 5
    for block in blocks:
        exec(compile(block, str(PAGE), "exec"), namespace)
    printed = capsys.readouterr().out
    assert "offline/paper-2022-sec5 450" in printed and "window/paper-2022-sec5/k0 15" in printed
    assert "[('uavpen-v1/paper', 1), ('uavpen-v1/paper-w2', 2)]" in printed
    assert "['cem', 'ihpso']" in printed
    assert (
        namespace["problem"].optimum is not None and namespace["f"].optimum.y == namespace["problem"].optimum
    )
    assert list(
        (page_folder / "results" / "ioh-offline").glob("IOHprofiler_f*_uavpen_offline_paper-2022-sec5.json")
    )
    scores = namespace["minari"].get_normalized_score(namespace["dataset"], namespace["returns"])
    assert scores.tolist() == pytest.approx([0.0], abs=1e-9)  # the greedy floor scores 0


@pytest.mark.slow
def test_the_d3rlpy_recipe_runs(page_folder, monkeypatch):
    pytest.importorskip("d3rlpy", reason="d3rlpy, installed as docs/blackbox.md §4 says (--no-deps)")
    import numpy as np

    monkeypatch.chdir(page_folder)
    namespace: dict = {}
    blocks = python_blocks()
    for block in blocks[:1] + [b for b in blocks if "import minari" in b or "import d3rlpy" in b]:
        exec(compile(block, str(PAGE), "exec"), namespace)
    scaler = namespace["scaler"]
    assert np.all(np.isfinite(namespace["bc"].predict(namespace["mdp"].episodes[0].observations[:3])))
    assert np.all(scaler.maximum > scaler.minimum)  # the declared box: no zero range, even on greedy data
    assert np.isfinite(namespace["total"])
