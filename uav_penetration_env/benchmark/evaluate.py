"""One evaluator for every planner: paired seeds, parallel episodes, a store that loses nothing.

``evaluate(policies, scenarios, seeds, ...)`` flies each (policy, scenario, seed) episode in the
single env and returns one row per episode. Seeds are paired across policies (api.md): for seed
``s`` on a scenario, ``env_seed, policy_seed = SeedSequence([s, int(scenario_hash, 16)]).spawn(2)``,
so every policy meets the same start (and jitter) and paired statistics are valid.

Episodes run in worker processes (joblib's loky, or a dask.distributed cluster) and come back to
the parent, which alone writes the store: one transaction per finished episode. A rerun skips
finished episodes and retries ``error`` rows; an episode whose planner raises becomes an ``error``
row and the sweep goes on.
"""

from __future__ import annotations

import contextlib
import copy
import datetime as dt
import hashlib
import json
import os
import sys
import time
import traceback
from collections.abc import Callable, Generator, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env import __version__, warmup
from uav_penetration_env.benchmark import workers
from uav_penetration_env.benchmark.clock import timed
from uav_penetration_env.benchmark.columns import EpisodeSteps, start_row, step_row, summarise
from uav_penetration_env.benchmark.information import BeliefFeed, episode_env, planning_model
from uav_penetration_env.benchmark.plugins import has_address_repr, import_plugins, stable_parameters
from uav_penetration_env.benchmark.provenance import provenance as run_provenance
from uav_penetration_env.benchmark.seeding import episode_seeds
from uav_penetration_env.benchmark.store import EPISODE_COLUMNS, ResultsStore
from uav_penetration_env.build import build_scenario
from uav_penetration_env.kernels import limit_worker_threads
from uav_penetration_env.scenario import Scenario, load_scenario

# The timings with their conditions (model.md §8): the same compile took 25-60 s on 2 idle cores and
# 289 s beside two busy processes.
COMPILE_MESSAGE = (
    "compiling the physics (first run only: about 25-60 s on 2 idle cores, several minutes on a busy "
    "machine) ..."
)
BACKENDS = workers.BACKENDS  # the sweep backends (workers.py, which imports no physics)


def policy_config(policy: Any) -> dict[str, Any]:
    """A policy's configuration: its ``config()`` when it has one, else its class and repr.

    A repr that names a memory address differs in every process, so its attributes stand in for it
    (:func:`~.plugins.stable_parameters`; a policy with neither is refused with a one-line error).
    """
    if hasattr(policy, "config"):
        config = dict(policy.config())
    else:
        # A default repr differs in every process: the policy's plain attributes stand in for it.
        text = stable_parameters(policy, "policies") if has_address_repr(policy) else repr(policy)
        config = {"class": f"{type(policy).__module__}.{type(policy).__qualname__}", "repr": text}
    config["package_version"] = __version__
    return config


def policy_hash(policy: Any) -> str:
    """16 hex digits of the policy configuration (the store key's first part)."""
    text = json.dumps(policy_config(policy), sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class EpisodeTask:
    """Everything a worker needs to fly one episode."""

    policy_name: str
    policy: Any
    policy_hash: str
    scenario: Scenario
    seed: int
    imports: tuple[str, ...] = ()
    extra: Mapping[str, Any] = field(default_factory=dict)
    threads: int | None = None  # compiled threads of the episode (None: one per worker process)

    @property
    def key(self) -> tuple[str, str, int]:
        """The store key (policy hash, scenario hash, seed)."""
        return (self.policy_hash, self.scenario.hash, self.seed)


def run_episode(task: EpisodeTask) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Fly one episode and summarise it; a raising planner yields an ``error`` row (never an exception).

    Returns:
        The episode row (the ``episodes`` columns) and one dict per track point, the start state's
        step-0 row first (no step rows for an ``error`` row).
    """
    limit_worker_threads(task.threads)  # workers share the cores: one compiled thread each unless told otherwise
    warmup.load_once()  # the compiled code is loaded before the episode's clock starts (warmup.load_once)
    started = time.perf_counter()
    scenario = task.scenario
    row = _episode_key_row(task)
    steps: list[dict[str, Any]] = []
    try:
        import_plugins(task.imports)
        policy = copy.deepcopy(task.policy)  # every episode starts from the same policy state
        env = episode_env(scenario)  # the dynamic env for a dynamic scenario (docs/dynamic.md)
        env_seed, policy_seed = episode_seeds(task.seed, scenario.hash)
        observation, info = env.reset(seed=env_seed)
        # per-map setup (V, weights, ...), api.md §4.12; the belief, or the truth for an oracle
        _, setup = timed(policy.reset, planning_model(env, policy), policy_seed)
        feed = BeliefFeed(env, policy)  # a new belief reaches the policy inside its timed decision
        steps.append(start_row(info))  # step 0: the start state, so no reader replays the reset
        states = [info["state"]]
        done = False
        while not done:
            decided, clock = timed(feed.act, observation, info)
            action = np.asarray(decided, dtype=np.float64)
            record = {**(getattr(policy, "last_record", None) or {}),
                      "planning_seconds": clock.wall, "planning_cpu_seconds": clock.cpu}  # fmt: skip
            observation, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
            steps.append(step_row(info, action, record))
            states.append(info["state"])
        row.update(summarise(EpisodeSteps(steps[1:], np.array(states), info, truncated)))
        row.update({"setup_seconds": setup.wall, "setup_cpu_seconds": setup.cpu})
        metadata = getattr(policy, "metadata", None)
        if isinstance(metadata, Mapping):
            row.update({k: v for k, v in metadata.items() if k in ("train_timesteps", "train_seconds")})
    except (Exception, SystemExit) as error:
        # A plug-in's SystemExit (even exit code 0) is its episode's failure, not the end of the run:
        # the other episodes go on and this one is stored as an error row. Ctrl-C still propagates.
        row.update(
            {"outcome": "error", "error": f"{type(error).__name__}: {error}\n{traceback.format_exc(limit=6)}"}
        )
        steps = []
    row["episode_seconds"] = time.perf_counter() - started
    row["finished"] = _now()
    return row, steps


def worker_died(task: EpisodeTask, reason: str) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The ``error`` row of an episode whose worker process died flying it (:mod:`.workers`)."""
    row = _episode_key_row(task)
    row.update(
        {
            "outcome": "error",
            "error": f"{reason}\nthe worker process flying this episode ended abruptly (a crash in "
            "compiled code, the OOM killer or os._exit in a plug-in); rerunning retries it",
            "finished": _now(),
        }
    )
    return row, []


def _episode_key_row(task: EpisodeTask) -> dict[str, Any]:
    """The columns of an episode row known before it is flown (its key, scenario and settings)."""
    scenario = task.scenario
    return {
        "policy": task.policy_name,
        "policy_hash": task.policy_hash,
        "scenario": scenario.name,
        "scenario_hash": scenario.hash,
        "seed": int(task.seed),
        "weights": ",".join(f"{w:g}" for w in scenario.cost.weights),
        "profile": scenario.profile,
        **{k: v for k, v in task.extra.items() if k in EPISODE_COLUMNS},
    }


def _now() -> str:
    return dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat()


# --- the sweep ----------------------------------------------------------------------------------------


def _iterate(
    tasks: Sequence[EpisodeTask], n_jobs: int, backend: str, scheduler: str | None, connection: Any = None
) -> Generator[tuple[dict, list], None, None]:
    """Episode results as they finish, from the chosen backend (a worker's death: :mod:`.workers`)."""
    if backend == "sequential" or (n_jobs == 1 and backend == "loky"):
        for task in tasks:
            yield run_episode(task)
    elif backend == "loky":
        yield from workers.loky_results(tasks, n_jobs, run_episode, worker_died)
    elif backend == "dask":
        yield from workers.dask_results(tasks, n_jobs, scheduler, run_episode, worker_died, connection)
    else:
        raise ValueError(f"backend: got {backend!r}, expected one of {', '.join(BACKENDS)}")


def check_arguments(
    policies: Any,
    scenarios: Any,
    seeds: Any,
    n_jobs: Any,
    backend: Any,
    store: Any,
) -> list[int]:
    """:func:`evaluate`'s arguments against their domains, before any work; returns the seeds.

    Raises:
        ValueError: naming the argument, the value and the domain.
        TypeError: a policy without ``reset``/``act``; a single scenario or seed where a sequence is due.
    """
    if not isinstance(policies, Mapping) or not policies:
        raise ValueError(f"policies: got {policies!r}, expected a non-empty mapping of name -> policy")
    for name, policy in policies.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"policies: got the name {name!r}, expected a non-empty string")
        if not (callable(getattr(policy, "reset", None)) and callable(getattr(policy, "act", None))):
            raise TypeError(
                f"policies[{name!r}]: got {type(policy).__name__}, expected a Policy "
                "(with reset(model, seed) and act(observation, info))"
            )
    if isinstance(scenarios, (str, Path, Mapping, Scenario)) or not isinstance(scenarios, Sequence):
        raise TypeError(f"scenarios: got {scenarios!r}, expected a sequence of scenarios (e.g. [scenario])")
    if not scenarios:
        raise ValueError("scenarios: got none, expected at least one scenario")
    if isinstance(seeds, (str, bytes)) or not isinstance(seeds, Iterable):
        raise TypeError(f"seeds: got {seeds!r}, expected a sequence of integers >= 0 (e.g. range(5))")
    seed_list = []
    for position, seed in enumerate(seeds):
        if not isinstance(seed, (int, np.integer)) or isinstance(seed, (bool, np.bool_)) or seed < 0:
            raise ValueError(f"seeds[{position}]: got {seed!r}, expected an integer >= 0")
        seed_list.append(int(seed))
    if not seed_list:
        raise ValueError("seeds: got none, expected at least one seed")
    if n_jobs is not None and (not isinstance(n_jobs, (int, np.integer)) or isinstance(n_jobs, bool)):
        raise ValueError(
            f"n_jobs: got {n_jobs!r}, expected None or an integer (0: all cores, -N: all but N-1)"
        )
    if backend not in BACKENDS:
        raise ValueError(f"backend: got {backend!r}, expected one of {', '.join(BACKENDS)}")
    if store is not None and not isinstance(store, (str, Path, ResultsStore)):
        raise TypeError(f"store: got {type(store).__name__}, expected a path, a ResultsStore or None")
    return seed_list


def _resolve_jobs(n_jobs: int | None) -> int:

    cores = os.cpu_count() or 1
    if n_jobs is None or n_jobs == 0:
        return cores
    if n_jobs < 0:
        return max(1, cores + 1 + n_jobs)
    return int(n_jobs)


def evaluate(
    policies: Mapping[str, Any],
    scenarios: Sequence[Scenario | str | Path | Mapping[str, Any]],
    seeds: Iterable[int],
    n_jobs: int | None = 1,
    backend: str = "loky",
    store: str | Path | ResultsStore | None = None,
    *,
    scheduler: str | None = None,
    imports: Sequence[str] = (),
    progress: bool = True,
    command: str | None = None,
    include: Callable[[str, Any, Scenario, int], bool] | None = None,
    run_settings: Mapping[str, Any] | None = None,
    threads: int | None = None,
) -> pd.DataFrame:
    """Score every policy on every scenario and seed; one row per episode (api.md).

    Args:
        policies: display name -> policy (anything with ``reset(model, seed)`` and ``act``).
        scenarios: scenarios (objects, YAML paths or mappings).
        seeds: episode seeds; paired across policies.
        n_jobs: worker processes (``None``/0 = all cores, negative = all but ``-n_jobs - 1``).
        backend: ``"loky"`` (joblib, one machine), ``"dask"`` (dask.distributed; ``scheduler`` is the
            cluster address, none starts a local cluster) or ``"sequential"``.
        store: SQLite results file (or an open :class:`ResultsStore`); ``None`` returns results only.
        scheduler: dask scheduler address, e.g. ``"tcp://host:8786"``.
        imports: plug-in modules to import in every worker before the policies are used.
        progress: show a progress bar (episodes done, ETA, failures).
        command: the command line recorded in the run's provenance.
        include: ``(policy name, policy, scenario, seed) -> bool``: fly only the episodes it accepts
            (default: every policy x scenario x seed); a suite's seed rule (docs/suite.md §4).
        run_settings: extra entries of the run's settings record (e.g. ``{"suite": "uavpen-v1"}``).
        threads: compiled threads per episode (``None``: one per worker process, numba's default in
            this process; model.md §8). Results do not depend on it.

    Returns:
        One row per requested episode (stored ones included when a store is given).

    Raises:
        ValueError: an argument outside its domain (no policy or scenario, a seed that is not an
            integer >= 0, an unknown backend, ...), naming the argument, the value and the domain;
            a scenario that does not load (``ScenarioError``).
        TypeError: a policy without ``reset``/``act``, or a single scenario where a sequence is due.
        KeyboardInterrupt: propagated after the store is left consistent.
    """
    seed_list = check_arguments(policies, scenarios, seeds, n_jobs, backend, store)
    hashes, scenario_list = _checked_inputs(policies, scenarios, imports, threads)
    tasks = episode_tasks(policies, hashes, scenario_list, seed_list, tuple(imports), include, threads)
    own_store = store is not None and not isinstance(store, ResultsStore)
    results: ResultsStore | None = (
        store if store is None or isinstance(store, ResultsStore) else ResultsStore(store)
    )
    connection = None
    try:
        if backend == "dask" and tasks:
            # Connected, and the plug-ins sent to the workers, before the run is recorded: an
            # unreachable scheduler or a plug-in the workers lack is refused before any work.
            connection = workers.dask_client(_resolve_jobs(n_jobs), scheduler, tuple(imports))
        pending, run_id = tasks, None
        if results is not None:
            settings = {"policies": list(policies), "scenarios": [s.name for s in scenario_list], "seeds": seed_list,
                        "n_jobs": n_jobs, "backend": backend, **dict(run_settings or {})}  # fmt: skip
            pending, run_id = _start_run(results, tasks, policies, hashes, scenario_list, command, settings)
        for scenario in {s.hash: s for s in scenario_list}.values():
            build_scenario(scenario)  # warm the disk cache once, so workers only load it
        if pending:
            _compile_first(progress)
        bar = _progress_bar(pending, len(tasks) - len(pending), progress)
        try:
            rows = _fly(pending, _resolve_jobs(n_jobs), backend, scheduler, results, run_id, bar, connection)
        finally:
            bar.close()
        return _frame(rows) if results is None else _requested(results, tasks)
    finally:
        _close(connection, results if own_store else None)


def _close(connection: Any, results: ResultsStore | None) -> None:
    """Close the dask client and cluster (already closed by the sweep unless nothing was pending) and our store."""
    if connection is not None:
        client, cluster = connection
        client.close()
        if cluster is not None:
            cluster.close()
    if results is not None:
        results.close()


def _checked_inputs(
    policies: Mapping[str, Any], scenarios: Sequence[Any], imports: Sequence[str], threads: int | None
) -> tuple[dict[str, str], list[Scenario]]:
    """The policies' configuration hashes (one name each) and the loaded scenarios, after the plug-ins' imports.

    Raises:
        ValueError: a bad ``threads``, two names of one configuration, or a scenario that does not load.
    """
    if threads is not None and (not isinstance(threads, (int, np.integer)) or isinstance(threads, bool) or threads < 1):
        raise ValueError(f"threads: got {threads!r}, expected None or an integer >= 1")
    import_plugins(imports)
    scenario_list = [load_scenario(s) for s in scenarios]
    hashes = {name: policy_hash(policy) for name, policy in policies.items()}
    if len(set(hashes.values())) < len(hashes):
        raise ValueError(
            f"policies: two names share one configuration ({hashes}); give each configuration one name"
        )
    return hashes, scenario_list


def episode_tasks(
    policies: Mapping[str, Any],
    hashes: Mapping[str, str],
    scenarios: Sequence[Scenario],
    seeds: Sequence[int],
    imports: tuple[str, ...],
    include: Callable[[str, Any, Scenario, int], bool] | None,
    threads: int | None = None,
) -> list[EpisodeTask]:
    """Every (scenario, seed, policy) episode ``include`` accepts, in that nesting order."""
    tasks = []
    for scenario in scenarios:
        for seed in seeds:
            for name, policy in policies.items():
                if include is not None and not include(name, policy, scenario, seed):
                    continue
                extra = {
                    k: getattr(policy, k)
                    for k in ("horizon", "max_evals")
                    if isinstance(getattr(policy, k, None), int)
                }
                tasks.append(EpisodeTask(name, policy, hashes[name], scenario, seed, imports, extra, threads))
    return tasks


def _start_run(
    results: ResultsStore,
    tasks: list[EpisodeTask],
    policies: Mapping[str, Any],
    hashes: Mapping[str, str],
    scenarios: Sequence[Scenario],
    command: str | None,
    settings: dict[str, Any],
) -> tuple[list[EpisodeTask], int]:
    """Register the policies and scenarios, open a run record; returns the tasks not yet stored and the run id."""
    done = results.done_keys()
    pending = [t for t in tasks if t.key not in done]
    results.register(
        {hashes[n]: (n, policy_config(p)) for n, p in policies.items()},
        {s.hash: (s.name, scenario_yaml(s)) for s in scenarios},
    )
    return pending, results.start_run(run_provenance(command), settings)


def _fly(
    pending: list[EpisodeTask],
    jobs: int,
    backend: str,
    scheduler: str | None,
    results: ResultsStore | None,
    run_id: int | None,
    bar: Any,
    connection: Any = None,
) -> list[dict[str, Any]]:
    """Fly the pending episodes, storing each as it finishes (an interruption loses none that did)."""
    rows: list[dict[str, Any]] = []
    failures = 0
    # closing: an interruption met while storing still shuts the workers down at once
    with contextlib.closing(_iterate(pending, jobs, backend, scheduler, connection)) as finished:
        for row, steps in finished:
            _store(row, steps, results, run_id)
            rows.append(row)
            failures += row.get("outcome") == "error"
            bar.finished(row["policy"], float(row.get("episode_seconds", float("nan"))))
            bar.set_postfix(failures=failures)
    return rows


def _store(row: dict[str, Any], steps: list[dict[str, Any]], results: ResultsStore | None, run_id: int | None) -> None:
    """Write one finished episode into the store (none: the rows are only returned)."""
    if results is not None:
        row["run_id"] = run_id
        results.write_episode(row, steps)


def _requested(results: ResultsStore, tasks: list[EpisodeTask]) -> pd.DataFrame:
    """The stored episodes of ``tasks`` (those flown now and those found done)."""
    wanted = {t.key for t in tasks}
    stored = results.episodes()
    keys = list(zip(stored["policy_hash"], stored["scenario_hash"], stored["seed"].astype(int), strict=True))
    return stored[[k in wanted for k in keys]].reset_index(drop=True)


def _frame(rows: list[dict[str, Any]]) -> pd.DataFrame:
    frame = pd.DataFrame(rows)
    for column in EPISODE_COLUMNS:
        if column not in frame:
            frame[column] = None
    return frame[list(EPISODE_COLUMNS)]


def scenario_yaml(scenario: Scenario) -> str:
    """The scenario as the store keeps it (``scenarios.yaml``): its full mapping, in field order."""
    import yaml

    return yaml.safe_dump(scenario.to_dict(), sort_keys=False)


def _compile_first(progress: bool) -> None:
    """On a first run, compile the physics here, saying so, before the workers start (they then load it)."""
    from uav_penetration_env import warmup

    if not warmup.is_cold():
        return
    if progress:
        print(COMPILE_MESSAGE, file=sys.stderr, flush=True)
    seconds = warmup.compile_physics()
    if progress:
        print(f"compiled in {seconds:.0f} s", file=sys.stderr, flush=True)


def _progress_bar(pending: list[EpisodeTask], already: int, enabled: bool):
    from uav_penetration_env.benchmark.progress import EpisodeETA, ProgressBar

    description = f"episodes ({already} already stored)" if already else "episodes"
    eta = EpisodeETA(task.policy_name for task in pending)
    return ProgressBar(len(pending), description, unit="ep", enabled=enabled, eta=eta)
