"""The lattice value function V(x, y, psi): the cheapest cost from a pose to the goal (model.md §7e).

Built once per scenario by value iteration on a lattice of positions and headings whose moves are
the model's own transitions, and cached on disk by the content of the arrays it was built from.
It prices the end of MPC windows (the ``value`` form of the terminal cost,
:mod:`uav_penetration_env.terminal`, and the calibrated c_T of the ``dubins`` form) and drives the
lattice planner (:func:`lattice_action`), the classical global-planner baseline.

The lattice (model.md §7e):

* nodes: positions on a square grid over the map, spacing <= ``spacing_m`` (1.5 km by default,
  half a step at v_max on the paper's scenario), times ``headings`` equally spaced headings (24:
  15 degrees, so a turn of dphi_max from a node lands on a node's heading exactly);
* moves: one dt step at v_max from a node at ``clearance_m`` above the terrain, turning by each
  of ``turns`` x dphi_max, with the pitch that brings the UAV to ``clearance_m`` above the terrain
  under the level end point (limited to +-theta_max), flown with the model's kinematics;
* move cost: the model's own J(k) of that transition (``PenetrationModel.costs``); a move that
  collides, leaves the map or breaks the ceiling is forbidden; a move whose segment passes within
  r_goal of the goal ends there (the env's goal test);
* V(node) = min over its moves of cost + V(end pose), V at the end pose interpolated between
  nodes (:func:`terminal_kernels.value_lookup`), 0 after a move that reaches the goal and at the nodes
  inside the goal disc (where the env's episode has ended); iterated
  (Gauss-Seidel, nodes nearest the goal first, alternating direction) until no node changes by
  more than ``tolerance``.

DECISION (a margin at the map edge, model.md §7e.2): a move that ends within ``edge_margin_m`` (1.5 km, one node
spacing) of the map edge is forbidden like one that leaves the map. Without it the cheapest routes
of open maps run along the edge, where V interpolated between an edge node and the forbidden
outside underprices poses a continuous flight cannot keep inside (the lattice planner left the map
of a procedural scenario that way).

DECISION (terrain-following clearance 100 m, model.md §7e.2): the lattice flies at a fixed height above the
terrain because its state has no altitude. 100 m is the greedy floor's clearance: low enough for
the terrain masking the MPC planners exploit (they fly 35-50 m, median, on the paper scenario),
high enough that a straight 3 km segment between two terrain-following points rarely clips the
ground between them (such moves are forbidden, not repaired).
"""

from __future__ import annotations

import hashlib
import math
import time
import weakref
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np
from numba import njit, prange

from uav_penetration_env import compile_cache  # noqa: F401  (numba's cache folder, before any compiled function)
from uav_penetration_env.cache import cached_arrays
from uav_penetration_env.kinematics import HEADING, PITCH, SPEED, wrap_angle
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.terminal_kernels import (
    G_DX,
    G_DY,
    G_MISSING,
    G_STEP_LENGTH,
    G_TURN_RADIUS,
    G_X0,
    G_Y0,
    N_GRID,
    value_lookup,
)
from uav_penetration_env.types import FloatArray

# Bump when the lattice, its moves or the iteration change: cached tables of older builds are
# then never read.
ALGORITHM_VERSION = 4
_CHUNK_ROWS = 131_072  # transitions scored per model.costs call while building (bounds memory)


@dataclass(frozen=True)
class LatticeSettings:
    """The lattice a value function is built on (model.md §7e).

    Attributes:
        spacing_m: largest distance between neighbouring position nodes [m] (> 0).
        headings: heading nodes over 360 degrees (>= 4).
        turns: heading changes of the moves, as fractions of dphi_max (each in [-1, 1]).
        clearance_m: terrain-following height of the lattice's moves [m] (> the model's minimum
            clearance; DECISION, model.md §7e.2).
        edge_margin_m: a move that ends closer than this to the map edge is forbidden [m] (>= 0,
            DECISION, model.md §7e.2).
        tolerance: value iteration stops when no node changes by more than this (> 0).
        max_sweeps: the most value-iteration sweeps (>= 1).
    """

    spacing_m: float = 1500.0
    headings: int = 24
    turns: tuple[float, ...] = (-1.0, 0.0, 1.0)
    clearance_m: float = 100.0
    edge_margin_m: float = 1500.0
    tolerance: float = 1e-9
    max_sweeps: int = 5000

    def __post_init__(self) -> None:
        if not (isinstance(self.spacing_m, (int, float)) and math.isfinite(self.spacing_m) and self.spacing_m > 0):
            raise ValueError(f"spacing_m: got {self.spacing_m!r}, expected a finite number > 0 [m]")
        if not (isinstance(self.headings, int) and self.headings >= 4):
            raise ValueError(f"headings: got {self.headings!r}, expected an integer >= 4")
        turns = tuple(self.turns)
        if not turns or not all(isinstance(t, (int, float)) and -1.0 <= t <= 1.0 for t in turns):
            raise ValueError(f"turns: got {self.turns!r}, expected a non-empty tuple of numbers in [-1, 1]")
        object.__setattr__(self, "turns", tuple(float(t) for t in turns))
        if not (isinstance(self.clearance_m, (int, float)) and math.isfinite(self.clearance_m)):
            raise ValueError(f"clearance_m: got {self.clearance_m!r}, expected a finite number [m]")
        if not (isinstance(self.edge_margin_m, (int, float)) and 0 <= self.edge_margin_m < math.inf):
            raise ValueError(f"edge_margin_m: got {self.edge_margin_m!r}, expected a finite number >= 0 [m]")
        if not (isinstance(self.tolerance, (int, float)) and self.tolerance > 0):
            raise ValueError(f"tolerance: got {self.tolerance!r}, expected a number > 0")
        if not (isinstance(self.max_sweeps, int) and self.max_sweeps >= 1):
            raise ValueError(f"max_sweeps: got {self.max_sweeps!r}, expected an integer >= 1")


LATTICE_DEFAULTS = LatticeSettings()


@dataclass(frozen=True, eq=False)
class ValueFunction:
    """V(x, y, psi) of one scenario on its lattice (model.md §7e).

    Attributes:
        table: (nx, ny, nh) V at the nodes; ``+inf`` where every move leaves the map or ends in
            its margin, ``-inf`` where every move clips the terrain (terminal_kernels.value_lookup).
        grid: (terminal_kernels.N_GRID,) the lattice slots (origin, spacing, fallback, step length, turning
            radius).
        settings: the lattice it was built on.
        sweeps: value-iteration sweeps until convergence.
        build_seconds: wall time of the build (0 when loaded from the cache).
        route_j_per_step: mean J per step of the lattice planner flown from the scenario's start
            (the calibration of the ``dubins`` form's c_T).
        route_steps: steps of that flight.
    """

    table: np.ndarray
    grid: np.ndarray
    settings: LatticeSettings
    sweeps: int
    build_seconds: float
    route_j_per_step: float
    route_steps: int

    @property
    def missing(self) -> float:
        """The value taken at a pose with no finite lattice corner around it."""
        return float(self.grid[G_MISSING])

    def __call__(self, x: FloatArray, y: FloatArray, heading: FloatArray) -> FloatArray:
        """V at poses [m, m, rad] (any matching shapes), interpolated as :func:`terminal_kernels.value_lookup`."""
        x, y, heading = np.broadcast_arrays(
            np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64), np.asarray(heading, dtype=np.float64)
        )
        out = np.empty(x.size)
        _lookup_batch(
            self.table,
            self.grid,
            np.ascontiguousarray(x).reshape(-1),
            np.ascontiguousarray(y).reshape(-1),
            np.ascontiguousarray(heading).reshape(-1),
            self.missing,
            out,
        )
        return out.reshape(x.shape)


@njit(cache=True)
def value_iteration(cost, reached, end_x, end_y, end_heading, order, inside_goal, table, grid, tolerance, max_sweeps):
    """Gauss-Seidel value iteration of V(n) = min_a [c(n, a) + (0 if a reaches the goal else V(f(n, a)))].

    Nodes inside the goal disc are terminal (the env's episode has ended there): V = 0, never updated.

    Args:
        cost: (N, A) move costs J(k) of each lattice node's moves; ``inf`` for a forbidden move.
        reached: (N, A) whether the move reaches the goal (its successor's value is then 0).
        end_x: (N, A) the move's end x [m].
        end_y: (N, A) the move's end y [m].
        end_heading: (N, A) the move's end heading [rad].
        order: (N,) node visiting order (nearest the goal first); odd sweeps run it backwards.
        inside_goal: (N,) nodes within r_goal of the goal (V = 0).
        table: (nx, ny, nh) in/out V: ``+inf`` to be computed, ``-inf`` for nodes whose every move
            clips the terrain (never updated, left out of interpolation).
        (flat node n = (ix ny + iy) nh + ih)
        grid: the lattice slots ``G_*``; a corner not yet finite counts as ``G_MISSING``, a pose
            with no finite corner is not a move (``inf``).
        tolerance: stop when no node changes by more than this and no node became finite.
        max_sweeps: the most sweeps.

    Returns:
        The number of sweeps made (``max_sweeps + 1`` if it did not converge).
    """
    flat = table.reshape(-1)
    nodes = cost.shape[0]
    moves = cost.shape[1]
    for n in range(nodes):
        if inside_goal[n]:
            flat[n] = 0.0
    for sweep in range(max_sweeps):
        change = 0.0
        for position in range(nodes):
            n = order[position] if sweep % 2 == 0 else order[nodes - 1 - position]
            if inside_goal[n] or flat[n] == -math.inf:
                continue
            best = math.inf
            for a in range(moves):
                c = cost[n, a]
                if c == math.inf:
                    continue
                if reached[n, a]:
                    q = c
                else:
                    q = c + value_lookup(table, grid, end_x[n, a], end_y[n, a], end_heading[n, a], math.inf)
                if q < best:
                    best = q
            # No pose costs more than a crash now: a region that reaches neither the goal nor the
            # edge (walled in by terrain) converges to that price instead of growing every sweep.
            if best < math.inf and best > grid[G_MISSING]:
                best = grid[G_MISSING]
            old = flat[n]
            if best < math.inf:
                if old == math.inf:
                    change = math.inf
                else:
                    delta = abs(best - old)
                    if delta > change:
                        change = delta
            flat[n] = best
        if change <= tolerance:
            return sweep + 1
    return max_sweeps + 1


@njit(parallel=True, cache=True)
def _lookup_batch(table, grid, x, y, heading, missing, out):
    for i in prange(x.shape[0]):
        out[i] = value_lookup(table, grid, x[i], y[i], heading[i], missing)


# --- building -------------------------------------------------------------------------------------


def _content_digest(model: PenetrationModel, scenario_index: int) -> str:
    """A digest of every array the moves' costs read for one pool member (the cache key's content)."""
    a = model.arrays
    p = scenario_index
    digest = hashlib.sha256()
    layers = a.floor_layer[p][a.radar_present[p] > 0]
    for part in (
        a.terrain[p],
        a.floors[layers] if len(layers) else a.floors[:0],
        a.radar_xyz[p],
        a.radar_present[p],
        a.ref_range[p],
        a.ref_rcs[p],
        a.mountain_centres[p],
        a.mountain_present[p],
        a.goal[p],
        a.rcs_table,
        a.sample_t,
        a.params,
        a.options,
    ):
        array = np.ascontiguousarray(part)
        digest.update(str(array.shape).encode())
        digest.update(array.tobytes())
    return digest.hexdigest()


def lattice_nodes(model: PenetrationModel, settings: LatticeSettings) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lattice's node coordinates: x (nx,), y (ny,) [m] spanning the map, headings (nh,) [rad]."""
    x_min, x_max, y_min, y_max = model.bounds
    nx = max(2, math.ceil((x_max - x_min) / settings.spacing_m - 1e-9) + 1)
    ny = max(2, math.ceil((y_max - y_min) / settings.spacing_m - 1e-9) + 1)
    xs = np.linspace(x_min, x_max, nx)
    ys = np.linspace(y_min, y_max, ny)
    headings = 2.0 * math.pi * np.arange(settings.headings) / settings.headings
    return xs, ys, headings


def lattice_moves(
    model: PenetrationModel, settings: LatticeSettings, scenario_index: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every node's moves: start states, end states (N, A, 6) and the pool index, node order (ix, iy, ih).

    The start is the node at ``clearance_m`` above the terrain, at v_max and level; the end is one
    dt step of the model's kinematics after turning by ``turns`` x dphi_max, pitched toward
    ``clearance_m`` above the terrain under the level end point (model.md §7e).
    """
    limits = model.limits
    xs, ys, headings = lattice_nodes(model, settings)
    gx, gy, gh = np.meshgrid(xs, ys, headings, indexing="ij")
    x, y, h = gx.reshape(-1), gy.reshape(-1), gh.reshape(-1)
    index = np.full(x.size, scenario_index)
    z = model.height(x, y, index) + settings.clearance_m
    turns = np.asarray(settings.turns) * limits.dheading_max
    length = limits.max_step_length
    new_heading = wrap_angle(h[:, None] + turns[None, :])
    level_x = x[:, None] + length * np.cos(new_heading)
    level_y = y[:, None] + length * np.sin(new_heading)
    target = model.height(level_x, level_y, np.broadcast_to(scenario_index, level_x.shape)) + settings.clearance_m
    climb = np.clip((target - z[:, None]) / length, -1.0, 1.0)
    pitch = np.clip(np.arcsin(climb), -limits.pitch_max, limits.pitch_max)
    horizontal = length * np.cos(pitch)
    moves = len(turns)
    starts = np.empty((x.size, moves, 6))
    starts[..., 0] = x[:, None]
    starts[..., 1] = y[:, None]
    starts[..., 2] = z[:, None]
    starts[..., 3] = limits.speed_max
    starts[..., 4] = h[:, None]
    starts[..., 5] = 0.0
    ends = np.empty_like(starts)
    ends[..., 0] = x[:, None] + horizontal * np.cos(new_heading)
    ends[..., 1] = y[:, None] + horizontal * np.sin(new_heading)
    ends[..., 2] = z[:, None] + length * np.sin(pitch)
    ends[..., 3] = limits.speed_max
    ends[..., 4] = new_heading
    ends[..., 5] = pitch
    return starts, ends, index


def move_costs(
    model: PenetrationModel, starts: np.ndarray, ends: np.ndarray, scenario_index: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """The model's J of each move (``inf`` when it collides, leaves the map or breaks the ceiling), whether it reaches the goal, whether it leaves the map.

    Args:
        model: the scenario's model.
        starts: (N, A, 6) states before the moves.
        ends: (N, A, 6) states after them.
        scenario_index: the pool member.

    Returns:
        cost (N, A), reached (N, A), and whether the move leaves the map (N, A).
    """
    shape = starts.shape[:2]
    flat_starts = starts.reshape(-1, 6)
    flat_ends = ends.reshape(-1, 6)
    cost = np.empty(flat_starts.shape[0])
    reached = np.empty(flat_starts.shape[0], dtype=bool)
    outside = np.empty(flat_starts.shape[0], dtype=bool)
    for lo in range(0, flat_starts.shape[0], _CHUNK_ROWS):
        hi = min(lo + _CHUNK_ROWS, flat_starts.shape[0])
        result = model.costs(
            flat_starts[lo:hi], flat_ends[lo:hi], 0, scenario_index=np.full(hi - lo, scenario_index)
        )
        failed = result.collided | result.out_of_area
        cost[lo:hi] = np.where(failed, np.inf, result.J)
        reached[lo:hi] = result.reached_goal
        outside[lo:hi] = result.out_of_area
    return cost.reshape(shape), reached.reshape(shape), outside.reshape(shape)


def _grid_slots(model: PenetrationModel, settings: LatticeSettings) -> np.ndarray:
    xs, ys, _ = lattice_nodes(model, settings)
    limits = model.limits
    grid = np.zeros(N_GRID)
    grid[G_X0] = xs[0]
    grid[G_Y0] = ys[0]
    grid[G_DX] = xs[1] - xs[0]
    grid[G_DY] = ys[1] - ys[0]
    # A pose no route leaves from costs a crash at the first step (model.md §7a's penalty).
    grid[G_MISSING] = model.crash_penalty_per_step * model.max_steps + 1.0
    grid[G_STEP_LENGTH] = limits.max_step_length
    grid[G_TURN_RADIUS] = limits.max_step_length / limits.dheading_max
    return grid


def _iterate(model: PenetrationModel, settings: LatticeSettings, scenario_index: int) -> dict[str, np.ndarray]:
    start_time = time.perf_counter()
    starts, ends, _ = lattice_moves(model, settings, scenario_index)
    cost, reached, edge = move_costs(model, starts, ends, scenario_index)
    x_min, x_max, y_min, y_max = model.bounds
    margin = settings.edge_margin_m
    near_edge = (
        (ends[..., 0] < x_min + margin)
        | (ends[..., 0] > x_max - margin)
        | (ends[..., 1] < y_min + margin)
        | (ends[..., 1] > y_max - margin)
    )
    edge = (edge | near_edge) & ~reached
    cost = np.where(edge, np.inf, cost)
    xs, ys, headings = lattice_nodes(model, settings)
    grid = _grid_slots(model, settings)
    goal = model.goal[scenario_index]
    node_distance = np.hypot(starts[:, 0, 0] - goal[0], starts[:, 0, 1] - goal[1])
    order = np.argsort(node_distance, kind="stable").astype(np.int64)
    table = np.full((xs.size, ys.size, headings.size), np.inf)
    # Nodes whose every move clips the terrain (none ends at the edge): -inf, left out of
    # interpolation (terminal_kernels.value_lookup).
    terrain_doomed = np.all(~np.isfinite(cost), axis=1) & ~np.any(edge, axis=1)
    table.reshape(-1)[terrain_doomed] = -np.inf
    sweeps = value_iteration(
        cost,
        reached,
        np.ascontiguousarray(ends[..., 0]),
        np.ascontiguousarray(ends[..., 1]),
        np.ascontiguousarray(ends[..., 4]),
        order,
        node_distance <= goal[2],
        table,
        grid,
        float(settings.tolerance),
        int(settings.max_sweeps),
    )
    if sweeps > settings.max_sweeps:
        raise RuntimeError(
            f"value iteration: no convergence to {settings.tolerance} in {settings.max_sweeps} sweeps "
            "(raise LatticeSettings.max_sweeps or tolerance)"
        )
    vf = ValueFunction(table, grid, settings, sweeps, 0.0, math.nan, 0)
    j_per_step, steps = _route_calibration(model, vf, scenario_index)
    seconds = time.perf_counter() - start_time
    return {
        "table": table,
        "grid": grid,
        "sweeps": np.array(sweeps),
        "build_seconds": np.array(seconds),
        "route": np.array([j_per_step, steps]),
    }


_memo: weakref.WeakKeyDictionary[PenetrationModel, dict] = weakref.WeakKeyDictionary()


def value_function(
    model: PenetrationModel, scenario_index: int = 0, settings: LatticeSettings = LATTICE_DEFAULTS
) -> ValueFunction:
    """The value function of one pool member of ``model``: from memory, the disk cache, or built.

    Cached by the content of the model's arrays for that member and the lattice settings
    (``cache.cached_arrays``, kind ``value``), so a scenario whose terrain, radars, goal or
    constants change gets a new table.

    Raises:
        ValueError: ``scenario_index`` outside the pool; invalid settings (from
            :class:`LatticeSettings`).
        RuntimeError: value iteration that did not converge within ``settings.max_sweeps``.
    """
    if not (isinstance(scenario_index, (int, np.integer)) and 0 <= scenario_index < model.pool_size):
        raise ValueError(f"scenario_index: got {scenario_index!r}, expected an integer in [0, {model.pool_size})")
    key = (int(scenario_index), settings)
    per_model = _memo.setdefault(model, {})
    if key in per_model:
        return per_model[key]
    inputs = {
        "content": _content_digest(model, int(scenario_index)),
        "settings": asdict(settings),
        "algorithm": ALGORITHM_VERSION,
        # The route calibration (route_j_per_step) flies the lattice planner from the fixed start.
        "start": [float(v) for v in model.initial_state(None, int(scenario_index))],
        "guidance": asdict(LATTICE_GUIDANCE),
    }
    built_now: list[bool] = []

    def build() -> dict[str, np.ndarray]:
        built_now.append(True)
        return _iterate(model, settings, int(scenario_index))

    arrays = cached_arrays("value", inputs, build)
    vf = ValueFunction(
        table=arrays["table"],
        grid=arrays["grid"],
        settings=settings,
        sweeps=int(arrays["sweeps"]),
        build_seconds=float(arrays["build_seconds"]) if built_now else 0.0,
        route_j_per_step=float(arrays["route"][0]),
        route_steps=int(arrays["route"][1]),
    )
    per_model[key] = vf
    return vf


# --- the lattice planner --------------------------------------------------------------------------


@dataclass(frozen=True)
class LatticeGuidance:
    """How the lattice planner turns V into an action (model.md §7e).

    Attributes:
        turns: candidate heading changes, fractions of dphi_max.
        clearance_m: terrain-following height [m] (the lattice's, by default).
        lookahead_steps: the altitude target clears the terrain under this many steps ahead.
        depth: steps of candidate sequences flown before V prices their end (C^depth sequences).
    """

    turns: tuple[float, ...] = (-1.0, -0.5, 0.0, 0.5, 1.0)
    clearance_m: float = LATTICE_DEFAULTS.clearance_m
    lookahead_steps: float = 2.0
    depth: int = 2


LATTICE_GUIDANCE = LatticeGuidance()


def terrain_following_dtheta(
    model: PenetrationModel,
    state: FloatArray,
    heading: float,
    speed: float,
    clearance_m: float,
    lookahead_steps: float,
    scenario_index: int = 0,
) -> float:
    """The pitch change that aims at ``clearance_m`` above the highest terrain ahead (api.md, greedy floor).

    The target is the highest terrain under the next ``lookahead_steps`` steps along ``heading``,
    sampled every half grid cell, plus the clearance; the pitch is the one that reaches it in one
    step at ``speed``, limited by the pitch bounds, and the change by the pitch-rate bound.
    """
    limits = model.limits
    x, y, z = float(state[0]), float(state[1]), float(state[2])
    reach = lookahead_steps * limits.max_step_length
    distance = np.linspace(0.0, reach, max(2, math.ceil(reach / (0.5 * model.grid.dx_m)) + 1))
    ground = model.height(
        x + distance * math.cos(heading),
        y + distance * math.sin(heading),
        np.full(distance.size, scenario_index) if model.pool_size > 1 else None,
    )
    target = float(ground.max()) + clearance_m
    climb = np.clip((target - z) / (speed * limits.dt), -1.0, 1.0)
    pitch = float(np.clip(math.asin(climb), -limits.pitch_max, limits.pitch_max))
    return float(np.clip(pitch - state[PITCH], -limits.dpitch_max, limits.dpitch_max))


def candidate_control(
    model: PenetrationModel,
    state: FloatArray,
    turn: float,
    guidance: LatticeGuidance = LATTICE_GUIDANCE,
    scenario_index: int = 0,
) -> FloatArray:
    """(3,) the lattice planner's candidate control for ``turn`` (a fraction of dphi_max) from ``state``.

    Accelerate toward v_max, turn by ``turn`` x dphi_max, and pitch toward ``guidance.clearance_m``
    above the highest terrain under the next ``guidance.lookahead_steps`` steps along the new
    heading (:func:`terrain_following_dtheta`).
    """
    limits = model.limits
    dv = float(np.clip(limits.speed_max - state[SPEED], -limits.dv_max, limits.dv_max))
    speed = min(limits.speed_max, state[SPEED] + dv)
    dphi = turn * limits.dheading_max
    dtheta = terrain_following_dtheta(
        model, state, state[HEADING] + dphi, speed, guidance.clearance_m, guidance.lookahead_steps, scenario_index
    )
    return np.array([dv, dphi, dtheta])


def _candidate_controls(
    model: PenetrationModel, states: np.ndarray, guidance: LatticeGuidance, scenario_index: int
) -> np.ndarray:
    """(B, C, 3) the lattice planner's candidate controls from each of B states (C = len(turns))."""
    controls = np.empty((states.shape[0], len(guidance.turns), 3))
    for b, state in enumerate(states):
        for i, turn in enumerate(guidance.turns):
            controls[b, i] = candidate_control(model, state, turn, guidance, scenario_index)
    return controls


def value_ahead(
    model: PenetrationModel, vf: ValueFunction, state: FloatArray, turns: Sequence[float] = LATTICE_GUIDANCE.turns
) -> tuple[float, FloatArray]:
    """V at the pose of ``state`` and (len(turns),) V one step of v_max * dt ahead along each turned heading.

    For turn i, the heading psi_i = psi + turn_i * dphi_max and the point p + v_max dt (cos psi_i,
    sin psi_i): where the field says each turn leads, read from V alone (no move is flown or priced;
    docs/rl.md §4.9). Used by the ``value-greedy`` rule and the distilled planners' ``value`` inputs.
    """
    step = model.limits.speed_max * model.limits.dt
    heading = float(state[HEADING])
    here = float(vf(state[0], state[1], heading))
    turned = heading + np.asarray(turns, dtype=np.float64) * model.limits.dheading_max
    return here, vf(state[0] + step * np.cos(turned), state[1] + step * np.sin(turned), turned)


def lattice_action(
    model: PenetrationModel,
    vf: ValueFunction,
    state: FloatArray,
    step: int,
    guidance: LatticeGuidance = LATTICE_GUIDANCE,
    scenario_index: int = 0,
) -> FloatArray:
    """The lattice planner's action (3,): the first control of the cheapest ``guidance.depth``-step candidate.

    Each step's candidates turn by one of ``guidance.turns`` x dphi_max, accelerate toward v_max
    and follow the terrain (:func:`terrain_following_dtheta`); every sequence of ``depth``
    candidates is flown with the model (``PenetrationModel.step``, the env's own transition) and
    priced by its J + penalty plus V at the pose it reaches (nothing after the goal is reached or
    a failure, whose penalty already prices it). Ties go to the first sequence in the order of
    ``guidance.turns``.
    """
    state = np.asarray(state, dtype=np.float64)
    choices = len(guidance.turns)
    states = state[None].copy()
    first = np.zeros((1, 3))
    spent = np.zeros(1)
    done = np.zeros(1, dtype=bool)
    for depth in range(guidance.depth):
        k = min(step + depth, model.max_steps - 1)
        controls = _candidate_controls(model, states, guidance, scenario_index)  # (B, C, 3)
        rows = states.shape[0]
        flat = controls.reshape(-1, 3)
        parents = np.repeat(np.arange(rows), choices)
        index = np.full(flat.shape[0], scenario_index) if model.pool_size > 1 else None
        result = model.step(states[parents], flat, k, index)
        stopped = done[parents]
        # A finished branch keeps its state and price: it spends nothing more.
        spent = spent[parents] + np.where(stopped, 0.0, result.J + result.penalty)
        states = np.where(stopped[:, None], states[parents], result.state)
        first = flat.copy() if depth == 0 else first[parents]
        done = stopped | result.terminated | result.truncated
    after = vf(states[:, 0], states[:, 1], states[:, HEADING])
    price = spent + np.where(done, 0.0, after)
    return first[int(np.argmin(price))].copy()


def _route_calibration(model: PenetrationModel, vf: ValueFunction, scenario_index: int) -> tuple[float, int]:
    """Mean J per step and steps of the lattice planner flown from the member's fixed start (no jitter)."""
    state = model.initial_state(None, scenario_index)
    total = 0.0
    steps = 0
    for k in range(model.max_steps):
        action = lattice_action(model, vf, state, k, scenario_index=scenario_index)
        index = np.array([scenario_index]) if model.pool_size > 1 else None
        result = model.step(state[None], action[None], k, index)
        total += float(result.J[0])
        steps += 1
        state = result.state[0]
        if result.terminated[0] or result.truncated[0]:
            break
    return total / max(steps, 1), steps


__all__ = [
    "ALGORITHM_VERSION",
    "LATTICE_DEFAULTS",
    "LATTICE_GUIDANCE",
    "LatticeGuidance",
    "LatticeSettings",
    "ValueFunction",
    "lattice_action",
    "lattice_moves",
    "lattice_nodes",
    "move_costs",
    "terrain_following_dtheta",
    "value_function",
]
