"""Separable CMA-ES restarts from named starts, then a refinement around the incumbent.

A batch minimiser of ``fun: (n, d) -> (n,)`` inside a box; it knows nothing of what ``fun`` scores.
It works in the box mapped onto [-1, 1]^d (``x = centre + half_width * u``), so its step sizes and
the spread of its random starts are fractions of each variable's half-width. The search is a
schedule of separable CMA-ES runs (``cmaes.SepCMA``, Ros & Hansen 2008: a diagonal covariance,
linear in the dimension, for hundreds of variables), one run per start:

1. *exploration*: first one run from each given start, then runs alternating between a restart
   around the incumbent and a random start drawn from the state's generator, until
   ``1 - refine_fraction`` of the budget is used;
2. *refinement*: runs around the incumbent with the step sizes ``refine_sigmas`` in turn until the
   budget is spent: a local search that polishes the best point.

A run ends when its best has not improved for ``stall_generations`` generations, when CMA-ES itself
stops, or when its phase ends. The budget is evaluations and/or wall seconds; the search stops
before a generation that would exceed the evaluation budget. With an evaluation budget alone the
result depends only on the seed.

Two ways in:

* :meth:`SepCMARestarts.minimize`, the interface of every optimiser here (optimizers.md §1), from the
  one start ``x0`` (or the centre of the box);
* :meth:`SepCMARestarts.begin`, then :meth:`SepCMARestarts.run` on the explicit
  :class:`RestartState`: several named starts, a wall-second budget, a callback after every
  generation that may stop the run, and a state that pickles exactly, so that a caller can save it,
  continue it later (in another process, with a larger budget) and get what one uninterrupted run
  gives.

DECISION (docs/best-known.md §1): the schedule is not in the optimiser registry. It is the offline
best-known search's optimiser, not a planner the leaderboard compares: a registered name would join
every MPC sweep (``uav-bench run --policies``), the contract tests and the golden listing, and the
contract's "a reference spends its whole budget" does not hold for it (it never evaluates a
generation it cannot finish, and its phases are shares of the budget).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from optimizers.base import (
    MESSAGE_MAX_EVALS,
    BatchObjective,
    BoundsLike,
    FloatArray,
    OptimizerBase,
    OptimizeResult,
    Problem,
    is_int,
    is_real,
    normalize_bounds,
    require,
    require_integer,
)

EXPLORE, REFINE = "explore", "refine"


@dataclass(frozen=True)
class Start:
    """One start of the search: a ``(d,)`` point and the label its runs carry (``start:<label>``)."""

    label: str
    x: FloatArray


@dataclass
class RestartState:
    """Everything the search needs to continue exactly; :meth:`SepCMARestarts.run` advances it.

    Points are in the caller's coordinates. Pickling keeps the running CMA-ES's random generator,
    which ``cmaes`` itself leaves out of a pickle, so a restored state draws the samples an
    uninterrupted one would.

    Attributes:
        lo, hi: (d,) the box.
        starts: the given starts (clipped into the box).
        rng: the generator of random starts and of every CMA-ES run's seed.
        best_x: (d,) the best point evaluated; ``best_f`` its cost; ``best_label`` the run that found it.
        evals: objective rows evaluated; ``seconds``: wall seconds spent in :meth:`~SepCMARestarts.run`.
        generations: CMA-ES generations evaluated.
        phase: ``"explore"`` or ``"refine"``; ``explore_runs``, ``refine_runs``: runs begun in each.
        optimizer: the running ``cmaes.SepCMA`` (``None`` between runs), in [-1, 1]^d.
        run_label, run_best, run_stall: the running run's label, best cost and generations without
            improvement.
        runs: one summary per run (``label``, ``evals``, ``best``); each start counts as a run of one
            evaluation.
        trace: (evaluations, seconds, best) after the starts and after every improving generation.
        finished: whether the last :meth:`~SepCMARestarts.run` ended on its budget.
    """

    lo: FloatArray
    hi: FloatArray
    starts: list[Start]
    rng: np.random.Generator
    best_x: FloatArray
    best_f: float
    best_label: str
    evals: int = 0
    seconds: float = 0.0
    generations: int = 0
    phase: str = EXPLORE
    explore_runs: int = 0
    refine_runs: int = 0
    optimizer: Any = None
    run_label: str = ""
    run_best: float = math.inf
    run_stall: int = 0
    runs: list[dict[str, Any]] = field(default_factory=list)
    trace: list[tuple[int, float, float]] = field(default_factory=list)
    finished: bool = False

    @property
    def dim(self) -> int:
        """Number of variables ``d``."""
        return int(self.lo.shape[0])

    def to_unit(self, x: FloatArray) -> FloatArray:
        """(..., d) points in the box -> the same points in [-1, 1]^d."""
        return (x - (self.lo + self.hi) / 2) / ((self.hi - self.lo) / 2)

    def from_unit(self, u: FloatArray) -> FloatArray:
        """(..., d) points in [-1, 1]^d -> the same points in the box."""
        return (self.lo + self.hi) / 2 + (self.hi - self.lo) / 2 * u

    def __getstate__(self) -> dict[str, Any]:
        data = dict(self.__dict__)
        data["optimizer_rng"] = None if self.optimizer is None else self.optimizer._rng.get_state()
        return data

    def __setstate__(self, data: dict[str, Any]) -> None:
        data = dict(data)
        optimizer_rng = data.pop("optimizer_rng")
        self.__dict__.update(data)
        if self.optimizer is not None:
            self.optimizer._rng.set_state(optimizer_rng)


Callback = Callable[[RestartState, float], bool | None]
"""Called after every generation with the state and the share of the budget used; ``True`` stops."""


def check_starts(starts: Sequence[Start], dim: int) -> None:
    """Refuse an empty list of starts or a start that is not a ``(dim,)`` point.

    Raises:
        ValueError: naming the start, its shape and the expected one.
    """
    if not starts:
        raise ValueError("starts: got none, expected at least one start")
    for start in starts:
        if np.shape(start.x) != (dim,):
            raise ValueError(f"starts[{start.label!r}]: got shape {np.shape(start.x)}, expected ({dim},)")


def _costs(fun: BatchObjective, x: FloatArray) -> FloatArray:
    values = np.asarray(fun(x), dtype=np.float64)
    if values.shape != (x.shape[0],):
        raise ValueError(f"objective returned shape {values.shape}, expected ({x.shape[0]},)")
    return values


@dataclass(frozen=True)
class SepCMARestarts(OptimizerBase):
    """The restart schedule of separable CMA-ES runs (module docstring); defaults: the best-known search's.

    Step sizes and the random starts' spread are fractions of the box's half-width (``u`` units).

    Attributes:
        population: CMA-ES population (``None``: cmaes' default ``4 + floor(3 ln d)``).
        start_sigma: initial step size of a run from a given start or the incumbent.
        random_sigma: initial step size of a run from a random start.
        random_scale: random starts are uniform in ``centre ± random_scale * half_width``.
        stall_generations: a run ends after this many generations without improving its best.
        refine_fraction: the share of the budget kept for the refinement phase.
        refine_sigmas: step sizes of the refinement runs, cycled.
    """

    population: int | None = None
    start_sigma: float = 0.01
    random_sigma: float = 0.3
    random_scale: float = 0.5
    stall_generations: int = 50
    refine_fraction: float = 0.2
    refine_sigmas: tuple[float, ...] = (0.005, 0.002, 0.001)

    def __post_init__(self) -> None:
        name = type(self).__name__
        p = self.population
        require(p is None or (is_int(p) and p >= 2), name, "population", p, "None or an integer >= 2")
        for key in ("start_sigma", "random_sigma", "random_scale"):
            value = getattr(self, key)
            require(is_real(value) and 0 < value <= 1, name, key, value, "a number in (0, 1]")
        require_integer(self, "stall_generations", 1)
        f = self.refine_fraction
        require(is_real(f) and 0 <= f < 1, name, "refine_fraction", f, "a number in [0, 1)")
        sigmas = self.refine_sigmas
        require(
            isinstance(sigmas, tuple) and len(sigmas) > 0 and all(is_real(v) and 0 < v <= 1 for v in sigmas),
            name, "refine_sigmas", sigmas, "a non-empty tuple of numbers in (0, 1]",
        )  # fmt: skip

    def population_for(self, dim: int) -> int:
        """The population of every run in ``dim`` variables."""
        return self.population or 4 + math.floor(3 * math.log(dim))

    def begin(
        self, fun: BatchObjective, bounds: BoundsLike, starts: Sequence[Start], rng: np.random.Generator
    ) -> RestartState:
        """Evaluate the starts (one batch, clipped into the box) and return the state before the first run.

        Args:
            fun: batch objective ``(n, d) -> (n,)``.
            bounds: the box, in any form :func:`optimizers.base.normalize_bounds` reads.
            starts: at least one start of shape ``(d,)``.
            rng: the search's generator (kept in the state, which then owns it).

        Raises:
            ValueError: bad bounds, no start, a start of the wrong shape, or a wrong-shaped return.
        """
        lo, hi = normalize_bounds(bounds)
        check_starts(starts, lo.shape[0])
        starts = [Start(s.label, np.clip(np.asarray(s.x, dtype=np.float64), lo, hi)) for s in starts]
        values = _costs(fun, np.stack([s.x for s in starts]))
        first = int(np.argmin(values))
        state = RestartState(
            lo=lo,
            hi=hi,
            starts=starts,
            rng=rng,
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
        return state

    def run(
        self,
        state: RestartState,
        fun: BatchObjective,
        *,
        max_evals: int | None = None,
        seconds: float | None = None,
        callback: Callback | None = None,
    ) -> RestartState:
        """Advance ``state`` generation by generation until the budget is spent or ``callback`` says stop.

        The budget counts everything the state has spent, in earlier calls too: a finished state
        given a larger budget continues. ``state.seconds`` grows by this call's wall time.

        Args:
            state: from :meth:`begin` (or a restored copy), changed in place.
            fun: the batch objective of :meth:`begin`.
            max_evals: evaluation budget (``None``: seconds only); the run stops before a generation
                that would exceed it.
            seconds: wall-second budget (``None``: evaluations only).
            callback: called as ``callback(state, share)`` after every generation; ``True`` stops
                the run (``state.finished`` stays ``False``; the state continues as it stands).

        Returns:
            ``state``.

        Raises:
            ValueError: neither budget given, or ``fun`` returns a wrong shape.
        """
        if max_evals is None and seconds is None:
            raise ValueError("budget: got neither max_evals nor seconds, expected at least one")
        clock = _Clock(state.seconds, max_evals, seconds)
        state.finished = False
        while True:
            running = state.optimizer
            population = self.population_for(state.dim) if running is None else running.population_size
            if clock.spent(state, population):
                state.finished = True
                break
            if state.phase == EXPLORE and clock.share(state) >= 1.0 - self.refine_fraction:
                state.phase, state.optimizer = REFINE, None
            if state.optimizer is None:
                self._new_run(state)
            self._generation(state, fun, clock)
            state.seconds = clock.elapsed()
            if callback is not None and callback(state, min(1.0, clock.share(state))):
                break
        state.seconds = clock.elapsed()
        return state

    def _new_run(self, state: RestartState) -> None:
        """Begin the schedule's next run (module docstring)."""
        from cmaes import SepCMA

        if state.phase == EXPLORE:
            r = state.explore_runs
            state.explore_runs += 1
            if r < len(state.starts):
                start = state.starts[r]
                mean, sigma, label = state.to_unit(start.x), self.start_sigma, f"start:{start.label}"
            elif (r - len(state.starts)) % 2 == 0:
                mean, sigma, label = state.to_unit(state.best_x), self.start_sigma, "incumbent"
            else:
                mean = state.rng.uniform(-self.random_scale, self.random_scale, state.dim)
                sigma, label = self.random_sigma, "random"
        else:
            r = state.refine_runs
            state.refine_runs += 1
            sigma = self.refine_sigmas[r % len(self.refine_sigmas)]
            mean, label = state.to_unit(state.best_x), f"refine(sigma={sigma:g})"
        state.optimizer = SepCMA(
            mean=np.clip(mean, -1.0, 1.0).copy(),
            sigma=float(sigma),
            bounds=np.tile([-1.0, 1.0], (state.dim, 1)),
            seed=int(state.rng.integers(2**31 - 1)),
            population_size=self.population,
            # Clip an out-of-box sample (cmaes' repair) instead of resampling it up to 100 times:
            # good points often sit on the box, so nearly every sample of hundreds of variables
            # leaves it, and resampling cost more than the evaluations (measured on the paper
            # scenario's whole-episode search: 917 against 375 evaluations/s).
            n_max_resampling=1,
        )
        state.run_label, state.run_best, state.run_stall = label, math.inf, 0
        state.runs.append({"label": label, "evals": 0, "best": math.inf})

    def _generation(self, state: RestartState, fun: BatchObjective, clock: _Clock) -> None:
        """Ask, evaluate and tell one generation of the running CMA-ES; end the run when it stalls or stops."""
        optimizer = state.optimizer
        population = optimizer.population_size
        candidates = np.stack([optimizer.ask() for _ in range(population)])
        points = state.from_unit(candidates)
        values = _costs(fun, points)
        optimizer.tell(list(zip(candidates, values.tolist(), strict=True)))
        state.evals += population
        state.generations += 1
        run = state.runs[-1]
        run["evals"] += population
        best = int(np.argmin(values))
        # A run's best improves only by more than 1e-12 relative: rounding noise does not reset the stall count.
        if values[best] < state.run_best - 1e-12 * abs(
            state.run_best if math.isfinite(state.run_best) else 0
        ):
            state.run_best, state.run_stall = float(values[best]), 0
            run["best"] = state.run_best
        else:
            state.run_stall += 1
        if values[best] < state.best_f:
            state.best_f = float(values[best])
            state.best_x = points[best].copy()
            state.best_label = state.run_label
            state.trace.append((state.evals, clock.elapsed(), state.best_f))
        if state.run_stall >= self.stall_generations or optimizer.should_stop():
            state.optimizer = None

    def solve(self, problem: Problem, rng: np.random.Generator) -> OptimizeResult:
        """Minimise from the one start ``x0`` (or the box centre) within ``max_evals`` (optimizers.md §1).

        ``nit`` counts generations; the history holds the best after the start and after each
        generation. CMA-ES never sees ``inf`` or NaN: it is told the finite stand-in.
        """
        objective = problem.objective
        x0 = (problem.lo + problem.hi) / 2 if problem.x0 is None else problem.x0
        label = "centre" if problem.x0 is None else "x0"

        def fun(x: FloatArray) -> FloatArray:
            return objective.finite_costs(objective(x))

        state = self.begin(fun, np.column_stack([problem.lo, problem.hi]), [Start(label, x0)], rng)
        objective.record()
        self.run(
            state, fun, max_evals=objective.max_evals, callback=lambda _state, _share: objective.record()
        )
        return objective.result(state.generations, MESSAGE_MAX_EVALS)


class _Clock:
    """The wall time of one :meth:`SepCMARestarts.run` call on top of what the state had spent, and the budget share."""

    def __init__(self, seconds_before: float, max_evals: int | None, seconds: float | None) -> None:
        self.before = seconds_before
        self.start = time.perf_counter()
        self.max_evals = max_evals
        self.seconds = seconds

    def elapsed(self) -> float:
        """Wall seconds of the state so far [s]."""
        return self.before + (time.perf_counter() - self.start)

    def share(self, state: RestartState) -> float:
        """The share of the budget used: the larger of the evaluation and the time shares."""
        shares = []
        if self.max_evals is not None:
            shares.append(state.evals / self.max_evals)
        if self.seconds is not None:
            shares.append(self.elapsed() / self.seconds)
        return max(shares)

    def spent(self, state: RestartState, population: int) -> bool:
        """Whether the next generation of ``population`` rows would exceed a budget (or time is up)."""
        return (self.max_evals is not None and state.evals + population > self.max_evals) or (
            self.seconds is not None and self.elapsed() >= self.seconds
        )
