"""The offline reference planner: a whole episode's controls optimised against the env's summed cost.

The decision variables are the K_max x 3 controls of an episode, normalised to the action box
([-1, 1] per component, physical control = x * ``limits.action_high``), flattened to a vector of
3 K_max numbers. The objective is the compiled model's :meth:`PenetrationModel.rollout_cost` of the
whole sequence from the start state with no discount and no cost-to-go: the sum of J(k) + penalty
of the transitions flown until the goal, a failure or K_max, which is the evaluator's
``total_cost`` of the same controls (docs/best-known.md §1; a test pins the equality).

The search is a schedule of separable CMA-ES runs (``cmaes.SepCMA``, Ros & Hansen 2008: a
diagonal covariance, linear in the dimension, for hundreds of variables), one run per start:

1. *exploration*: first one run from each given start (stored tracks, the existing record, the
   greedy episode), then runs alternating between a restart around the incumbent and a random
   start drawn from the search's generator, until ``1 - refine_fraction`` of the budget is used;
2. *refinement*: runs around the incumbent with a decreasing step size (``refine_sigmas``) until
   the budget is spent: a local search that polishes the best track.

A run ends when its best has not improved for ``stall_generations`` generations, when CMA-ES
itself stops, or when its phase ends. The budget is wall seconds and/or evaluations; with an
evaluation budget alone the result depends only on the seed (the compiled model does not depend
on the thread count). The whole search state (optimiser, incumbent, generator, budget used) is
pickled atomically to the work folder every ``checkpoint_seconds``, so an interrupted search
continues where its last checkpoint stood.
"""

from __future__ import annotations

import math
import pickle
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from uav_penetration_env.atomic import write_bytes_atomic
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.types import FloatArray

CHECKPOINT_FORMAT = "uav-penetration-best-known-search/2"


@dataclass(frozen=True)
class SearchSettings:
    """The offline search's settings (docs/best-known.md §1).

    Attributes:
        seconds: wall-clock budget of the search [s] (``None``: evaluations only).
        max_evals: evaluation budget (``None``: seconds only). With both, the first reached stops.
        seed: seed of the search's generator (random starts and every CMA-ES run's seed).
        population: CMA-ES population (``None``: cmaes' default 4 + floor(3 ln n), 22 for n = 450).
        start_sigma: initial step size of a run from a given start or the incumbent (normalised).
            DECISION (docs/best-known.md §1): 0.01 of the action box (0.02 m/s, 0.15 deg per step): a start is a good
            track, and on the paper scenario a step of 0.05 turned almost every sample of the
            450 variables into a crash (measured: 20 of 22 samples crashed).
        random_sigma: initial step size of a run from a random start.
        random_scale: random starts are uniform in [-random_scale, random_scale] per variable.
        stall_generations: a run ends after this many generations without improving its best.
        refine_fraction: the share of the budget kept for the refinement phase.
        refine_sigmas: step sizes of the refinement runs, cycled.
        checkpoint_seconds: wall seconds between checkpoints.
    """

    seconds: float | None = 90.0
    max_evals: int | None = None
    seed: int = 0
    population: int | None = None
    start_sigma: float = 0.01
    random_sigma: float = 0.3
    random_scale: float = 0.5
    stall_generations: int = 50
    refine_fraction: float = 0.2
    refine_sigmas: tuple[float, ...] = (0.005, 0.002, 0.001)
    checkpoint_seconds: float = 5.0

    def __post_init__(self) -> None:
        if self.seconds is None and self.max_evals is None:
            raise ValueError("budget: got neither seconds nor max_evals, expected at least one")
        if self.seconds is not None and not (math.isfinite(self.seconds) and self.seconds > 0):
            raise ValueError(f"seconds: got {self.seconds!r}, expected a number of seconds > 0")
        if self.max_evals is not None and self.max_evals < 1:
            raise ValueError(f"max_evals: got {self.max_evals!r}, expected an integer >= 1")
        if self.population is not None and self.population < 2:
            raise ValueError(f"population: got {self.population!r}, expected None or an integer >= 2")
        for name in ("start_sigma", "random_sigma", "random_scale"):
            value = getattr(self, name)
            if not 0 < value <= 1:
                raise ValueError(f"{name}: got {value!r}, expected a number in (0, 1]")
        if not 0 <= self.refine_fraction < 1:
            raise ValueError(f"refine_fraction: got {self.refine_fraction!r}, expected a number in [0, 1)")
        if not self.refine_sigmas or not all(0 < s <= 1 for s in self.refine_sigmas):
            raise ValueError(f"refine_sigmas: got {self.refine_sigmas!r}, expected numbers in (0, 1]")
        if self.stall_generations < 1:
            raise ValueError(f"stall_generations: got {self.stall_generations!r}, expected an integer >= 1")

    def key(self) -> dict[str, Any]:
        """The settings a checkpoint must share to be continued (everything but the budget)."""
        data = asdict(self)
        for name in ("seconds", "max_evals", "checkpoint_seconds"):
            data.pop(name)
        data["refine_sigmas"] = list(self.refine_sigmas)
        return data


@dataclass(frozen=True)
class Start:
    """One start of the search: a (K_max, 3) normalised control sequence and where it came from."""

    label: str
    x: FloatArray


@dataclass
class SearchState:
    """Everything a checkpoint holds: the search continues from it exactly."""

    scenario_hash: str
    key: dict[str, Any]
    starts: list[Start]
    rng_state: dict[str, Any]
    best_x: FloatArray
    best_f: float
    best_label: str
    evals: int = 0
    seconds: float = 0.0
    generations: int = 0
    phase: str = "explore"
    explore_runs: int = 0
    refine_runs: int = 0
    optimizer: Any = None
    run_label: str = ""
    run_best: float = math.inf
    run_stall: int = 0
    runs: list[dict[str, Any]] = field(default_factory=list)
    trace: list[tuple[int, float, float]] = field(default_factory=list)
    finished: bool = False


@dataclass(frozen=True)
class SearchResult:
    """The outcome of :func:`search`.

    Attributes:
        controls: (K_max, 3) physical controls of the best sequence.
        total: its rollout cost (the summed J + penalty).
        label: the run that found it (``start:greedy``, ``random``, ``refine``, ...).
        evals: objective evaluations spent (all sessions).
        seconds: wall seconds spent (all sessions; time after the last checkpoint of a killed
            session is not counted).
        runs: one summary per CMA-ES run (label, evaluations, best).
        trace: (evaluations, seconds, best-so-far) after every improving generation.
        starts: the starts' labels and rollout costs.
    """

    controls: FloatArray
    total: float
    label: str
    evals: int
    seconds: float
    runs: list[dict[str, Any]]
    trace: list[tuple[int, float, float]]
    starts: list[dict[str, Any]]


class EpisodeObjective:
    """Whole-episode cost of normalised control vectors: (B, 3 K_max) -> (B,) (docs/best-known.md).

    Args:
        model: the scenario's compiled model (one scenario, not a pool).
        state: (6,) the start state.
    """

    def __init__(self, model: PenetrationModel, state: FloatArray) -> None:
        self.model = model
        self.state = np.ascontiguousarray(state, dtype=np.float64)
        self.high = np.asarray(model.limits.action_high, dtype=np.float64)
        self.steps = model.max_steps
        self.dimension = 3 * self.steps

    def controls(self, x: FloatArray) -> FloatArray:
        """(..., K_max, 3) physical controls of (..., 3 K_max) normalised vectors (clipped to [-1, 1])."""
        x = np.clip(np.asarray(x, dtype=np.float64), -1.0, 1.0)
        return x.reshape(*x.shape[:-1], self.steps, 3) * self.high

    def normalise(self, controls: FloatArray) -> FloatArray:
        """(3 K_max,) normalised vector of (K, 3) physical controls, zero-padded to K_max (holding course)."""
        controls = np.asarray(controls, dtype=np.float64).reshape(-1, 3)[: self.steps]
        x = np.zeros((self.steps, 3))
        x[: len(controls)] = np.clip(controls / self.high, -1.0, 1.0)
        return x.reshape(-1)

    def __call__(self, x: FloatArray) -> FloatArray:
        """(B,) summed costs of (B, 3 K_max) normalised vectors (no discount, no cost-to-go)."""
        controls = np.ascontiguousarray(self.controls(np.atleast_2d(x)))
        return self.model.rollout_cost(self.state, controls, step=0)


def checkpoint_path(work: str | Path, scenario_hash: str, mode: str) -> Path:
    """The checkpoint file of one search: ``<work>/<scenario_hash>-<mode>.pkl``."""
    return Path(work) / f"{scenario_hash}-{mode}.pkl"


def _load_checkpoint(path: Path, scenario_hash: str, key: dict[str, Any]) -> SearchState | None:
    if not path.is_file():
        return None
    with path.open("rb") as handle:
        data = pickle.load(handle)
    if not isinstance(data, dict) or data.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(f"--work {path}: not a best-known search checkpoint; expected {CHECKPOINT_FORMAT}")
    state: SearchState = data["state"]
    if state.optimizer is not None:
        state.optimizer._rng.set_state(data["optimizer_rng"])
    if state.scenario_hash != scenario_hash or state.key != key:
        raise ValueError(
            f"--work {path}: holds a search with settings {state.key} of scenario {state.scenario_hash}, "
            f"expected {key} of {scenario_hash}; remove the file or choose another --work folder"
        )
    return state


def _save_checkpoint(path: Path, state: SearchState) -> None:
    """Pickle the search state atomically.

    ``cmaes`` optimisers leave their random generator out of a pickle (``__getstate__`` drops
    ``_rng``), so its state is saved beside them and restored on load; without it a continued run
    would draw other samples than an uninterrupted one.
    """
    optimizer_rng = None if state.optimizer is None else state.optimizer._rng.get_state()
    data = {"format": CHECKPOINT_FORMAT, "state": state, "optimizer_rng": optimizer_rng}
    write_bytes_atomic(path, pickle.dumps(data))


def search(
    objective: EpisodeObjective,
    starts: Sequence[Start],
    settings: SearchSettings,
    *,
    scenario_hash: str,
    checkpoint: str | Path | None = None,
    progress: Callable[[SearchState, float], None] | None = None,
    stop_after_generations: int | None = None,
) -> SearchResult:
    """Minimise the whole-episode cost from ``starts`` (module docstring; docs/best-known.md).

    Args:
        objective: the scenario's :class:`EpisodeObjective`.
        starts: the given starts (at least one; random starts are drawn by the search).
        settings: budget, seed and schedule.
        scenario_hash: the scenario's hash (checkpoints of another scenario are refused).
        checkpoint: the checkpoint file; an existing one with the same settings is continued
            (its starts are the ones used), ``None`` keeps everything in memory.
        progress: called after every generation with the state and the share of the budget used.
        stop_after_generations: testing hook: checkpoint and raise ``KeyboardInterrupt`` after
            this many generations of this session, as a kill after a checkpoint would.

    Returns:
        The :class:`SearchResult`.

    Raises:
        ValueError: no start, a start of the wrong size, or a checkpoint of another search.
    """
    from cmaes import SepCMA

    if not starts:
        raise ValueError("starts: got none, expected at least one start (e.g. the greedy episode)")
    for start in starts:
        if np.shape(start.x) != (objective.dimension,):
            raise ValueError(
                f"starts[{start.label!r}]: got shape {np.shape(start.x)}, expected ({objective.dimension},)"
            )
    path = None if checkpoint is None else Path(checkpoint)
    key = settings.key()
    state = None if path is None else _load_checkpoint(path, scenario_hash, key)
    if state is None:
        starts = [Start(s.label, np.clip(np.asarray(s.x, dtype=np.float64), -1.0, 1.0)) for s in starts]
        values = objective(np.stack([s.x for s in starts]))
        first = int(np.argmin(values))
        state = SearchState(
            scenario_hash=scenario_hash,
            key=key,
            starts=starts,
            rng_state=np.random.default_rng(settings.seed).bit_generator.state,
            best_x=starts[first].x.copy(),
            best_f=float(values[first]),
            best_label=f"start:{starts[first].label}",
            evals=len(starts),
        )
        state.runs = [
            {"label": f"start:{s.label}", "evals": 1, "best": float(v)}
            for s, v in zip(starts, values, strict=True)
        ]
        state.trace.append((state.evals, 0.0, state.best_f))
    rng = np.random.default_rng()
    rng.bit_generator.state = state.rng_state
    session_start = time.perf_counter()
    seconds_before = state.seconds
    last_checkpoint = session_start
    session_generations = 0

    def elapsed() -> float:
        return seconds_before + (time.perf_counter() - session_start)

    def used(seconds: float) -> float:
        shares = []
        if settings.max_evals is not None:
            shares.append(state.evals / settings.max_evals)
        if settings.seconds is not None:
            shares.append(seconds / settings.seconds)
        return max(shares)

    def new_run() -> None:
        """Start the next run of the schedule (module docstring)."""
        if state.phase == "explore":
            r = state.explore_runs
            state.explore_runs += 1
            if r < len(state.starts):
                mean, sigma, label = state.starts[r].x, settings.start_sigma, f"start:{state.starts[r].label}"
            elif (r - len(state.starts)) % 2 == 0:
                mean, sigma, label = state.best_x, settings.start_sigma, "incumbent"
            else:
                scale = settings.random_scale
                mean = rng.uniform(-scale, scale, objective.dimension)
                sigma, label = settings.random_sigma, "random"
        else:
            r = state.refine_runs
            state.refine_runs += 1
            sigma = settings.refine_sigmas[r % len(settings.refine_sigmas)]
            mean, label = state.best_x, f"refine(sigma={sigma:g})"
        bounds = np.tile([-1.0, 1.0], (objective.dimension, 1))
        state.optimizer = SepCMA(
            mean=np.clip(mean, -1.0, 1.0).copy(),
            sigma=float(sigma),
            bounds=bounds,
            seed=int(rng.integers(2**31 - 1)),
            population_size=settings.population,
            # Clip an out-of-box sample (cmaes' repair) instead of resampling it up to 100 times:
            # tracks sit on the box (greedy turns at the maximum rate), so nearly every sample of
            # 450 variables leaves it, and resampling cost more than the evaluations (measured:
            # 917 against 375 evaluations/s on the paper scenario).
            n_max_resampling=1,
        )
        state.run_label, state.run_best, state.run_stall = label, math.inf, 0
        state.runs.append({"label": label, "evals": 0, "best": math.inf})

    default_population = settings.population or 4 + math.floor(3 * math.log(objective.dimension))
    state.finished = False  # a finished search continues when it is given a larger budget
    while True:
        population = default_population if state.optimizer is None else state.optimizer.population_size
        if (settings.max_evals is not None and state.evals + population > settings.max_evals) or (
            settings.seconds is not None and elapsed() >= settings.seconds
        ):
            state.finished = True
            break
        if state.phase == "explore" and used(elapsed()) >= 1.0 - settings.refine_fraction:
            state.phase, state.optimizer = "refine", None
        if state.optimizer is None:
            new_run()
        optimizer = state.optimizer
        population = optimizer.population_size
        candidates = np.stack([optimizer.ask() for _ in range(population)])
        values = objective(candidates)
        optimizer.tell(list(zip(candidates, values.tolist(), strict=True)))
        state.evals += population
        state.generations += 1
        session_generations += 1
        run = state.runs[-1]
        run["evals"] += population
        best = int(np.argmin(values))
        if values[best] < state.run_best - 1e-12 * abs(
            state.run_best if math.isfinite(state.run_best) else 0
        ):
            state.run_best, state.run_stall = float(values[best]), 0
            run["best"] = state.run_best
        else:
            state.run_stall += 1
        if values[best] < state.best_f:
            state.best_f = float(values[best])
            state.best_x = candidates[best].copy()
            state.best_label = state.run_label
            state.trace.append((state.evals, elapsed(), state.best_f))
        if state.run_stall >= settings.stall_generations or optimizer.should_stop():
            state.optimizer = None
        state.rng_state = rng.bit_generator.state
        now = time.perf_counter()
        if progress is not None:
            progress(state, min(1.0, used(elapsed())))
        if path is not None and now - last_checkpoint >= settings.checkpoint_seconds:
            state.seconds = elapsed()
            _save_checkpoint(path, state)
            last_checkpoint = now
        if stop_after_generations is not None and session_generations >= stop_after_generations:
            state.seconds = elapsed()
            if path is not None:
                _save_checkpoint(path, state)
            raise KeyboardInterrupt(f"stop_after_generations={stop_after_generations} (testing hook)")
    state.seconds = elapsed()
    state.rng_state = rng.bit_generator.state
    if path is not None:
        _save_checkpoint(path, state)
    start_costs = [{"label": r["label"], "total": r["best"]} for r in state.runs[: len(state.starts)]]
    return SearchResult(
        controls=objective.controls(state.best_x),
        total=state.best_f,
        label=state.best_label,
        evals=state.evals,
        seconds=state.seconds,
        runs=[dict(r) for r in state.runs],
        trace=list(state.trace),
        starts=start_costs,
    )
