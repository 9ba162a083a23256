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

import dataclasses
import hashlib
import math
import time
import weakref
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np
from numba import njit, prange

from uav_penetration_env import (
    compile_cache,  # noqa: F401  (numba's cache folder, before any compiled function)
    kernels,
    value_kernels,
)
from uav_penetration_env.cache import cached_arrays
from uav_penetration_env.kinematics import HEADING, PITCH, SPEED, wrap_angle
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.scenario import Radar
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
from uav_penetration_env.value_kernels import capped, changed_by

# Bump when the lattice, its moves or the iteration change: cached tables of older builds are
# then never read.
ALGORITHM_VERSION = 6  # 5: the dirty-sweep builder (V equal to the tolerance), build_cpu_seconds stored; 6: its stencils, label-setting guess and spatial sweep order
# DECISION (model.md §7e.2): what V is (the lattice, its moves and costs, the fixed point to the
# tolerance), apart from how it is built. A planner's configuration, hence its store key, names
# this: a builder that reaches the same fixed point (to the 1e-9 tolerance, tested against the
# reference builder) flies the same episodes, so published rows stay keyed to their planners.
DEFINITION_VERSION = 4
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
        build_cpu_seconds: CPU time of the build (``time.process_time``; 0 when loaded from the
            cache).
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
    build_cpu_seconds: float = 0.0

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
            best = capped(best, grid[G_MISSING])
            change = changed_by(change, flat[n], best)
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
    new_heading = wrap_angle(h[:, None] + turns[None, :])
    starts, ends = _moves(model, settings, scenario_index, x[:, None], y[:, None], z[:, None], h[:, None], new_heading)
    return starts, ends, index


def _moves(
    model: PenetrationModel,
    settings: LatticeSettings,
    scenario_index: int,
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    heading: np.ndarray,
    new_heading: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Start and end states (..., 6) of lattice moves from (x, y, z, heading) to ``new_heading`` (broadcast)."""
    limits = model.limits
    length = limits.max_step_length
    x, y, z, heading, new_heading = np.broadcast_arrays(x, y, z, heading, new_heading)
    level_x = x + length * np.cos(new_heading)
    level_y = y + length * np.sin(new_heading)
    target = model.height(level_x, level_y, np.broadcast_to(scenario_index, level_x.shape)) + settings.clearance_m
    climb = np.clip((target - z) / length, -1.0, 1.0)
    pitch = np.clip(np.arcsin(climb), -limits.pitch_max, limits.pitch_max)
    horizontal = length * np.cos(pitch)
    starts = np.empty((*x.shape, 6))
    starts[..., 0] = x
    starts[..., 1] = y
    starts[..., 2] = z
    starts[..., 3] = limits.speed_max
    starts[..., 4] = heading
    starts[..., 5] = 0.0
    ends = np.empty_like(starts)
    ends[..., 0] = x + horizontal * np.cos(new_heading)
    ends[..., 1] = y + horizontal * np.sin(new_heading)
    ends[..., 2] = z + length * np.sin(pitch)
    ends[..., 3] = limits.speed_max
    ends[..., 4] = new_heading
    ends[..., 5] = pitch
    return starts, ends


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


class BuildClock:
    """CPU (time.process_time) and wall seconds of the named parts of a build."""

    def __init__(self) -> None:
        self.cpu: dict[str, float] = {}
        self.wall: dict[str, float] = {}
        self._cpu = time.process_time()
        self._wall = time.perf_counter()

    def lap(self, part: str) -> None:
        """Add the time since the last lap (or the start) to ``part``."""
        cpu, wall = time.process_time(), time.perf_counter()
        self.cpu[part] = self.cpu.get(part, 0.0) + cpu - self._cpu
        self.wall[part] = self.wall.get(part, 0.0) + wall - self._wall
        self._cpu, self._wall = cpu, wall


def _iterate_reference(
    model: PenetrationModel, settings: LatticeSettings, scenario_index: int, clock: BuildClock | None = None
) -> dict[str, np.ndarray]:
    """V by the first builder: every move scored, Gauss-Seidel sweeps from V = inf (the test oracle).

    Nodes in order of distance to the goal, alternating direction, until no node changes by more
    than ``settings.tolerance``; kept as the oracle of :class:`ValueFunctionBuilder` and as the
    reference of ``benchmarks/bench_value.py`` (model.md §7e.2). ``clock`` (optional) records the
    parts' times (``moves``, ``costs``, ``sweeps``, ``route``).
    """
    clock = clock or BuildClock()
    start_time = time.perf_counter()
    start_cpu = time.process_time()
    starts, ends, _ = lattice_moves(model, settings, scenario_index)
    clock.lap("moves")
    cost, reached, edge = move_costs(model, starts, ends, scenario_index)
    clock.lap("costs")
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
    clock.lap("sweeps")
    vf = ValueFunction(table, grid, settings, sweeps, 0.0, math.nan, 0)
    j_per_step, steps = _route_calibration(model, vf, scenario_index)
    clock.lap("route")
    return {
        "table": table,
        "grid": grid,
        "sweeps": np.array(sweeps),
        "build_seconds": np.array(time.perf_counter() - start_time),
        "build_cpu_seconds": np.array(time.process_time() - start_cpu),
        "route": np.array([j_per_step, steps]),
    }


def build_arrays(
    model: PenetrationModel,
    settings: LatticeSettings,
    scenario_index: int = 0,
    method: str = "sweeps",
    clock: BuildClock | None = None,
) -> dict[str, np.ndarray]:
    """The arrays of V for one pool member, built now (no cache): ``method`` ``sweeps`` (the default builder) or ``reference``.

    Raises:
        ValueError: an unknown ``method``.
    """
    if method == "reference":
        return _iterate_reference(model, settings, scenario_index, clock)
    if method != "sweeps":
        raise ValueError(f"method: got {method!r}, expected 'sweeps' or 'reference'")
    builder = ValueFunctionBuilder(model, scenario_index, settings)
    if clock is not None:
        clock.cpu.update(builder.cpu_seconds)
        clock.wall.update(builder.wall_seconds)
    return builder.arrays()


# --- the fast builder and its incremental rebuild (model.md §7e.2) ------------------------------

# DECISION (model.md §7e.2): a change of V dirties the nodes upstream only when it exceeds this
# fraction of the tolerance; smaller changes are written but not passed upstream. The final
# Jacobi check applies the reference's stopping rule (no node changes by more than the tolerance)
# to the whole table, so the result passes the test the reference iteration stops on.
PROPAGATION_FRACTION = 1e-3
# DECISION (model.md §7e.2): in the label-setting first pass a move offers its q once corners
# holding this share of its usable interpolation weight have settled. 0.5 measured best on the
# paper map (1.21 M node updates to converge; 1.23 M at 0.999; 2.28 M when any settled corner
# sufficed, 1.81 M with the former nearest-node guess). Only the guess and the order depend on it.
SETTLED_SHARE = 0.5


def _shared_steps(model: PenetrationModel, settings: LatticeSettings) -> np.ndarray | None:
    """Each turn in heading nodes when every turn lands on a node heading (then moves share end states), else None."""
    steps = np.asarray(settings.turns) * model.limits.dheading_max / (2.0 * math.pi / settings.headings)
    rounded = np.round(steps)
    return rounded.astype(np.int64) if np.all(np.abs(steps - rounded) < 1e-9) else None


def _transitions(
    model: PenetrationModel, settings: LatticeSettings, scenario_index: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lattice's distinct transitions: starts, ends (T, 6), and each node's moves as transition indices (N, A).

    A move's J does not depend on the start heading (the model scores a transition by its start
    position and its end state), so when every turn lands on a node heading the moves of the
    headings at one position that end on the same heading are one transition: T = N instead of
    N x A. Otherwise each move is its own transition, as :func:`lattice_moves` makes them.
    """
    xs, ys, headings = lattice_nodes(model, settings)
    nh = headings.size
    steps = _shared_steps(model, settings)
    if steps is None:
        starts, ends, _ = lattice_moves(model, settings, scenario_index)
        moves = starts.shape[1]
        return starts.reshape(-1, 6), ends.reshape(-1, 6), np.arange(starts.shape[0] * moves).reshape(-1, moves)
    px, py = np.meshgrid(xs, ys, indexing="ij")
    px, py = px.reshape(-1), py.reshape(-1)
    pz = model.height(px, py, np.full(px.size, scenario_index)) + settings.clearance_m
    end_heading = wrap_angle(headings)
    starts, ends = _moves(
        model, settings, scenario_index, px[:, None], py[:, None], pz[:, None], end_heading[None, :], end_heading[None, :]
    )
    node = np.arange(px.size * nh)
    position, heading_index = node // nh, node % nh
    move_t = position[:, None] * nh + (heading_index[:, None] + steps[None, :]) % nh
    return starts.reshape(-1, 6), ends.reshape(-1, 6), move_t.astype(np.int64)


def _same_radar(old: PenetrationModel, i: int, new: PenetrationModel, j: int, p: int) -> bool:
    """Whether slot i of ``old`` and slot j of ``new`` (member p) hold the same radar with the same masking floor."""
    a, b = old.arrays, new.arrays
    if not (a.radar_present[p, i] == b.radar_present[p, j] == 1.0):
        return False
    if not (
        np.array_equal(a.radar_xyz[p, i], b.radar_xyz[p, j])
        and a.ref_range[p, i] == b.ref_range[p, j]
        and a.ref_rcs[p, i] == b.ref_rcs[p, j]
    ):
        return False
    return bool(np.array_equal(a.floors[a.floor_layer[p, i]], b.floors[b.floor_layer[p, j]]))


def _same_except_radars(old: PenetrationModel, new: PenetrationModel, p: int) -> bool:
    """Whether member p of the two models differs at most in its radars (then only radar terms change)."""
    a, b = old.arrays, new.arrays
    if new.pool_size <= p or tuple(old.bounds) != tuple(new.bounds) or old.limits.action_high.tolist() != new.limits.action_high.tolist():
        return False
    pairs = (
        (a.terrain[p], b.terrain[p]),
        (a.mountain_centres[p], b.mountain_centres[p]),
        (a.mountain_present[p], b.mountain_present[p]),
        (a.goal[p], b.goal[p]),
        (a.rcs_table, b.rcs_table),
        (a.sample_t, b.sample_t),
        (a.params, b.params),
        (a.options, b.options),
    )
    return all(x.shape == y.shape and np.array_equal(x, y) for x, y in pairs)


class ValueFunctionBuilder:
    """V of one pool member, built by ordered sweeps over dirty nodes, and rebuilt incrementally when radars change (model.md §7e.2).

    The builder scores each distinct lattice transition once with the model's own transition
    (keeping each radar's threat, the terrain and third terms), then solves the Bellman equation of
    :func:`value_iteration` by Gauss-Seidel sweeps from a label-setting guess of V (a Dijkstra
    pass from the goal outward over settled interpolation corners,
    :func:`value_kernels.settled_values`), in the reference's order (by distance to the goal,
    alternating direction), each over the dirty nodes only (a node is re-evaluated when one of its
    moves' interpolation corners moved by more than ``tolerance x PROPAGATION_FRACTION``; each
    move's corners and weights are computed once, :func:`value_kernels.stencils`), and
    checks the result with the reference's stopping rule: a full Jacobi application of the
    Bellman operator changes no node by more than ``settings.tolerance`` (else the moved nodes'
    upstream is swept again). :meth:`with_model` and :meth:`with_radars` rebuild after a change of
    radars: only the changed radars' threats are computed, the moves whose fused J changed
    re-priced, and the nodes upstream of them re-converged from the old V by the same rule.

    DECISION (model.md §7e.2): a rebuild recomputes J exactly (per radar, fused in the new model's
    radar order), rather than bounding a radar's reach: the Swerling-I P_d is never exactly 0 inside
    the visibility's soft edge, so a range bound would change J far away by a little.

    Attributes:
        model: the model it was built on.
        scenario_index: the pool member.
        settings: the lattice.
        value_function: the built :class:`ValueFunction`.
        cpu_seconds: CPU seconds per part (``moves``, ``costs``, ``sweeps``, ``route``) of this build.
        wall_seconds: wall seconds per part.
        changed_moves: moves whose J changed (a rebuild; every move for a full build).
    """

    def __init__(
        self,
        model: PenetrationModel,
        scenario_index: int = 0,
        settings: LatticeSettings = LATTICE_DEFAULTS,
        *,
        _previous: ValueFunctionBuilder | None = None,
    ) -> None:
        if not (isinstance(scenario_index, (int, np.integer)) and 0 <= scenario_index < model.pool_size):
            raise ValueError(f"scenario_index: got {scenario_index!r}, expected an integer in [0, {model.pool_size})")
        self.model = model
        self.scenario_index = int(scenario_index)
        self.settings = settings
        clock = BuildClock()
        if _previous is None:
            self._build_lattice(clock)
            self._price_all(clock)
            dirty = self._first_pass()
        else:
            self._inherit(_previous)
            clock.lap("moves")
            dirty = self._reprice(_previous, clock)
        self._converge(dirty, clock)
        self._finish(clock)

    # --- the lattice and its move costs ------------------------------------------------------

    def _build_lattice(self, clock: BuildClock) -> None:
        model, settings, p = self.model, self.settings, self.scenario_index
        starts, ends, move_t = _transitions(model, settings, p)
        self._shared = _shared_steps(model, settings) is not None
        self._starts, self._ends, self._move_t = starts, ends, move_t
        self._ex = np.ascontiguousarray(ends[:, 0])
        self._ey = np.ascontiguousarray(ends[:, 1])
        self._eh = np.ascontiguousarray(ends[:, 4])
        xs, ys, headings = lattice_nodes(model, settings)
        self._shape = (xs.size, ys.size, headings.size)
        self._grid = _grid_slots(model, settings)
        self._move_near = self._near_edge_moves(starts, ends, move_t)
        node = np.arange(move_t.shape[0])
        goal = model.goal[p]
        ix, iy = node // (ys.size * headings.size), (node // headings.size) % ys.size
        self._inside_goal = np.hypot(xs[ix] - goal[0], ys[iy] - goal[1]) <= goal[2]
        clock.lap("moves")

    def _near_edge_moves(self, starts: np.ndarray, ends: np.ndarray, move_t: np.ndarray) -> np.ndarray:
        """(N, A) whether each move ends in the edge margin, tested on the move's own end point.

        A shared transition's end differs from each of its moves' by rounding (its heading is the
        node heading, theirs heading + turn), and on a map whose edge and nodes fall on multiples
        of the margin an end can lie on the margin exactly (a 60-degree move of 3 km from the edge
        ends 1500 m from it). So the moves from nodes within a step and a margin of the edge are
        flown as :func:`lattice_moves` flies them and tested on their own ends.
        """
        model, settings = self.model, self.settings
        x_min, x_max, y_min, y_max = model.bounds
        m = settings.edge_margin_m

        def near(x: np.ndarray, y: np.ndarray) -> np.ndarray:
            return (x < x_min + m) | (x > x_max - m) | (y < y_min + m) | (y > y_max - m)

        move_near = near(ends[:, 0], ends[:, 1])[move_t]
        if not self._shared:
            return move_near
        x, y, h = starts[move_t[:, 0], 0], starts[move_t[:, 0], 1], self._node_headings()
        reach = m + model.limits.max_step_length + settings.spacing_m
        border = near(x, y) | (x < x_min + reach) | (x > x_max - reach) | (y < y_min + reach) | (y > y_max - reach)
        if border.any():
            z = starts[move_t[border, 0], 2]
            turns = np.asarray(settings.turns) * model.limits.dheading_max
            hb = h[border]
            _, own = _moves(
                model, settings, self.scenario_index, x[border, None], y[border, None], z[:, None], hb[:, None],
                wrap_angle(hb[:, None] + turns[None, :]),
            )  # fmt: skip
            move_near[border] = near(own[..., 0], own[..., 1])
        return move_near

    def _node_headings(self) -> np.ndarray:
        """(N,) each node's heading [rad], as :func:`lattice_nodes` spaces them."""
        _, _, headings = lattice_nodes(self.model, self.settings)
        return np.tile(headings, self._move_t.shape[0] // headings.size)

    def _price_all(self, clock: BuildClock) -> None:
        model, p = self.model, self.scenario_index
        rows = self._starts.shape[0]
        cost, terrain_n, third_n = np.empty(rows), np.empty(rows), np.empty(rows)
        reached, collided, outside = (np.empty(rows, dtype=np.bool_) for _ in range(3))
        per_radar = np.empty((rows, model.radar_slots))
        kernels.with_threads(
            model.threads, value_kernels.transition_costs,
            model.arrays, p, self._starts, self._ends, cost, reached, collided, outside, terrain_n, third_n, per_radar,
        )  # fmt: skip
        # A move that leaves the map or ends in its margin (without reaching the goal) is an edge
        # move: forbidden, and its node edge-doomed when no move is feasible.
        self._blocked = (outside[self._move_t] | self._move_near) & ~reached[self._move_t]
        self._forbidden = collided | outside
        self._reached, self._terrain_n, self._third_n, self._per_radar = reached, terrain_n, third_n, per_radar
        self._cost = cost
        terrain_doomed = np.all(~np.isfinite(cost[self._move_t]), axis=1) & ~np.any(self._blocked, axis=1)
        self._table = np.full(self._shape, np.inf)
        flat = self._table.reshape(-1)
        flat[terrain_doomed] = -np.inf
        flat[self._inside_goal] = 0.0  # the reference writes the goal's 0 last
        self._fixed = self._inside_goal | terrain_doomed
        self.changed_moves = rows
        clock.lap("costs")
        self._corner = np.empty((rows, value_kernels.CORNERS), dtype=np.int64)
        self._weight = np.empty((rows, value_kernels.CORNERS))
        kernels.with_threads(
            model.threads, value_kernels.stencils,
            self._shape, self._grid, self._ex, self._ey, self._eh, cost, reached, self._corner, self._weight,
        )  # fmt: skip
        corners = self._corner.reshape(-1)
        used = np.nonzero(corners >= 0)[0]
        # rev: each node's stencil slots (t CORNERS + s); users: each move's node moves (n A + a).
        self._rev_ptr, self._rev = value_kernels.grouped(corners[used], used, flat.size)
        self._users_ptr, self._users = value_kernels.grouped(self._move_t.reshape(-1), np.arange(self._move_t.size), rows)
        clock.lap("sweeps")

    def _first_pass(self) -> np.ndarray:
        """V's first guess, by the label-setting pass (value_kernels.settled_values), and the sweeps' order; every node starts dirty.

        DECISION (model.md §7e.2): the sweeps run in the reference's order (nodes by distance to
        the goal, alternating direction), not in the guess's settling order: consecutive nodes
        then lie side by side in memory, and a sweep ran about three times faster per node for
        about as many node updates (paper map: 1.01 M against 1.21 M).
        """
        value_kernels.settled_values(
            self._table, self._grid, self._cost, self._reached, self._corner, self._weight, self._move_t, self._blocked,
            self._fixed, self._users_ptr, self._users, self._rev_ptr, self._rev, SETTLED_SHARE,
        )  # fmt: skip
        xs, ys, _ = lattice_nodes(self.model, self.settings)
        nh = self._shape[2]
        node = np.arange(self._move_t.shape[0])
        goal = self.model.goal[self.scenario_index]
        distance = np.hypot(xs[node // (ys.size * nh)] - goal[0], ys[(node // nh) % ys.size] - goal[1])
        self._order = np.argsort(distance, kind="stable").astype(np.int64)
        self.sweeps = 0
        return ~self._fixed

    def _moved(self, old: np.ndarray, new: np.ndarray) -> np.ndarray:
        """The nodes whose value moved by more than the propagation threshold (or became finite)."""
        threshold = self.settings.tolerance * PROPAGATION_FRACTION
        both = np.isfinite(old) & np.isfinite(new)
        moved = np.where(both, np.abs(np.where(both, new, 0.0) - np.where(both, old, 0.0)) > threshold, np.isfinite(old) != np.isfinite(new))
        return np.nonzero(moved & ~self._fixed)[0].astype(np.int64)

    def _jacobi(self, new: np.ndarray) -> None:
        kernels.with_threads(
            self.model.threads, value_kernels.jacobi_pass,
            self._table, self._grid, self._cost, self._reached, self._corner, self._weight,
            self._move_t, self._blocked, self._fixed, new,
        )  # fmt: skip

    # --- solving -----------------------------------------------------------------------------

    def _converge(self, dirty: np.ndarray, clock: BuildClock) -> None:
        """Sweeps over the dirty nodes in order, then Jacobi checks until no node changes by more than the tolerance."""
        threshold = self.settings.tolerance * PROPAGATION_FRACTION
        flat = self._table.reshape(-1)
        new = np.empty(flat.size)
        while True:
            while dirty.any():
                value_kernels.dirty_sweep(
                    self._table, self._grid, self._cost, self._reached, self._corner, self._weight, self._move_t,
                    self._blocked, self._order, self.sweeps % 2 == 1, self._fixed, dirty, self._users_ptr, self._users, self._rev_ptr, self._rev, threshold,
                )  # fmt: skip
                self.sweeps += 1
                self._check_sweeps()
            self._jacobi(new)
            change = value_kernels.largest_change(flat, new)
            moved = self._moved(flat, new)
            flat[:] = new
            self.sweeps += 1
            if change <= self.settings.tolerance:
                break
            self._check_sweeps()
            value_kernels.dirty_upstream(moved, dirty, self._move_t.shape[1], self._users_ptr, self._users, self._rev_ptr, self._rev)
        clock.lap("sweeps")

    def _check_sweeps(self) -> None:
        if self.sweeps > self.settings.max_sweeps:
            raise RuntimeError(
                f"value iteration: no convergence to {self.settings.tolerance} in {self.settings.max_sweeps} sweeps "
                "(raise LatticeSettings.max_sweeps or tolerance)"
            )

    def _finish(self, clock: BuildClock) -> None:
        vf = ValueFunction(self._table, self._grid, self.settings, self.sweeps, 0.0, math.nan, 0)
        j_per_step, steps = _route_calibration(self.model, vf, self.scenario_index)
        clock.lap("route")
        self.cpu_seconds = dict(clock.cpu)
        self.wall_seconds = dict(clock.wall)
        self.value_function = ValueFunction(
            self._table.copy(), self._grid, self.settings, self.sweeps, sum(clock.wall.values()),
            j_per_step, steps, build_cpu_seconds=sum(clock.cpu.values()),
        )  # fmt: skip

    def arrays(self) -> dict[str, np.ndarray]:
        """The arrays :func:`value_function` caches (``cache.cached_arrays``, kind ``value``)."""
        vf = self.value_function
        return {
            "table": vf.table,
            "grid": vf.grid,
            "sweeps": np.array(vf.sweeps),
            "build_seconds": np.array(vf.build_seconds),
            "build_cpu_seconds": np.array(vf.build_cpu_seconds),
            "route": np.array([vf.route_j_per_step, vf.route_steps]),
        }

    # --- rebuilding after a change of radars ---------------------------------------------------

    def with_model(self, model: PenetrationModel) -> ValueFunctionBuilder:
        """The builder of the same member of ``model``: incremental when only its radars differ, else built afresh.

        Radars are matched by position, reference range and RCS and masking floor; only the
        unmatched radars' threats are computed, and V re-converges from this builder's V.
        """
        if not _same_except_radars(self.model, model, self.scenario_index):
            return ValueFunctionBuilder(model, self.scenario_index, self.settings)
        return ValueFunctionBuilder(model, self.scenario_index, self.settings, _previous=self)

    def with_radars(self, radars: Sequence[Radar]) -> ValueFunctionBuilder:
        """The builder after the scenario's radars become ``radars`` (a single-scenario model; its threads kept).

        Raises:
            ValueError: a pool model (build its new pool and call :meth:`with_model`).
        """
        if self.model.pool_size != 1:
            raise ValueError(f"with_radars: got a pool of {self.model.pool_size} scenarios, expected one (use with_model)")
        scenario = dataclasses.replace(self.model.scenario, radars=tuple(radars))
        return self.with_model(PenetrationModel(scenario, threads=self.model.threads))

    def _inherit(self, old: ValueFunctionBuilder) -> None:
        for name in (
            "_starts", "_ends", "_move_t", "_shared", "_ex", "_ey", "_eh", "_shape", "_grid", "_move_near", "_blocked", "_inside_goal",
            "_forbidden", "_reached", "_terrain_n", "_third_n", "_rev_ptr", "_rev", "_users_ptr", "_users", "_fixed",
            "_corner", "_weight",
        ):  # fmt: skip
            setattr(self, name, getattr(old, name))  # read-only after a build: shared, not copied
        self._order = old._order
        self._table = old._table.copy()
        self.sweeps = 0

    def _reprice(self, old: ValueFunctionBuilder, clock: BuildClock) -> np.ndarray:
        """The new radars' threats, the moves' new J, and the nodes to re-evaluate (those with a re-priced move)."""
        model, p = self.model, self.scenario_index
        per_radar = np.zeros((self._starts.shape[0], model.radar_slots))
        taken: set[int] = set()
        for j in range(model.radar_slots):
            if model.arrays.radar_present[p, j] != 1.0:
                continue  # an empty slot's threat is 0 (its visibility is multiplied by 0)
            match = next(
                (i for i in range(old.model.radar_slots) if i not in taken and _same_radar(old.model, i, model, j, p)),
                None,
            )
            if match is None:
                kernels.with_threads(model.threads, value_kernels.radar_column, model.arrays, p, j, self._ends, per_radar[:, j])
            else:
                taken.add(match)
                per_radar[:, j] = old._per_radar[:, match]
        self._per_radar = per_radar
        cost = np.empty(per_radar.shape[0])
        kernels.with_threads(
            model.threads, value_kernels.fused_costs,
            model.arrays, per_radar, self._terrain_n, self._third_n, self._forbidden, cost,
        )  # fmt: skip
        self._cost = cost
        changed = np.nonzero(cost != old._cost)[0].astype(np.int64)
        self.changed_moves = int(changed.size)
        clock.lap("costs")
        dirty = np.zeros(self._move_t.shape[0], dtype=np.bool_)
        value_kernels.dirty_users(changed, dirty, self._move_t.shape[1], self._users_ptr, self._users)
        return dirty


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
        return build_arrays(model, settings, int(scenario_index))

    arrays = cached_arrays("value", inputs, build)
    vf = ValueFunction(
        table=arrays["table"],
        grid=arrays["grid"],
        settings=settings,
        sweeps=int(arrays["sweeps"]),
        build_seconds=float(arrays["build_seconds"]) if built_now else 0.0,
        build_cpu_seconds=float(arrays["build_cpu_seconds"]) if built_now else 0.0,
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
    "DEFINITION_VERSION",
    "LATTICE_DEFAULTS",
    "LATTICE_GUIDANCE",
    "BuildClock",
    "LatticeGuidance",
    "LatticeSettings",
    "ValueFunction",
    "ValueFunctionBuilder",
    "build_arrays",
    "lattice_action",
    "lattice_moves",
    "lattice_nodes",
    "move_costs",
    "terrain_following_dtheta",
    "value_function",
]
