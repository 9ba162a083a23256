"""Running one command of a campaign: in this tree, on a clean commit, its attempt logged.

Shared by the publication campaigns (:mod:`~uav_penetration_env.benchmark.campaign.runner`) and
the RL programme (``baselines/programme.py``).
"""

from __future__ import annotations

import datetime as dt
import os
import resource
import shutil
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from uav_penetration_env.benchmark.campaign.log import append_attempt, command_key


def uav_bench_command() -> list[str]:
    """How to call ``uav-bench``: the console script beside this Python, else the module."""
    script = Path(sys.executable).with_name("uav-bench")
    if script.is_file():
        return [str(script)]
    found = shutil.which("uav-bench")
    return [found] if found else [sys.executable, "-m", "uav_penetration_env.benchmark.cli"]


def program(argv: Sequence[str]) -> list[str]:
    """The full command line: a script of the tree (``*.py``) under this Python, else ``uav-bench``."""
    return [sys.executable, *argv] if argv and argv[0].endswith(".py") else [*uav_bench_command(), *argv]


def child_environment(repo: Path) -> dict[str, str]:
    """The environment of every command: ``repo`` first on ``PYTHONPATH``.

    So the commands import the code whose commit is checked and recorded, not an editable install
    of another checkout.
    """
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(repo), env.get("PYTHONPATH", "")) if p)
    return env


def imported_from(repo: Path) -> Path:
    """Where the commands import the package from (checked against ``repo`` before anything runs)."""
    out = subprocess.run([sys.executable, "-c", "import uav_penetration_env as p; print(p.__file__)"],
                         cwd=repo, env=child_environment(repo), capture_output=True, text=True, check=True).stdout  # fmt: skip
    return Path(out.strip()).resolve().parent


def dirty_files(repo: Path) -> list[str]:
    """Tracked files that differ from the commit (untracked files do not count, as in provenance)."""
    out = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=repo,
                         capture_output=True, text=True, check=True).stdout  # fmt: skip
    return [line[3:] for line in out.splitlines() if line.strip()]


def commit(repo: Path) -> str:
    """The commit ``repo`` is at (``unknown`` outside a git checkout)."""
    done = subprocess.run(["git", "rev-parse", "HEAD"], cwd=repo, capture_output=True, text=True)
    return done.stdout.strip() if done.returncode == 0 else "unknown"


def wait_through_interrupt(process: subprocess.Popen) -> int:
    """The exit status of ``process``, a signal read as a shell's ``128 + N``.

    On Ctrl-C the child (same process group) saves its state and ends; this waits for it instead
    of killing it mid-write.
    """
    try:
        status = process.wait()
    except KeyboardInterrupt:
        status = process.wait()
    return 128 - status if status < 0 else status


def run_attempt(repo: Path, part: str, argv: Sequence[str], log: Path | None) -> int:
    """Run one command in ``repo`` and append its attempt (wall and CPU seconds, status) to ``log``.

    Args:
        repo: the repository the command runs in (its working directory, first on ``PYTHONPATH``).
        part: the part (or step) name logged with the attempt.
        argv: ``uav-bench`` arguments, or a ``*.py`` script of the tree and its arguments.
        log: the compute log (``None``: not logged).

    Returns:
        The command's exit status.
    """
    revision = commit(repo)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat()
    clock = time.perf_counter()
    status = wait_through_interrupt(subprocess.Popen(program(argv), cwd=repo, env=child_environment(repo)))
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if log is not None:
        append_attempt(log, {"part": part, "command": command_key(argv), "started": started,
                             "wall_s": round(time.perf_counter() - clock, 1), "cpu_s": round(cpu, 1),
                             "status": status, "commit": revision})  # fmt: skip
    return status


def bench(repo: Path, argv: Sequence[str]) -> int:
    """One ``uav-bench`` command in ``repo``, not logged (its exit status)."""
    return subprocess.run([*uav_bench_command(), *argv], cwd=repo, env=child_environment(repo)).returncode
