"""Compiled kernels of the lattice value function's builder (model.md §7e.2).

The lattice's distinct transitions are scored once each by the model's own transition
(:func:`kernels.transition`), keeping each radar's threat so that a changed radar can be re-priced
alone; value iteration runs as Gauss-Seidel sweeps in the order of a nearest-node Dijkstra guess
of V, each over the dirty nodes only (a node is re-evaluated only when one of its moves'
interpolation corners changed, or its move costs did), then is checked by full Jacobi passes of
the Bellman operator with the reference iteration's stopping rule. Every
relation (a transition's J, the fusion of radars, V between nodes) is the one of
:mod:`uav_penetration_env.kernels` and :mod:`uav_penetration_env.terminal_kernels`.
"""

from __future__ import annotations

import heapq
import math

import numpy as np
from numba import njit, prange

from uav_penetration_env import compile_cache  # noqa: F401  (numba's cache folder, before any compiled function)
from uav_penetration_env.kernels import (
    F_COLLIDED,
    F_OUT_OF_AREA,
    F_REACHED,
    N_FLAGS,
    N_SCALARS,
    O_FUSION,
    S_J,
    S_TERRAIN_N,
    S_THIRD_N,
    fuse,
    radar_threat,
    transition,
    weighted_cost,
)
from uav_penetration_env.terminal_kernels import G_DX, G_DY, G_MISSING, G_X0, G_Y0, value_lookup

_BLOCK = 2048  # rows per parallel block (scratch arrays allocated once per block)


@njit(parallel=True, cache=True)
def transition_costs(arrays, p, starts, ends, cost, reached, collided, outside, terrain_n, third_n, per_radar):
    """Score (T,) lattice transitions with the model's own J (model.md §7a), keeping each radar's threat.

    Args:
        arrays: the model's :class:`kernels.ModelArrays`.
        p: the pool member.
        starts: (T, 6) states before the moves.
        ends: (T, 6) states after them.
        cost: (T,) out: J, ``inf`` for a move that collides or leaves the map (or the ceiling).
        reached: (T,) out: whether the move reaches the goal.
        collided: (T,) out: whether it collides.
        outside: (T,) out: whether it leaves the map or breaks the ceiling.
        terrain_n: (T,) out: the normalised terrain term.
        third_n: (T,) out: the normalised third term.
        per_radar: (T, M) out: each radar's threat at the end state.
    """
    rows = starts.shape[0]
    radars = per_radar.shape[1]
    blocks = (rows + _BLOCK - 1) // _BLOCK
    for block in prange(blocks):
        visible = np.empty(radars)
        scalars = np.empty(N_SCALARS)
        flags = np.empty(N_FLAGS, dtype=np.bool_)
        for t in range(block * _BLOCK, min(rows, (block + 1) * _BLOCK)):
            transition(arrays, p, starts[t], ends[t], 1, per_radar[t], visible, scalars, flags)
            collided[t] = flags[F_COLLIDED]
            outside[t] = flags[F_OUT_OF_AREA]
            reached[t] = flags[F_REACHED]
            cost[t] = math.inf if flags[F_COLLIDED] or flags[F_OUT_OF_AREA] else scalars[S_J]
            terrain_n[t] = scalars[S_TERRAIN_N]
            third_n[t] = scalars[S_THIRD_N]


@njit(parallel=True, cache=True)
def radar_column(arrays, p, m, ends, out):
    """(T,) radar ``m``'s threat at each end state (:func:`kernels.radar_threat`, as the transition prices it)."""
    for t in prange(ends.shape[0]):
        heading = ends[t, 4]
        pitch = ends[t, 5]
        threat, _ = radar_threat(
            arrays, p, m, ends[t, 0], ends[t, 1], ends[t, 2],
            math.cos(heading), math.sin(heading), math.cos(pitch), math.sin(pitch),
        )  # fmt: skip
        out[t] = threat


@njit(parallel=True, cache=True)
def fused_costs(arrays, per_radar, terrain_n, third_n, forbidden, cost):
    """(T,) J from the kept terms and a new set of radar threats (fusion and weights as :func:`kernels.transition`)."""
    params = arrays.params
    rule = arrays.options[O_FUSION]
    for t in prange(per_radar.shape[0]):
        if forbidden[t]:
            cost[t] = math.inf
        else:
            _, j = weighted_cost(params, terrain_n[t], fuse(per_radar[t], rule), third_n[t])
            cost[t] = j


@njit(inline="always", cache=True)
def _q_value(table, grid, cost, reached, ex, ey, eh, t):
    """A move's cost plus V after it (0 after reaching the goal; ``inf`` for a forbidden move)."""
    c = cost[t]
    if c == math.inf:
        return math.inf
    if reached[t]:
        return c
    return c + value_lookup(table, grid, ex[t], ey[t], eh[t], math.inf)


@njit(inline="always", cache=True)
def _node_value(q, move_t, blocked, n, cap):
    """The least q over the node's moves (``blocked`` ones left out), capped at the crash price (value_function.value_iteration)."""
    best = math.inf
    for a in range(move_t.shape[1]):
        if blocked[n, a]:
            continue
        v = q[move_t[n, a]]
        if v < best:
            best = v
    if best < math.inf and best > cap:
        best = cap
    return best


@njit(parallel=True, cache=True)
def jacobi_pass(table, grid, cost, reached, ex, ey, eh, move_t, blocked, fixed, q, new):
    """One Jacobi application of the Bellman operator: q (T,) of every move, then new (N,) of every node.

    ``fixed`` nodes (inside the goal disc, or terrain-doomed) keep their value; ``blocked`` (N, A)
    moves (ending in the edge margin) are left out.
    """
    for t in prange(cost.shape[0]):
        q[t] = _q_value(table, grid, cost, reached, ex, ey, eh, t)
    flat = table.reshape(-1)
    cap = grid[G_MISSING]
    for n in prange(move_t.shape[0]):
        new[n] = flat[n] if fixed[n] else _node_value(q, move_t, blocked, n, cap)


@njit(cache=True)
def largest_change(old, new):
    """The reference iteration's convergence measure: the largest |new - old|, ``inf`` where a node became finite."""
    change = 0.0
    for n in range(old.shape[0]):
        if new[n] < math.inf:
            if old[n] == math.inf:
                return math.inf
            delta = abs(new[n] - old[n])
            if delta > change:
                change = delta
    return change


@njit(cache=True)
def corner_lists(table_shape, grid, ex, ey, eh, cost, reached):
    """For each move t (T,), the flat lattice nodes its end pose interpolates over: (T, 8), -1 where unused.

    A forbidden move, one that reaches the goal, or an end pose off the lattice uses none. The
    corners are those :func:`terminal_kernels.value_lookup` weighs (weight > 0).
    """
    nx, ny, nh = table_shape
    out = np.full((ex.shape[0], 8), -1, dtype=np.int64)
    two_pi = 2.0 * math.pi
    for t in range(ex.shape[0]):
        if cost[t] == math.inf or reached[t]:
            continue
        fx = (ex[t] - grid[G_X0]) / grid[G_DX]
        fy = (ey[t] - grid[G_Y0]) / grid[G_DY]
        if not (fx >= 0.0 and fx <= nx - 1.0 and fy >= 0.0 and fy <= ny - 1.0):
            continue
        i0 = min(int(fx), nx - 2)
        j0 = min(int(fy), ny - 2)
        tx = fx - i0
        ty = fy - j0
        fh = (eh[t] % two_pi) * nh / two_pi
        k0 = int(fh)
        th = fh - k0
        k0 = k0 % nh
        k1 = (k0 + 1) % nh
        c = 0
        for di in range(2):
            wx = tx if di == 1 else 1.0 - tx
            for dj in range(2):
                wy = ty if dj == 1 else 1.0 - ty
                for dk in range(2):
                    wh = th if dk == 1 else 1.0 - th
                    if wx * wy * wh <= 0.0:
                        continue
                    out[t, c] = ((i0 + di) * ny + (j0 + dj)) * nh + (k1 if dk == 1 else k0)
                    c += 1
    return out


@njit(cache=True)
def nearest_values(table_shape, grid, cost, reached, ex, ey, eh, move_t, users_ptr, users, fixed, inside_goal):
    """(N,) a first guess of V: exact shortest paths when each move ends at its nearest node (Dijkstra).

    Only an order for the sweeps (their nodes of lowest guess first): the sweeps' values start from
    ``inf`` as the reference iteration's do. Nodes no path reaches keep ``inf``.
    """
    nx, ny, nh = table_shape
    nodes = move_t.shape[0]
    rows = cost.shape[0]
    succ = np.full(rows, -1, dtype=np.int64)
    two_pi = 2.0 * math.pi
    for t in range(rows):
        if cost[t] == math.inf or reached[t]:
            continue
        fx = (ex[t] - grid[G_X0]) / grid[G_DX]
        fy = (ey[t] - grid[G_Y0]) / grid[G_DY]
        if not (fx >= 0.0 and fx <= nx - 1.0 and fy >= 0.0 and fy <= ny - 1.0):
            continue
        fh = (eh[t] % two_pi) * nh / two_pi
        succ[t] = ((int(fx + 0.5)) * ny + int(fy + 0.5)) * nh + int(fh + 0.5) % nh
    count = np.zeros(nodes + 1, dtype=np.int64)
    for t in range(rows):
        if succ[t] >= 0:
            count[succ[t] + 1] += 1
    for n in range(nodes):
        count[n + 1] += count[n]
    fill = count[:-1].copy()
    pred = np.empty(count[nodes], dtype=np.int64)
    for t in range(rows):
        if succ[t] >= 0:
            pred[fill[succ[t]]] = t
            fill[succ[t]] += 1
    dist = np.full(nodes, math.inf)
    for n in range(nodes):
        if inside_goal[n]:
            dist[n] = 0.0
    for t in range(rows):
        if reached[t] and cost[t] < math.inf:
            for s in range(users_ptr[t], users_ptr[t + 1]):
                u = users[s]
                if not fixed[u] and cost[t] < dist[u]:
                    dist[u] = cost[t]
    heap = [(dist[n], n) for n in range(nodes) if dist[n] < math.inf]
    heapq.heapify(heap)
    while len(heap) > 0:
        d, n = heapq.heappop(heap)
        if d != dist[n]:
            continue
        for r in range(count[n], count[n + 1]):
            t = pred[r]
            candidate = cost[t] + d
            for s in range(users_ptr[t], users_ptr[t + 1]):
                u = users[s]
                if not fixed[u] and candidate < dist[u]:
                    dist[u] = candidate
                    heapq.heappush(heap, (candidate, u))
    return dist


@njit(cache=True)
def dirty_sweep(
    table, grid, cost, reached, ex, ey, eh, move_t, blocked, order, fixed, dirty, users_ptr, users, rev_ptr, rev, threshold
):
    """A Gauss-Seidel sweep in ``order`` over the dirty nodes only; returns (the reference's change measure, nodes updated).

    Each dirty node takes its Bellman update (its ``blocked`` moves left out) and is cleaned; a node
    whose value moved by more than ``threshold`` (``inf`` counting as the crash price, as the
    interpolation reads it) dirties every node with a move whose end pose interpolates over it,
    later in this sweep or in the next.
    """
    flat = table.reshape(-1)
    cap = grid[G_MISSING]
    change = 0.0
    updated = 0
    nodes = order.shape[0]
    for position in range(nodes):
        n = order[position]
        if not dirty[n]:
            continue
        dirty[n] = False
        if fixed[n]:
            continue
        updated += 1
        best = math.inf
        for a in range(move_t.shape[1]):
            if blocked[n, a]:
                continue
            v = _q_value(table, grid, cost, reached, ex, ey, eh, move_t[n, a])
            if v < best:
                best = v
        if best < math.inf and best > cap:
            best = cap
        old = flat[n]
        if best < math.inf:
            if old == math.inf:
                change = math.inf
            else:
                delta = abs(best - old)
                if delta > change:
                    change = delta
        flat[n] = best
        seen_old = cap if old == math.inf else old
        seen_new = cap if best == math.inf else best
        if abs(seen_new - seen_old) > threshold:
            for r in range(rev_ptr[n], rev_ptr[n + 1]):
                t = rev[r]
                for s in range(users_ptr[t], users_ptr[t + 1]):
                    dirty[users[s]] = True
    return change, updated


@njit(cache=True)
def dirty_upstream(nodes, dirty, users_ptr, users, rev_ptr, rev):
    """Mark ``nodes`` and every node with a move whose end pose interpolates over one of them dirty."""
    for i in range(nodes.shape[0]):
        n = nodes[i]
        dirty[n] = True
        for r in range(rev_ptr[n], rev_ptr[n + 1]):
            t = rev[r]
            for s in range(users_ptr[t], users_ptr[t + 1]):
                dirty[users[s]] = True


@njit(cache=True)
def dirty_users(changed, dirty, users_ptr, users):
    """Mark the nodes that have one of the moves ``changed`` dirty."""
    for i in range(changed.shape[0]):
        t = changed[i]
        for s in range(users_ptr[t], users_ptr[t + 1]):
            dirty[users[s]] = True


@njit(cache=True)
def grouped(keys, values, size):
    """(ptr (size + 1,), values grouped by key in their given order): a counting sort (keys in [0, size))."""
    ptr = np.zeros(size + 1, dtype=np.int64)
    for i in range(keys.shape[0]):
        ptr[keys[i] + 1] += 1
    for k in range(size):
        ptr[k + 1] += ptr[k]
    fill = ptr[:-1].copy()
    out = np.empty(keys.shape[0], dtype=np.int64)
    for i in range(keys.shape[0]):
        out[fill[keys[i]]] = values[i]
        fill[keys[i]] += 1
    return ptr, out
