"""Gymnasium environments: a thin shell around :class:`PenetrationModel` (model.md §7a).

``UAVPenetrationEnv`` validates the action, calls the model on a batch of one and packs the
Gymnasium tuple; the native vector env (:mod:`uav_penetration_env.vector_env`) calls the same
model on ``(num_envs, 6)``. Both share the scenario sources and the one info builder below
(:func:`step_info`), so a vector env equals N single envs step by step.

Version history:
    v0 (0.1.0): first release (model.md as of 2026-11).
    v0 (0.2.0): the spec registers max_episode_steps = K_max; same physics and reward (the
        compiled model agrees with 0.1.0's to about 1e-15 relative).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from uav_penetration_env import kernels
from uav_penetration_env.build import BuiltScenario, build_scenario
from uav_penetration_env.catalogue import random_scenario
from uav_penetration_env.catalogue import resolve_scenario as resolve_catalogue_scenario
from uav_penetration_env.kinematics import UAVLimits
from uav_penetration_env.model import PenetrationModel, StepResult
from uav_penetration_env.observation import OBSERVATION_LIMIT, OBSERVATION_SIZE
from uav_penetration_env.scenario import Scenario, ScenarioError
from uav_penetration_env.types import FloatArray

if TYPE_CHECKING:  # matplotlib is imported only when a frame is drawn
    from uav_penetration_env.render import SceneRenderer

ScenarioLike = Scenario | Mapping[str, Any] | str | Path | None
RANDOM_RADAR_SLOTS = 8  # model.md §7a: radars padded to M_max = 8 in the Random id
POOL_SEED_OFFSET = 2**32  # pool scenarios never collide with user seeds or the held-out set


def resolve_scenario(
    scenario: ScenarioLike, default: str, profile: str | None, id_profile: str | None
) -> Scenario:
    """The scenario an env runs: a catalogue name, path, dict or Scenario (else the id's default), with its profile.

    Names resolve in the catalogue (:func:`uav_penetration_env.catalogue.resolve_scenario`).
    Profile precedence (model.md §7a): the ``profile=`` keyword, else the id's profile, else the
    file's.
    """
    resolved = resolve_catalogue_scenario(default if scenario is None else scenario)
    return resolved.with_profile(profile or id_profile)


class FixedScenarioSource:
    """One scenario for every episode (its natural terrain redrawn per reset if it says so)."""

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.radar_slots: int | None = None

    def choose(self, seed: int | None, rng: np.random.Generator) -> Scenario:
        """The scenario of the next episode; draws from ``rng`` only for ``randomize_terrain``."""
        del seed
        return redraw_terrain(self.scenario, rng)


class RandomScenarioSource:
    """Procedural scenarios (model.md §7c): the scenario of seed s, or a pick from a shared pool.

    ``choose(seed=s)`` returns ``random_scenario(default_rng(s), difficulty)``; ``choose(None)``
    draws uniformly, with the env's generator, among ``pool_size`` scenarios whose seeds derive
    from ``pool_seed`` (by default the first reset's seed).
    """

    def __init__(
        self,
        difficulty: float = 0.5,
        pool_size: int = 32,
        pool_seed: int | None = None,
        profile: str | None = None,
    ) -> None:
        if not 0.0 <= difficulty <= 1.0:
            raise ScenarioError("difficulty", difficulty, "a number in [0, 1]")
        if pool_size < 1:
            raise ScenarioError("pool_size", pool_size, "an integer >= 1")
        self.difficulty = difficulty
        self.pool_size = pool_size
        self.pool_seed = pool_seed
        self.profile = profile
        self.radar_slots = RANDOM_RADAR_SLOTS
        self._cache: dict[int, Scenario] = {}

    def scenario_of_seed(self, seed: int) -> Scenario:
        """The scenario of seed ``seed`` (memoised)."""
        if seed not in self._cache:
            scenario = random_scenario(np.random.default_rng(seed), self.difficulty, name=f"random-{seed}")
            self._cache[seed] = scenario.with_profile(self.profile)
        return self._cache[seed]

    def pool_seeds(self) -> list[int]:
        """The seeds of the pool scenarios (requires ``pool_seed``)."""
        state = np.random.SeedSequence(self.pool_seed).generate_state(self.pool_size, dtype=np.uint32)
        return [POOL_SEED_OFFSET + int(s) for s in state]

    def choose(self, seed: int | None, rng: np.random.Generator) -> Scenario:
        """The scenario of the next episode."""
        if self.pool_seed is None:
            self.pool_seed = seed if seed is not None else int(rng.integers(2**63 - 1))
        if seed is not None:
            return redraw_terrain(self.scenario_of_seed(seed), rng)
        pick = self.pool_seeds()[int(rng.integers(self.pool_size))]
        return redraw_terrain(self.scenario_of_seed(pick), rng)


def redraw_terrain(scenario: Scenario, rng: np.random.Generator) -> Scenario:
    """With ``terrain.randomize_terrain``, a new natural-terrain seed drawn from the env generator."""
    if not scenario.terrain.randomize_terrain:
        return scenario
    return replace(scenario, terrain=replace(scenario.terrain, seed=int(rng.integers(2**31))))


class BuiltCache:
    """Built scenarios by content hash, shared by the episodes of one env."""

    def __init__(self, limit: int = 256) -> None:
        self._built: dict[str, BuiltScenario] = {}
        self._limit = limit

    def get(self, scenario: Scenario) -> BuiltScenario:
        """Build (or fetch) the arrays of ``scenario``."""
        key = scenario.hash
        if key not in self._built:
            if len(self._built) >= self._limit:
                self._built.pop(next(iter(self._built)))
            self._built[key] = build_scenario(scenario)
        return self._built[key]


def observation_space() -> spaces.Box:
    """The 67-slot observation box of model.md §7a."""
    return spaces.Box(-OBSERVATION_LIMIT, OBSERVATION_LIMIT, (OBSERVATION_SIZE,), dtype=np.float32)


def action_space(limits: UAVLimits) -> spaces.Box:
    """Physical-unit action box [dv (m/s), dphi (rad), dtheta (rad)] from the scenario's limits."""
    high = limits.action_high.astype(np.float32)
    return spaces.Box(-high, high, dtype=np.float32)


def validate_action(action: Any, high: FloatArray, shape: tuple[int, ...] = (3,)) -> FloatArray:
    """Convert to float64 once, reject NaN/inf and wrong shapes, clip to the action box.

    Raises:
        ValueError: the action is complex, has the wrong shape or a non-finite value.
    """
    if np.iscomplexobj(action):  # numpy would drop the imaginary part with only a ComplexWarning
        values = np.asarray(action)
        shown = values.tolist() if values.size <= 12 else f"of shape {values.shape}"
        raise ValueError(f"action: got complex values {shown}, expected real numbers of shape {shape} [dv, dphi, dtheta]")
    try:
        array = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(
            f"action: got {action!r}, expected a float array of shape {shape} [dv, dphi, dtheta]"
        ) from error
    if array.shape != shape:
        raise ValueError(
            f"action: got shape {array.shape}, expected {shape} [dv (m/s), dphi (rad), dtheta (rad)]"
        )
    if not np.all(np.isfinite(array)):
        raise ValueError(f"action: got {array.tolist()}, expected finite values (no NaN or inf)")
    return np.clip(array, -high, high)


_POSITION_SCALE = np.array([1000.0, 1000.0, 1.0])  # x, y to km; z stays in metres


def step_info(
    J: Any,
    penalty: Any,
    terrain_threat: Any,
    radar_threat: Any,
    third_term: Any,
    fuel_kg: Any,
    progress_km: Any,
    terrain_threat_n: Any,
    radar_threat_n: Any,
    third_term_n: Any,
    radar_threat_per_radar: Any,
    detection_prob: Any,
    altitude_agl: Any,
    goal_distance_m: Any,
    reached_goal: Any,
    collided: Any,
    out_of_area: Any,
    step: Any,
    state: np.ndarray,
) -> dict[str, Any]:
    """The ``info`` entries of api.md, in their order, for one transition or a batch of them.

    The one place the info is assembled: the single env passes Python scalars and (M,) / (6,)
    arrays, the vector env (:func:`batched_info`) arrays with a leading batch axis; the derived
    entries (``detected``, ``position``, ``distance_to_goal``) are computed here alike for both.
    ``state`` is stored as given (the caller hands over an array no one else writes to).
    """
    return {
        "J": J,
        "penalty": penalty,
        "terrain_threat": terrain_threat,
        "radar_threat": radar_threat,
        "third_term": third_term,
        "fuel_kg": fuel_kg,
        "progress": progress_km,
        "terrain_threat_n": terrain_threat_n,
        "radar_threat_n": radar_threat_n,
        "third_term_n": third_term_n,
        "radar_threat_per_radar": radar_threat_per_radar,
        "detection_prob": detection_prob,
        "detected": detection_prob > 0.5,
        "position": state[..., :3] / _POSITION_SCALE,
        "altitude_agl": altitude_agl,
        "distance_to_goal": goal_distance_m / 1000.0,
        "reached_goal": reached_goal,
        "collided": collided,
        "out_of_area": out_of_area,
        "step": step,
        "state": state,
    }


def batched_info(result: StepResult) -> dict[str, np.ndarray]:
    """:func:`step_info` of a batch of transitions, as arrays with a leading batch axis."""
    return step_info(
        result.J,
        result.penalty,
        result.terrain_threat,
        result.radar_threat,
        result.third_term,
        result.fuel_kg,
        result.progress_km,
        result.terrain_threat_n,
        result.radar_threat_n,
        result.third_term_n,
        result.radar_threat_per_radar,
        result.detection_prob,
        result.altitude_agl,
        result.goal_distance,
        result.reached_goal,
        result.collided,
        result.out_of_area,
        result.step_index.astype(np.int64),
        result.state,
    )


def unbatch(info: dict[str, np.ndarray], row: int) -> dict[str, Any]:
    """One row of a batched info as Python scalars and small arrays."""
    out: dict[str, Any] = {}
    for key, value in info.items():
        item = value[row]
        out[key] = item.copy() if isinstance(item, np.ndarray) else item.item()
    return out


def _refuse_action(action: Any, high: FloatArray) -> NoReturn:
    """Raise :func:`validate_action`'s error for an action the compiled step cannot take."""
    validate_action(action, high)
    raise AssertionError(f"validate_action accepted {action!r}, which the compiled step refused")


class UAVPenetrationEnv(gym.Env):
    """UAV low-altitude penetration over terrain past a radar network (Luo, Liang & Li 2022).

    The labelled paragraphs below are the env pages' specification (docs/envs/UAVPenetration-v0.md,
    written by ``benchmarks/env_pages.py``); keep one label per paragraph.

    Observation: 67 float32 slots, each clipped to [-10, 10] (model.md §7a lists them).

    Action: three float32 values in physical units ``[dv (m/s), dphi (rad), dtheta (rad)]``,
    bounded by the scenario's per-step limits; the env converts it to float64 once, **clips it to
    the box**, and raises ``ValueError`` for NaN/inf or a wrong shape.

    Reward: ``-(J(k) + penalty)`` on every step, terminal ones included; ``penalty`` is 0 unless
    the step ended the episode by a failure (model.md §7a).

    Episode end: terminates at the goal, on a collision, or out of the map/above the ceiling;
    truncates itself at ``time.max_steps``.

    Args:
        scenario: a YAML path, a mapping, a :class:`Scenario`, or ``None`` for the id's default.
        profile: ``"benchmark"`` or ``"paper"``; overrides the id's and the file's profile.
        render_mode: ``"rgb_array"`` or ``"human"``.
        default_scenario: the id's scenario when ``scenario`` is None (``"paper"`` or ``"dem"``).
        id_profile: the id's profile (set at registration).
        threads: compiled threads of the env's model when a planner batches on it
            (``env.unwrapped.model.rollout_cost``); the env's own step is one row on the calling
            thread. None keeps numba's count (:class:`PenetrationModel`).

    Version history:
        v0: first release.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 4}

    def __init__(
        self,
        scenario: ScenarioLike = None,
        profile: str | None = None,
        render_mode: str | None = None,
        *,
        default_scenario: str = "paper",
        id_profile: str | None = None,
        threads: int | None = None,
    ) -> None:
        self._init_source(
            FixedScenarioSource(resolve_scenario(scenario, default_scenario, profile, id_profile)),
            render_mode,
            threads,
        )

    def _init_source(
        self,
        source: FixedScenarioSource | RandomScenarioSource,
        render_mode: str | None,
        threads: int | None = None,
    ) -> None:
        self._threads = kernels.check_threads(threads)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode: got {render_mode!r}, expected one of {self.metadata['render_modes']} or None"
            )
        self.render_mode = render_mode
        self.source = source
        self._built = BuiltCache()
        self._models: dict[str, PenetrationModel] = {}
        self.model: PenetrationModel | None = None
        self.scenario: Scenario | None = None
        if isinstance(source, FixedScenarioSource):
            self._use(source.scenario)
            limits = self._loaded.limits
            self.state = self._loaded.initial_state()
        else:
            # Procedural scenarios keep the default airframe, so the action box is known before
            # the first (expensive) scenario build at reset.
            limits = UAVLimits.from_scenario(Scenario())
            self.state = np.zeros(6)
        self.observation_space = observation_space()
        self.action_space = action_space(limits)
        self.step_index = 0
        self._done = True
        self._track: list[FloatArray] = []
        self._renderer: SceneRenderer | None = None

    @property
    def _loaded(self) -> PenetrationModel:
        """The model of the current scenario (a Random id has none before its first reset)."""
        if self.model is None:
            raise RuntimeError("no scenario loaded yet: call reset() first")
        return self.model

    def _use(self, scenario: Scenario) -> None:
        key = scenario.hash
        if key not in self._models:
            if len(self._models) >= 64:
                self._models.pop(next(iter(self._models)))
            self._models[key] = PenetrationModel(
                self._built.get(scenario), radar_slots=self.source.radar_slots, threads=self._threads
            )
        self.model = self._models[key]
        self.scenario = scenario

    # --- Gymnasium API ---------------------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode; ``seed`` seeds the env generator (and picks the Random id's scenario).

        Raises:
            ValueError: ``options`` with any key: the env takes no reset options, and a key it
                silently ignored (a start state, a scenario) would fly something else than asked.
        """
        if options is not None and not isinstance(options, dict):
            raise TypeError(f"options: got {type(options).__name__} {options!r}, expected None or an empty dict")
        if options:
            raise ValueError(
                f"options: got the key(s) {', '.join(map(repr, options))}, expected none "
                "(UAVPenetrationEnv.reset takes no options; choose the scenario with gym.make(..., scenario=...))"
            )
        super().reset(seed=seed)
        self._use(self.source.choose(seed, self.np_random))
        self.state = self._loaded.initial_state(self.np_random)
        self.step_index = 0
        self._done = False
        self._track = [self.state.copy()]
        return self._describe_state()

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Fly one planning period with ``action``; see the class docstring for the reward."""
        if self._done or self.model is None:
            raise RuntimeError("step() called without a running episode: call reset() first")
        observation, reward, terminated, truncated, info = self._step_compiled(action)
        self.step_index += 1
        self._done = terminated or truncated
        self._track.append(self.state.copy())
        if self.render_mode == "human":
            self.render()
        return observation, reward, terminated, truncated, info

    def _step_compiled(
        self, action: Any, model: PenetrationModel | None = None
    ) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """:meth:`step`'s transition in one compiled call (:meth:`PenetrationModel._env_step_one`) on ``model``.

        ``model`` is the one the env scores on: the scenario's (None), or a dynamic env's truth.

        The same action checks and numbers as the model's public ``step`` and ``observe``, without
        their per-call array checks and per-key conversions: a single env's step costs about 30 us
        instead of 150 us (benchmarks/bench_env.py).

        DECISION (model.md §7a): this is the env's only production path; the env never consults a
        subclass's overrides of the model's methods (``step``, ``observe``, ``reset_result``, the
        state queries). The numpy formulation (tests/numpy_model.py) is a test oracle, compared
        with the compiled model directly, so it does not shape the env's dispatch.
        """
        array: np.ndarray | None
        if type(action) is np.ndarray and action.dtype == np.float64 and action.flags.c_contiguous:
            array = action
        else:
            try:
                raw = np.asarray(action)
                # complex: refused by validate_action below, not cut to its real part
                array = None if raw.dtype.kind == "c" else np.ascontiguousarray(raw, dtype=np.float64)
            except (TypeError, ValueError):
                array = None
        model = self._loaded if model is None else model
        if array is None or array.shape != (3,):
            _refuse_action(action, model.limits.action_high)  # the error of the generic path
        out = model._env_step_one(self.state, array, self.step_index)
        if out is None:
            _refuse_action(action, model.limits.action_high)  # a NaN or infinite entry
        scalars, flags = out.scalars, out.flags
        self.state = out.state
        J, penalty = scalars[kernels.S_J], scalars[kernels.S_PENALTY]
        after = scalars[kernels.S_GOAL_AFTER]
        info = step_info(
            J,
            penalty,
            scalars[kernels.S_TERRAIN],
            scalars[kernels.S_RADAR],
            scalars[kernels.S_THIRD],
            scalars[kernels.S_FUEL],
            (scalars[kernels.S_GOAL_BEFORE] - after) / 1000.0,
            scalars[kernels.S_TERRAIN_N],
            scalars[kernels.S_RADAR_N],
            scalars[kernels.S_THIRD_N],
            out.radar_threat_per_radar,
            scalars[kernels.S_DETECTION],
            scalars[kernels.S_ALTITUDE_AGL],
            after,
            flags[kernels.F_REACHED],
            flags[kernels.F_COLLIDED],
            flags[kernels.F_OUT_OF_AREA],
            self.step_index + 1,
            out.state.copy(),
        )
        terminated, truncated = flags[kernels.F_TERMINATED], flags[kernels.F_TRUNCATED]
        return out.observation, -(J + penalty), terminated, truncated, info

    def _describe_state(self, model: PenetrationModel | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """The observation and info of ``self.state`` at ``self.step_index`` before any transition.

        As :meth:`PenetrationModel.reset_result` describes it (zero transition quantities, no
        event flag), in one compiled call (:meth:`PenetrationModel._env_reset_one`) on ``model``
        (None: the scenario's).
        """
        out = (self._loaded if model is None else model)._env_reset_one(self.state, self.step_index)
        info = step_info(
            0.0,
            0.0,
            out.terrain_threat,
            out.radar_threat,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            out.radar_threat_per_radar,
            out.detection_prob,
            out.altitude_agl,
            out.goal_distance,
            False,
            False,
            False,
            self.step_index,
            self.state.copy(),
        )
        return out.observation, info

    def set_state(self, state: Any, step_index: int = 0) -> tuple[np.ndarray, dict[str, Any]]:
        """Continue the episode from any exact state and step index (planners, tests).

        Returns:
            The observation and info of that state (zero costs, as at reset).

        Raises:
            ValueError: the state is not 6 finite real numbers or the step index is outside [0, K_max).
        """
        if self.model is None:
            raise RuntimeError("set_state() needs a scenario: call reset() first")
        expected = "expected 6 finite real numbers [x, y, z, v, phi, theta]"
        shown = " ".join(repr(state).split())  # one line: an array's repr spans several
        shown = shown if len(shown) <= 200 else f"{shown[:160]}..."
        if isinstance(state, (str, bytes, dict)) or state is None or np.iscomplexobj(state):
            raise ValueError(f"state: got {shown}, {expected}")
        try:
            array = np.asarray(state, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"state: got {shown}, {expected}") from None
        if array.shape != (6,) or not np.all(np.isfinite(array)):
            raise ValueError(f"state: got {shown}, {expected}")
        if not (isinstance(step_index, (int, np.integer)) and 0 <= step_index < self._loaded.max_steps):
            raise ValueError(
                f"step_index: got {step_index!r}, expected an integer in [0, {self._loaded.max_steps})"
            )
        self.state = array.copy()
        self.step_index = int(step_index)
        self._done = False
        self._track = [self.state.copy()]
        return self._describe_state()

    def render(self) -> np.ndarray | None:
        """Draw terrain, radars with their coverage at the UAV's altitude, start, goal and the track."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
            return None
        from uav_penetration_env.render import SceneRenderer

        if self._renderer is None or self._renderer.model is not self.model:
            if self._renderer is not None:
                self._renderer.close()
            self._renderer = SceneRenderer(self._loaded, human=self.render_mode == "human")
        frame = self._renderer.draw(np.array(self._track), self.state)
        return frame if self.render_mode == "rgb_array" else None

    def close(self) -> None:
        """Release the renderer's figure."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


class UAVPenetrationRandomEnv(UAVPenetrationEnv):
    """Procedurally generated scenarios (model.md §7c), ``UAVPenetrationRandom-v0``.

    ``reset(seed=s)`` flies the scenario of seed s; ``reset()`` picks one of ``pool_size`` pool
    scenarios with the env generator. Radars are padded to 8 slots, so ``radar_threat_per_radar``
    has shape (8,).

    Args:
        difficulty: d in [0, 1] (model.md §7c).
        pool_size: number of pool scenarios for seedless resets.
        pool_seed: seed of the pool (default: the first reset's seed).
        profile: ``"benchmark"`` or ``"paper"`` (the paper profile needs payoff constants).
        render_mode: ``"rgb_array"`` or ``"human"``.
        id_profile: the id's profile (set at registration).
        threads: compiled threads of the env's model (as for :class:`UAVPenetrationEnv`).
    """

    def __init__(
        self,
        difficulty: float = 0.5,
        pool_size: int = 32,
        pool_seed: int | None = None,
        profile: str | None = None,
        render_mode: str | None = None,
        *,
        id_profile: str | None = None,
        threads: int | None = None,
    ) -> None:
        self._init_source(
            RandomScenarioSource(difficulty, pool_size, pool_seed, profile or id_profile), render_mode, threads
        )
