"""The project's thread setting caps NumPy's and SciPy's BLAS pools too (model.md §8, BLAS threads)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

CHILD = textwrap.dedent(
    """
    import sys
    import numpy, scipy.linalg  # both BLAS libraries loaded, at their default (all cores)
    from threadpoolctl import threadpool_info
    {setting}
    pools = [p for p in threadpool_info() if p["user_api"] == "blas"]
    assert pools, "no BLAS pool found"
    print(sorted({{p["num_threads"] for p in pools}}), len(pools))
    """
)
SETTINGS = {
    "cli": "from uav_penetration_env.benchmark.cli import main; main(['scenario', 'show', 'paper'])",
    "worker": "from uav_penetration_env.kernels import limit_worker_threads; limit_worker_threads(1)",
    "threads": "from uav_penetration_env.kernels import limit_worker_threads; limit_worker_threads(2)",
}


def blas_threads(setting: str, **environment: str) -> tuple[list[int], int]:
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS",
                                                          "MKL_NUM_THREADS", "BLIS_NUM_THREADS")}  # fmt: skip
    env.update(environment, PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-c", CHILD.format(setting=setting)], capture_output=True, text=True,
                          env=env, timeout=600, cwd=ROOT)  # fmt: skip
    assert done.returncode == 0, done.stderr
    counts, pools = done.stdout.strip().splitlines()[-1].rsplit(" ", 1)
    return json.loads(counts), int(pools)


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="one core: every BLAS pool has one thread anyway")
def test_without_a_setting_the_blas_pools_use_every_core():
    """The control: the child sees pools larger than one thread, so the checks below can fail."""
    counts, pools = blas_threads("pass")
    assert pools >= 1 and max(counts) > 1


def test_the_cli_caps_every_blas_pool_at_one_thread():
    counts, pools = blas_threads(SETTINGS["cli"])
    assert counts == [1] and pools >= 2  # NumPy's and SciPy's own OpenBLAS


def test_a_worker_gets_as_many_blas_threads_as_numba_threads():
    assert blas_threads(SETTINGS["worker"])[0] == [1]
    import numba

    if numba.config.NUMBA_NUM_THREADS >= 2:
        assert blas_threads(SETTINGS["threads"])[0] == [2]


def test_a_users_blas_variable_is_kept_by_the_cli():
    counts, _ = blas_threads(SETTINGS["cli"], OPENBLAS_NUM_THREADS="2")
    assert 1 not in counts or (os.cpu_count() or 1) < 2


def test_the_test_session_runs_blas_on_one_thread():
    from threadpoolctl import threadpool_info

    if any(name in os.environ for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")):
        pytest.skip("the user chose the BLAS threads")
    assert {p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"} == {1}
