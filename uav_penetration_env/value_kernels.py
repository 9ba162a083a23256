"""Compiled kernels of the lattice value function's builder (model.md §7e.2).

The lattice's distinct transitions are scored once each by the model's own transition
(:func:`kernels.transition`), keeping each radar's threat so that a changed radar can be re-priced
alone; each move's interpolation corners and weights are computed once (its stencil); a
label-setting pass from the goal outward gives V's first guess, and value iteration runs as
Gauss-Seidel sweeps in the reference's order (alternating direction), each over the dirty nodes only (a node is re-evaluated only when one of its moves'
interpolation corners changed, or its move costs did), then is checked by full Jacobi passes of
the Bellman operator with the reference iteration's stopping rule. Every
relation (a transition's J, the fusion of radars, V between nodes) is the one of
:mod:`uav_penetration_env.kernels` and :mod:`uav_penetration_env.terminal_kernels`.
"""

from __future__ import annotations

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
from uav_penetration_env.terminal_kernels import G_MISSING, lattice_cell

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


CORNERS = 8  # the most interpolation corners of an end pose (2 x 2 positions x 2 headings)


@njit(parallel=True, cache=True)
def stencils(table_shape, grid, ex, ey, eh, cost, reached, corner, weight):
    """Each move's interpolation corners and their weights, once, as :func:`terminal_kernels.value_lookup` weighs them.

    Args:
        table_shape: (nx, ny, nh) the lattice.
        grid: the lattice slots ``G_*``.
        ex: (T,) the moves' end x [m].
        ey: (T,) their end y [m].
        eh: (T,) their end heading [rad].
        cost: (T,) J (``inf``: forbidden, then the move uses no corner).
        reached: (T,) whether the move reaches the goal (then it uses no corner; nor does an end
            pose off the lattice).
        corner: (T, CORNERS) out: flat nodes with weight > 0, in value_lookup's order, then -1.
        weight: (T, CORNERS) out: their weights (0 after the last corner).
    """
    nx, ny, nh = table_shape
    for t in prange(ex.shape[0]):
        for c in range(CORNERS):
            corner[t, c] = -1
            weight[t, c] = 0.0
        if cost[t] == math.inf or reached[t]:
            continue
        inside, i0, j0, k0, k1, tx, ty, th = lattice_cell(nx, ny, nh, grid, ex[t], ey[t], eh[t])
        if not inside:
            continue
        c = 0
        for di in range(2):
            wx = tx if di == 1 else 1.0 - tx
            for dj in range(2):
                wy = ty if dj == 1 else 1.0 - ty
                for dk in range(2):
                    wh = th if dk == 1 else 1.0 - th
                    w = wx * wy * wh
                    if w <= 0.0:
                        continue
                    corner[t, c] = ((i0 + di) * ny + (j0 + dj)) * nh + (k1 if dk == 1 else k0)
                    weight[t, c] = w
                    c += 1


@njit(inline="always", cache=True)
def _q_value(flat, cost, reached, corner, weight, t, missing):
    """A move's cost plus V after it, from its stencil: the arithmetic of value_lookup (``inf`` for a forbidden move or no usable corner)."""
    c = cost[t]
    if c == math.inf:
        return math.inf
    if reached[t]:
        return c
    total = 0.0
    weights = 0.0
    for s in range(CORNERS):
        n = corner[t, s]
        if n < 0:
            break
        v = flat[n]
        if v == -math.inf:
            continue
        w = weight[t, s]
        total += w * (v if v < math.inf else missing)
        weights += w
    if weights <= 1e-12:
        return math.inf
    return c + total / weights


@njit(inline="always", cache=True)
def capped(best, cap):
    """A node's Bellman value: no pose costs more than a crash (a walled-in region converges to that price)."""
    if best < math.inf and best > cap:
        return cap
    return best


@njit(inline="always", cache=True)
def changed_by(change, old, new):
    """The reference's convergence measure after one update: the larger of ``change`` and |new - old| (``inf`` where a node became finite)."""
    if new < math.inf:
        if old == math.inf:
            return math.inf
        delta = abs(new - old)
        if delta > change:
            return delta
    return change


@njit(inline="always", cache=True)
def _node_value(flat, cost, reached, corner, weight, move_t, blocked, n, cap):
    """The least q over the node's moves (``blocked`` ones left out), capped at the crash price (value_function.value_iteration)."""
    best = math.inf
    for a in range(move_t.shape[1]):
        if blocked[n, a]:
            continue
        v = _q_value(flat, cost, reached, corner, weight, move_t[n, a], cap)
        if v < best:
            best = v
    return capped(best, cap)


@njit(parallel=True, cache=True)
def jacobi_pass(table, grid, cost, reached, corner, weight, move_t, blocked, fixed, new):
    """One Jacobi application of the Bellman operator: new (N,) of every node from ``table``.

    ``fixed`` nodes (inside the goal disc, or terrain-doomed) keep their value; ``blocked`` (N, A)
    moves (ending in the edge margin) are left out.
    """
    flat = table.reshape(-1)
    cap = grid[G_MISSING]
    for n in prange(move_t.shape[0]):
        new[n] = flat[n] if fixed[n] else _node_value(flat, cost, reached, corner, weight, move_t, blocked, n, cap)


@njit(cache=True)
def largest_change(old, new):
    """The reference iteration's convergence measure: the largest |new - old|, ``inf`` where a node became finite."""
    change = 0.0
    for n in range(old.shape[0]):
        change = changed_by(change, old[n], new[n])
    return change


@njit(inline="always", cache=True)
def _sift_up(heap, where, key, i):
    """Move heap[i] toward the root of the binary min-heap of nodes ``heap`` (by ``key``); ``where`` is each node's slot."""
    n = heap[i]
    k = key[n]
    while i > 0:
        parent = (i - 1) >> 1
        p = heap[parent]
        if key[p] <= k:
            break
        heap[i] = p
        where[p] = i
        i = parent
    heap[i] = n
    where[n] = i


@njit(inline="always", cache=True)
def _sift_down(heap, where, key, size, i):
    """Move heap[i] toward the leaves of the binary min-heap of the first ``size`` nodes of ``heap`` (by ``key``)."""
    n = heap[i]
    k = key[n]
    while True:
        child = 2 * i + 1
        if child >= size:
            break
        if child + 1 < size and key[heap[child + 1]] < key[heap[child]]:
            child += 1
        c = heap[child]
        if key[c] >= k:
            break
        heap[i] = c
        where[c] = i
        i = child
    heap[i] = n
    where[n] = i


@njit(cache=True)
def _settled_from_the_start(flat, fixed, blocked, cost, move_t):
    """(N,) the nodes settled before the pass: fixed ones, and those whose every move is forbidden (set to ``inf``)."""
    nodes, moves = move_t.shape
    settled = np.zeros(nodes, dtype=np.bool_)
    for n in range(nodes):
        if fixed[n]:
            settled[n] = True
            continue
        dead = True
        for a in range(moves):
            if not blocked[n, a] and cost[move_t[n, a]] < math.inf:
                dead = False
        if dead:
            settled[n] = True
            flat[n] = math.inf
    return settled


@njit(cache=True)
def _settled_corner_sums(flat, settled, corner, weight, share, cap):
    """Per move: the weighted sum and weight of its settled corners, and the weight it needs settled to count."""
    rows = corner.shape[0]
    total = np.zeros(rows)
    weights = np.zeros(rows)
    needed = np.zeros(rows)
    for t in range(rows):
        for s in range(CORNERS):
            n = corner[t, s]
            if n < 0:
                break
            if flat[n] != -math.inf:
                needed[t] += share * weight[t, s]
            if settled[n] and flat[n] != -math.inf:
                total[t] += weight[t, s] * (flat[n] if flat[n] < math.inf else cap)
                weights[t] += weight[t, s]
    return total, weights, needed


@njit(cache=True)
def _heap_of_finite_keys(key):
    """An indexed binary min-heap of the nodes with a finite key: (heap, position of each node or -1, size)."""
    nodes = key.size
    heap = np.empty(nodes, dtype=np.int64)
    where = np.full(nodes, -1, dtype=np.int64)
    size = 0
    for n in range(nodes):
        if key[n] < math.inf:
            heap[size] = n
            where[n] = size
            size += 1
    for i in range(size // 2 - 1, -1, -1):
        _sift_down(heap, where, key, size, i)
    return heap, where, size


@njit(cache=True)
def _least_settled_q(n, move_t, blocked, cost, reached, total, weights, needed):
    """The least q over node ``n``'s moves that reach the goal or have enough settled corner weight (``inf``: none)."""
    best = math.inf
    for a in range(move_t.shape[1]):
        t = move_t[n, a]
        if blocked[n, a] or cost[t] == math.inf:
            continue
        if reached[t]:
            q = cost[t]
        elif weights[t] > 1e-12 and weights[t] >= needed[t]:
            q = cost[t] + total[t] / weights[t]
        else:
            continue
        if q < best:
            best = q
    return best


@njit(cache=True)
def settled_values(table, grid, cost, reached, corner, weight, move_t, blocked, fixed, users_ptr, users, rev_ptr, rev, share):
    """A label-setting first pass (Dijkstra from the goal outward): V's first guess (in ``table``) and the order nodes settled in.

    Nodes settle in order of their tentative value. A move's q is its cost plus the weighted mean
    of its stencil's corners settled so far (running sums, so each settling costs the moves that
    interpolate over the node); the nodes with that move lower their tentative value to it. A node
    takes, when it settles, the least q of its moves at that moment (capped at the crash price).
    Fixed nodes (goal disc, terrain-doomed) and nodes whose every move is forbidden or blocked
    (edge-doomed, ``inf``) count as settled from the start. The guess is exact where every corner
    a node's best move reads settled before it; elsewhere the sweeps correct it.

    Returns:
        (N,) the nodes in settling order (those settled from the start first, those never reached,
        ``inf``, last).
    """
    flat = table.reshape(-1)
    nodes, moves = move_t.shape
    rows = cost.shape[0]
    cap = grid[G_MISSING]
    settled = _settled_from_the_start(flat, fixed, blocked, cost, move_t)
    total, weights, needed = _settled_corner_sums(flat, settled, corner, weight, share, cap)
    key = np.full(nodes, math.inf)
    for t in range(rows):
        if cost[t] == math.inf or not (reached[t] or (weights[t] > 1e-12 and weights[t] >= needed[t])):
            continue
        q = cost[t] if reached[t] else cost[t] + total[t] / weights[t]
        for e in range(users_ptr[t], users_ptr[t + 1]):
            u = users[e] // moves
            if not settled[u] and not blocked.flat[users[e]] and q < key[u]:
                key[u] = q
    heap, where, size = _heap_of_finite_keys(key)
    order = np.empty(nodes, dtype=np.int64)
    count = 0
    for n in range(nodes):
        if settled[n]:
            order[count] = n
            count += 1
    while size > 0:
        n = heap[0]
        size -= 1
        where[n] = -1
        if size > 0:
            heap[0] = heap[size]
            where[heap[0]] = 0
            _sift_down(heap, where, key, size, 0)
        settled[n] = True
        order[count] = n
        count += 1
        value = capped(_least_settled_q(n, move_t, blocked, cost, reached, total, weights, needed), cap)
        flat[n] = value
        for r in range(rev_ptr[n], rev_ptr[n + 1]):
            t = rev[r] // CORNERS
            w = weight.flat[rev[r]]
            total[t] += w * value
            weights[t] += w
            if weights[t] < needed[t]:
                continue
            q = cost[t] + total[t] / weights[t]
            for e in range(users_ptr[t], users_ptr[t + 1]):
                u = users[e] // moves
                if not settled[u] and not blocked.flat[users[e]] and q < key[u]:
                    key[u] = q
                    if where[u] < 0:
                        heap[size] = u
                        where[u] = size
                        size += 1
                    _sift_up(heap, where, key, where[u])
    for n in range(nodes):
        if not settled[n]:
            order[count] = n
            count += 1
    return order


@njit(cache=True)
def dirty_sweep(table, grid, cost, reached, corner, weight, move_t, blocked, order, backward, fixed, dirty, users_ptr, users, rev_ptr, rev, threshold):
    """A Gauss-Seidel sweep in ``order`` over the dirty nodes only; returns (the reference's change measure, nodes updated).

    Each dirty node takes its Bellman update (its ``blocked`` moves left out) and is cleaned; a node
    whose value moved by more than ``threshold`` (``inf`` counting as the crash price, as the
    interpolation reads it) dirties every node with a move whose end pose interpolates over it,
    later in this sweep or in the next; ``backward`` runs ``order`` from its end. ``rev`` holds flat stencil slots (t CORNERS + s),
    ``users`` flat node moves (n A + a).
    """
    flat = table.reshape(-1)
    cap = grid[G_MISSING]
    moves = move_t.shape[1]
    change = 0.0
    updated = 0
    nodes = order.shape[0]
    for position in range(nodes):
        n = order[nodes - 1 - position] if backward else order[position]
        if not dirty[n]:
            continue
        dirty[n] = False
        if fixed[n]:
            continue
        updated += 1
        best = _node_value(flat, cost, reached, corner, weight, move_t, blocked, n, cap)
        old = flat[n]
        change = changed_by(change, old, best)
        flat[n] = best
        seen_old = cap if old == math.inf else old
        seen_new = cap if best == math.inf else best
        if abs(seen_new - seen_old) > threshold:
            for r in range(rev_ptr[n], rev_ptr[n + 1]):
                t = rev[r] // CORNERS
                for e in range(users_ptr[t], users_ptr[t + 1]):
                    dirty[users[e] // moves] = True
    return change, updated


@njit(cache=True)
def dirty_upstream(nodes, dirty, moves, users_ptr, users, rev_ptr, rev):
    """Mark ``nodes`` and every node with a move whose end pose interpolates over one of them dirty."""
    for i in range(nodes.shape[0]):
        n = nodes[i]
        dirty[n] = True
        for r in range(rev_ptr[n], rev_ptr[n + 1]):
            t = rev[r] // CORNERS
            for e in range(users_ptr[t], users_ptr[t + 1]):
                dirty[users[e] // moves] = True


@njit(cache=True)
def dirty_users(changed, dirty, moves, users_ptr, users):
    """Mark the nodes that have one of the moves ``changed`` dirty."""
    for i in range(changed.shape[0]):
        t = changed[i]
        for e in range(users_ptr[t], users_ptr[t + 1]):
            dirty[users[e] // moves] = True


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
