"""Episodes on worker processes that may die: a dead worker costs its episode an error row, not the run.

A worker process ended by the operating system (a crash in compiled code, the OOM killer, a plug-in
calling ``os._exit``) raises no exception a planner could catch. loky then breaks its whole pool:
every episode in flight fails with ``TerminatedWorkerError``, which does not say which of them
killed the worker. dask retries the episode on other workers and then gives it up as
``KilledWorker``.

DECISION (api.md §4.7, a worker that dies): the loky sweep keeps at most one episode per worker in
flight, so that the episodes a broken pool takes down are known. Each of them is flown again alone
(one episode in flight), once: one that kills its worker again is stored as an error row
``worker died (exit code N)``; the others' rows are stored as usual. The remaining episodes go on
on a fresh pool. A dask episode given up as ``KilledWorker`` becomes the same error row. An error
row is retried by the next run (the resume rule, api.md §4.4), which therefore repeats only the crashing
episodes, each once.
"""

from __future__ import annotations

import logging
import os
import re
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

Result = tuple[dict[str, Any], list[dict[str, Any]]]
Fly = Callable[[Any], Result]
Died = Callable[[Any, str], Result]

# The thread pools a worker may start, each capped at the worker's share of the cores (as joblib's
# loky backend does) unless the user set the variable: workers share the machine.
THREAD_VARIABLES = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "BLIS_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMBA_NUM_THREADS",
    "NUMEXPR_NUM_THREADS",
)
BACKENDS = ("loky", "dask", "sequential")  # evaluate(backend=...), uav-bench run --backend
IDLE_WORKER_SECONDS = 300  # idle workers wait this long for the next sweep in the same process


def death_reason(error: BaseException) -> str:
    """``worker died (exit code N)`` from loky's error (its message lists the workers' exit codes)."""
    codes = re.findall(r"([A-Z]+)\((-?\d+)\)", str(error))
    if not codes:
        return f"worker died ({str(error).splitlines()[0] if str(error) else type(error).__name__})"
    shown = ", ".join(code if name == "EXIT" else f"{code}, {name}" for name, code in codes)
    return f"worker died (exit code {shown})"


def ignore_interrupts() -> None:
    """A worker's initializer: Ctrl-C (SIGINT) is the parent's to handle, never the worker's.

    DECISION (api.md §4.7, a quiet Ctrl-C): a terminal sends SIGINT to the whole process group, so
    without this each loky worker raised ``KeyboardInterrupt`` inside its episode and printed its
    traceback beside the run's one line. The parent alone takes the interruption: it kills the
    workers (:func:`loky_results`) and says ``interrupted: N finished episodes are stored ...``.
    """
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _executor(jobs: int) -> Any:
    """The reusable loky pool of ``jobs`` workers (a fresh one when the last one broke or was shut down)."""
    from joblib.externals.loky import cpu_count, get_reusable_executor

    share = str(max(cpu_count() // jobs, 1))
    env = {name: os.environ.get(name, share) for name in THREAD_VARIABLES}
    return get_reusable_executor(
        max_workers=jobs, timeout=IDLE_WORKER_SECONDS, env=env, initializer=ignore_interrupts
    )


def loky_results(tasks: Sequence[Any], jobs: int, fly: Fly, died: Died) -> Iterator[Result]:
    """``fly(task)`` of every task on ``jobs`` loky workers, as they finish; ``died(task, reason)`` for a killer.

    An interruption (Ctrl-C, SIGTERM) or any error leaving this generator kills the workers.
    """
    queue = deque(tasks)
    executor = None
    try:
        while queue:
            executor = _executor(jobs)
            running: dict[Any, Any] = {}
            suspects: list[Any] = []
            while (queue or running) and not suspects:
                while queue and len(running) < jobs:
                    task = queue.popleft()
                    running[executor.submit(fly, task)] = task
                done, _ = wait(running, return_when=FIRST_COMPLETED)
                yield from _collect(done, running, suspects)
            if suspects:
                wait(running)  # a broken pool fails the rest of its futures at once
                yield from _collect(list(running), running, suspects)
                for task in suspects:
                    executor = _executor(jobs)
                    yield _alone(executor, task, fly, died)
    except BaseException:
        if executor is not None:
            executor.shutdown(wait=False, kill_workers=True)
        raise


def _collect(done: Any, running: dict[Any, Any], suspects: list[Any]) -> list[Result]:
    """The results of the finished futures; the tasks of those a broken pool took down join ``suspects``."""
    results = []
    for future in done:
        task = running.pop(future)
        try:
            results.append(future.result())
        except BrokenProcessPool:
            suspects.append(task)
    return results


def _alone(executor: Any, task: Any, fly: Fly, died: Died) -> Result:
    """One suspect flown with nothing else in flight: if its worker dies now, the episode killed it."""
    try:
        return executor.submit(fly, task).result()
    except BrokenProcessPool as error:
        return died(task, death_reason(error))


class ClusterError(RuntimeError):
    """A dask cluster that cannot run the sweep: an unreachable scheduler, a plug-in its workers lack (one line)."""


CONNECT_SECONDS = 10  # how long a --scheduler address is tried before the run is refused


def importable(name: str) -> bool:
    """Whether this process can import module ``name`` (run on each dask worker by :func:`ship_imports`)."""
    import importlib

    try:
        importlib.import_module(name)
    except ImportError:
        return False
    return True


def ship_imports(client: Any, imports: Sequence[str], where: str) -> None:
    """Make every ``--import`` module importable on the cluster's workers, or refuse in one line.

    DECISION (api.md §4.7, plug-ins on a dask cluster): a module the workers already import (installed
    there) is left alone; a single-file module that they lack is sent to them with dask's
    ``client.upload_file`` (which also reaches workers that join later); a package they lack cannot
    be sent as one file, so the run is refused before any episode, naming the module and what to do,
    instead of each episode failing to unpickle its policy on the workers with a long traceback.
    """
    import sys
    from pathlib import Path

    for name in imports:
        answers = client.run(importable, name)
        lacking = sorted(worker for worker, ok in answers.items() if not ok)
        if not lacking:
            continue
        path = getattr(sys.modules.get(name), "__file__", None)
        if path is not None and Path(path).suffix == ".py" and Path(path).name != "__init__.py":
            # load=False: dask's own import reloads the module, which would run its registrations
            # twice; each episode imports it (EpisodeTask.imports) from the worker's folder instead.
            client.upload_file(path, load=False)
            if lacking_after := sorted(w for w, ok in client.run(importable, name).items() if not ok):
                raise ClusterError(f"--import {name}: sent to the dask workers at {where}, but {len(lacking_after)} "
                                   "cannot import it; expected it installed on every worker")  # fmt: skip
            continue
        raise ClusterError(
            f"--import {name}: {len(lacking)} of the {len(answers)} dask workers at {where} cannot import it; "
            "expected it installed on every worker (pip install it there; a single-file module is sent by "
            "uav-bench itself)"
        )


def dask_client(jobs: int, scheduler: str | None, imports: Sequence[str] = ()) -> tuple[Any, Any]:
    """A connected dask client (a local cluster of ``jobs`` workers unless ``scheduler``) whose workers import ``imports``.

    Returns:
        The client and the local cluster it owns (None with ``scheduler``); close both.

    Raises:
        ImportError: the dist extra is not installed.
        ClusterError: the scheduler cannot be reached, or a module cannot reach the workers (one line).
    """
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as error:  # pragma: no cover - depends on the installed extras
        raise ImportError("backend='dask' needs the dist extra: pip install -e '.[dist]'") from error
    cluster = None
    if scheduler is None:
        # A dying worker's restarts are warnings from every nanny, its task's failure an error of
        # the scheduler and a closing worker's heartbeat a traceback; the episode's error row and
        # the run's summary line say it once, so the local cluster logs only what is critical.
        cluster = LocalCluster(
            n_workers=max(1, jobs), threads_per_worker=1, processes=True, dashboard_address=None,
            silence_logs=logging.CRITICAL,
        )  # fmt: skip
    try:
        client = Client(scheduler or cluster, timeout=CONNECT_SECONDS)
    except (OSError, TimeoutError, ValueError) as error:
        if cluster is not None:
            cluster.close()
        reason = (str(error).splitlines() or [type(error).__name__])[0]
        raise ClusterError(
            f"--scheduler {scheduler}: cannot connect ({reason}); expected the address of a running dask "
            "scheduler, e.g. tcp://HOST:8786"
        ) from None
    try:
        ship_imports(client, imports, scheduler or "the local cluster")
    except BaseException:
        client.close()
        if cluster is not None:
            cluster.close()
        raise
    return client, cluster


def dask_results(
    tasks: Sequence[Any], jobs: int, scheduler: str | None, fly: Fly, died: Died, connection: Any = None
) -> Iterator[Result]:
    """``fly(task)`` of every task on a dask cluster (a local one of ``jobs`` workers unless ``scheduler``).

    ``connection``: a ``(client, cluster)`` from :func:`dask_client` to use (and close); None opens one.
    """
    from dask.distributed import as_completed
    from distributed.scheduler import KilledWorker

    client, cluster = connection if connection is not None else dask_client(jobs, scheduler)
    try:
        futures = client.map(fly, list(tasks), pure=False)
        owner = {future.key: task for future, task in zip(futures, tasks, strict=True)}
        for future in as_completed(futures):
            try:
                result = future.result()
            except KilledWorker as error:
                # dask tried the episode on several workers and every one died running it.
                result = died(owner[future.key], _dask_reason(error))
            yield result
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _dask_reason(error: BaseException) -> str:
    """``worker died (dask tried it on N workers, each died)`` from dask's ``KilledWorker``."""
    tries = re.search(r"on (\d+) different workers", str(error))
    return f"worker died (dask tried it on {tries.group(1)} workers, each died)" if tries else "worker died (dask)"
