"""The MPC window's terminal cost, compiled: the record the rollout kernel reads and its scalar functions (model.md §7e).

The terminal cost (its setting, its forms and how one is built on a scenario:
:mod:`uav_penetration_env.terminal`) reaches the rollout kernel as a :class:`TerminalCost`. This
module holds that record, its check, and the compiled scalar functions that evaluate it, below the
model (the kernels import them); the four forms a window's end state can be priced by:

========  =====  ==================================================================================
form      kind   terminal cost of an end state (x, y, psi)
========  =====  ==================================================================================
none      0      0 (the paper's literal eq. 37)
distance  1      c_T d_goal / (v_max dt): the straight-line steps left, c_T each
dubins    2      c_T L_dubins / (v_max dt): the steps of the shortest forward path at the turning
                 radius v_max dt / dphi_max (a circle arc, then a straight line to the goal)
value     3      V(x, y, psi): the lattice value function, the cheapest cost to the goal over a
                 lattice of positions and headings whose moves are the model's own transitions
========  =====  ==================================================================================

The same scalar functions serve the rollout kernel (``kernels.rollout_batch``), the value
iteration that builds V (``value_function.value_iteration``) and the lattice planner. V is built
by :mod:`uav_penetration_env.value_function`; a :class:`TerminalCost` by
:func:`uav_penetration_env.terminal.terminal_cost`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from uav_penetration_env import compile_cache  # noqa: F401  (numba's cache folder, before any compiled function)
from uav_penetration_env.types import TERMINAL_FORMS  # the kernels' codes of the forms

# Slots of TerminalCost.grid (float64): the value table's lattice and its fallback.
G_X0, G_Y0, G_DX, G_DY, G_MISSING, G_STEP_LENGTH, G_TURN_RADIUS, N_GRID = range(8)


class TerminalCost(NamedTuple):
    """The terminal cost of MPC windows, built on a scenario, as the rollout kernel reads it (model.md §7e).

    Built by :func:`uav_penetration_env.terminal.terminal_cost` from a
    :class:`~uav_penetration_env.mpc.Terminal`; :data:`NO_TERMINAL_COST` is the ``none`` form.

    Attributes:
        kind: the form's code in :data:`TERMINAL_FORMS` (int).
        scale: c_T for ``distance`` and ``dubins`` [J per step]; 1 for ``value``.
        table: (nx, ny, nh) V on the lattice nodes, ``inf`` where no move sequence reaches the
            goal; a (1, 1, 1) placeholder for the other forms.
        grid: (N_GRID,) float slots ``G_*``: lattice origin and spacing [m], the value taken where
            no lattice corner around a point is finite, the step length v_max dt [m] and the
            turning radius v_max dt / dphi_max [m].
    """

    kind: int
    scale: float
    table: np.ndarray
    grid: np.ndarray


# The terminal cost of a window priced by nothing (the ``none`` form): rollout_cost's default.
NO_TERMINAL_COST = TerminalCost(0, 0.0, np.zeros((1, 1, 1)), np.zeros(N_GRID))


def checked_terminal(terminal: TerminalCost) -> TerminalCost:
    """``terminal`` with its fields as the kernel reads them (int kind, float scale, contiguous float64 arrays).

    Raises:
        ValueError: an unknown kind, a negative or non-finite scale, a table that is not 3-D, or a
            grid of the wrong length.
    """
    kind = terminal.kind
    if not (isinstance(kind, (int, np.integer)) and int(kind) in TERMINAL_FORMS.values()):
        raise ValueError(f"terminal_cost.kind: got {kind!r}, expected one of {sorted(TERMINAL_FORMS.values())}")
    scale = float(terminal.scale)
    if not (math.isfinite(scale) and scale >= 0.0):
        raise ValueError(f"terminal_cost.scale: got {terminal.scale!r}, expected a finite number >= 0")
    table = np.ascontiguousarray(terminal.table, dtype=np.float64)
    if table.ndim != 3 or min(table.shape) < 1 or (int(kind) == 3 and min(table.shape[:2]) < 2):
        raise ValueError(f"terminal_cost.table: got shape {table.shape}, expected (nx >= 2, ny >= 2, nh >= 1)")
    grid = np.ascontiguousarray(terminal.grid, dtype=np.float64)
    if grid.shape != (N_GRID,):
        raise ValueError(f"terminal_cost.grid: got shape {grid.shape}, expected ({N_GRID},)")
    needed = {1: (G_STEP_LENGTH,), 2: (G_STEP_LENGTH, G_TURN_RADIUS), 3: (G_DX, G_DY)}.get(int(kind), ())
    for slot in needed:
        if not (math.isfinite(grid[slot]) and grid[slot] > 0.0):
            raise ValueError(f"terminal_cost.grid[{slot}]: got {grid[slot]!r}, expected a finite length > 0 [m]")
    return TerminalCost(int(kind), scale, table, grid)


@njit(inline="always", cache=True)
def dubins_length(x, y, heading, goal_x, goal_y, radius):
    """Arc-then-tangent path length [m] from a pose to a point at turning radius ``radius`` (model.md §7e.1).

    For each turn direction s (+1 left, -1 right) the turning circle is centred at
    c = p + s R (-sin psi, cos psi); when the goal lies outside it at distance d from c, the path
    is the arc to the tangent point (angle beta - s acos(R/d) on the circle, beta the bearing of
    the goal from c) followed by the tangent of length sqrt(d^2 - R^2). The shorter direction wins;
    the goal cannot lie inside both circles unless it is the start itself (length 0).
    """
    best = math.inf
    for side in (1.0, -1.0):
        cx = x - side * radius * math.sin(heading)
        cy = y + side * radius * math.cos(heading)
        dx = goal_x - cx
        dy = goal_y - cy
        d = math.hypot(dx, dy)
        if d < radius:
            continue
        tangent = math.sqrt(max(d * d - radius * radius, 0.0))
        start_angle = heading - side * 0.5 * math.pi
        touch_angle = math.atan2(dy, dx) - side * math.acos(min(radius / max(d, 1e-300), 1.0))
        arc = (side * (touch_angle - start_angle)) % (2.0 * math.pi)
        length = radius * arc + tangent
        if length < best:
            best = length
    if best == math.inf:
        return math.hypot(goal_x - x, goal_y - y)
    return best


@njit(inline="always", cache=True)
def lattice_cell(nx, ny, nh, grid, x, y, heading):
    """The lattice cell a pose falls in and its place in it (the interpolation of :func:`value_lookup`).

    Args:
        nx: the lattice's node count in x.
        ny: its node count in y.
        nh: its node count in heading.
        grid: the lattice slots ``G_*`` (origin and spacing [m]).
        x: the position's x [m].
        y: its y [m].
        heading: the heading [rad], any real (periodic).

    Returns:
        (inside, i0, j0, k0, k1, tx, ty, th): whether (x, y) lies on the lattice; the cell's lower
        x and y node indices and its two heading indices (k1 = k0 + 1, periodic); the fractions
        tx, ty, th in [0, 1] from the lower nodes. The eight corners (i0 + di, j0 + dj, k0 or k1)
        weigh (tx or 1 - tx) (ty or 1 - ty) (th or 1 - th), in that order of factors.
    """
    fx = (x - grid[G_X0]) / grid[G_DX]
    fy = (y - grid[G_Y0]) / grid[G_DY]
    if not (fx >= 0.0 and fx <= nx - 1.0 and fy >= 0.0 and fy <= ny - 1.0):
        return False, 0, 0, 0, 0, 0.0, 0.0, 0.0
    i0 = min(int(fx), nx - 2)
    j0 = min(int(fy), ny - 2)
    fh = (heading % (2.0 * math.pi)) * nh / (2.0 * math.pi)
    k0 = int(fh)
    th = fh - k0
    k0 = k0 % nh
    return True, i0, j0, k0, (k0 + 1) % nh, fx - i0, fy - j0, th


@njit(inline="always", cache=True)
def value_lookup(table, grid, x, y, heading, empty):
    """V at a continuous pose: bilinear in (x, y), linear and periodic in the heading.

    Nodes no route leaves are of two kinds (DECISION, model.md §7e.2). ``+inf``: every move leaves
    the map or ends in its edge margin; such a corner counts as ``grid[G_MISSING]`` (the price of a
    crash), so a pose between a feasible and an edge-doomed node pays its share of the doom and
    interpolation never lends a cornered pose its neighbours' value. ``-inf``: every move clips the
    terrain at the lattice's clearance; such a corner is left out and the others' weights
    renormalised, since a flight above the lattice's height may still pass there. A pose outside
    the lattice, or with no usable corner, gets ``empty``.
    """
    inside, i0, j0, k0, k1, tx, ty, th = lattice_cell(table.shape[0], table.shape[1], table.shape[2], grid, x, y, heading)
    if not inside:
        return empty
    missing = grid[G_MISSING]
    total = 0.0
    weights = 0.0
    for di in range(2):
        wx = tx if di == 1 else 1.0 - tx
        for dj in range(2):
            wy = ty if dj == 1 else 1.0 - ty
            for dk in range(2):
                wh = th if dk == 1 else 1.0 - th
                w = wx * wy * wh
                if w <= 0.0:
                    continue
                v = table[i0 + di, j0 + dj, k1 if dk == 1 else k0]
                if v == -math.inf:
                    continue
                total += w * (v if v < math.inf else missing)
                weights += w
    if weights <= 1e-12:
        return empty
    return total / weights


@njit(inline="always", cache=True)
def terminal_value(terminal, x, y, heading, goal_x, goal_y):
    """The terminal cost of a window that ends at (x, y, heading) still flying (see the module table)."""
    kind = terminal.kind
    grid = terminal.grid
    if kind == 1:
        return terminal.scale * math.hypot(goal_x - x, goal_y - y) / grid[G_STEP_LENGTH]
    if kind == 2:
        length = dubins_length(x, y, heading, goal_x, goal_y, grid[G_TURN_RADIUS])
        return terminal.scale * length / grid[G_STEP_LENGTH]
    if kind == 3:
        return terminal.scale * value_lookup(terminal.table, grid, x, y, heading, grid[G_MISSING])
    return 0.0
