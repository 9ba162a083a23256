"""The lattice value function and the MPC terminal costs (model.md §7e), against independent oracles."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from conftest import tiny_scenario

from uav_penetration_env import terminal_kernels
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.mpc import Terminal
from uav_penetration_env.terminal import DISTANCE_COST_PER_STEP, terminal_cost
from uav_penetration_env.terminal_kernels import G_DX, G_DY, G_X0, G_Y0, TerminalCost
from uav_penetration_env.value_function import (
    LatticeSettings,
    lattice_action,
    lattice_moves,
    lattice_nodes,
    move_costs,
    value_function,
)

# The tiny scenario (75 km map, goal 35 km from the start) on a coarse lattice for the Python
# oracles, and on the default lattice for the error against brute force.
SMALL: dict = {}
COARSE = LatticeSettings(spacing_m=5000.0, headings=8, turns=(-1.0, 0.0, 1.0))


@pytest.fixture(scope="module")
def small_model():
    return PenetrationModel(tiny_scenario(**SMALL))


@pytest.fixture(scope="module")
def small_vf(small_model):
    return value_function(small_model, 0, COARSE)


# --- oracles -------------------------------------------------------------------------------------


def oracle_lookup(table, grid, x, y, heading, empty):
    """V at a pose, written from the definition: the 8 lattice corners, +inf ones at the crash price, -inf ones left out."""
    nx, ny, nh = table.shape
    missing = grid[terminal_kernels.G_MISSING]
    fx = (x - grid[G_X0]) / grid[G_DX]
    fy = (y - grid[G_Y0]) / grid[G_DY]
    if not (0.0 <= fx <= nx - 1 and 0.0 <= fy <= ny - 1):
        return empty
    i0, j0 = min(int(fx), nx - 2), min(int(fy), ny - 2)
    fh = (heading % (2 * math.pi)) / (2 * math.pi / nh)
    k0 = int(fh)
    corners = []
    for di, dj, dk in itertools.product((0, 1), repeat=3):
        w = (fx - i0 if di else 1 - (fx - i0)) * (fy - j0 if dj else 1 - (fy - j0)) * (fh - k0 if dk else 1 - (fh - k0))
        corners.append((w, table[i0 + di, j0 + dj, (k0 + dk) % nh]))
    usable = [(w, missing if v == np.inf else v) for w, v in corners if w > 0 and v != -np.inf]
    weight = sum(w for w, _ in usable)
    return empty if weight <= 1e-12 else sum(w * v for w, v in usable) / weight


def oracle_lookup_many(table, grid, x, y, heading, empty):
    """:func:`oracle_lookup` over arrays, in numpy (the same definition, vectorised)."""
    nx, ny, nh = table.shape
    missing = grid[terminal_kernels.G_MISSING]
    fx = (x - grid[G_X0]) / grid[G_DX]
    fy = (y - grid[G_Y0]) / grid[G_DY]
    inside = (fx >= 0) & (fx <= nx - 1) & (fy >= 0) & (fy <= ny - 1)
    fx, fy = np.clip(fx, 0, nx - 1), np.clip(fy, 0, ny - 1)
    i0, j0 = np.minimum(fx.astype(int), nx - 2), np.minimum(fy.astype(int), ny - 2)
    fh = np.mod(heading, 2 * math.pi) / (2 * math.pi / nh)
    k0 = fh.astype(int)
    total = np.zeros(x.shape)
    weights = np.zeros(x.shape)
    for di, dj, dk in itertools.product((0, 1), repeat=3):
        w = (np.where(di, fx - i0, 1 - (fx - i0)) * np.where(dj, fy - j0, 1 - (fy - j0))
             * np.where(dk, fh - k0, 1 - (fh - k0)))
        v = table[i0 + di, j0 + dj, (k0 + dk) % nh]
        use = (w > 0) & (v != -np.inf)
        total += np.where(use, w * np.where(use, np.where(v == np.inf, missing, v), 0.0), 0.0)
        weights += np.where(use, w, 0.0)
    out = np.where(weights > 1e-12, total / np.maximum(weights, 1e-300), empty)
    return np.where(inside, out, empty)


def oracle_value_iteration(model, settings):
    """Jacobi value iteration in numpy over the same moves (no shared iteration or lookup code)."""
    starts, ends, _ = lattice_moves(model, settings)
    cost, reached, outside = move_costs(model, starts, ends)
    x_min, x_max, y_min, y_max = model.bounds
    m = settings.edge_margin_m
    ex, ey = ends[..., 0], ends[..., 1]
    edge = (outside | (ex < x_min + m) | (ex > x_max - m) | (ey < y_min + m) | (ey > y_max - m)) & ~reached
    cost[edge] = np.inf
    xs, ys, hs = lattice_nodes(model, settings)
    goal = model.goal[0]
    grid = np.zeros(terminal_kernels.N_GRID)
    grid[[G_X0, G_Y0, G_DX, G_DY]] = xs[0], ys[0], xs[1] - xs[0], ys[1] - ys[0]
    grid[terminal_kernels.G_MISSING] = model.crash_penalty_per_step * model.max_steps + 1.0
    table = np.full((xs.size, ys.size, hs.size), np.inf)
    inside = np.hypot(starts[:, 0, 0] - goal[0], starts[:, 0, 1] - goal[1]) <= goal[2]
    terrain_doomed = np.all(~np.isfinite(cost), axis=1) & ~np.any(edge, axis=1) & ~inside
    table.reshape(-1)[inside] = 0.0
    table.reshape(-1)[terrain_doomed] = -np.inf
    fixed = inside | terrain_doomed
    for _ in range(5000):
        after = oracle_lookup_many(table, grid, ends[..., 0], ends[..., 1], ends[..., 4], np.inf)
        q = np.where(np.isfinite(cost), cost + np.where(reached, 0.0, after), np.inf)
        best = q.min(axis=1)
        best = np.where(np.isfinite(best), np.minimum(best, grid[terminal_kernels.G_MISSING]), best)  # capped at a crash
        new = np.where(fixed, table.reshape(-1), best).reshape(table.shape)
        both = np.isfinite(new) & np.isfinite(table)
        done = np.array_equal(np.isfinite(new), np.isfinite(table)) and np.all(np.abs(new[both] - table[both]) < 1e-12)
        done = done and np.array_equal(np.isneginf(new), np.isneginf(table))
        table = new
        if done:
            return table
    raise AssertionError("the oracle did not converge")


def fly_move(model, pose, turn, clearance):
    """One lattice move from a continuous pose (x, y, heading) flown exactly: (cost or inf, reached, next pose)."""
    limits = model.limits
    x, y, h = pose
    z = float(model.height(np.array([x]), np.array([y]))[0]) + clearance
    heading = h + turn * limits.dheading_max
    length = limits.max_step_length
    level = float(model.height(np.array([x + length * math.cos(heading)]), np.array([y + length * math.sin(heading)]))[0])
    pitch = float(np.clip(math.asin(np.clip((level + clearance - z) / length, -1, 1)), -limits.pitch_max, limits.pitch_max))
    state = np.array([[x, y, z, limits.speed_max, h, 0.0]])
    result = model.step(state, np.array([[0.0, turn * limits.dheading_max, pitch]]), 0)
    failed = bool(result.collided[0] or result.out_of_area[0])
    s = result.state[0]
    return (math.inf if failed else float(result.J[0])), bool(result.reached_goal[0]), (s[0], s[1], s[4])


def brute_force_cost(model, pose, depth, settings):
    """The cheapest total J over every turn sequence of up to ``depth`` moves that reaches the goal."""
    best = math.inf
    frontier = [(0.0, pose)]
    for _ in range(depth):
        nxt = []
        for spent, p in frontier:
            for turn in settings.turns:
                c, reached, q = fly_move(model, p, turn, settings.clearance_m)
                if not math.isfinite(c) or spent + c >= best:
                    continue
                if reached:
                    best = spent + c
                else:
                    nxt.append((spent + c, q))
        frontier = nxt
    return best


# --- the value function --------------------------------------------------------------------------


def test_lattice_moves_are_the_models_own_kinematics(small_model):
    """Each move's end state is what model.step makes of (0, turn, pitch) from the node's state at v_max."""
    starts, ends, _ = lattice_moves(small_model, COARSE)
    s = starts.reshape(-1, 6)
    e = ends.reshape(-1, 6)
    controls = np.column_stack([np.zeros(len(s)), np.tile(np.array(COARSE.turns) * small_model.limits.dheading_max, len(starts)), e[:, 5]])
    stepped = small_model.step(s, controls, 0).state
    np.testing.assert_allclose(stepped, e, rtol=0, atol=1e-6)


def test_value_iteration_equals_python_bellman_oracle(small_model, small_vf):
    oracle = oracle_value_iteration(small_model, COARSE)
    assert np.array_equal(np.isposinf(oracle), np.isposinf(small_vf.table))
    assert np.array_equal(np.isneginf(oracle), np.isneginf(small_vf.table))
    finite = np.isfinite(oracle)
    np.testing.assert_allclose(small_vf.table[finite], oracle[finite], rtol=1e-9, atol=1e-9)


def test_compiled_lookup_equals_oracle(small_vf):
    rng = np.random.default_rng(4)
    x = rng.uniform(-6000, 23000, 300)
    y = rng.uniform(-6000, 23000, 300)
    h = rng.uniform(-7, 7, 300)
    got = small_vf(x, y, h)
    want = [oracle_lookup(small_vf.table, small_vf.grid, *p, small_vf.missing) for p in zip(x, y, h, strict=True)]
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_value_error_against_brute_force_search(small_model):
    """V on the default lattice against exhaustive search over flown turn sequences (no interpolation).

    The true cost to go is a step function of the pose (one more 3 km step past a threshold), and
    the lattice interpolates it between nodes 1.5 km and 15 degrees apart, so its error is up to
    about one step's J (measured: mean 0.10, largest 0.36 J over these poses 7-14 km from the goal,
    where the median move costs 0.38; model.md §7e). Far from the goal that is a few per cent of
    the total.
    """
    vf = value_function(small_model)
    goal = small_model.goal[0]
    errors = []
    poses = [(7, 0, 0), (8, 40, -20), (9, 200, 30), (10, 120, 20), (12, 300, -45), (14, 80, 10), (11, 160, -30), (13, 250, 40)]
    for distance_km, off_deg, heading_off_deg in poses:
        x = goal[0] + 1000 * distance_km * math.cos(math.radians(off_deg))
        y = goal[1] + 1000 * distance_km * math.sin(math.radians(off_deg))
        heading = math.atan2(goal[1] - y, goal[0] - x) + math.radians(heading_off_deg)
        exact = brute_force_cost(small_model, (x, y, heading), 8, vf.settings)
        assert math.isfinite(exact)
        errors.append(float(vf(x, y, heading)) - exact)
    starts, ends, _ = lattice_moves(small_model, vf.settings)
    step_j = float(np.median(move_costs(small_model, starts, ends)[0][np.isfinite(move_costs(small_model, starts, ends)[0])]))
    assert max(abs(e) for e in errors) < step_j, errors  # within one (median) step's J
    assert np.mean(np.abs(errors)) < 0.15, errors


def test_value_prices_the_loop_when_the_goal_is_inside_the_turning_circle(small_model):
    """10 km out, 60 degrees off: the goal lies inside the 11.5 km turning circle, no short path exists."""
    vf = value_function(small_model)
    goal = small_model.goal[0]
    x = goal[0] + 10000 * math.cos(math.radians(120))
    y = goal[1] + 10000 * math.sin(math.radians(120))
    bearing = math.atan2(goal[1] - y, goal[0] - x)
    assert brute_force_cost(small_model, (x, y, bearing + math.radians(60)), 8, vf.settings) == math.inf
    assert vf(x, y, bearing + math.radians(60)) > 4 * vf(x, y, bearing)


def test_value_is_zero_in_the_goal_and_decreases_along_its_own_path(small_model):
    """V = 0 in the goal disc; along the lattice planner's flight V falls every step, by about that step's J."""
    vf = value_function(small_model)
    goal = small_model.goal[0]
    assert vf(goal[0], goal[1], 0.3) == 0.0
    assert vf(goal[0] + 2500.0, goal[1], -2.0) == 0.0
    state = small_model.initial_state(None)
    values = [float(vf(state[0], state[1], state[4]))]
    for k in range(small_model.max_steps):
        r = small_model.step(state[None], lattice_action(small_model, vf, state, k)[None], k)
        state = r.state[0]
        if r.terminated[0]:
            break
        values.append(float(vf(state[0], state[1], state[4])))
        assert values[-1] < values[-2]
        assert abs((values[-2] - values[-1]) - float(r.J[0])) < 0.35
    assert bool(r.reached_goal[0]) and len(values) >= 5


def test_value_lower_pointing_at_the_goal_than_away(small_model, small_vf):
    goal = small_model.goal[0]
    for x, y in [(2000.0, 3000.0), (36000.0, 2000.0), (3000.0, 35000.0)]:
        bearing = math.atan2(goal[1] - y, goal[0] - x)
        assert small_vf(x, y, bearing) < small_vf(x, y, bearing + math.pi)


def test_value_function_is_cached_by_content(small_model, small_vf, monkeypatch):
    again = value_function(PenetrationModel(tiny_scenario(**SMALL)), 0, COARSE)
    assert again.build_seconds == 0.0 and np.array_equal(again.table, small_vf.table)
    moved = {"radars": [{"name": "A", "x_km": 6, "y_km": 12, "z_m": 200}]}
    other = value_function(PenetrationModel(tiny_scenario(**moved)), 0, COARSE)
    assert not np.array_equal(other.table, small_vf.table)
    # The start pose enters the key too: the route calibration flies from it.
    started = value_function(PenetrationModel(tiny_scenario(start={"x_km": -15, "y_km": 10})), 0, COARSE)
    assert started.route_steps != small_vf.route_steps or started.route_j_per_step != small_vf.route_j_per_step


def test_settings_refuse_bad_values():
    with pytest.raises(ValueError, match="spacing_m: got -1"):
        LatticeSettings(spacing_m=-1)
    with pytest.raises(ValueError, match="turns: got"):
        LatticeSettings(turns=(2.0,))
    with pytest.raises(ValueError, match="headings: got 3"):
        LatticeSettings(headings=3)


# --- terminal costs ------------------------------------------------------------------------------


def oracle_dubins(x, y, heading, gx, gy, radius):
    """Fly the turning circle in fine arc steps until the heading points at the goal, then straight on.

    For each turn direction: the first arc angle a at which the bearing from the point on the
    circle to the goal equals the heading psi + s a (a sign change of their difference), refined
    linearly; the length is R a + the straight distance from there. The shorter direction wins.
    """
    best = math.inf
    angles = np.linspace(0.0, 2 * math.pi, 400_001)
    for side in (1.0, -1.0):
        cx, cy = x - side * radius * math.sin(heading), y + side * radius * math.cos(heading)
        if math.hypot(gx - cx, gy - cy) < radius:
            continue
        start = heading - side * math.pi / 2
        px = cx + radius * np.cos(start + side * angles)
        py = cy + radius * np.sin(start + side * angles)
        miss = np.angle(np.exp(1j * (np.arctan2(gy - py, gx - px) - (heading + side * angles))))
        crossing = np.flatnonzero((np.sign(miss[:-1]) != np.sign(miss[1:])) & (np.abs(miss[:-1] - miss[1:]) < 1.0))
        if abs(miss[0]) < 1e-12:
            best = min(best, math.hypot(gx - x, gy - y))
            continue
        i = int(crossing[0])
        a = angles[i] + (angles[i + 1] - angles[i]) * miss[i] / (miss[i] - miss[i + 1])
        ex = cx + radius * math.cos(start + side * a)
        ey = cy + radius * math.sin(start + side * a)
        best = min(best, radius * a + math.hypot(gx - ex, gy - ey))
    return best


@pytest.mark.parametrize("pose", [(0.0, 0.0, 0.0), (5000.0, -3000.0, 2.5), (20000.0, 20000.0, -1.0), (11000.0, 10000.0, 3.0)])
def test_dubins_length_equals_oracle(pose):
    got = terminal_kernels.dubins_length.py_func(*pose, 12000.0, 12000.0, 11459.0)  # the pure-Python body
    assert got == pytest.approx(oracle_dubins(*pose, 12000.0, 12000.0, 11459.0), rel=1e-6, abs=1.0)


@pytest.mark.parametrize("form", ["distance", "dubins", "value"])
def test_compiled_terminal_cost_equals_numpy_oracle(small_model, form):
    """rollout_cost with a terminal form = the window's summed costs + gamma^H x the form at the end pose."""
    model = small_model
    vf = value_function(model)
    terminal = terminal_cost(model, Terminal(form, 0.2 if form == "distance" else None))
    rng = np.random.default_rng(1)
    state = model.initial_state(None)
    controls = rng.uniform(-1, 1, (40, 4, 3)) * model.limits.action_high * 0.3
    discount = 0.9
    got = model.rollout_cost(state, controls, step=0, discount=discount, terminal_cost=terminal)
    plain = model.rollout_cost(state, controls, step=0, discount=discount)  # the none form
    goal = model.goal[0]
    for b in range(len(controls)):
        s = state.copy()
        alive = True
        for j in range(controls.shape[1]):
            r = model.step(s[None], controls[b, j][None], j)
            s = r.state[0]
            if r.terminated[0]:
                alive = False
                break
        if not alive:
            assert got[b] == plain[b]
            continue
        if form == "distance":
            extra = 0.2 * math.hypot(goal[0] - s[0], goal[1] - s[1]) / model.limits.max_step_length
        elif form == "dubins":
            radius = model.limits.max_step_length / model.limits.dheading_max
            extra = vf.route_j_per_step * oracle_dubins(s[0], s[1], s[4], goal[0], goal[1], radius) / model.limits.max_step_length
        else:
            extra = oracle_lookup(vf.table, vf.grid, s[0], s[1], s[4], vf.missing)
        assert got[b] == pytest.approx(plain[b] + discount**4 * extra, rel=1e-6)


def test_each_form_takes_its_default_c_t(small_model):
    state = small_model.initial_state(None)
    controls = np.zeros((3, 2, 3))

    def costs(terminal):
        return small_model.rollout_cost(state, controls, step=0, terminal_cost=terminal_cost(small_model, terminal))

    assert DISTANCE_COST_PER_STEP == 0.06
    assert np.array_equal(costs(Terminal("distance")), costs(Terminal("distance", 0.06)))
    vf = value_function(small_model)
    assert np.array_equal(costs(Terminal("dubins")), costs(Terminal("dubins", vf.route_j_per_step)))
    assert np.array_equal(costs(Terminal("none")), small_model.rollout_cost(state, controls, step=0))
    assert not np.array_equal(costs(Terminal("distance")), costs(Terminal("none")))


def test_malformed_terminal_cost_is_refused(small_model):
    state = small_model.initial_state(None)
    bad = TerminalCost(7, 1.0, np.zeros((1, 1, 1)), np.zeros(terminal_kernels.N_GRID))
    with pytest.raises(ValueError, match=r"terminal_cost\.kind: got 7"):
        small_model.rollout_cost(state, np.zeros((1, 2, 3)), step=0, terminal_cost=bad)
    with pytest.raises(ValueError, match="terminal: got 'euclid', expected one of none, distance, dubins, value"):
        Terminal("euclid")
    with pytest.raises(TypeError, match=r"^terminal: got 'value', expected a Terminal\(form, scale\)"):
        terminal_cost(small_model, "value")


# --- the lattice planner -------------------------------------------------------------------------


def test_lattice_planner_reaches_the_goal(small_model):
    vf = value_function(small_model)
    state = small_model.initial_state(None)
    for k in range(small_model.max_steps):
        r = small_model.step(state[None], lattice_action(small_model, vf, state, k)[None], k)
        state = r.state[0]
        if r.terminated[0]:
            break
    assert bool(r.reached_goal[0])
