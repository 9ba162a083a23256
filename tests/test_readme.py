"""The README's commands and code run as printed (a newcomer copies them as they are)."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from uav_penetration_env.benchmark import cli

README = Path(__file__).resolve().parents[1] / "README.md"
GUIDE = Path(__file__).resolve().parents[1] / "docs" / "guide.md"


def blocks(language: str, page: Path = README) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", page.read_text(), flags=re.M | re.S)


def uav_bench_lines() -> list[list[str]]:
    """Every ``uav-bench`` command of the README's shell blocks, as argv lists (comments dropped)."""
    commands = []
    for block in blocks("bash"):
        for line in block.splitlines():
            for part in line.split("#", 1)[0].split("&&"):
                words = shlex.split(part)
                if words[:1] == ["uav-bench"]:
                    commands.append(words[1:])
    return commands


def test_the_readme_has_python_and_shell_blocks():
    assert blocks("python") and len(uav_bench_lines()) >= 4


@pytest.mark.parametrize("argv", uav_bench_lines(), ids=" ".join)
def test_every_uav_bench_line_of_the_readme_parses(argv):
    """Each printed command names a real subcommand and only flags it accepts (argparse exits 2 otherwise)."""
    cli.build_parser().parse_args(argv)


def test_the_python_blocks_of_the_readme_run(monkeypatch, tmp_path):
    """The env snippet runs as printed, in a fresh namespace (no name it relies on is defined elsewhere)."""
    monkeypatch.chdir(tmp_path)
    for block in blocks("python"):
        exec(compile(block, str(README), "exec"), {})


# The guide's Python blocks build on each other (one namespace, in order, as a reader runs them);
# the fifth flies ihpso on 20 seeds (about a minute) and the sixth trains PPO: those are slow. The
# block with SB3's SubprocVecEnv needs the rl extra and starts four processes: it stands alone and
# tests/test_faults_round4.py flies it.
GUIDE_FAST_BLOCKS = 4


def guide_blocks() -> list[str]:
    """The guide's Python blocks a reader runs in one namespace (the SB3 vector-env example apart)."""
    return [b for b in blocks("python", GUIDE) if "stable_baselines3" not in b]


def test_the_guides_first_python_blocks_run_in_order(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for block in guide_blocks()[:GUIDE_FAST_BLOCKS]:
        exec(compile(block, str(GUIDE), "exec"), namespace)
    assert namespace["costs"].shape == (100,) and namespace["res"].nfev <= 20_000


@pytest.mark.slow
def test_the_guides_evaluate_block_runs_after_the_others(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for block in guide_blocks()[: GUIDE_FAST_BLOCKS + 1]:
        exec(compile(block, str(GUIDE), "exec"), namespace)
    assert len(namespace["df"]) == 40
