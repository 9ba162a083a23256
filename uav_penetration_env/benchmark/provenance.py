"""Provenance of a run: command, commit, versions, machine, date (headers of every leaderboard)."""

from __future__ import annotations

import datetime as dt
import os
import platform
import subprocess
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

LIBRARIES = (
    "numpy",
    "scipy",
    "gymnasium",
    "pandas",
    "joblib",
    "cmaes",
    "matplotlib",
    "stable-baselines3",
    "torch",
    "distributed",
)


def git_commit(folder: str | Path | None = None) -> str:
    """The current commit (with ``-dirty`` for uncommitted changes), or ``unknown`` outside git."""
    folder = Path(folder or Path(__file__).resolve().parents[2])
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=folder, capture_output=True, text=True, check=True, timeout=10
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=folder,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return commit + ("-dirty" if dirty.strip() else "")


def library_versions() -> dict[str, str]:
    """Installed versions of the package and the libraries whose numbers it depends on."""
    versions = {"uav-penetration": _version("uav-penetration"), "python": platform.python_version()}
    for name in LIBRARIES:
        versions[name] = _version(name)
    return versions


def _version(name: str) -> str:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "not installed"


def cpu_description() -> str:
    """The CPU model name (from /proc/cpuinfo where available)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def provenance(command: str | None = None) -> dict[str, Any]:
    """Everything a reader needs to reproduce a table: command, commit, versions, machine, date."""
    return {
        "command": command if command is not None else " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]),
        "commit": git_commit(),
        "versions": library_versions(),
        "cpu": cpu_description(),
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "date": dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat(),
    }
