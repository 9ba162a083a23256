"""The penetration model's numpy formulation: a test oracle for the compiled kernels.

This is the batched numpy physics the model ran before it was compiled (STYLE.md §2b): it lives
only under tests/, never as a runtime path. :class:`NumpyPenetrationModel` subclasses
:class:`PenetrationModel` for its pool arrays and constants and overrides every physics method
with the array formulation, so a parity test can call the same method on both.
"""

from __future__ import annotations

import math

import numpy as np

from uav_penetration_env import observation as layout
from uav_penetration_env import rcs, terminal_kernels
from uav_penetration_env.cost import FuelParams
from uav_penetration_env.kinematics import HEADING, PITCH, SPEED, UAVLimits, X, Y, Z
from uav_penetration_env.model import FAR_RANGE_RATIO, PenetrationModel, StepResult
from uav_penetration_env.observation import (
    OBSERVATION_LIMIT,
    OBSERVATION_SIZE,
    OBSERVED_RADARS,
    RADAR_FEATURES,
    SLOTS,
    TERRAIN_ACROSS_M,
    TERRAIN_AHEAD_M,
)
from uav_penetration_env.terminal_kernels import TerminalCost
from uav_penetration_env.terrain import GridSpec, bilinear, mountain_shape
from uav_penetration_env.types import FloatArray, IntArray

# --- the physics as numpy functions over batches (moved here from the runtime modules) ------------

# kinematics.py


def wrap_angle(angle: FloatArray) -> FloatArray:
    """Wrap angles to (-pi, pi]."""
    wrapped = np.mod(angle + np.pi, 2.0 * np.pi) - np.pi  # [-pi, pi)
    return np.where(wrapped <= -np.pi, wrapped + 2.0 * np.pi, wrapped)


def clip_action(control: FloatArray, limits: UAVLimits) -> FloatArray:
    """Clip controls (..., 3) to the per-step action box."""
    high = limits.action_high
    return np.clip(control, -high, high)


def step_kinematics(state: FloatArray, control: FloatArray, limits: UAVLimits) -> FloatArray:
    """Advance UAV states one step, action-then-move (model.md §1, DECISION A2).

    The control first updates speed, heading and pitch; the UAV then flies the whole step with
    the updated values, so every input affects the very next track point.

    Args:
        state: (..., 6) [x, y, z, v, phi, theta] in m, m, m, m/s, rad, rad.
        control: (..., 3) [dv, dphi, dtheta] in m/s, rad, rad; clipped to ``limits``.
        limits: flight envelope and step limits.

    Returns:
        (..., 6) next states.
    """
    control = clip_action(control, limits)
    speed = np.clip(state[..., SPEED] + control[..., 0], limits.speed_min, limits.speed_max)
    heading = wrap_angle(state[..., HEADING] + control[..., 1])
    pitch = np.clip(state[..., PITCH] + control[..., 2], -limits.pitch_max, limits.pitch_max)
    step = speed * limits.dt
    horizontal = step * np.cos(pitch)
    return np.stack(
        (
            state[..., X] + horizontal * np.cos(heading),
            state[..., Y] + horizontal * np.sin(heading),
            state[..., Z] + step * np.sin(pitch),
            speed,
            heading,
            pitch,
        ),
        axis=-1,
    )


# terrain.py


def terrain_threat(
    x_km: FloatArray,
    y_km: FloatArray,
    centres_km: FloatArray,
    decay_per_km2: float,
    present: FloatArray | None = None,
) -> FloatArray:
    """Th_e(k) = max_i f_i(x_k, y_k) in [0, 1] (eq. 6, index typo fixed; model.md §3).

    Args:
        x_km: (...) UAV x [km].
        y_km: (...) UAV y [km].
        centres_km: (..., I, 2) peak centres [km].
        decay_per_km2: lambda [km^-2].
        present: optional (..., I) 1/0 mask for padded peak lists.

    Returns:
        (...) threat in [0, 1]; 0 with no peaks.
    """
    if centres_km.shape[-2] == 0:
        return np.zeros(np.broadcast(np.asarray(x_km), np.asarray(y_km)).shape)
    shape = mountain_shape(x_km, y_km, centres_km, decay_per_km2)
    if present is not None:
        shape = shape * present
    return np.max(shape, axis=-1)


# radar.py


def detection_ratio(
    rcs_m2: FloatArray, ref_rcs_m2: FloatArray, ref_range_m: FloatArray, range_m: FloatArray
) -> FloatArray:
    """D = P_r / S = (sigma / sigma_ref) (R_ref / R)^4 (model.md §4.2): 1 for sigma_ref at R_ref."""
    ratio = ref_range_m / range_m
    ratio = ratio * ratio
    return (rcs_m2 / ref_rcs_m2) * (ratio * ratio)


def swerling1_detection_probability(ratio: FloatArray, false_alarm_prob: float, snr_ref: float) -> FloatArray:
    """Single-look Swerling-I, square-law P_d = P_fa^(1 / (1 + SNR)) with SNR = SNR_ref D (model.md §4.6).

    Computed as exp(ln P_fa / (1 + SNR)) so the huge D near a radar stays finite.
    """
    return np.exp(math.log(false_alarm_prob) / (1.0 + snr_ref * ratio))


def horizon_range(radar_alt_m: FloatArray, target_alt_m: FloatArray, earth_radius_m: float) -> FloatArray:
    """Radar horizon R_lim = sqrt(2 R_eff) (sqrt(z_m) + sqrt(max(z, 0))) [m] (eq. 12).

    With R_eff = 8487.2 km, sqrt(2 R_eff * 1 m) = 4.12 km, the paper's constant (model.md §4.3).
    """
    scale = math.sqrt(2.0 * earth_radius_m)
    return scale * (np.sqrt(np.maximum(radar_alt_m, 0.0)) + np.sqrt(np.maximum(target_alt_m, 0.0)))


def visibility_probability(altitude_m: FloatArray, floor_m: FloatArray, softness_m: float) -> FloatArray:
    """P_vis = 1 / (1 + exp(-(z - V) / s)) (model.md §4.4); ``softness_m = 0`` is the hard step z >= V."""
    if softness_m <= 0.0:
        return (altitude_m >= floor_m).astype(np.float64)
    # tanh form of the logistic: no overflow for any margin.
    return 0.5 + 0.5 * np.tanh((altitude_m - floor_m) / (2.0 * softness_m))


def fuse(per_radar: FloatArray, rule: str) -> FloatArray:
    """Network threat over the last axis: ``max`` (eq. 14) or ``or`` = 1 - prod(1 - P_d)."""
    if per_radar.shape[-1] == 0:
        return np.zeros(per_radar.shape[:-1])
    if rule == "or":
        return 1.0 - np.prod(1.0 - per_radar, axis=-1)
    return np.max(per_radar, axis=-1)


# cost.py


def thrust(pitch: FloatArray, params: FuelParams) -> FloatArray:
    """Steady-flight thrust T = W (1/E + sin theta) clipped to [T_idle, T_max] [N] (model.md §6.1).

    theta > 0 is eq. 17's ascent state, theta = 0 level flight and theta < 0 descent down to idle.
    """
    raw = params.level_thrust_n + params.weight_n * np.sin(pitch)
    return np.clip(raw, params.idle_thrust_n, params.max_thrust_n)


def fuel_burned(pitch: FloatArray, params: FuelParams) -> FloatArray:
    """Fuel for one step, C_fuel = eta T dt [kg]."""
    return params.tsfc * params.dt * thrust(pitch, params)


def third_term(
    third: str,
    fuel_kg: FloatArray,
    step_length_m: FloatArray,
    goal_distance_before_m: FloatArray,
    goal_distance_after_m: FloatArray,
    params: FuelParams,
) -> FloatArray:
    """The third objective C(k) with its progress (cost-to-go) shaping (model.md §6.2, A22/A24).

    ``fuel``: C = C_fuel + G(p_{k+1}) - G(p_k) with G = eta T_level d_goal / v_max, so straight level
    flight at v_max toward the goal costs 0. ``length``: C = s + d_goal(p_{k+1}) - d_goal(p_k) >= 0.
    Either way the sum over an episode telescopes: shaping never changes which complete
    trajectory is cheaper among those ending at the same distance from the goal.
    """
    change = goal_distance_after_m - goal_distance_before_m
    if third == "length":
        return step_length_m + change
    return fuel_kg + params.potential_per_m * change


def normalise(value: FloatArray, bounds: tuple[float, float]) -> FloatArray:
    """(x - lo) / (hi - lo)."""
    low, high = bounds
    return (value - low) / (high - low)


def weighted_cost(
    terrain_n: FloatArray, radar_n: FloatArray, third_n: FloatArray, weights: tuple[float, float, float]
) -> FloatArray:
    """J(k) = w_e Th_e^n + w_r Th_r^n + w_C C^n (eq. 19)."""
    return weights[0] * terrain_n + weights[1] * radar_n + weights[2] * third_n


def failure_penalty(
    failed: FloatArray, step_index: FloatArray, max_steps: int, per_step: float
) -> FloatArray:
    """Penalty for ending the episode by failure at step k: per_step (K_max - k + 1) (model.md §7a).

    DECISION: charging every remaining step (the + 1 counts the failing step itself) makes an early
    crash never cheaper than flying on, since J(k) <= per_step in the benchmark profile.
    """
    remaining = np.maximum(max_steps - np.asarray(step_index) + 1, 0)
    return np.where(failed, per_step * remaining, 0.0)


def terminal_cost_to_go(goal_distance_m: FloatArray, step_length_m: float, per_step: float) -> FloatArray:
    """MPC cost-to-go: c_T d_goal / (v_max dt), the remaining steps at full speed (model.md §7)."""
    return per_step * goal_distance_m / step_length_m


# radar.py: the visibility floor by the spec's literal per-node ray sampling (a test oracle only)


def visibility_floor_exact(
    heights: FloatArray, grid: GridSpec, radar_xyz: tuple[float, float, float], earth_radius_m: float
) -> FloatArray:
    """Per-node ray sampling of the visibility floor: the spec's literal method (slow; a test oracle).

    Each node T at distance d gets ``S = ceil(d / (dx / 2))`` and samples ``t_j = j / S``,
    ``j = 1..S-1``, along its own ray (model.md §4.4).
    """
    xr, yr, zr = radar_xyz
    two_r = 2.0 * earth_radius_m
    floor = heights.copy()
    gx, gy = grid.mesh()
    for i in range(grid.nx):
        for j in range(grid.ny):
            d = math.hypot(gx[i, j] - xr, gy[i, j] - yr)
            samples = math.ceil(d / (0.5 * grid.dx_m))
            if samples < 2:
                continue
            t = np.arange(1, samples) / samples
            sx, sy = xr + t * (gx[i, j] - xr), yr + t * (gy[i, j] - yr)
            fi, fj = grid.fractional_index(sx, sy)
            s = t * d
            slope = np.max((bilinear(heights, fi, fj) - s * s / two_r - zr) / s)
            floor[i, j] = max(heights[i, j], zr + d * slope + d * d / two_r)
    return floor


class NumpyPenetrationModel(PenetrationModel):
    """:class:`PenetrationModel` with its physics evaluated by numpy array operations (the oracle)."""

    def _pick(self, array: np.ndarray, index: IntArray | None) -> np.ndarray:
        if index is None:
            if self.pool_size != 1:
                raise ValueError("scenario_index: required for a model with a pool of scenarios")
            return array[0][None]
        return array[index]

    def _layer(self, index: IntArray | None) -> IntArray | int:
        return 0 if index is None else index

    def height(self, x_m: FloatArray, y_m: FloatArray, scenario_index: IntArray | None = None) -> FloatArray:
        """Terrain height [m] at points [m] (bilinear, edge values outside the grid)."""
        fi, fj = self.grid.fractional_index(x_m, y_m)
        return bilinear(self.terrain, fi, fj, self._layer(scenario_index))

    def goal_distance(self, states: FloatArray, scenario_index: IntArray | None = None) -> FloatArray:
        """Horizontal distance to the goal [m]."""
        goal = self._pick(self.goal, scenario_index)
        return np.hypot(goal[..., 0] - states[..., 0], goal[..., 1] - states[..., 1])

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
        threat_e = terrain_threat(x / 1000.0, y / 1000.0, centres, self.constants.mountain_decay, present)
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
            terminal_cost: c_T >= 0 per remaining full-speed step, or a ``TerminalCost`` (model.md §7e).
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
        if isinstance(terminal_cost, TerminalCost) and terminal_cost.kind != 1:
            if terminal_cost.kind != 0 and step + horizon < self.max_steps:
                goal = self.goal[scenario_index]
                # The Dubins and value forms: the scalar definitions, row by row (model.md §7e).
                to_go = np.array(
                    [terminal_kernels.terminal_value.py_func(terminal_cost, s[0], s[1], s[4], goal[0], goal[1]) for s in states]
                )
                total += np.where(flying, weight * to_go, 0.0)
            return total
        if isinstance(terminal_cost, TerminalCost):
            terminal_cost = terminal_cost.scale
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
        obs[:, layout.POSITION] = (x - self.bounds[0]) / (self.bounds[1] - self.bounds[0])
        obs[:, layout.POSITION + 1] = (y - self.bounds[2]) / (self.bounds[3] - self.bounds[2])
        obs[:, layout.ALTITUDE_AGL] = (z - ground) / 1000.0
        obs[:, layout.ALTITUDE_CEILING] = z / self.ceiling
        obs[:, layout.SPEED] = (speed - limits.speed_min) / (limits.speed_max - limits.speed_min)
        obs[:, layout.HEADING], obs[:, layout.HEADING + 1] = cos_h, sin_h
        obs[:, layout.PITCH] = pitch / limits.pitch_max

        goal = self._pick(self.goal, index)
        gx, gy = goal[:, 0] - x, goal[:, 1] - y
        obs[:, layout.GOAL_OFFSET] = gx / self.map_side
        obs[:, layout.GOAL_OFFSET + 1] = gy / self.map_side
        obs[:, layout.GOAL_DISTANCE] = np.hypot(gx, gy) / self.map_side
        relative = np.arctan2(gy, gx) - heading
        obs[:, layout.GOAL_BEARING], obs[:, layout.GOAL_BEARING + 1] = np.cos(relative), np.sin(relative)

        # Terrain ahead: 5 x 5 samples on a heading-aligned grid (ahead-major, across = to the left).
        ahead = TERRAIN_AHEAD_M[:, None]
        across = TERRAIN_ACROSS_M[None, :]
        px = x[:, None, None] + ahead * cos_h[:, None, None] - across * sin_h[:, None, None]
        py = y[:, None, None] + ahead * sin_h[:, None, None] + across * cos_h[:, None, None]
        fi, fj = self.grid.fractional_index(px, py)
        sample_layer = layer if index is None else index[:, None, None]
        obs[:, SLOTS["terrain"]] = ((bilinear(self.terrain, fi, fj, sample_layer) - z[:, None, None]) / 1000.0).reshape(
            batch, 25
        )

        features = self._observed_radars(states, result, index)
        obs[:, SLOTS["radars"]] = features.reshape(batch, OBSERVED_RADARS * RADAR_FEATURES)
        obs[:, layout.STEP_FRACTION] = np.asarray(step_index) / self.max_steps
        return np.clip(obs, -OBSERVATION_LIMIT, OBSERVATION_LIMIT).astype(np.float32)

    def _observed_radars(self, states: FloatArray, result: StepResult | None, index: IntArray | None) -> FloatArray:
        """The (B, OBSERVED_RADARS, RADAR_FEATURES) radar block of :meth:`observe`, nearest radar first."""
        batch = states.shape[0]
        z, heading = states[:, Z], states[:, HEADING]
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
        return features
