#!/usr/bin/env python3
"""The README's quick start on a fresh clone, with busy processes beside it (issue 42: "a fresh clone that passes").

Reads the commands of the README's "Set up and run" block (so it runs what a newcomer types, never
a copy that could drift), clones the current commit into a temporary folder, makes a virtual
environment there, starts ``--busy`` processes that each keep one core busy, and runs the commands
one after the other in the clone with that environment active and an empty build and compile
cache. Prints each command's exit status and wall time, and the machine's load, then ends the busy
processes it started (by their ids). Exit status: 0 when every command passed, else 1.

It takes long (a cold compile, the main job and the whole default test suite, on a loaded machine),
so CI does not run it; run it before a release, or after a change to the install,
the compile cache, the thread settings or the test suite's speed (CONTRIBUTING.md):

    python3 .ci/quickstart_under_load.py                 # two busy processes, as on a shared 2-core machine
    python3 .ci/quickstart_under_load.py --busy 0        # idle, for comparison
    python3 .ci/quickstart_under_load.py --dry-run       # the commands and the plan only
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BUSY_LOOP = "while True: pass"


def quick_start_commands(readme: str) -> list[str]:
    """The shell commands of the first ``bash`` block under the README's "Set up and run" heading, comments removed.

    Raises:
        ValueError: the README has no such block.
    """
    section = re.search(r"^## Set up and run\n(.*?)(?=^## )", readme, re.MULTILINE | re.DOTALL)
    block = re.search(r"^```bash\n(.*?)^```", section.group(1), re.MULTILINE | re.DOTALL) if section else None
    if block is None:
        raise ValueError("README.md: no ```bash block under '## Set up and run'; expected the quick start's commands")
    commands = [re.sub(r"\s+#.*$", "", line).strip() for line in block.group(1).splitlines()]
    return [command for command in commands if command and not command.startswith("#")]


def main(argv: list[str] | None = None) -> int:
    """Run the quick start on a fresh clone beside ``--busy`` busy processes; 0 when every command passed."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--busy", type=int, default=2, help="busy processes beside the quick start (default 2)")
    parser.add_argument("--keep", action="store_true", help="keep the clone (its path is printed)")
    parser.add_argument("--dry-run", action="store_true", help="print the commands and the plan, run nothing")
    args = parser.parse_args(argv)
    if args.busy < 0:
        parser.error(f"--busy: got {args.busy}, expected an integer >= 0")
    commands = quick_start_commands((ROOT / "README.md").read_text(encoding="utf-8"))
    commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                            check=True).stdout.strip()  # fmt: skip
    print(f"quick start of {commit[:12]} with {args.busy} busy processes: {' ; '.join(commands)}")
    if args.dry_run:
        return 0
    work = Path(tempfile.mkdtemp(prefix="uav-quickstart-"))
    busy: list[subprocess.Popen] = []
    results = []
    try:
        clone = work / "clone"
        subprocess.run(["git", "clone", "--quiet", "--no-hardlinks", str(ROOT), str(clone)], check=True)
        subprocess.run(["git", "checkout", "--quiet", commit], cwd=clone, check=True)
        subprocess.run([sys.executable, "-m", "venv", str(work / "venv")], check=True)
        env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
        env.update(
            VIRTUAL_ENV=str(work / "venv"),
            PATH=f"{work / 'venv' / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}",
            UAV_PENETRATION_CACHE=str(work / "cache"),  # cold builds and compiles, as on a new machine
            MPLBACKEND="Agg",
        )
        busy = [subprocess.Popen([sys.executable, "-c", BUSY_LOOP]) for _ in range(args.busy)]
        for command in commands:
            started = time.monotonic()
            done = subprocess.run(["bash", "-c", command], cwd=clone, env=env)
            seconds = time.monotonic() - started
            load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
            results.append((command, done.returncode, seconds))
            print(f"== {command}: exit {done.returncode} in {seconds:.0f} s (load average {load:.1f})", flush=True)
            if done.returncode != 0:
                break
    finally:
        for process in busy:  # only the processes this script started
            process.terminate()
            process.wait()
        if args.keep:
            print(f"clone kept in {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)
    print("\n".join(f"{'ok  ' if status == 0 else 'FAIL'} {seconds:7.0f} s  {command}"
                    for command, status, seconds in results))  # fmt: skip
    passed = len(results) == len(commands) and all(status == 0 for _, status, _ in results)
    return 0 if passed else 1


if __name__ == "__main__":
    sys.exit(main())
