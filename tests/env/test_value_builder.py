"""The lattice value function's builder and its incremental rebuild (model.md §7e.2), against the reference iteration."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import tiny_scenario

from uav_penetration_env import value_kernels
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.terminal_kernels import G_MISSING, value_lookup
from uav_penetration_env.value_function import (
    LATTICE_DEFAULTS,
    LatticeSettings,
    ValueFunctionBuilder,
    build_arrays,
)

COARSE = LatticeSettings(spacing_m=5000.0, headings=8, turns=(-1.0, 0.0, 1.0))
# Turns of 7.5 degrees land between the 15-degree headings: every move is its own transition.
OFF_NODE = LatticeSettings(spacing_m=3000.0, headings=24, turns=(-0.5, 0.0, 0.5))


def assert_same_values(got: np.ndarray, want: np.ndarray) -> None:
    """Equal doom (+inf, -inf) at every node and finite values equal to 1e-9 relative."""
    assert np.array_equal(np.isposinf(got), np.isposinf(want))
    assert np.array_equal(np.isneginf(got), np.isneginf(want))
    finite = np.isfinite(want)
    np.testing.assert_allclose(got[finite], want[finite], rtol=1e-9, atol=0)


@pytest.fixture(scope="module")
def model():
    return PenetrationModel(tiny_scenario(), threads=1)


@pytest.mark.parametrize("settings", [COARSE, OFF_NODE, LATTICE_DEFAULTS], ids=["coarse", "off-node", "default"])
def test_builder_equals_the_reference_iteration(model, settings):
    reference = build_arrays(model, settings, 0, method="reference")
    built = build_arrays(model, settings, 0)
    assert_same_values(built["table"], reference["table"])
    assert np.array_equal(built["grid"], reference["grid"])
    np.testing.assert_allclose(built["route"], reference["route"], rtol=1e-9)
    assert float(built["build_cpu_seconds"]) > 0.0


def test_builder_gives_the_same_table_on_one_and_two_threads():
    one = ValueFunctionBuilder(PenetrationModel(tiny_scenario(), threads=1))
    two = ValueFunctionBuilder(PenetrationModel(tiny_scenario(), threads=2))
    assert np.array_equal(one.value_function.table, two.value_function.table)


def _radar(name, x_km, y_km):
    return dataclasses.replace(tiny_scenario().radars[0], name=name, x_km=x_km, y_km=y_km)


def _changes(radars, rng):
    """Random radar changes of the tiny scenario: one added, one moved, one removed (ids, radar tuples)."""
    added = (*radars, _radar("C", *rng.uniform(-15, 45, 2)))
    moved = (dataclasses.replace(radars[0], x_km=radars[0].x_km + rng.uniform(-8, 8), y_km=radars[0].y_km + rng.uniform(-8, 8)), *radars[1:])
    removed = radars[1:]
    return [("added", added), ("moved", moved), ("removed", removed)]


@pytest.mark.parametrize("settings", [COARSE, LATTICE_DEFAULTS], ids=["coarse", "default"])
def test_incremental_rebuild_equals_a_full_rebuild(settings):
    scenario = tiny_scenario()
    builder = ValueFunctionBuilder(PenetrationModel(scenario, threads=1), 0, settings)
    rng = np.random.default_rng(44)
    for label, radars in _changes(scenario.radars, rng):
        rebuilt = builder.with_radars(radars)
        full = ValueFunctionBuilder(PenetrationModel(dataclasses.replace(scenario, radars=radars), threads=1), 0, settings)
        assert 0 < rebuilt.changed_moves < full.changed_moves, label  # only the moves a radar prices again
        assert_same_values(rebuilt.value_function.table, full.value_function.table)
        assert not np.array_equal(rebuilt.value_function.table, builder.value_function.table), label
        assert rebuilt.value_function.route_steps == full.value_function.route_steps


def test_rebuild_after_a_rebuild_and_back_again():
    """A radar moved away and back: the second rebuild's V equals the first build's."""
    scenario = tiny_scenario()
    builder = ValueFunctionBuilder(PenetrationModel(scenario, threads=1), 0, COARSE)
    moved = (_radar("A", 20, 30), *scenario.radars[1:])
    back = builder.with_radars(moved).with_radars(scenario.radars)
    assert_same_values(back.value_function.table, builder.value_function.table)


def test_a_change_beyond_radars_builds_afresh():
    builder = ValueFunctionBuilder(PenetrationModel(tiny_scenario(), threads=1), 0, COARSE)
    other = PenetrationModel(tiny_scenario(goal={"x_km": 24, "y_km": 26}), threads=1)
    rebuilt = builder.with_model(other)
    assert rebuilt.changed_moves == rebuilt._cost.size  # every move priced: a full build
    assert_same_values(rebuilt.value_function.table, build_arrays(other, COARSE, 0, method="reference")["table"])


def test_bad_method_and_pool_are_refused(model):
    with pytest.raises(ValueError, match="method: got 'jacobi', expected 'sweeps' or 'reference'"):
        build_arrays(model, COARSE, 0, method="jacobi")
    pool = PenetrationModel([tiny_scenario(), tiny_scenario(goal={"x_km": 24, "y_km": 26})])
    with pytest.raises(ValueError, match="with_radars: got a pool of 2 scenarios"):
        ValueFunctionBuilder(pool, 1, COARSE).with_radars(())


def test_moves_ending_on_the_edge_margin_are_judged_on_their_own_end_points():
    """A flat map whose edge lies at 0: a level 60-degree move of 3 km from an edge node ends on the 1.5 km margin.

    A shared transition's end differs from its moves' by rounding; the margin test must see each
    move's own end, as the reference does (the DEM member's map, model.md §7e.2), or a node's doom
    flips and V moves by a per mille.
    """
    shifted = tiny_scenario(
        map={"x_km": [0, 75], "y_km": [0, 75]},
        start={"x_km": 25, "y_km": 25},
        goal={"x_km": 50, "y_km": 50},
        terrain={"natural": {"height_m": 0}, "mountains": [{"x_km": 37, "y_km": 39, "height_m": 400}]},
        radars=[{"name": "A", "x_km": 30, "y_km": 50, "z_m": 300}, {"name": "B", "x_km": 50, "y_km": 30, "mast_m": 15}],
    )
    model = PenetrationModel(shifted, threads=1)
    assert_same_values(build_arrays(model, LATTICE_DEFAULTS, 0)["table"], build_arrays(model, LATTICE_DEFAULTS, 0, method="reference")["table"])


@pytest.mark.parametrize("settings", [COARSE, OFF_NODE], ids=["coarse", "off-node"])
def test_stencils_price_moves_as_value_lookup_does(model, settings):
    """One Jacobi pass over the precomputed stencils equals the Bellman operator through value_lookup, bit for bit.

    The table is the built V with noise on its finite nodes (so no node is at its fixed point);
    the loop below is the reference's update (value_function.value_iteration) written out.
    """
    builder = ValueFunctionBuilder(model, 0, settings)
    rng = np.random.default_rng(7)
    table = builder.value_function.table.copy()
    finite = np.isfinite(table)
    table[finite] += rng.uniform(0.0, 0.5, finite.sum())
    new = np.empty(table.size)
    value_kernels.jacobi_pass(
        table, builder._grid, builder._cost, builder._reached, builder._corner, builder._weight,
        builder._move_t, builder._blocked, builder._fixed, new,
    )  # fmt: skip
    want = table.reshape(-1).copy()
    cap = builder._grid[G_MISSING]
    for n in np.nonzero(~builder._fixed)[0]:
        best = math.inf
        for a, t in enumerate(builder._move_t[n]):
            if builder._blocked[n, a] or builder._cost[t] == math.inf:
                continue
            q = builder._cost[t]
            if not builder._reached[t]:
                q = q + value_lookup(table, builder._grid, builder._ex[t], builder._ey[t], builder._eh[t], math.inf)
            best = min(best, q)
        want[n] = min(best, cap) if best < math.inf else best
    assert np.array_equal(new, want)


def test_label_setting_pass_orders_every_node_once_settled_ones_first(model):
    builder = ValueFunctionBuilder(model, 0, COARSE)
    table = np.full(builder._shape, np.inf)
    flat = table.reshape(-1)
    flat[builder._fixed] = builder.value_function.table.reshape(-1)[builder._fixed]
    order = value_kernels.settled_values(
        table, builder._grid, builder._cost, builder._reached, builder._corner, builder._weight, builder._move_t,
        builder._blocked, builder._fixed, builder._users_ptr, builder._users, builder._rev_ptr, builder._rev, 0.5,
    )  # fmt: skip
    assert np.array_equal(np.sort(order), np.arange(flat.size))
    dead = ~builder._fixed & np.all(builder._blocked | ~np.isfinite(builder._cost[builder._move_t]), axis=1)
    head = builder._fixed | dead
    assert set(order[: head.sum()].tolist()) == set(np.nonzero(head)[0].tolist())
    # The guess of a node that settled is a move's cost plus a mean of corner values: never below
    # the cheapest move alone, never above the crash price.
    guessed = np.isfinite(flat) & ~builder._fixed
    cheapest = np.min(np.where(builder._blocked, np.inf, builder._cost[builder._move_t]), axis=1)
    assert guessed.sum() > 0.5 * (~builder._fixed).sum()
    assert np.all(flat[guessed] >= cheapest[guessed] - 1e-12)
    assert np.all(flat[guessed] <= builder._grid[G_MISSING])
