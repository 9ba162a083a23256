"""The offline reference planner: a whole episode's controls optimised against the env's summed cost.

The decision variables are the K_max x 3 controls of an episode, normalised to the action box
([-1, 1] per component, physical control = x * ``limits.action_high``), flattened to a vector of
3 K_max numbers. The objective is the compiled model's :meth:`PenetrationModel.rollout_cost` of the
whole sequence from the start state with no discount and no terminal cost: the sum of J(k) + penalty
of the transitions flown until the goal, a failure or K_max, which is the evaluator's
``total_cost`` of the same controls (docs/best-known.md §1; a test pins the equality).

The search is :class:`optimizers.sep_cma_restarts.SepCMARestarts` on that box: separable CMA-ES
runs from each given start (stored tracks, the existing record, the greedy episode), then restarts
around the incumbent and from random starts, then a refinement around the incumbent with
decreasing step sizes. The budget is wall seconds and/or evaluations; with an evaluation budget
alone the result depends only on the seed (the compiled model does not depend on the thread
count). The search state is saved every ``checkpoint_seconds`` (:mod:`.checkpoint`), so an
interrupted search continues where its last checkpoint stood.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from optimizers.sep_cma_restarts import RestartState, SepCMARestarts, Start, check_starts
from uav_penetration_env.benchmark.bestknown.checkpoint import Checkpoints
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.types import FloatArray

__all__ = ["EpisodeObjective", "SearchResult", "SearchSettings", "Start", "search"]


@dataclass(frozen=True)
class SearchSettings:
    """The offline search's settings (docs/best-known.md §1): its budget, seed and optimiser.

    Attributes:
        seconds: wall-clock budget of the search [s] (``None``: evaluations only).
        max_evals: evaluation budget (``None``: seconds only). With both, the first reached stops.
        seed: seed of the search's generator (random starts and every CMA-ES run's seed).
        optimizer: the restart schedule (population, step sizes, stall and refinement settings,
            checked there); on the action box a step size is a fraction of each control's limit.
            DECISION (docs/best-known.md §1): its default ``start_sigma`` is 0.01 of the action box
            (0.02 m/s, 0.15 deg per step): a start is a good track, and on the paper scenario a step
            of 0.05 turned almost every sample of the 450 variables into a crash (measured: 20 of 22
            samples crashed).
        checkpoint_seconds: wall seconds between checkpoints.
    """

    seconds: float | None = 90.0
    max_evals: int | None = None
    seed: int = 0
    optimizer: SepCMARestarts = field(default_factory=SepCMARestarts)
    checkpoint_seconds: float = 5.0

    def __post_init__(self) -> None:
        if self.seconds is None and self.max_evals is None:
            raise ValueError("budget: got neither seconds nor max_evals, expected at least one")
        if self.seconds is not None and not (math.isfinite(self.seconds) and self.seconds > 0):
            raise ValueError(f"seconds: got {self.seconds!r}, expected a number of seconds > 0")
        if self.max_evals is not None and self.max_evals < 1:
            raise ValueError(f"max_evals: got {self.max_evals!r}, expected an integer >= 1")
        if not isinstance(self.optimizer, SepCMARestarts):
            raise ValueError(f"optimizer: got {self.optimizer!r}, expected a SepCMARestarts")

    def key(self) -> dict[str, Any]:
        """The settings a checkpoint must share to be continued (everything but the budget).

        One flat mapping: the seed, then the optimiser's fields.
        """
        return {"seed": self.seed, **asdict(self.optimizer), "refine_sigmas": list(self.optimizer.refine_sigmas)}


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
        """(B,) summed costs of (B, 3 K_max) normalised vectors (no discount, no terminal cost)."""
        controls = np.ascontiguousarray(self.controls(np.atleast_2d(x)))
        return self.model.rollout_cost(self.state, controls, step=0)


def search(
    objective: EpisodeObjective,
    starts: Sequence[Start],
    settings: SearchSettings,
    *,
    scenario_hash: str,
    checkpoint: str | Path | None = None,
    progress: Callable[[RestartState, float], None] | None = None,
) -> SearchResult:
    """Minimise the whole-episode cost from ``starts`` (module docstring; docs/best-known.md).

    Args:
        objective: the scenario's :class:`EpisodeObjective`.
        starts: the given starts (at least one; random starts are drawn by the search).
        settings: budget, seed and schedule.
        scenario_hash: the scenario's hash (checkpoints of another scenario are refused).
        checkpoint: the checkpoint file; an existing one with the same settings is continued
            (its starts are the ones used), ``None`` keeps everything in memory.
        progress: called after every generation with the search state and the share of the
            budget used (before that generation's checkpoint is saved).

    Returns:
        The :class:`SearchResult`.

    Raises:
        ValueError: no start, a start of the wrong size, or a checkpoint of another search.
    """
    if not starts:
        raise ValueError("starts: got none, expected at least one start (e.g. the greedy episode)")
    check_starts(starts, objective.dimension)
    optimizer = settings.optimizer
    saver = Checkpoints(
        None if checkpoint is None else Path(checkpoint),
        scenario_hash,
        settings.key(),
        settings.checkpoint_seconds,
    )
    state = saver.load()
    if state is None:
        bounds = np.tile([-1.0, 1.0], (objective.dimension, 1))
        state = optimizer.begin(objective, bounds, starts, np.random.default_rng(settings.seed))

    def after_generation(state: RestartState, share: float) -> None:
        if progress is not None:
            progress(state, share)
        saver.maybe_save(state)

    optimizer.run(
        state, objective, max_evals=settings.max_evals, seconds=settings.seconds, callback=after_generation
    )
    saver.save(state)
    return SearchResult(
        controls=objective.controls(state.best_x),
        total=state.best_f,
        label=state.best_label,
        evals=state.evals,
        seconds=state.seconds,
        runs=[dict(r) for r in state.runs],
        trace=list(state.trace),
        starts=[{"label": r["label"], "total": r["best"]} for r in state.runs[: len(state.starts)]],
    )
