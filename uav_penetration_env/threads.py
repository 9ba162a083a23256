"""The BLAS thread pools of NumPy and SciPy, capped where the project sets numba's threads (model.md §8).

numba's compiled threads are set by :func:`uav_penetration_env.kernels.limit_worker_threads`; the
linear algebra of NumPy and SciPy (CMA-ES's eigendecomposition and its sampling, ``B @ diag(D)``)
runs on the thread pools of their own BLAS libraries (OpenBLAS in the wheels: one in NumPy, one in
SciPy), which the environment variables ``OPENBLAS_NUM_THREADS`` and friends set only before the
library loads. :func:`limit_blas_threads` caps both pools in a running process with
``threadpoolctl``.

DECISION (model.md §8, BLAS threads): the project's processes run BLAS on the threads numba gets:
one in each harness worker (or ``--threads N``), and one in the main process of ``uav-bench`` and
of the test session, unless the user set ``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``,
``MKL_NUM_THREADS`` or ``BLIS_NUM_THREADS`` (then the main process keeps the user's setting). The
project's matrices are small (CMA-ES in d dimensions: d x d), where a second BLAS thread gains
little and, on a busy machine, waits for a core: CMA-ES in 100 dimensions spent 112 s in one
generation with two BLAS threads beside two busy processes on 2 cores, and 5 s with one.
"""

from __future__ import annotations

import os

# The variables a user sets to choose the BLAS threads themselves (read by the libraries at load time).
BLAS_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


def limit_blas_threads(threads: int = 1, *, respect_environment: bool = False) -> int | None:
    """Cap every loaded BLAS pool (NumPy's and SciPy's, both loaded here first) at ``threads``.

    Args:
        threads: the pool size, at least 1.
        respect_environment: leave the pools alone when the user set one of :data:`BLAS_VARIABLES`
            (a main process; a harness worker's variables are set by the harness itself).

    Returns:
        The count now in force, or None when the user's setting was kept.

    Raises:
        ValueError: ``threads`` is not an integer >= 1.
    """
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"threads: got {threads!r}, expected an integer >= 1")
    if respect_environment and any(name in os.environ for name in BLAS_VARIABLES):
        return None
    import numpy  # noqa: F401  # its BLAS is loaded, so the limit reaches it
    import scipy.linalg  # noqa: F401  # SciPy's wheels ship their own BLAS: load it too
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=threads, user_api="blas")  # in force until changed (not a context here)
    return threads
