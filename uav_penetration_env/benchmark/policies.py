"""Policies: the Protocol every planner meets, MPC, the greedy and random floors, and policy names (api.md).

A policy is anything with ``reset(model, seed)`` and ``act(observation, info) -> action``.
Planners read the exact state from ``info["state"]`` and the step index from ``info["step"]``;
they never parse the observation. On a dynamic scenario a policy may also offer
``update_model(model)``: the harness calls it with each new belief (docs/dynamic.md §4).
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np
from scipy.optimize import Bounds

from uav_penetration_env.belief_value import advance_value_function
from uav_penetration_env.benchmark.plugins import (
    PluginUnavailable,
    PolicyKind,
    policy_kinds,
    stable_parameters,
)
from uav_penetration_env.benchmark.policy_names import (  # the kinds and their names, re-exported
    parse_policy,
    policy_names,  # noqa: F401  # re-exported: every plain name make_policy accepts
    unknown_policy,  # noqa: F401  # re-exported: the fast refusal of a name
)
from uav_penetration_env.benchmark.policy_spec import BELIEF, PolicySpec
from uav_penetration_env.kinematics import HEADING, SPEED, wrap_angle
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.mpc import MPC_DEFAULTS, MPCSettings
from uav_penetration_env.terminal import terminal_cost as build_terminal_cost
from uav_penetration_env.terminal_kernels import NO_TERMINAL_COST, TerminalCost
from uav_penetration_env.types import FloatArray
from uav_penetration_env.value_function import (
    DEFINITION_VERSION as VALUE_ALGORITHM_VERSION,
)
from uav_penetration_env.value_function import (
    LATTICE_DEFAULTS,
    LATTICE_GUIDANCE,
    LatticeGuidance,
    ValueFunction,
    candidate_control,
    lattice_action,
    terrain_following_dtheta,
    value_ahead,
    value_function,
)


@runtime_checkable
class Policy(Protocol):
    """The interface the evaluator scores: MPC planners, floors, RL agents."""

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None) -> None:
        """Prepare for an episode on ``model``'s scenario; ``seed`` drives any randomness."""

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """The action (3,) for the current step."""


@dataclass
class GreedyPolicy:
    """Floor: turn toward the goal at the maximum rate, fly v_max, hold ``clearance_m`` above the terrain.

    The altitude target is ``clearance_m`` above the highest terrain under the next ``lookahead_steps``
    steps of flight along the new heading (api.md: 100 m, two steps); the pitch is the one that
    would reach it in one step, limited by the pitch bounds.
    """

    deterministic: ClassVar[bool] = True  # is_deterministic: its actions are a function of the state
    clearance_m: float = 100.0
    lookahead_steps: int = 2
    model: PenetrationModel | None = field(default=None, repr=False)

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None = None) -> None:
        """Bind the model (the policy is deterministic; ``seed`` is unused)."""
        del seed
        self.model = model

    def update_model(self, model: PenetrationModel) -> None:
        """Plan on ``model`` from the next step (a new belief, docs/dynamic.md §4)."""
        self.model = model

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """Greedy control from the exact state in ``info``."""
        if self.model is None:
            raise RuntimeError("GreedyPolicy.act() before reset(model, seed)")
        return greedy_action(
            self.model, np.asarray(info["state"], dtype=np.float64), self.clearance_m, self.lookahead_steps
        )


def is_deterministic(policy: Any) -> bool:
    """Whether a policy's actions are a function of the observed state alone (no random draws).

    A policy says so with a ``deterministic = True`` attribute (the greedy floor) or a
    ``"deterministic": True`` entry of its ``config()`` (the SB3 agents, which act with
    ``predict(deterministic=True)``); anything else counts as stochastic. On a scenario without
    start jitter or terrain redraws, every seed of a deterministic policy replicates one episode,
    so the suite runs give it one seed (docs/suite.md §4).
    """
    if getattr(policy, "deterministic", False) is True:
        return True
    config = policy.config() if callable(getattr(policy, "config", None)) else {}
    return isinstance(config, Mapping) and config.get("deterministic") is True


def greedy_action(
    model: PenetrationModel, state: FloatArray, clearance_m: float = 100.0, lookahead_steps: int = 2
) -> FloatArray:
    """The greedy floor's action for one state (see :class:`GreedyPolicy`)."""
    limits = model.limits
    x, y = state[:2]
    goal = model.goal[0]
    bearing = math.atan2(goal[1] - y, goal[0] - x)
    dphi = float(np.clip(wrap_angle(bearing - state[HEADING]), -limits.dheading_max, limits.dheading_max))
    dv = float(np.clip(limits.speed_max - state[SPEED], -limits.dv_max, limits.dv_max))
    heading = state[HEADING] + dphi
    speed = min(limits.speed_max, state[SPEED] + dv)
    dtheta = terrain_following_dtheta(model, state, heading, speed, clearance_m, lookahead_steps)
    return np.array([dv, dphi, dtheta])


@dataclass
class _ValueRule:
    """A rule on the scenario's lattice value function V: built once per scenario at ``reset``, read each step.

    The two classical planners on V share their settings, their configuration (hashed into the
    results store key, with their ``KIND``) and their reset; each writes its own ``act``.
    """

    KIND: ClassVar[str] = ""
    deterministic: ClassVar[bool] = True
    guidance: LatticeGuidance = LATTICE_GUIDANCE
    model: PenetrationModel | None = field(default=None, repr=False)
    _value: ValueFunction | None = field(default=None, repr=False)

    def config(self) -> dict[str, Any]:
        """The lattice and guidance settings (hashed into the results store key)."""
        return {
            "kind": self.KIND,
            "lattice": dataclasses.asdict(LATTICE_DEFAULTS),
            "guidance": dataclasses.asdict(self.guidance),
            "algorithm": VALUE_ALGORITHM_VERSION,
            "deterministic": True,
        }

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None = None) -> None:
        """Bind the model and load (or build) its value function; ``seed`` is unused."""
        del seed
        self.model = model
        self._value = value_function(model)

    def update_model(self, model: PenetrationModel) -> None:
        """Plan on ``model`` from the next step: a new belief of a dynamic scenario (docs/dynamic.md §4).

        V is rebuilt incrementally from the current belief's (:func:`advance_value_function`).
        """
        self._value = value_function(model) if self.model is None else advance_value_function(self.model, model)
        self.model = model

    def _bound(self, info: dict[str, Any]) -> tuple[PenetrationModel, ValueFunction, FloatArray]:
        """The model, V and the exact state in ``info``; refused before ``reset``."""
        if self.model is None or self._value is None:
            raise RuntimeError(f"{type(self).__name__}.act() before reset(model, seed)")
        return self.model, self._value, np.asarray(info["state"], dtype=np.float64)


@dataclass
class LatticePolicy(_ValueRule):
    """The lattice planner: each step, the turn that minimises J(k) + V(next pose) (model.md §7e).

    V is the scenario's lattice value function (:func:`value_function.value_function`, built once
    and cached); the altitude follows the terrain at the lattice's clearance. The classical global
    planner next to the swarm planners and the agents: no online optimisation, a few model steps
    per decision.
    """

    KIND: ClassVar[str] = "lattice"

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """The lattice planner's control from the exact state in ``info``."""
        model, value, state = self._bound(info)
        return lattice_action(model, value, state, int(info["step"]), self.guidance)


@dataclass
class ValueGreedyPolicy(_ValueRule):
    """The turn whose point one step ahead has the lowest V, flown as the lattice's candidate (docs/rl.md §4.9).

    Each step: for each of the lattice's turns, V one step of v_max * dt ahead along the turned
    heading (:func:`value_function.value_ahead`, five look-ups, no move flown or priced); the
    turn with the lowest is flown as the lattice's candidate control at ``guidance.clearance_m``
    (:func:`value_function.candidate_control`), ties to the first turn. It reads exactly the
    inputs the distilled planners' ``value`` features hold, so it is the rule a network on those
    inputs competes with (``value-greedy``; ``value-greedy-cN`` at N metres, as ``lattice-cN``).
    """

    KIND: ClassVar[str] = "value-greedy"

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """The candidate control of the turn with the lowest V ahead, from the exact state in ``info``."""
        model, value, state = self._bound(info)
        _, ahead = value_ahead(model, value, state, self.guidance.turns)
        return candidate_control(model, state, self.guidance.turns[int(np.argmin(ahead))], self.guidance)


@dataclass
class RandomPolicy:
    """Floor: actions uniform in the action box, drawn from the episode's policy seed."""

    model: PenetrationModel | None = field(default=None, repr=False)
    rng: np.random.Generator | None = field(default=None, repr=False)

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None = None) -> None:
        """Bind the model and seed the generator."""
        self.model = model
        self.rng = np.random.default_rng(seed)

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """A uniform draw in [-u_max, u_max]."""
        if self.model is None or self.rng is None:
            raise RuntimeError("RandomPolicy.act() before reset(model, seed)")
        high = self.model.limits.action_high
        return self.rng.uniform(-high, high)


@dataclass
class MPCPolicy:
    """Model-predictive control with any optimiser (paper §4.1, eq. 37; model.md §7).

    At each step the optimiser minimises ``model.rollout_cost`` over the flattened (H, 3) control
    sequence, starting from ``info["state"]`` at step ``info["step"]``; the first control is
    applied. The next step is warm-started from this plan shifted by one step (last step zeros)
    through ``x0``, when the optimiser's ``minimize`` accepts it. If no finite plan is found the
    policy applies zeros (hold course).

    Args:
        optimizer: anything with ``minimize(fun, bounds, *, rng, max_evals[, x0])``.
        settings: the horizon, discount, budget and terminal cost (:class:`MPCSettings`; default
            :data:`MPC_DEFAULTS`). ``horizon``, ``discount`` and ``max_evals`` read them.
        warm_start: pass the shifted previous plan as ``x0``.
        name: a label for tables (the registry name when built by :func:`make_policy`).

    Attributes:
        last_record: per-step diagnostics of the last ``act`` (evaluations, planning seconds,
            seconds inside ``rollout_cost``, the optimiser's ``history``/``history_nfev`` and the
            :func:`trace_summary` of its trace).

    Raises:
        TypeError: an optimiser without ``minimize``; settings that are not an :class:`MPCSettings`.
        ValueError: a c_T with a form that has none (:meth:`MPCSettings.check_terminal_pair`).
    """

    optimizer: Any
    settings: MPCSettings = MPC_DEFAULTS
    warm_start: bool = True
    name: str | None = None
    model: PenetrationModel | None = field(default=None, repr=False)
    rng: np.random.Generator | None = field(default=None, repr=False)
    last_record: dict[str, Any] = field(default_factory=dict, repr=False)
    _plan: FloatArray | None = field(default=None, repr=False)
    _terminal: TerminalCost | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if not hasattr(self.optimizer, "minimize"):
            raise TypeError(
                f"optimizer: got {self.optimizer!r}, expected an object with a minimize(fun, bounds, ...) method"
            )
        if not isinstance(self.settings, MPCSettings):
            raise TypeError(f"settings: got {self.settings!r}, expected an MPCSettings")
        self.settings.check_terminal_pair()
        self._accepts_x0 = "x0" in inspect.signature(self.optimizer.minimize).parameters

    @property
    def horizon(self) -> int:
        """H, control steps per plan (``settings.horizon``)."""
        return self.settings.horizon

    @property
    def max_evals(self) -> int:
        """Objective evaluations per planning step (``settings.max_evals``)."""
        return self.settings.max_evals


    def config(self) -> dict[str, Any]:
        """Everything that determines this policy's behaviour (hashed into the results store key)."""
        optimizer = self.optimizer
        params = stable_parameters(optimizer, f"optimizer {type(optimizer).__qualname__}")
        return {
            "kind": "mpc",
            "optimizer": f"{type(optimizer).__module__}.{type(optimizer).__qualname__}",
            "optimizer_params": params,
            "horizon": self.horizon,
            "discount": self.settings.discount,
            "max_evals": self.max_evals,
            # The terminal cost as its two settings keys, as policy keys have always held it.
            "terminal": self.settings.terminal.form,
            "terminal_cost": self.settings.terminal.scale,
            **self._value_function_config(),
            "warm_start": self.warm_start,
        }

    def _value_function_config(self) -> dict[str, Any]:
        """The lattice behind the terminal cost, when the form reads it (so a changed V is a new policy)."""
        form, c_t = self.settings.terminal.form, self.settings.terminal.scale
        if form == "value" or (form == "dubins" and c_t is None):
            return {"lattice": dataclasses.asdict(LATTICE_DEFAULTS), "value_algorithm": VALUE_ALGORITHM_VERSION}
        return {}

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None = None) -> None:
        """Bind the scenario's model and seed the optimiser's generator for the episode."""
        self.model = model
        self.rng = np.random.default_rng(seed)
        self._plan = None
        self.last_record = {}
        self._terminal = build_terminal_cost(model, self.settings.terminal)

    def update_model(self, model: PenetrationModel) -> None:
        """Plan on ``model`` from the next step: a new belief of a dynamic scenario (docs/dynamic.md §4).

        The terminal cost is rebuilt on it (V, for a form that reads it, incrementally from the
        current belief's: :func:`advance_value_function`); the generator and the shifted plan carry
        over, so the next step still warm-starts from this plan.
        """
        if self.model is not None and self._value_function_config():
            advance_value_function(self.model, model)  # V of the new belief, where terminal_cost reads it
        self.model = model
        self._terminal = build_terminal_cost(model, self.settings.terminal)

    def initial_guess(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray | None:
        """The (H, 3) plan the optimiser starts from (its ``x0``), or None for no warm start.

        Here: the previous plan shifted by one step, when ``warm_start`` is on and the optimiser
        takes ``x0``. A subclass may start from another plan (``baselines.hybrid``: an RL agent's
        rollout, docs/rl-statistics.md §3); each optimiser uses ``x0`` by its own rule (optimizers.md D1).
        """
        del observation, info
        if self.warm_start and self._accepts_x0 and self._plan is not None:
            return self._plan
        return None

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """Plan on ``rollout_cost`` from the exact state and apply the plan's first control.

        The harness times the whole call (``planning_seconds``, ``planning_cpu_seconds``); the
        record holds what only the planner knows (evaluations, the objective's own seconds).
        """
        if self.model is None or self.rng is None or self._terminal is None:
            raise RuntimeError("MPCPolicy.act() before reset(model, seed)")
        state = np.asarray(info["state"], dtype=np.float64)
        cost = mpc_objective(self.model, state, int(info["step"]), self.settings, terminal_cost=self._terminal)
        objective = CountedObjective(cost)
        kwargs: dict[str, Any] = {"rng": self.rng, "max_evals": self.settings.max_evals}
        guess = self.initial_guess(observation, info)
        if guess is not None:
            kwargs["x0"] = np.asarray(guess, dtype=np.float64).reshape(-1)
        result = self.optimizer.minimize(objective, cost.bounds, **kwargs)
        nfev = checked_result(result, objective, cost.bounds, self.settings.max_evals, type(self.optimizer).__name__)
        found = bool(np.isfinite(result.fun))
        horizon = self.horizon
        plan = np.asarray(result.x, dtype=np.float64).reshape(horizon, 3) if found else np.zeros((horizon, 3))
        self._plan = np.vstack([plan[1:], np.zeros((1, 3))]) if found else None
        self.last_record = {
            "nfev": nfev,
            "objective_seconds": objective.seconds,
            "plan_cost": float(result.fun),
            "history": np.asarray(getattr(result, "history", []), dtype=np.float64).tolist(),
            "history_nfev": np.asarray(getattr(result, "history_nfev", []), dtype=np.int64).tolist(),
            **trace_summary(getattr(result, "trace", {}), nfev, self.max_evals),
        }
        return plan[0].copy()


class PlanError(ValueError):
    """An optimiser's answer the harness will not fly: over its budget, or a plan outside the box."""


class CountedObjective:
    """An objective that counts the rows it evaluates and the seconds it spends.

    The harness stores its own count, never the optimiser's claim: a plug-in that overspends and
    reports ``nfev = max_evals`` would otherwise rank as an equal-budget run.
    """

    def __init__(self, objective: Callable[[FloatArray], FloatArray]) -> None:
        self.objective = objective
        self.rows = 0
        self.seconds = 0.0

    def __call__(self, flat: FloatArray) -> FloatArray:
        """(n,) costs of (n, 3H) rows, counted."""
        start = time.perf_counter()
        costs = self.objective(flat)
        self.seconds += time.perf_counter() - start
        self.rows += len(flat)
        return costs


def checked_result(result: Any, counted: CountedObjective, bounds: Bounds, max_evals: int, where: str) -> int:
    """The evaluations ``result`` really spent; refuse an overspent budget or a plan outside ``bounds``.

    Raises:
        PlanError: more rows evaluated than ``max_evals``, or a finite-cost ``result.x`` outside the
            box (beyond rounding, 1e-9 of the box's width), naming ``where`` (the optimiser).
    """
    if counted.rows > max_evals:
        raise PlanError(
            f"{where}: evaluated {counted.rows} control sequences, over its budget max_evals={max_evals} "
            f"(it reported nfev={getattr(result, 'nfev', None)})"
        )
    x = np.asarray(result.x, dtype=np.float64)
    if not np.isfinite(result.fun):
        return counted.rows  # no finite plan: nothing is flown from it
    if x.shape != bounds.lb.shape:
        raise PlanError(f"{where}: returned a plan of shape {x.shape}; expected shape {bounds.lb.shape}")
    slack = 1e-9 * (bounds.ub - bounds.lb)
    outside = ~((x >= bounds.lb - slack) & (x <= bounds.ub + slack))
    if outside.any():
        i = int(np.argmax(outside))
        raise PlanError(
            f"{where}: returned a plan with x[{i}] = {x[i]:.6g} outside the action box "
            f"[{bounds.lb[i]:.6g}, {bounds.ub[i]:.6g}]; expected a plan inside the bounds it was given"
        )
    return counted.rows


@dataclass(frozen=True, eq=False)
class MPCObjective:
    """The MPC objective of one window (paper eq. 37; model.md §7): control sequences -> window costs.

    Built by :func:`mpc_objective`; :class:`MPCPolicy` plans on it and ``uav-bench windows`` reruns
    optimisers on it, so both see the same function.

    Attributes:
        model: the scenario's model.
        state: (6,) the exact state the window starts from.
        step: the step index k of that state (the third term and the horizon's clock read it).
        settings: the planner's settings; the objective reads ``horizon`` and ``discount``, and a
            window run its budget ``max_evals``.
        terminal_cost: the terminal cost built from ``settings.terminal`` (model.md §7e,
            :func:`uav_penetration_env.terminal.terminal_cost`).
    """

    model: PenetrationModel
    state: FloatArray
    step: int
    settings: MPCSettings = MPC_DEFAULTS
    terminal_cost: TerminalCost = NO_TERMINAL_COST

    @property
    def horizon(self) -> int:
        """H, control steps per plan (``settings.horizon``)."""
        return self.settings.horizon

    @property
    def bounds(self) -> Bounds:
        """The (3H,) box of the flattened control sequence: the action box repeated H times.

        scipy ``Bounds`` are unambiguous for every dimension (a (lower, upper) pair of length-2
        arrays would read as two (lo, hi) pairs, optimizers.md D29).
        """
        high = np.tile(self.model.limits.action_high, self.horizon)
        return Bounds(-high, high)

    def __call__(self, flat: FloatArray) -> FloatArray:
        """(n,) window costs ``model.rollout_cost`` of (n, 3H) flattened control sequences."""
        return self._costs(flat.reshape(len(flat), self.horizon, 3))

    @functools.cached_property
    def _costs(self) -> Callable[[FloatArray], FloatArray]:
        """``model.rollout_cost`` with this window's state, discount and terminal cost bound (checked once)."""
        return self.model.rollout_function(
            self.state, step=self.step, discount=self.settings.discount, terminal_cost=self.terminal_cost
        )


def mpc_objective(
    model: PenetrationModel,
    state: FloatArray,
    step: int,
    settings: MPCSettings = MPC_DEFAULTS,
    *,
    terminal_cost: TerminalCost | None = None,
) -> MPCObjective:
    """The objective MPC minimises at ``state`` (step ``step``): the one function planners and window runs share.

    Args:
        model: the scenario's model.
        state: (6,) the exact state.
        step: its step index k.
        settings: the planner's settings (horizon H, gamma of eq. 37, the terminal cost).
        terminal_cost: ``settings.terminal`` already built on ``model`` (a planner builds it once
            per episode), or None: built here (:func:`uav_penetration_env.terminal.terminal_cost`).

    Returns:
        A callable ``(n, 3H) -> (n,)`` with its ``bounds``.
    """
    built = build_terminal_cost(model, settings.terminal) if terminal_cost is None else terminal_cost
    return MPCObjective(
        model, np.asarray(state, dtype=np.float64).copy(), int(step), settings, terminal_cost=built
    )


def trace_summary(trace: Any, nfev: int, max_evals: int) -> dict[str, Any]:
    """A compact, optimiser-independent summary of one run's ``OptimizeResult.trace`` (docs/swarm.md §6).

    DECISION (api.md §4.8): ``stopped_early`` is read from the budget, ``nfev < max_evals``, not from a
    trace key, so it means the same for every optimiser (IHPSO's adaptive termination, a scipy
    method's convergence, an optimiser that gives up). The counts are ``None`` where the optimiser
    does not trace that mechanism (its trace lacks the key), so a leaderboard shows "no such
    mechanism" rather than a 0 that reads as "never happened".

    Args:
        trace: the result's trace mapping (empty or absent for optimisers without phases).
        nfev: evaluations the run spent.
        max_evals: the budget it was given.

    Returns:
        ``stopped_early`` (bool), ``switches`` (broad -> accurate switches, IHPSO eqs. 25-28),
        ``reverse_switches`` (accurate -> broad, eq. 33), ``extinctions`` (PS2O iterations in which
        species died out).
    """
    trace = trace if isinstance(trace, Mapping) else {}

    def count(key: str) -> int | None:
        return len(trace[key]) if key in trace and trace[key] is not None else None

    return {
        "stopped_early": bool(nfev < max_evals),
        "switches": count("switch_iterations"),
        "reverse_switches": count("reverse_switch_iterations"),
        "extinctions": count("extinctions"),
    }


FLOOR_POLICIES = {"greedy": GreedyPolicy, "random": RandomPolicy}
# Named policies that are neither floors nor MPC planners: the classical global planner.
BASELINE_POLICIES: dict[str, Any] = {"lattice": LatticePolicy, "value-greedy": ValueGreedyPolicy}


def policy_label(spec: str | PolicySpec) -> str:
    """The name of a policy in result tables and the store: the published name where one exists (api.md §4.1).

    ``lattice[clearance=60]`` -> ``lattice-c60``; a plug-in kind may shorten it
    (``sb3:DIR/m.zip`` -> ``sb3:m``); a hybrid keeps its planner (``ihpso+sb3:DIR/m.zip`` ->
    ``ihpso+sb3:m``).

    Raises:
        KeyError, ValueError: a name :func:`~.policy_names.parse_policy` cannot read.
    """
    return (spec if isinstance(spec, PolicySpec) else parse_policy(spec)).label


def make_policy(spec: str | PolicySpec, settings: MPCSettings = MPC_DEFAULTS, **changes: Any) -> Any:
    """A policy from its name (api.md §4.1) or its read :class:`PolicySpec`, MPC planners with ``settings``.

    ``changes`` are settings keys that replace those of ``settings``
    (``make_policy("ihpso", max_evals=300)``, ``terminal="distance"``, ``terminal_cost=0.2``:
    :meth:`MPCSettings.with_keys`). Names (the grammar ``kind[param=value,...]``,
    :mod:`~.policy_spec`): an optimiser name, an MPC planner with ``settings.terminal``'s form,
    or ``NAME[terminal=FORM]`` (published: ``NAME-eq37``, the paper's literal eq. 37;
    ``NAME-ctg-distance``, ``NAME-ctg-dubins``, ``NAME-ctg-value``; model.md §7e); ``greedy``,
    ``random``; ``lattice`` (the lattice planner) and ``value-greedy`` (the turn toward the
    lowest V one step ahead), with ``[clearance=N]`` (published ``lattice-cN``,
    ``value-greedy-cN``) to follow the terrain at N metres; a plug-in policy kind (entry-point
    group ``uav_penetration.policies``; the ``rl`` extra's ``baselines`` adds
    ``sb3[model=PATH.zip]`` and ``distill[run=DIR,guard=...]``, and their published forms
    ``sb3:PATH.zip``, ``distill-shield:DIR``); or ``PLANNER+AGENT``: the MPC planner warm-started
    by the plug-in policy, when its kind offers that (``ihpso+sb3:PATH.zip``,
    docs/rl-statistics.md §3). A plug-in kind is checked for its run-time needs here, so a
    missing extra is refused before any episode runs.

    A planner's ``terminal`` fixes the form (:meth:`MPCSettings.with_form`): c_T then reaches
    only the forms that have one; without it c_T goes through, so a c_T given with the ``value``
    form is refused, not ignored.

    Raises:
        KeyError: an unknown name or kind, with suggestions and the list of known forms.
        PluginUnavailable: (an ImportError) a plug-in kind whose needs are not installed, or that
            failed to import; one line saying what to install.
        ValueError: a parameter outside its domain (naming it and the expected value), a hybrid
            whose parts cannot form one, or a setting outside its domain
            (:class:`~uav_penetration_env.mpc.SettingError`).
        TypeError: a change that names no setting.
    """
    parsed = spec if isinstance(spec, PolicySpec) else parse_policy(spec)
    what = f"policy {parsed.text or parsed.canonical()!r}"  # for errors: the name as it was written
    settings = settings.with_keys(changes) if changes else settings
    if parsed.information != BELIEF:  # the same policy, told more or less (docs/dynamic.md §4)
        from uav_penetration_env.benchmark.information import INFORMATION_WRAPPERS

        inner = make_policy(dataclasses.replace(parsed, information=BELIEF), settings)
        return INFORMATION_WRAPPERS[parsed.information](inner)
    if parsed.family == "floor":
        return FLOOR_POLICIES[parsed.kind]()
    if parsed.family == "value-rule":
        clearance = parsed.params.clearance
        if clearance is None:
            return BASELINE_POLICIES[parsed.kind]()
        return BASELINE_POLICIES[parsed.kind](dataclasses.replace(LATTICE_GUIDANCE, clearance_m=float(clearance)))
    if parsed.family == "plugin":
        return _plugin_kind(parsed, what).load(parsed.params)
    from optimizers import get_optimizer

    planner = MPCPolicy(get_optimizer(parsed.kind), settings.with_form(parsed.params.terminal), name=parsed.base_label)
    if parsed.warm_start is None:
        return planner
    kind = _plugin_kind(parsed.warm_start, what)
    if kind.hybrid is None:  # parse_policy refuses it; a hand-built spec may not
        raise ValueError(f"{what}: the plug-in kind {kind.name!r} cannot warm-start a planner")
    return kind.hybrid(parsed.warm_start.params, planner)


def _plugin_kind(spec: PolicySpec, what: str) -> PolicyKind:
    """The plug-in kind of a parsed spec, its run-time needs checked (:class:`PluginUnavailable` if missing)."""
    kind = policy_kinds().get(spec.kind)
    if not isinstance(kind, PolicyKind):  # parse_policy refuses it; a hand-built spec may not
        raise PluginUnavailable(f"{what}: no installed plug-in provides the kind {spec.kind!r}")
    kind.needs.check(what)
    return kind
