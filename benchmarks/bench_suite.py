"""What verifying and running the frozen suite cost (docs/suite.md).

Prints the wall-clock seconds of

* ``suite verify`` with the build cache warm (every member rebuilt from the cache, fingerprinted
  and replayed),
* the same in an empty cache (every terrain and masking floor computed afresh: a fresh install),
* ``uav-bench run --suite NAME --policies greedy --seeds 1`` into a new store, the suite tables
  included (cache warm).

Run from the repository root:

    python benchmarks/bench_suite.py            # the whole suite: a few minutes on 2 cores
    python benchmarks/bench_suite.py --quick    # three members, a smoke run
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from uav_penetration_env import cache
from uav_penetration_env.benchmark import cli
from uav_penetration_env.suites import load_suite, verify_suite

QUICK_MEMBERS = ("uavpen-v1/paper", "uavpen-v1/d0.25/30000", "uavpen-v1/d0.75/30200")


def _verify(name: str, members: Sequence[str] | None) -> float:
    started = time.perf_counter()
    failures = [check for check in verify_suite(name, members) if check.error is not None]
    if failures:
        raise SystemExit(f"verify failed: {failures[0].error}")
    return time.perf_counter() - started


def main(argv: Sequence[str] | None = None) -> dict[str, float]:
    """Time the three operations; returns their seconds by name."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--suite", default="uavpen-v1")
    parser.add_argument("--quick", action="store_true", help=f"only {', '.join(QUICK_MEMBERS)}")
    args = parser.parse_args(argv)
    members = list(QUICK_MEMBERS) if args.quick else None
    count = len(load_suite(args.suite).select(members))
    results = {"verify_warm_s": _verify(args.suite, members)}  # also warms the cache for the run below
    saved = os.environ.get(cache.ENV_VAR)
    with tempfile.TemporaryDirectory(prefix="bench-suite-") as folder:
        os.environ[cache.ENV_VAR] = str(Path(folder) / "cache")
        cache.clear_memory()
        try:
            results["verify_cold_s"] = _verify(args.suite, members)
        finally:
            if saved is None:
                os.environ.pop(cache.ENV_VAR, None)
            else:
                os.environ[cache.ENV_VAR] = saved
            cache.clear_memory()
        run = ["run", "--suite", args.suite, "--policies", "greedy", "--seeds", "1", "--no-progress"]
        run += ["--store", str(Path(folder) / "suite.sqlite"), "--out", str(Path(folder) / "out")]
        if members:
            run += ["--members", *members]
        started = time.perf_counter()
        with contextlib.redirect_stdout(io.StringIO()):
            status = cli.main(run)
        results["run_greedy_s"] = time.perf_counter() - started
    if status != 0:
        raise SystemExit(f"uav-bench {' '.join(run)} exited with {status}")
    print(f"suite {args.suite}, {count} members, {os.cpu_count()} cores")
    print(f"  verify, build cache warm:                  {results['verify_warm_s']:7.1f} s")
    print(f"  verify, empty cache (a fresh install):     {results['verify_cold_s']:7.1f} s")
    print(f"  run --suite --policies greedy --seeds 1:   {results['run_greedy_s']:7.1f} s (tables included)")
    return results


if __name__ == "__main__":
    main()
