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
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from uav_penetration_env import rcs
from uav_penetration_env.build import BuiltScenario, build_scenario
from uav_penetration_env.cost import (
    FuelParams,
    Normalisation,
    failure_penalty,
    fuel_burned,
    normalise,
    terminal_cost_to_go,
    third_term,
    weighted_cost,
)
from uav_penetration_env.kinematics import HEADING, PITCH, SPEED, UAVLimits, step_kinematics, wrap_angle
from uav_penetration_env.radar import (
    detection_ratio,
    fuse,
    horizon_range,
    reference_snr,
    swerling1_detection_probability,
    visibility_probability,
)
from uav_penetration_env.scenario import Scenario, ScenarioError
from uav_penetration_env.terrain import bilinear, terrain_threat
from uav_penetration_env.types import BoolArray, FloatArray, IntArray

OBSERVATION_SIZE = 67
OBSERVATION_LIMIT = 10.0
OBSERVED_RADARS = 4
RADAR_FEATURES = 7
FAR_RANGE_RATIO = 5.0  # observed R / R_ref is capped here; a missing radar reads as this far
TERRAIN_AHEAD_M = np.array([0.0, 1500.0, 3000.0, 4500.0, 6000.0])
TERRAIN_ACROSS_M = np.array([-3000.0, -1500.0, 0.0, 1500.0, 3000.0])

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


class PenetrationModel:
    """The batched physics and cost model of one scenario or of a compatible pool of scenarios.

    Args:
        scenarios: a :class:`Scenario`, a :class:`BuiltScenario`, or a sequence of them (a pool).
        radar_slots: pad the radar axis to this many slots (default: the pool's largest count).
    """

    def __init__(
        self,
        scenarios: Scenario | BuiltScenario | Sequence[Scenario | BuiltScenario],
        *,
        radar_slots: int | None = None,
    ) -> None:
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
        self.fuel = FuelParams.from_scenario(first)
        self.normalisation = Normalisation.from_scenario(first, self.fuel)
        self.weights = first.cost.weights
        self.detection = first.detection
        self.masking = first.masking
        if self.detection == "ratio" and first.radar_model.fusion == "or":
            raise ScenarioError(
                "radar_model.fusion", "or", "'max' with the ratio detection (D is not a probability)"
            )
        self.max_steps = first.time.max_steps
        self.crash_penalty_per_step = first.crash_penalty_per_step
        model = first.radar_model
        self.earth_radius = model.effective_earth_radius_km * 1000.0
        self.snr_ref = reference_snr(model.false_alarm_prob, model.reference_detection_prob)
        self.ceiling = first.map.ceiling_m
        self.bounds = (
            np.array([first.map.x_km[0], first.map.x_km[1], first.map.y_km[0], first.map.y_km[1]]) * 1000.0
        )
        self.map_side = max(self.bounds[1] - self.bounds[0], self.bounds[3] - self.bounds[2])
        self.clearance = first.uav.min_clearance_m
        self.rcs_table = built[0].rcs_table
        self.threat_altitude_scale = first.terrain.threat_altitude_scale_m
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
        floors = []
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
        self._decay = self.scenario.terrain.mountain_decay_per_km2
        for b in built[1:]:
            if b.scenario.terrain.mountain_decay_per_km2 != self._decay:
                raise ScenarioError(
                    "pool.terrain.mountain_decay_per_km2",
                    b.scenario.terrain.mountain_decay_per_km2,
                    f"{self._decay}",
                )

    def _pick(self, array: np.ndarray, index: IntArray | None) -> np.ndarray:
        """Pool parameters for each batch row: ``array[index]``, or the one scenario broadcast."""
        if index is None:
            if self.pool_size != 1:
                raise ValueError("scenario_index: required for a model with a pool of scenarios")
            return array[0][None]
        return array[index]

    def _layer(self, index: IntArray | None) -> IntArray | int:
        return 0 if index is None else index

    # --- queries --------------------------------------------------------------------------------

    def height(self, x_m: FloatArray, y_m: FloatArray, scenario_index: IntArray | None = None) -> FloatArray:
        """Terrain height [m] at points [m] (bilinear, edge values outside the grid)."""
        fi, fj = self.grid.fractional_index(x_m, y_m)
        return bilinear(self.terrain, fi, fj, self._layer(scenario_index))

    def initial_state(self, rng: np.random.Generator | None = None, scenario_index: int = 0) -> FloatArray:
        """The scenario's start state (6,), with the start jitter drawn from ``rng`` when configured."""
        return self.initial_states([rng], [scenario_index])[0]

    def initial_states(
        self, rngs: Sequence[np.random.Generator | None], scenario_index: Sequence[int]
    ) -> FloatArray:
        """Start states (n, 6) for several episodes, each drawing its jitter from its own generator."""
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
        goal = self._pick(self.goal, scenario_index)
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
        states = np.asarray(states, dtype=np.float64)
        batch = len(states)
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
        _, per_radar, _, _ = self.state_threats(np.asarray(states, dtype=np.float64), scenario_index)
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
        """
        states = np.asarray(states, dtype=np.float64)
        next_states = step_kinematics(states, np.asarray(controls, dtype=np.float64), self.limits)
        k_next = np.broadcast_to(np.asarray(step_index, dtype=np.int64) + 1, states.shape[:1])
        return self._evaluate(states, next_states, k_next, scenario_index)

    def costs(
        self,
        states: FloatArray,
        next_states: FloatArray,
        step_index: IntArray | int,
        scenario_index: IntArray | None = None,
    ) -> StepResult:
        """Score a given transition ``states -> next_states`` taken at step k (no kinematics)."""
        states = np.asarray(states, dtype=np.float64)
        k_next = np.broadcast_to(np.asarray(step_index, dtype=np.int64) + 1, states.shape[:1])
        return self._evaluate(states, np.asarray(next_states, dtype=np.float64), k_next, scenario_index)

    def _evaluate(
        self, states: FloatArray, next_states: FloatArray, k_next: IntArray, index: IntArray | None
    ) -> StepResult:
        goal = self._pick(self.goal, index)
        layer = self._layer(index)

        # Events along the segment, in flight order (model.md §7a).
        start_xyz, end_xyz = states[:, :3], next_states[:, :3]
        delta = end_xyz - start_xyz
        samples = start_xyz[:, None, :] + self._sample_t[None, :, None] * delta[:, None, :]
        fi, fj = self.grid.fractional_index(samples[..., 0], samples[..., 1])
        ground = bilinear(self.terrain, fi, fj, layer if index is None else index[:, None])
        below = samples[..., 2] < ground + self.clearance
        hit = below.any(axis=1)
        first_hit_t = np.where(hit, self._sample_t[np.argmax(below, axis=1)], np.inf)
        to_goal = goal[:, :2] - start_xyz[:, :2]
        travel = delta[:, :2]
        travel_sq = np.einsum("bi,bi->b", travel, travel)
        closest_t = np.clip(np.einsum("bi,bi->b", to_goal, travel) / np.maximum(travel_sq, 1e-12), 0.0, 1.0)
        miss = to_goal - closest_t[:, None] * travel
        reaches = np.einsum("bi,bi->b", miss, miss) <= goal[:, 2] ** 2
        reached_goal = reaches & (closest_t < first_hit_t)
        collided = hit & ~reached_goal
        x, y, z = next_states[:, 0], next_states[:, 1], next_states[:, 2]
        outside = (
            (x < self.bounds[0])
            | (x > self.bounds[1])
            | (y < self.bounds[2])
            | (y > self.bounds[3])
            | (z > self.ceiling)
        )
        out_of_area = outside & ~reached_goal & ~collided
        terminated = reached_goal | collided | out_of_area
        truncated = (k_next >= self.max_steps) & ~terminated

        altitude_agl = z - ground[:, -1]
        threat_e, per_radar, visibility, detection = self.state_threats(next_states, index, altitude_agl)
        threat_r = fuse(per_radar, self.scenario.radar_model.fusion)

        # Third term: fuel plus potential-based progress (model.md §6).
        fuel = fuel_burned(next_states[:, PITCH], self.fuel)
        before = np.hypot(to_goal[:, 0], to_goal[:, 1])
        after = np.hypot(goal[:, 0] - x, goal[:, 1] - y)
        step_length = next_states[:, SPEED] * self.limits.dt
        third = third_term(self.scenario.cost.third_term, fuel, step_length, before, after, self.fuel)

        norm = self.normalisation
        terrain_n = normalise(threat_e, norm.terrain)
        radar_n = normalise(threat_r, norm.radar)
        third_n = normalise(third, norm.third)
        cost = weighted_cost(terrain_n, radar_n, third_n, self.weights)
        penalty = failure_penalty(collided | out_of_area, k_next, self.max_steps, self.crash_penalty_per_step)
        return StepResult(
            state=next_states,
            step_index=k_next,
            J=cost,
            penalty=penalty,
            terrain_threat=threat_e,
            radar_threat=threat_r,
            third_term=third,
            terrain_threat_n=terrain_n,
            radar_threat_n=radar_n,
            third_term_n=third_n,
            fuel_kg=fuel,
            progress_km=(before - after) / 1000.0,
            radar_threat_per_radar=per_radar,
            visibility=visibility,
            detection_prob=detection,
            altitude_agl=altitude_agl,
            goal_distance=after,
            reached_goal=reached_goal,
            collided=collided,
            out_of_area=out_of_area,
            terminated=terminated,
            truncated=truncated,
        )

    def state_threats(
        self, states: FloatArray, index: IntArray | None = None, altitude_agl: FloatArray | None = None
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Threats that depend on the state alone: Th_e, per-radar threat, visibility, detection prob.

        Args:
            states: (B, 6) states.
            index: (B,) pool index of each row.
            altitude_agl: (B,) height above the terrain when already known (saves a lookup).

        Returns:
            terrain threat (B,), per-radar threat (B, M), visibility (B, M), detection probability (B,).
        """
        x, y = states[:, 0], states[:, 1]
        # Terrain threat (eq. 6), optionally fading with height above the terrain (model.md §3).
        centres = self._pick(self.mountain_centres, index)
        present = self._pick(self.mountain_present, index)
        threat_e = terrain_threat(x / 1000.0, y / 1000.0, centres, self._decay, present)
        if self.threat_altitude_scale is not None:
            if altitude_agl is None:
                altitude_agl = states[:, 2] - self.height(x, y, index)
            threat_e = threat_e * np.exp(-np.maximum(altitude_agl, 0.0) / self.threat_altitude_scale)
        per_radar, visibility, detection = self._radar(states, index)
        return threat_e, per_radar, visibility, detection

    def _radar(self, states: FloatArray, index: IntArray | None) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Per-radar threat (D or P_d), visibility and the network detection probability (model.md §4-5)."""
        radars = self._pick(self.radar_xyz, index)  # (B, M, 3)
        present = self._pick(self.radar_present, index)
        position = states[:, None, :3]
        offset = radars - position
        distance = np.sqrt(np.einsum("bmi,bmi->bm", offset, offset))
        distance = np.maximum(distance, self.scenario.radar_model.min_range_m)
        direction = offset / distance[..., None]
        az, el = rcs.aspect_angles(direction, states[:, HEADING], states[:, PITCH])
        sigma = rcs.rcs_lookup(self.rcs_table, az, el)
        ratio = detection_ratio(
            sigma, self._pick(self.ref_rcs, index), self._pick(self.ref_range, index), distance
        )
        z = states[:, 2:3]
        if self.masking == "off":
            visible = (distance <= horizon_range(radars[..., 2], z, self.earth_radius)).astype(np.float64)
        else:
            fi, fj = self.grid.fractional_index(states[:, 0], states[:, 1])
            layers = self._pick(self.floor_layer, index)
            floor = bilinear(self.floors, fi[:, None], fj[:, None], layers)
            softness = self.scenario.radar_model.masking_softness_m if self.masking == "soft" else 0.0
            visible = visibility_probability(z, floor, softness)
        visible = visible * present
        if self.detection == "ratio":
            # Eqs. 11/13 (A19): D counts iff D >= 1 inside the horizon and, with masking on, in sight.
            gate = (
                (ratio >= 1.0)
                & (distance <= horizon_range(radars[..., 2], z, self.earth_radius))
                & (visible >= 0.5)
            )
            per_radar = np.where(gate, ratio, 0.0)
            detection = np.any(gate, axis=1).astype(np.float64)
        else:
            per_radar = visible * swerling1_detection_probability(
                ratio, self.scenario.radar_model.false_alarm_prob, self.snr_ref
            )
            detection = per_radar.max(axis=1) if per_radar.shape[1] else np.zeros(len(states))
        return per_radar, visible, detection

    # --- planning -----------------------------------------------------------------------------------

    def rollout_cost(
        self,
        state: FloatArray,
        controls: FloatArray,
        *,
        step: int,
        discount: float = 1.0,
        terminal_cost: float = 0.0,
        scenario_index: int = 0,
    ) -> FloatArray:
        """Discounted window cost J^(H) of control sequences flown from one state (eq. 37, model.md §7-8).

        Each row accumulates gamma^j (J + penalty) of its transitions exactly as the env scores them,
        stops once it reaches the goal, fails, or the episode reaches K_max, and, if it is still flying
        when the window ends before K_max, adds ``terminal_cost * d_goal / (v_max dt)`` discounted by
        gamma^H (DECISION, model.md §7: MPC's cost-to-go; 0 reproduces the env's summed costs).

        Args:
            state: (6,) the current exact state.
            controls: (B, H, 3) control sequences.
            step: k, transitions already made in the episode.
            discount: gamma in (0, 1].
            terminal_cost: c_T >= 0 per remaining full-speed step.
            scenario_index: pool index of the scenario flown.

        Returns:
            (B,) window costs.
        """
        controls = np.asarray(controls, dtype=np.float64)
        if controls.ndim != 3 or controls.shape[2] != 3:
            raise ValueError(f"controls: got shape {controls.shape}, expected (B, H, 3)")
        state = np.asarray(state, dtype=np.float64)
        if state.shape != (6,):
            raise ValueError(f"state: got shape {state.shape}, expected (6,)")
        batch, horizon = controls.shape[:2]
        index = None if self.pool_size == 1 else np.full(batch, scenario_index)
        states = np.broadcast_to(state, (batch, 6))
        total = np.zeros(batch)
        flying = np.ones(batch, dtype=bool)
        steps = max(0, min(horizon, self.max_steps - step))
        weight = 1.0
        for j in range(steps):
            result = self.step(states, controls[:, j], step + j, index)
            total += np.where(flying, weight * (result.J + result.penalty), 0.0)
            flying &= ~result.terminated
            states = result.state
            weight *= discount
        if terminal_cost > 0.0 and step + horizon < self.max_steps:
            to_go = terminal_cost_to_go(
                self.goal_distance(states, index), self.limits.max_step_length, terminal_cost
            )
            total += np.where(flying, weight * to_go, 0.0)
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
        """
        states = np.asarray(states, dtype=np.float64)
        batch = states.shape[0]
        x, y, z = states[:, 0], states[:, 1], states[:, 2]
        speed, heading, pitch = states[:, SPEED], states[:, HEADING], states[:, PITCH]
        cos_h, sin_h = np.cos(heading), np.sin(heading)
        limits = self.limits
        index = scenario_index
        layer = self._layer(index)
        obs = np.zeros((batch, OBSERVATION_SIZE))

        ground = self.height(x, y, index)
        obs[:, 0] = (x - self.bounds[0]) / (self.bounds[1] - self.bounds[0])
        obs[:, 1] = (y - self.bounds[2]) / (self.bounds[3] - self.bounds[2])
        obs[:, 2] = (z - ground) / 1000.0
        obs[:, 3] = z / self.ceiling
        obs[:, 4] = (speed - limits.speed_min) / (limits.speed_max - limits.speed_min)
        obs[:, 5], obs[:, 6] = cos_h, sin_h
        obs[:, 7] = pitch / limits.pitch_max

        goal = self._pick(self.goal, index)
        gx, gy = goal[:, 0] - x, goal[:, 1] - y
        obs[:, 8] = gx / self.map_side
        obs[:, 9] = gy / self.map_side
        obs[:, 10] = np.hypot(gx, gy) / self.map_side
        relative = np.arctan2(gy, gx) - heading
        obs[:, 11], obs[:, 12] = np.cos(relative), np.sin(relative)

        # Terrain ahead: 5 x 5 samples on a heading-aligned grid (ahead-major, across = to the left).
        ahead = TERRAIN_AHEAD_M[:, None]
        across = TERRAIN_ACROSS_M[None, :]
        px = x[:, None, None] + ahead * cos_h[:, None, None] - across * sin_h[:, None, None]
        py = y[:, None, None] + ahead * sin_h[:, None, None] + across * cos_h[:, None, None]
        fi, fj = self.grid.fractional_index(px, py)
        sample_layer = layer if index is None else index[:, None, None]
        obs[:, 13:38] = ((bilinear(self.terrain, fi, fj, sample_layer) - z[:, None, None]) / 1000.0).reshape(
            batch, 25
        )

        if result is None:
            threat, visibility, _ = self._radar(states, index)
        else:
            threat, visibility = result.radar_threat_per_radar, result.visibility
        if self.detection == "ratio":
            threat = np.minimum(threat, 1.0)
        slots = self.radar_slots
        radars = np.broadcast_to(self._pick(self.radar_xyz, index), (batch, slots, 3))
        present = np.broadcast_to(self._pick(self.radar_present, index), (batch, slots))
        offset = radars - states[:, None, :3]
        distance = np.sqrt(np.einsum("bmi,bmi->bm", offset, offset))
        order = np.argsort(np.where(present > 0, distance, np.inf), axis=1, kind="stable")[
            :, :OBSERVED_RADARS
        ]
        rows = np.arange(batch)[:, None]
        features = np.zeros((batch, OBSERVED_RADARS, RADAR_FEATURES))
        features[..., 1] = FAR_RANGE_RATIO
        taken = order.shape[1]
        sel_present = present[rows, order]
        bearing = np.arctan2(offset[rows, order, 1], offset[rows, order, 0]) - heading[:, None]
        ref_range = np.broadcast_to(self._pick(self.ref_range, index), (batch, slots))[rows, order]
        values = np.stack(
            (
                sel_present,
                np.minimum(distance[rows, order] / ref_range, FAR_RANGE_RATIO),
                np.cos(bearing),
                np.sin(bearing),
                (radars[rows, order, 2] - z[:, None]) / 1000.0,
                visibility[rows, order],
                threat[rows, order],
            ),
            axis=-1,
        )
        features[:, :taken] = np.where(sel_present[..., None] > 0, values, features[:, :taken])
        obs[:, 38:66] = features.reshape(batch, OBSERVED_RADARS * RADAR_FEATURES)
        obs[:, 66] = np.asarray(step_index) / self.max_steps
        return np.clip(obs, -OBSERVATION_LIMIT, OBSERVATION_LIMIT).astype(np.float32)
