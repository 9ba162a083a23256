"""The penetration model: one batched transition and cost for the env, the vector env and planners.

``PenetrationModel`` owns the precomputed arrays of one scenario, or of a pool of scenarios
that share their grid, UAV, time, radar-model, cost and normalisation settings (the Random
id's vector env serves every sub-env from one pool; radars and mountains are padded with a
presence mask). All its methods take batches: states ``(B, 6)``, controls ``(B, 3)``, and an
optional ``scenario_index`` ``(B,)`` into the pool.

* :meth:`step` is the environment transition: kinematics, events along the segment (model.md
  §7a), every cost term of the transition (§3-7) and the failure penalty.
* :meth:`rollout_cost` scores ``(B, H, 3)`` control sequences from one state with the very same
  code, so it equals the summed ``-(reward)`` of the env flying the same controls.
* :meth:`observe` packs the 67-slot observation of §7a.

The physics itself is compiled (``kernels.py``): every method above hands its batch to
one of a few numba loop kernels built from the same scalar functions, with the scenario passed as
typed arrays (:class:`kernels.ModelArrays`; the scalar settings once, by name, as the
:class:`kernels.ModelConstants` and :class:`kernels.ModelOptions` of :func:`model_constants`,
packed into vectors). Results do not depend on the thread count; batches of
fewer than ``kernels.SERIAL_BELOW_ROWS`` rows run on the calling thread.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from uav_penetration_env import checks, kernels, terminal_kernels
from uav_penetration_env.build import BuiltScenario, build_scenario
from uav_penetration_env.cost import FuelParams, Normalisation
from uav_penetration_env.kernels import FAR_RANGE_RATIO, ModelArrays, ModelConstants, ModelOptions
from uav_penetration_env.kinematics import UAVLimits, wrap_angle
from uav_penetration_env.observation import (
    OBSERVATION_LIMIT,
    OBSERVATION_SIZE,
    OBSERVED_RADARS,
    RADAR_FEATURES,
    TERRAIN_ACROSS_M,
    TERRAIN_AHEAD_M,
)
from uav_penetration_env.radar import fuse, reference_snr
from uav_penetration_env.scenario import Scenario, ScenarioError
from uav_penetration_env.terminal_kernels import TerminalCost
from uav_penetration_env.terrain import GridSpec
from uav_penetration_env.types import BoolArray, FloatArray, IntArray

__all__ = [
    "FAR_RANGE_RATIO",
    "OBSERVATION_LIMIT",
    "OBSERVATION_SIZE",
    "OBSERVED_RADARS",
    "RADAR_FEATURES",
    "TERRAIN_ACROSS_M",
    "TERRAIN_AHEAD_M",
    "PenetrationModel",
    "StepResult",
]

_POOL_SHARED = ("map", "uav", "time", "radar_model", "cost", "normalisation", "profile")


@dataclass(frozen=True)
class StepResult:
    """Everything one transition produces, per batch row (SI units unless named otherwise)."""

    state: FloatArray  # (B, 6) next state
    step_index: IntArray  # (B,) k after the transition
    J: FloatArray  # (B,) normalised weighted cost J(k)
    penalty: FloatArray  # (B,) failure penalty (0 unless the step failed)
    terrain_threat: FloatArray  # (B,) Th_e(k) raw
    radar_threat: FloatArray  # (B,) Th_r(k) raw (fused over radars)
    third_term: FloatArray  # (B,) C(k) raw
    terrain_threat_n: FloatArray
    radar_threat_n: FloatArray
    third_term_n: FloatArray
    fuel_kg: FloatArray  # (B,) fuel burned on the step
    progress_km: FloatArray  # (B,) horizontal distance gained toward the goal
    radar_threat_per_radar: FloatArray  # (B, M) D_m or P_d,m (0 for padded radars)
    visibility: FloatArray  # (B, M) P_vis,m (soft), 1/0 (hard, or the eq. 12 horizon when masking is off)
    detection_prob: FloatArray  # (B,)
    altitude_agl: FloatArray  # (B,) z - h(x, y) [m]
    goal_distance: FloatArray  # (B,) horizontal distance to the goal [m]
    reached_goal: BoolArray
    collided: BoolArray
    out_of_area: BoolArray
    terminated: BoolArray
    truncated: BoolArray

    @property
    def reward(self) -> FloatArray:
        """-(J + penalty): the environment's reward."""
        return -(self.J + self.penalty)


def _constant(field: str, doc: str) -> property:
    """A read-only attribute of the model that reads ``field`` of its :class:`ModelConstants` (one home)."""
    return property(lambda model: getattr(model.constants, field), doc=doc)


class PenetrationModel:
    """The batched physics and cost model of one scenario or of a compatible pool of scenarios.

    Args:
        scenarios: a :class:`Scenario`, a :class:`BuiltScenario`, or a sequence of them (a pool).
        radar_slots: pad the radar axis to this many slots (default: the pool's largest count).
        threads: compiled threads of this model's batch kernels (``step``, ``costs``,
            ``observe``, ``rollout_cost``): 1 runs them on the calling thread, N on N threads;
            None keeps numba's count in force (all cores in a main process, one in the harness's
            workers). Results never depend on it (model.md §8, threads).

    Raises:
        ValueError: ``threads`` not None or an integer >= 1; an empty pool.
    """

    def __init__(
        self,
        scenarios: Scenario | BuiltScenario | Sequence[Scenario | BuiltScenario],
        *,
        radar_slots: int | None = None,
        threads: int | None = None,
    ) -> None:
        self.threads = kernels.check_threads(threads)
        items = [scenarios] if isinstance(scenarios, (Scenario, BuiltScenario)) else list(scenarios)
        if not items:
            raise ValueError("scenarios: got an empty pool, expected at least one scenario")
        built = [item if isinstance(item, BuiltScenario) else build_scenario(item) for item in items]
        self.built: tuple[BuiltScenario, ...] = tuple(built)
        first = built[0].scenario
        for i, other in enumerate(built[1:], start=1):
            for name in _POOL_SHARED:
                if getattr(other.scenario, name) != getattr(first, name):
                    raise ScenarioError(
                        f"pool[{i}].{name}",
                        getattr(other.scenario, name),
                        f"the same {name} as pool[0] (a pool varies only geometry)",
                    )
        self.scenario: Scenario = first
        self.grid = built[0].grid
        self.limits = UAVLimits.from_scenario(first)
        self._action_high = self.limits.action_high  # (3,) float64, read by the single env's hot path
        self._start_jitters = [
            b.scenario.start.jitter.xy_km > 0 or b.scenario.start.jitter.heading_deg > 0 for b in built
        ]
        self._fixed_starts: FloatArray | None = None  # (P, 6) start poses without jitter, on first use
        self.fuel = FuelParams.from_scenario(first)
        self.normalisation = Normalisation.from_scenario(first, self.fuel)
        self.weights = first.cost.weights
        self.detection = first.detection
        self.masking = first.masking
        if self.detection == "ratio" and first.radar_model.fusion == "or":
            raise ScenarioError(
                "radar_model.fusion", "or", "'max' with the ratio detection (D is not a probability)"
            )
        self.rcs_table = built[0].rcs_table
        self.constants, self.options = model_constants(first, self.grid, self.limits, self.fuel, self.normalisation)
        # Collision samples per segment: intervals of at most half a grid cell on the longest
        # possible step (model.md §1, §8). A fixed count keeps batches of any size identical.
        self.segment_samples = max(1, math.ceil(self.limits.max_step_length / (0.5 * self.grid.dx_m)))
        self._sample_t = np.arange(1, self.segment_samples + 1) / self.segment_samples
        self._stack_pool(built, radar_slots)

    # --- pool arrays ----------------------------------------------------------------------------

    def _stack_pool(self, built: list[BuiltScenario], radar_slots: int | None) -> None:
        pool = len(built)
        counts = [len(b.radar_xyz) for b in built]
        slots = max(counts) if radar_slots is None else radar_slots
        if slots < max(counts):
            raise ValueError(
                f"radar_slots: got {slots}, expected at least the pool's largest radar count {max(counts)}"
            )
        peaks = max(len(b.mountains) for b in built)
        self.pool_size = pool
        self.radar_slots = slots
        self.terrain = np.stack([b.terrain for b in built])  # (P, nx, ny)
        self.radar_xyz = np.zeros((pool, slots, 3))
        self.radar_present = np.zeros((pool, slots))
        self.ref_range = np.ones((pool, slots))
        self.ref_rcs = np.ones((pool, slots))
        self.floor_layer = np.zeros((pool, slots), dtype=np.intp)
        self.mountain_centres = np.zeros((pool, peaks, 2))
        self.mountain_present = np.zeros((pool, peaks))
        self.goal = np.zeros((pool, 3))  # x, y, radius [m]
        self.start = np.zeros((pool, 2))
        floors: list[np.ndarray] = []
        for p, b in enumerate(built):
            s = b.scenario
            m = len(b.radar_xyz)
            self.radar_xyz[p, :m] = b.radar_xyz
            self.radar_present[p, :m] = 1.0
            self.ref_range[p, :m] = [r.ref_range_km * 1000.0 for r in s.radars]
            self.ref_rcs[p, :m] = [r.ref_rcs_m2 for r in s.radars]
            if len(b.floors):
                self.floor_layer[p, :m] = len(floors) + np.arange(m)
                floors.extend(b.floors)
            self.mountain_centres[p, : len(b.mountains)] = b.mountains[:, :2]
            self.mountain_present[p, : len(b.mountains)] = 1.0
            self.goal[p] = (s.goal.x_km * 1000.0, s.goal.y_km * 1000.0, s.goal.radius_km * 1000.0)
            self.start[p] = (s.start.x_km * 1000.0, s.start.y_km * 1000.0)
        self.floors = np.stack(floors) if floors else np.zeros((1, self.grid.nx, self.grid.ny))
        decay = self.constants.mountain_decay
        for b in built[1:]:
            if b.scenario.terrain.mountain_decay_per_km2 != decay:
                raise ScenarioError(
                    "pool.terrain.mountain_decay_per_km2", b.scenario.terrain.mountain_decay_per_km2, f"{decay}"
                )
        self.arrays = self._kernel_arrays()

    def _kernel_arrays(self) -> ModelArrays:
        """The pool, the RCS table and the packed constants and options, as the typed arrays the kernels read."""

        def f64(array: np.ndarray) -> np.ndarray:
            return np.ascontiguousarray(array, dtype=np.float64)

        return ModelArrays(
            terrain=f64(self.terrain),
            floors=f64(self.floors),
            radar_xyz=f64(self.radar_xyz),
            radar_present=f64(self.radar_present),
            ref_range=f64(self.ref_range),
            ref_rcs=f64(self.ref_rcs),
            floor_layer=np.ascontiguousarray(self.floor_layer, dtype=np.int64),
            mountain_centres=f64(self.mountain_centres),
            mountain_present=f64(self.mountain_present),
            goal=f64(self.goal),
            rcs_table=f64(self.rcs_table),
            sample_t=f64(self._sample_t),
            params=kernels.pack(self.constants),
            options=kernels.pack(self.options),
        )

    # --- constants, as named in the scenario's terms -----------------------------------------

    @property
    def max_steps(self) -> int:
        """K_max, the episode length in steps."""
        return self.options.max_steps

    @property
    def bounds(self) -> FloatArray:
        """(4,) map bounds x_min, x_max, y_min, y_max [m]."""
        c = self.constants
        return np.array([c.x_min, c.x_max, c.y_min, c.y_max])

    ceiling = _constant("ceiling", "The map's ceiling [m].")
    clearance = _constant("clearance", "The minimum height above the terrain [m].")
    map_side = _constant("map_side", "L, the larger map extent [m].")
    crash_penalty_per_step = _constant("crash_per_step", "The failure penalty per remaining step (model.md §7a).")
    snr_ref = _constant("snr_ref", "SNR_ref of the Swerling-I detection (model.md §4.6).")

    @property
    def threat_altitude_scale(self) -> float | None:
        """The scale s [m] of the terrain threat's fade with height, or None without the fade (model.md §3)."""
        return self.constants.threat_altitude_scale if self.options.altitude_fade else None

    @property
    def earth_radius(self) -> float:
        """The effective earth radius R_eff [m] (model.md §4.3)."""
        return self.scenario.radar_model.effective_earth_radius_km * 1000.0

    def _rows(self, index: IntArray | int | None, batch: int) -> np.ndarray:
        """Pool index of each of ``batch`` rows as contiguous int64 (the kernels' layout)."""
        if index is None:
            if self.pool_size != 1:
                raise ValueError("scenario_index: required for a model with a pool of scenarios")
            return np.zeros(batch, dtype=np.int64)
        return checks.integer_array(
            index,
            "scenario_index",
            batch,
            0,
            self.pool_size - 1,
            f"[0, {self.pool_size}) (integer pool indices)",
        )

    @staticmethod
    def _batch(array: FloatArray, name: str, width: int) -> np.ndarray:
        """``array`` as a contiguous float64 (B, width) batch of finite numbers (api.md §2.4)."""
        return checks.finite_array(array, name, (None, width), f"a (B, {width}) array of finite numbers")

    def _step_indices(self, step_index: IntArray | int, batch: int, last: int) -> np.ndarray:
        """The step index k of each row as int64 (B,), each in [0, last] (``last`` is K_max or K_max - 1)."""
        return checks.integer_array(
            step_index, "step_index", batch, 0, last, f"integers in [0, {last}] (K_max = {self.max_steps})"
        )

    # --- queries --------------------------------------------------------------------------------

    def height(self, x_m: FloatArray, y_m: FloatArray, scenario_index: IntArray | None = None) -> FloatArray:
        """Terrain height [m] at points [m] (bilinear, edge values outside the grid; model.md §2.1).

        Raises:
            TypeError: coordinates that are not numbers, or a non-integer ``scenario_index``.
            ValueError: a NaN or infinite coordinate, shapes that do not broadcast, or a
                ``scenario_index`` outside the pool.
        """
        expected = "finite coordinates [m] (arrays of one shape, or broadcastable)"
        x = checks.as_float_array(x_m, "x_m", expected)
        y = checks.as_float_array(y_m, "y_m", expected)
        try:
            x, y = np.broadcast_arrays(x, y)
        except ValueError:
            raise ValueError(f"x_m, y_m: got shapes {x.shape} and {y.shape}, expected {expected}") from None
        for name, array in (("x_m", x), ("y_m", y)):
            if not checks.all_finite(np.ascontiguousarray(array)):
                raise ValueError(
                    f"{name}: got a non-finite entry {name}{checks._first_bad(array)}, expected {expected}"
                )
        shape = x.shape
        x, y = np.ascontiguousarray(x).reshape(-1), np.ascontiguousarray(y).reshape(-1)
        index = self._rows(
            None if scenario_index is None else np.broadcast_to(scenario_index, shape).reshape(-1), x.size
        )
        out = np.empty(x.size)
        kernels.heights_batch(self.arrays, x, y, index, out)
        return out.reshape(shape)

    def initial_state(self, rng: np.random.Generator | None = None, scenario_index: int = 0) -> FloatArray:
        """The scenario's start state (6,), with the start jitter drawn from ``rng`` when configured."""
        return self.initial_states([rng], [scenario_index])[0]

    def initial_states(
        self, rngs: Sequence[np.random.Generator | None], scenario_index: Sequence[int]
    ) -> FloatArray:
        """Start states (n, 6) for several episodes, each drawing its jitter from its own generator.

        Rows that draw no jitter (no generator, or a scenario without ``start.jitter``) copy the
        pool's fixed start poses, computed once by the same code (an env resets often).
        """
        rngs = list(rngs)
        indices = list(scenario_index)
        if len(rngs) != len(indices):
            raise ValueError(
                f"scenario_index: got {len(indices)} entries, expected {len(rngs)} (one per generator)"
            )
        if all(rng is None or not self._start_jitters[p] for rng, p in zip(rngs, indices, strict=True)):
            if self._fixed_starts is None:
                self._fixed_starts = self._draw_initial_states([None] * self.pool_size, range(self.pool_size))
            return self._fixed_starts[np.asarray(indices, dtype=np.intp)]
        return self._draw_initial_states(rngs, indices)

    def _draw_initial_states(
        self, rngs: Sequence[np.random.Generator | None], scenario_index: Sequence[int]
    ) -> FloatArray:
        """:meth:`initial_states` computed row by row."""
        poses = np.zeros((len(rngs), 6))
        for row, (rng, p) in enumerate(zip(rngs, scenario_index, strict=True)):
            start = self.built[p].scenario.start
            x, y = self.start[p]
            gx, gy = self.goal[p, :2]
            heading = (
                math.atan2(gy - y, gx - x) if start.heading_deg is None else math.radians(start.heading_deg)
            )
            jitter = start.jitter
            if rng is not None and (jitter.xy_km > 0 or jitter.heading_deg > 0):
                dx, dy, dh = rng.uniform(-1.0, 1.0, size=3)
                x += dx * jitter.xy_km * 1000.0
                y += dy * jitter.xy_km * 1000.0
                heading += math.radians(dh * jitter.heading_deg)
            poses[row] = (x, y, start.z_agl_m, start.speed_m_s, heading, math.radians(start.pitch_deg))
        index = None if self.pool_size == 1 else np.asarray(scenario_index, dtype=np.intp)
        poses[:, 2] += self.height(poses[:, 0], poses[:, 1], index)
        poses[:, 4] = wrap_angle(poses[:, 4])
        return poses

    def goal_distance(self, states: FloatArray, scenario_index: IntArray | None = None) -> FloatArray:
        """Horizontal distance to the goal [m]."""
        states = np.asarray(states, dtype=np.float64)
        if scenario_index is None:
            goal = self._rows(None, 1)[:1]
        else:
            goal = np.asarray(scenario_index, dtype=np.int64)
        goal = self.goal[goal]
        return np.hypot(goal[..., 0] - states[..., 0], goal[..., 1] - states[..., 1])

    def reset_result(
        self,
        states: FloatArray,
        scenario_index: IntArray | None = None,
        step_index: IntArray | int = 0,
    ) -> StepResult:
        """A :class:`StepResult` describing states before any transition: at reset, or at a set state.

        Quantities of the state alone (terrain and fused radar threat, per-radar threat,
        visibility, detection probability, altitude above the terrain, goal distance) describe
        ``states``; those of a transition (J, penalty, the third term, fuel, progress and the
        normalised terms) are 0 and no event flag is set (model.md §7a, the reset info).

        Args:
            states: (B, 6) states.
            scenario_index: (B,) pool index of each row.
            step_index: k of each row, scalar or (B,) (0 at reset).

        Returns:
            The result, every field with a leading batch axis B.
        """
        states = self._batch(states, "states", 6)
        batch = len(states)
        step_index = self._step_indices(step_index, batch, self.max_steps)
        zeros = np.zeros(batch)
        false = np.zeros(batch, dtype=bool)
        terrain, per_radar, visibility, detection = self.state_threats(states, scenario_index)
        return StepResult(
            state=states,
            step_index=np.broadcast_to(np.asarray(step_index, dtype=np.int64), (batch,)).copy(),
            J=zeros,
            penalty=zeros,
            terrain_threat=terrain,
            radar_threat=fuse(per_radar, self.scenario.radar_model.fusion),
            third_term=zeros,
            terrain_threat_n=zeros,
            radar_threat_n=zeros,
            third_term_n=zeros,
            fuel_kg=zeros,
            progress_km=zeros,
            radar_threat_per_radar=per_radar,
            visibility=visibility,
            detection_prob=detection,
            altitude_agl=states[:, 2] - self.height(states[:, 0], states[:, 1], scenario_index),
            goal_distance=self.goal_distance(states, scenario_index),
            reached_goal=false,
            collided=false,
            out_of_area=false,
            terminated=false,
            truncated=false,
        )

    def coverage_level(self, states: FloatArray, scenario_index: IntArray | None = None) -> FloatArray:
        """The radar network's detection at states on a [0, 1] scale, for coverage maps (model.md §4-5).

        With the probability detection it is the fused threat Th_r (``max`` or ``or`` of the
        per-radar P_d); with the ratio detection (eqs. 11/13) it is 1 where some radar detects
        (D >= 1, inside the horizon, in sight) and 0 elsewhere, since D itself is no probability.

        Args:
            states: (B, 6) states.
            scenario_index: (B,) pool index of each row.

        Returns:
            (B,) values in [0, 1].
        """
        _, per_radar, _, _ = self.state_threats(states, scenario_index)
        threat = fuse(per_radar, self.scenario.radar_model.fusion)
        if self.detection == "ratio":
            return (threat >= 1.0).astype(np.float64)
        return threat

    # --- the transition ---------------------------------------------------------------------------

    def step(
        self,
        states: FloatArray,
        controls: FloatArray,
        step_index: IntArray | int,
        scenario_index: IntArray | None = None,
    ) -> StepResult:
        """One transition for a batch: kinematics, segment events, costs and penalty (model.md §7a).

        Args:
            states: (B, 6) current states.
            controls: (B, 3) controls (clipped to the action box).
            step_index: k before the transition, scalar or (B,).
            scenario_index: (B,) pool index of each row (``None`` for a one-scenario model).

        Returns:
            The :class:`StepResult`; ``step_index`` in it is k + 1.

        Raises:
            TypeError: arrays that are not numbers; a non-integer ``step_index`` or ``scenario_index``.
            ValueError: arrays of the wrong shape or with a NaN or infinite entry; a ``step_index``
                outside [0, K_max - 1] (a transition from step K_max does not exist: the episode
                has ended); a missing or out-of-range ``scenario_index``.
        """
        return self._transitions(states, controls, "controls", step_index, scenario_index)

    def costs(
        self,
        states: FloatArray,
        next_states: FloatArray,
        step_index: IntArray | int,
        scenario_index: IntArray | None = None,
    ) -> StepResult:
        """Score a given transition ``states -> next_states`` taken at step k (no kinematics).

        Raises:
            TypeError, ValueError: as :meth:`step` (``next_states`` in place of ``controls``).
        """
        return self._transitions(states, next_states, "next_states", step_index, scenario_index)

    def _transitions(
        self,
        states: FloatArray,
        moves: FloatArray,
        moves_name: str,
        step_index: IntArray | int,
        scenario_index: IntArray | None,
    ) -> StepResult:
        """:meth:`step` or :meth:`costs`, their arguments checked first.

        ``moves_name`` is ``"controls"`` ((B, 3) controls, flown) or ``"next_states"`` ((B, 6) states).
        """
        moves_are_controls = moves_name == "controls"
        states = self._batch(states, "states", 6)
        moves = self._batch(moves, moves_name, 3 if moves_are_controls else 6)
        step_index = self._step_indices(step_index, states.shape[0], self.max_steps - 1)
        batch = states.shape[0]
        if moves.shape[0] != batch:
            raise ValueError(
                f"controls/next_states: got {moves.shape[0]} rows, expected {batch} (one per state)"
            )
        if (
            isinstance(step_index, np.ndarray)
            and step_index.dtype == np.int64
            and step_index.shape == (batch,)
        ):
            k_next = step_index + 1  # checked by the public method (contiguous int64)
        elif isinstance(step_index, (int, np.integer)):
            k_next = np.full(batch, int(step_index) + 1, dtype=np.int64)
        else:
            k_next = np.ascontiguousarray(
                np.broadcast_to(np.asarray(step_index, dtype=np.int64) + 1, (batch,))
            )
        index = self._rows(scenario_index, batch)
        slots = self.radar_slots
        next_states = np.empty((batch, 6))
        per_radar = np.empty((batch, slots))
        visible = np.empty((batch, slots))
        scalars = np.empty((batch, kernels.N_SCALARS))
        flags = np.empty((batch, kernels.N_FLAGS), dtype=np.bool_)
        kernels.run_kernel(
            kernels.transition_batch,
            kernels.transition_rows,
            batch,
            self.arrays,
            states,
            moves,
            moves_are_controls,
            k_next,
            index,
            (next_states, per_radar, visible, scalars, flags),
            threads=self.threads,
        )
        return self._step_result(next_states, k_next, per_radar, visible, scalars, flags)

    @staticmethod
    def _step_result(
        next_states: np.ndarray,
        k_next: np.ndarray,
        per_radar: np.ndarray,
        visible: np.ndarray,
        scalars: np.ndarray,
        flags: np.ndarray,
    ) -> StepResult:
        """The :class:`StepResult` of the transition kernels' outputs (views of ``scalars`` and ``flags``)."""
        before, after = scalars[:, kernels.S_GOAL_BEFORE], scalars[:, kernels.S_GOAL_AFTER]
        return StepResult(
            state=next_states,
            step_index=k_next,
            J=scalars[:, kernels.S_J],
            penalty=scalars[:, kernels.S_PENALTY],
            terrain_threat=scalars[:, kernels.S_TERRAIN],
            radar_threat=scalars[:, kernels.S_RADAR],
            third_term=scalars[:, kernels.S_THIRD],
            terrain_threat_n=scalars[:, kernels.S_TERRAIN_N],
            radar_threat_n=scalars[:, kernels.S_RADAR_N],
            third_term_n=scalars[:, kernels.S_THIRD_N],
            fuel_kg=scalars[:, kernels.S_FUEL],
            progress_km=(before - after) / 1000.0,
            radar_threat_per_radar=per_radar,
            visibility=visible,
            detection_prob=scalars[:, kernels.S_DETECTION],
            altitude_agl=scalars[:, kernels.S_ALTITUDE_AGL],
            goal_distance=after,
            reached_goal=flags[:, kernels.F_REACHED],
            collided=flags[:, kernels.F_COLLIDED],
            out_of_area=flags[:, kernels.F_OUT_OF_AREA],
            terminated=flags[:, kernels.F_TERMINATED],
            truncated=flags[:, kernels.F_TRUNCATED],
        )

    def state_threats(
        self, states: FloatArray, index: IntArray | None = None
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Threats that depend on the state alone: Th_e, per-radar threat, visibility, detection prob.

        Args:
            states: (B, 6) states.
            index: (B,) pool index of each row.

        Returns:
            terrain threat (B,), per-radar threat (B, M), visibility (B, M), detection probability (B,).
        """
        threat_e, per_radar, visible, detection, _ = self._state_threats(
            self._batch(states, "states", 6), index
        )
        return threat_e, per_radar, visible, detection

    def _state_threats(
        self, states: np.ndarray, index: IntArray | None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        batch = states.shape[0]
        rows = self._rows(index, batch)
        terrain = np.empty(batch)
        per_radar = np.empty((batch, self.radar_slots))
        visible = np.empty((batch, self.radar_slots))
        detection = np.empty(batch)
        altitude_agl = np.empty(batch)
        kernels.threats_batch(self.arrays, states, rows, terrain, per_radar, visible, detection, altitude_agl)
        return terrain, per_radar, visible, detection, altitude_agl

    # --- planning -----------------------------------------------------------------------------------

    def rollout_cost(
        self,
        state: FloatArray,
        controls: FloatArray,
        *,
        step: int,
        discount: float = 1.0,
        terminal_cost: TerminalCost = terminal_kernels.NO_TERMINAL_COST,
        scenario_index: int = 0,
    ) -> FloatArray:
        """Discounted window cost J^(H) of control sequences flown from one state (eq. 37, model.md §7-8).

        Each row accumulates gamma^j (J + penalty) of its transitions exactly as the env scores them,
        stops once it reaches the goal, fails, or the episode reaches K_max, and, if it is still flying
        when the window ends before K_max, adds the terminal cost of its end pose discounted by gamma^H
        (model.md §7e: a :class:`~uav_penetration_env.terminal_kernels.TerminalCost` built by
        :func:`uav_penetration_env.terminal.terminal_cost`; the default, the ``none`` form,
        reproduces the env's summed costs).

        Args:
            state: (6,) the current exact state.
            controls: (B, H, 3) control sequences.
            step: k, transitions already made in the episode.
            discount: gamma in (0, 1].
            terminal_cost: the built terminal cost
                (``terminal.terminal_cost(model, Terminal(form, scale))``); never a bare number.
            scenario_index: pool index of the scenario flown.

        Returns:
            (B,) window costs.

        Raises:
            TypeError: arrays that are not numbers; a non-integer ``step`` or ``scenario_index``; a
                ``discount`` that is not a number; a ``terminal_cost`` that is not a ``TerminalCost``.
            ValueError: ``controls`` not (B, H, 3) with H >= 1, or ``state`` not (6,); a NaN or
                infinite entry; ``step`` outside [0, K_max]; ``discount`` outside (0, 1];
                a ``TerminalCost`` of an unknown kind, a negative scale or a malformed table;
                ``scenario_index`` outside the pool.
        """
        controls = _rollout_controls(controls)
        window = self._rollout_window(state, step, discount, terminal_cost, scenario_index)
        return self._rollout_cost(window[0], controls, *window[1:])

    def _rollout_window(
        self, state: FloatArray, step: int, discount: float, terminal_cost: TerminalCost, scenario_index: int
    ) -> tuple[np.ndarray, int, float, TerminalCost, int]:
        """:meth:`rollout_cost`'s arguments other than the controls, checked and converted."""
        state = checks.finite_array(state, "state", (6,), "a (6,) state of finite numbers")
        step = checks.integer_scalar(
            step, "step", 0, self.max_steps, f"an integer in [0, {self.max_steps}] (K_max)"
        )
        discount = checks.real_scalar(discount, "discount", 0.0, 1.0, "a number in (0, 1]", open_low=True)
        terminal_cost = self._terminal(terminal_cost)
        scenario_index = checks.integer_scalar(
            scenario_index, "scenario_index", 0, self.pool_size - 1, f"an integer in [0, {self.pool_size})"
        )
        return state, step, discount, terminal_cost, scenario_index

    def _terminal(self, terminal_cost: TerminalCost) -> TerminalCost:
        """``terminal_cost`` checked (:func:`terminal_kernels.checked_terminal`); anything but a TerminalCost is refused.

        DECISION (model.md §7e): a terminal cost is one built object, never a bare number. A number
        used to mean the ``distance`` form's c_T here while every planner defaulted to ``value``,
        so the same word named two things; now the form is always written down
        (``terminal_cost(model, Terminal("distance", 0.06))``).

        Raises:
            TypeError: ``terminal_cost: got 0.06, expected a TerminalCost (...)``, one line.
        """
        if not isinstance(terminal_cost, TerminalCost):
            raise TypeError(
                f"terminal_cost: got {terminal_cost!r}, expected a TerminalCost "
                "(uav_penetration_env.terminal.terminal_cost(model, Terminal(form, scale)))"
            )
        return terminal_kernels.checked_terminal(terminal_cost)

    def rollout_function(
        self,
        state: FloatArray,
        *,
        step: int,
        discount: float = 1.0,
        terminal_cost: TerminalCost = terminal_kernels.NO_TERMINAL_COST,
        scenario_index: int = 0,
    ) -> Callable[[FloatArray], FloatArray]:
        """:meth:`rollout_cost` from one window's state, as a function of the controls alone.

        A planner scores thousands of batches from one state: the state and the scalars are checked
        here once, and each call checks only its (B, H, 3) controls. The same numbers as
        :meth:`rollout_cost` (a subclass that redefines :meth:`rollout_cost` gets its own method
        with the arguments bound).

        Args:
            state: (6,) the window's exact state (copied).
            step: k, as :meth:`rollout_cost`.
            discount: gamma, as :meth:`rollout_cost`.
            terminal_cost: the built terminal cost, as :meth:`rollout_cost`.
            scenario_index: pool index, as :meth:`rollout_cost`.

        Returns:
            ``costs(controls) -> (B,)`` window costs.

        Raises:
            TypeError, ValueError: as :meth:`rollout_cost`, for the bound arguments here and for
                ``controls`` at each call.
        """
        if type(self).rollout_cost is not PenetrationModel.rollout_cost:
            return functools.partial(
                self.rollout_cost,
                state,
                step=step,
                discount=discount,
                terminal_cost=terminal_cost,
                scenario_index=scenario_index,
            )
        state, step, discount, terminal_cost, scenario_index = self._rollout_window(
            state, step, discount, terminal_cost, scenario_index
        )
        state = state.copy()  # bound: later changes to the caller's array must not move the window

        def costs(controls: FloatArray) -> FloatArray:
            return self._rollout_cost(
                state, _rollout_controls(controls), step, discount, terminal_cost, scenario_index
            )

        return costs

    def _rollout_cost(
        self,
        state: np.ndarray,
        controls: np.ndarray,
        step: int,
        discount: float,
        terminal_cost: TerminalCost,
        scenario_index: int,
    ) -> FloatArray:
        """:meth:`rollout_cost` on checked arguments (contiguous float64 arrays, Python scalars)."""
        total = np.empty(controls.shape[0])
        kernels.with_threads(
            self.threads,
            kernels.rollout_batch,
            self.arrays, state, controls, step, discount, terminal_cost, scenario_index, total,
        )  # fmt: skip
        return total

    # --- observation ------------------------------------------------------------------------------------

    def observe(
        self,
        states: FloatArray,
        step_index: IntArray | int,
        result: StepResult | None = None,
        scenario_index: IntArray | None = None,
    ) -> np.ndarray:
        """The 67-slot observation of model.md §7a for a batch, float32, clipped to +-10.

        Args:
            states: (B, 6) states.
            step_index: k, scalar or (B,).
            result: the transition that produced ``states`` (its per-radar threat and visibility are
                reused); ``None`` at reset, where they are evaluated for ``states``.
            scenario_index: (B,) pool index of each row.

        Returns:
            (B, 67) float32 observations.

        Raises:
            TypeError: ``states`` not numbers, a non-integer ``step_index`` or ``scenario_index``,
                or a ``result`` that is no :class:`StepResult`.
            ValueError: ``states`` not (B, 6) finite numbers; ``step_index`` outside [0, K_max];
                a ``result`` of another batch size or radar count; a bad ``scenario_index``.
        """
        states = self._batch(states, "states", 6)
        batch = states.shape[0]
        k = self._step_indices(step_index, batch, self.max_steps)
        index = self._rows(scenario_index, batch)
        if result is None:
            _, per_radar, visible, _, _ = self._state_threats(states, scenario_index)
        else:
            if not isinstance(result, StepResult):
                raise TypeError(f"result: got {type(result).__name__}, expected a StepResult or None")
            per_radar = np.ascontiguousarray(result.radar_threat_per_radar, dtype=np.float64)
            visible = np.ascontiguousarray(result.visibility, dtype=np.float64)
            if per_radar.shape != (batch, self.radar_slots) or visible.shape != per_radar.shape:
                raise ValueError(
                    f"result: got per-radar arrays of shape {per_radar.shape}, expected "
                    f"({batch}, {self.radar_slots}) (the transition that produced these states)"
                )
        fraction = k / float(self.max_steps)
        out = np.empty((batch, OBSERVATION_SIZE), dtype=np.float32)
        kernels.run_kernel(
            kernels.observe_batch,
            kernels.observe_rows,
            batch,
            self.arrays,
            states,
            fraction,
            index,
            per_radar,
            visible,
            TERRAIN_AHEAD_M,
            TERRAIN_ACROSS_M,
            np.empty((batch, kernels.observe_scratch_width(self.radar_slots))),
            out,
            threads=self.threads,
        )
        return out

    # --- the native vector env's hot path -------------------------------------------------------------

    def _step_observe_rows(
        self,
        states: np.ndarray,
        controls: np.ndarray,
        step_index: np.ndarray,
        index: np.ndarray,
        rows: np.ndarray,
        reset_rows: np.ndarray,
    ) -> tuple[StepResult, np.ndarray]:
        """One vector-env step in place in full-size arrays: ``rows`` step, ``reset_rows`` were just reset.

        The native vector env's hot path, on arguments the env holds: ``states`` (N, 6) float64,
        ``controls`` (N, 3) float64 already clipped to the action box, ``step_index`` (N,) int64 k
        before the step, ``index`` (N,) int64 pool indices, ``rows`` and ``reset_rows`` (int64)
        disjoint, together every row. The rows of ``rows`` are flown and observed in one compiled
        pass (:func:`kernels.step_observe_batch`): the same numbers, row for row, as ``step`` on
        them followed by ``observe(result.state, result.step_index, result)``. The rows of
        ``reset_rows`` (their states the reset states) read as :meth:`reset_result` at k = 0 and
        its observation (:func:`kernels.reset_observe_rows`), as the vector env reports an
        autoreset.

        Returns:
            A :class:`StepResult` and (N, 67) float32 observations, both N rows.

        Raises:
            ValueError: a row in ``rows`` at k >= K_max (no transition from the end of an episode).
        """
        n = states.shape[0]
        if len(rows) and int(step_index[rows].max()) >= self.max_steps:
            raise ValueError(
                f"step_index: got {int(step_index[rows].max())}, expected integers in "
                f"[0, {self.max_steps - 1}] (K_max = {self.max_steps})"
            )
        slots = self.radar_slots
        k_next = step_index + 1
        next_states = states.copy()
        per_radar = np.empty((n, slots))
        visible = np.empty((n, slots))
        scalars = np.empty((n, kernels.N_SCALARS))
        flags = np.empty((n, kernels.N_FLAGS), dtype=np.bool_)
        obs = np.empty((n, OBSERVATION_SIZE), dtype=np.float32)
        scratch = np.empty((n, kernels.observe_scratch_width(slots)))
        fraction = k_next / float(self.max_steps)
        kernels.run_kernel(
            kernels.step_observe_batch,
            kernels.step_observe_rows,
            len(rows),
            self.arrays, rows, states, controls, k_next, index, fraction,
            TERRAIN_AHEAD_M, TERRAIN_ACROSS_M, next_states, per_radar, visible, scalars, flags,
            scratch, obs,
            threads=self.threads,
        )  # fmt: skip
        if len(reset_rows):
            k_next[reset_rows] = 0
            fraction[reset_rows] = 0 / float(self.max_steps)
            kernels.reset_observe_rows(
                self.arrays, reset_rows, states, index, fraction, TERRAIN_AHEAD_M, TERRAIN_ACROSS_M,
                per_radar, visible, scalars, flags, scratch, obs,
            )  # fmt: skip
            distance = self.goal_distance(states[reset_rows], None if self.pool_size == 1 else index[reset_rows])
            scalars[reset_rows, kernels.S_GOAL_BEFORE] = distance
            scalars[reset_rows, kernels.S_GOAL_AFTER] = distance  # progress 0 as at a reset
        return self._step_result(next_states, k_next, per_radar, visible, scalars, flags), obs

    # --- a single env's hot path ------------------------------------------------------------------------

    def _env_step_one(self, state: np.ndarray, action: np.ndarray, step_index: int) -> SingleStep | None:
        """One env step from ``state`` (6,) with the float64 ``action`` (3,) at k = ``step_index``.

        The single env's hot path: the action check and clip, :meth:`step` and
        :meth:`observe` of one row in one compiled call (:func:`kernels.env_step_one`), on
        arguments the env has already checked. The same numbers as the public methods.

        Returns:
            The raw outputs, or ``None`` when the action holds a NaN or infinite entry.
        """
        slots = self.radar_slots
        next_states = np.empty((1, 6))
        per_radar = np.empty((1, slots))
        visible = np.empty((1, slots))
        scalars = np.empty((1, kernels.N_SCALARS))
        flags = np.empty((1, kernels.N_FLAGS), dtype=np.bool_)
        obs = np.empty((1, OBSERVATION_SIZE), dtype=np.float32)
        ok = kernels.env_step_one(
            self.arrays,
            action,
            self._action_high,
            state.reshape(1, 6),
            step_index,
            _ROW_ZERO,
            next_states,
            per_radar,
            visible,
            scalars,
            flags,
            obs,
        )
        if not ok:
            return None
        return SingleStep(next_states[0], per_radar[0], scalars[0].tolist(), flags[0].tolist(), obs[0])

    def _env_reset_one(self, state: np.ndarray, step_index: int) -> SingleReset:
        """The reset quantities and observation of ``state`` (6,) at k = ``step_index`` (one compiled call).

        The single env's hot path for :meth:`reset_result` plus :meth:`observe`: the
        same numbers (the goal distance with ``np.hypot``, as :meth:`goal_distance`).
        """
        per_radar = np.empty((1, self.radar_slots))
        visible = np.empty((1, self.radar_slots))
        obs = np.empty((1, OBSERVATION_SIZE), dtype=np.float32)
        terrain, radar, detection, altitude_agl = kernels.env_reset_one(
            self.arrays, state.reshape(1, 6), step_index, _ROW_ZERO, per_radar, visible, obs
        )
        goal = self.goal[0]
        distance = float(np.hypot(goal[0] - state[0], goal[1] - state[1]))
        return SingleReset(terrain, radar, per_radar[0], detection, altitude_agl, distance, obs[0])


def model_constants(
    scenario: Scenario, grid: GridSpec, limits: UAVLimits, fuel: FuelParams, normalisation: Normalisation
) -> tuple[ModelConstants, ModelOptions]:
    """The kernels' named constants and options of ``scenario`` (with its grid and derived parameters).

    The one place a scenario's settings become the numbers the kernels read: the model keeps the
    result and packs it (:func:`kernels.pack`); its constant properties read it by name.
    """
    radar = scenario.radar_model
    x_min, x_max = (value * 1000.0 for value in scenario.map.x_km)
    y_min, y_max = (value * 1000.0 for value in scenario.map.y_km)
    fade = scenario.terrain.threat_altitude_scale_m
    w_terrain, w_radar, w_third = scenario.cost.weights
    constants = ModelConstants(
        dt=limits.dt,
        speed_min=limits.speed_min,
        speed_max=limits.speed_max,
        dv_max=limits.dv_max,
        dheading_max=limits.dheading_max,
        dpitch_max=limits.dpitch_max,
        pitch_max=limits.pitch_max,
        grid_x0=grid.x0_m,
        grid_y0=grid.y0_m,
        grid_dx=grid.dx_m,
        clearance=scenario.uav.min_clearance_m,
        x_min=x_min,
        x_max=x_max,
        y_min=y_min,
        y_max=y_max,
        ceiling=scenario.map.ceiling_m,
        mountain_decay=scenario.terrain.mountain_decay_per_km2,
        threat_altitude_scale=1.0 if fade is None else fade,
        min_range=radar.min_range_m,
        horizon_scale=math.sqrt(2.0 * (radar.effective_earth_radius_km * 1000.0)),
        softness=radar.masking_softness_m,
        log_false_alarm=math.log(radar.false_alarm_prob),
        snr_ref=reference_snr(radar.false_alarm_prob, radar.reference_detection_prob),
        tsfc=fuel.tsfc,
        weight=fuel.weight_n,
        level_thrust=fuel.level_thrust_n,
        idle_thrust=fuel.idle_thrust_n,
        max_thrust=fuel.max_thrust_n,
        potential_per_m=fuel.potential_per_m,
        terrain_lo=normalisation.terrain[0],
        terrain_hi=normalisation.terrain[1],
        radar_lo=normalisation.radar[0],
        radar_hi=normalisation.radar[1],
        third_lo=normalisation.third[0],
        third_hi=normalisation.third[1],
        w_terrain=w_terrain,
        w_radar=w_radar,
        w_third=w_third,
        crash_per_step=scenario.crash_penalty_per_step,
        max_step_length=limits.max_step_length,
        map_side=max(x_max - x_min, y_max - y_min),
    )
    options = ModelOptions(
        detection=kernels.DETECTION[scenario.detection],
        masking=kernels.MASKING[scenario.masking],
        fusion=kernels.FUSION[radar.fusion],
        third=kernels.THIRD_TERM[scenario.cost.third_term],
        altitude_fade=int(fade is not None),
        max_steps=scenario.time.max_steps,
    )
    return constants, options


def _rollout_controls(controls: FloatArray) -> np.ndarray:
    """``controls`` as a contiguous float64 (B, H, 3) batch of finite numbers with H >= 1 (rollout_cost)."""
    controls = checks.finite_array(
        controls, "controls", (None, None, 3), "a (B, H, 3) array of finite controls"
    )
    if controls.shape[1] == 0:
        raise ValueError("controls: got shape (B, 0, 3), expected a horizon H >= 1")
    return controls


_ROW_ZERO = np.zeros(1, dtype=np.int64)  # pool index of a single env's one row (a one-scenario model)


class SingleStep(NamedTuple):
    """Raw outputs of :meth:`PenetrationModel._env_step_one` (one row; lists indexed by ``kernels.S_*`` / ``F_*``)."""

    state: FloatArray  # (6,) the next state
    radar_threat_per_radar: FloatArray  # (M,)
    scalars: list[float]  # kernels.N_SCALARS values
    flags: list[bool]  # kernels.N_FLAGS values
    observation: np.ndarray  # (67,) float32


class SingleReset(NamedTuple):
    """Outputs of :meth:`PenetrationModel._env_reset_one`: the state-only quantities of one state."""

    terrain_threat: float
    radar_threat: float
    radar_threat_per_radar: FloatArray  # (M,)
    detection_prob: float
    altitude_agl: float
    goal_distance: float  # [m]
    observation: np.ndarray  # (67,) float32
