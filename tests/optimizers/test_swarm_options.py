"""The shared swarm options: boundary rules, initialisation region, velocity cap (docs/swarm.md)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optimizers import available_optimizers, get_optimizer
from optimizers.pso import PSO
from optimizers.swarm import BOUNDARY_RULES, SwarmOptimizer, confine, reflect_into_bounds

SWARMS = [name for name in available_optimizers() if isinstance(get_optimizer(name), SwarmOptimizer)]


def sphere(x: np.ndarray) -> np.ndarray:
    return (x * x).sum(axis=1)


class Recorder:
    """Keeps a copy of every batch the optimiser evaluates."""

    def __init__(self, fun):
        self.fun = fun
        self.calls: list[np.ndarray] = []

    def __call__(self, x: np.ndarray) -> np.ndarray:
        self.calls.append(x.copy())
        return self.fun(x)


def test_every_swarm_but_the_references_has_the_options():
    for name in available_optimizers():
        opt = get_optimizer(name)
        if not type(opt).__module__.startswith("optimizers."):
            continue  # a plug-in registered by another test
        assert isinstance(opt, SwarmOptimizer) == (name not in {"cem", "de", "cmaes", "cmaes-default"}), name
    for name in SWARMS:
        opt = get_optimizer(name)
        assert (opt.boundary, opt.init_bounds, opt.velocity_fraction) == ("absorb", None, 0.2)


# ------------------------------------------------------------------------------------------------
# Boundary rules on hand examples
# ------------------------------------------------------------------------------------------------

LO, HI = np.array([0.0, -1.0]), np.array([10.0, 1.0])


def test_reflect_by_the_overshoot():
    # Dimension 0 in [0, 10]: 8 + 5 = 13 overshoots by 3 -> 7; 1 - 4 = -3 undershoots by 3 -> 3.
    # Dimension 1 in [-1, 1]: 0.5 + 0.25 stays inside, unchanged.
    x = np.array([[8.0, 0.5], [1.0, 0.5]])
    v = np.array([[5.0, 0.25], [-4.0, 0.25]])
    x_new, v_new = confine(x, v, LO, HI, "reflect")
    assert x_new.tolist() == [[7.0, 0.75], [3.0, 0.75]]
    assert v_new.tolist() == [[-5.0, 0.25], [4.0, 0.25]]  # one bounce: the direction reverses


def test_reflect_huge_overshoots_bounce_until_inside():
    # 47 in [0, 10]: 47 -> -27 (off 10) -> 27 (off 0) -> -7 (off 10) -> 7 (off 0): four bounces, same
    # direction. -13: -13 -> 13 (off 0) -> 7 (off 10): two bounces. 25: 25 -> -5 -> 5: two bounces.
    # 15: 15 -> 5: one bounce, reversed.
    moved = np.array([47.0, -13.0, 25.0, 15.0])
    x, flipped = reflect_into_bounds(moved, np.zeros(4), np.full(4, 10.0))
    assert x.tolist() == [7.0, 7.0, 5.0, 5.0]
    assert flipped.tolist() == [False, False, False, True]


def test_reflect_keeps_points_on_the_walls_and_inside():
    moved = np.array([0.0, 10.0, 4.25])
    x, flipped = reflect_into_bounds(moved, np.zeros(3), np.full(3, 10.0))
    assert x.tolist() == [0.0, 10.0, 4.25] and not flipped.any()


def test_damp_clips_and_reverses_and_halves_the_velocity():
    x = np.array([[8.0, 0.5]])
    v = np.array([[5.0, -2.0]])  # 13 > 10 and -1.5 < -1: both leave
    x_new, v_new = confine(x, v, LO, HI, "damp")
    assert x_new.tolist() == [[10.0, -1.0]]
    assert v_new.tolist() == [[-2.5, 1.0]]
    inside_x, inside_v = confine(x, np.array([[1.0, 0.1]]), LO, HI, "damp")
    assert inside_x.tolist() == [[9.0, 0.6]] and inside_v.tolist() == [[1.0, 0.1]]


def test_absorb_is_todays_rule():
    x_new, v_new = confine(np.array([[8.0, 0.5]]), np.array([[5.0, 0.25]]), LO, HI, "absorb")
    assert x_new.tolist() == [[10.0, 0.75]] and v_new.tolist() == [[0.0, 0.25]]


def test_random_redraws_only_the_offending_coordinates():
    x = np.array([[8.0, 0.5], [2.0, 0.0]])
    v = np.array([[5.0, 0.25], [1.0, -3.0]])  # offenders: (0, 0) and (1, 1), in row-major order
    x_new, v_new = confine(x, v, LO, HI, "random", np.random.default_rng(4))
    u = np.random.default_rng(4).random(2)
    assert x_new.tolist() == [[10.0 * u[0], 0.75], [3.0, -1.0 + 2.0 * u[1]]]
    assert v_new.tolist() == [[0.0, 0.25], [1.0, 0.0]]
    with pytest.raises(ValueError, match="rng"):
        confine(x, v, LO, HI, "random")


def test_unknown_rule():
    with pytest.raises(ValueError, match=r"boundary: got 'wrap'"):
        confine(np.zeros((1, 2)), np.zeros((1, 2)), LO, HI, "wrap")


@settings(max_examples=200, deadline=None)
@given(
    lo=st.floats(-1e3, 1e3),
    span=st.floats(1e-3, 1e3),
    start=st.floats(0.0, 1.0),
    step=st.floats(-1e4, 1e4),
    rule=st.sampled_from(BOUNDARY_RULES),
)
def test_every_rule_lands_inside_the_bounds(lo, span, start, step, rule):
    lo_arr, hi_arr = np.array([lo]), np.array([lo + span])
    span = float(hi_arr[0] - lo_arr[0])
    x = np.minimum(lo_arr + start * span, hi_arr)[None]
    v = np.array([[step * span]])  # up to 10^4 ranges: many bounces for reflect
    x_new, v_new = confine(x, v, lo_arr, hi_arr, rule, np.random.default_rng(0))
    assert lo_arr[0] <= x_new[0, 0] <= hi_arr[0]
    assert np.isfinite(v_new).all()


@pytest.mark.parametrize("rule", BOUNDARY_RULES)
@pytest.mark.parametrize("name", SWARMS)
def test_every_evaluated_point_inside_the_bounds_for_every_rule(name, rule):
    # The optimum sits in a corner, so the swarm keeps hitting two walls; a large velocity cap makes
    # the overshoots reach several ranges.
    lo, hi = np.array([-1.0, -2.0, 0.0]), np.array([1.0, 0.5, 3.0])
    rec = Recorder(lambda x: ((x - np.array([1.0, -2.0, 3.0])) ** 2).sum(axis=1))
    opt = get_optimizer(name, boundary=rule, velocity_fraction=3.0)
    opt.minimize(rec, (lo, hi), rng=0, max_evals=800)
    points = np.concatenate(rec.calls)
    assert np.all(points >= lo) and np.all(points <= hi)


# ------------------------------------------------------------------------------------------------
# Options as configuration fields
# ------------------------------------------------------------------------------------------------


def test_get_optimizer_takes_the_options():
    opt = get_optimizer("pso", boundary="reflect", init_bounds=[(50.0, 100.0)] * 3, velocity_fraction=1.0)
    assert opt.boundary == "reflect"
    assert opt.init_bounds == ((50.0, 100.0),) * 3
    assert opt.velocity_fraction == 1.0
    assert opt == PSO(boundary="reflect", init_bounds=[(50, 100)] * 3, velocity_fraction=1)  # hashable form
    hash(opt)


@pytest.mark.parametrize(
    ("params", "pattern"),
    [
        ({"boundary": "wrap"}, r"PSO\.boundary: got 'wrap', expected one of \('absorb'"),
        ({"velocity_fraction": 0.0}, r"PSO\.velocity_fraction: got 0\.0, expected a finite number > 0"),
        ({"velocity_fraction": float("inf")}, r"PSO\.velocity_fraction"),
        ({"init_bounds": [(1.0, 0.0)]}, r"PSO\.init_bounds: bounds\[0\]: got lower=1\.0, upper=0\.0"),
        ({"init_bounds": "abc"}, r"PSO\.init_bounds: bounds"),
    ],
)
def test_bad_options(params, pattern):
    with pytest.raises(ValueError, match=pattern):
        get_optimizer("pso", **params)


def test_init_bounds_must_lie_inside_the_bounds():
    opt = get_optimizer("pso", init_bounds=[(0.0, 1.0), (-3.0, 1.0)])
    with pytest.raises(
        ValueError,
        match=r"PSO\.init_bounds\[1\]: got \(-3\.0, 1\.0\), expected an interval "
        r"inside the bounds \[-2\.0, 2\.0\]",
    ):
        opt.minimize(sphere, [(-2.0, 2.0)] * 2, rng=0, max_evals=200)
    with pytest.raises(ValueError, match=r"PSO\.init_bounds: got 2 \(lower, upper\) pairs, expected 3"):
        opt.minimize(sphere, [(-2.0, 2.0)] * 3, rng=0, max_evals=200)


@pytest.mark.parametrize("name", SWARMS)
def test_init_bounds_sets_where_the_swarm_starts(name):
    lo, hi = -100.0 * np.ones(4), 100.0 * np.ones(4)
    rec = Recorder(sphere)
    opt = get_optimizer(name, init_bounds=[(50.0, 100.0)] * 4)
    opt.minimize(rec, (lo, hi), rng=2, max_evals=300)
    first = rec.calls[0]
    assert np.all(first >= 50.0) and np.all(first <= 100.0)


def test_warm_start_wins_over_init_bounds():
    rec = Recorder(sphere)
    get_optimizer("pso", init_bounds=[(50.0, 100.0)] * 2).minimize(
        rec, [(-100.0, 100.0)] * 2, rng=0, max_evals=200, x0=[0.0, -5.0]
    )
    assert rec.calls[0][0].tolist() == [0.0, -5.0]
    assert np.all(rec.calls[0][1:] >= 50.0)


def test_default_options_change_nothing():
    bounds = [(-5.0, 5.0)] * 4
    explicit = get_optimizer("hpso", boundary="absorb", init_bounds=bounds, velocity_fraction=0.2)
    a = explicit.minimize(sphere, bounds, rng=3, max_evals=900)
    b = get_optimizer("hpso").minimize(sphere, bounds, rng=3, max_evals=900)
    assert np.array_equal(a.x, b.x) and a.fun == b.fun and np.array_equal(a.history, b.history)


@pytest.mark.parametrize("fraction", [0.05, 0.2, 1.0])
def test_velocity_fraction_caps_every_step(fraction):
    # PSO with absorb: each particle moves by its clamped velocity (or less, at a wall).
    lo, hi = np.array([-10.0, 0.0]), np.array([10.0, 1.0])
    rec = Recorder(lambda x: ((x - np.array([9.0, 0.9])) ** 2).sum(axis=1))
    opt = get_optimizer("pso", swarm_size=20, velocity_fraction=fraction)
    opt.minimize(rec, [(-10.0, 10.0), (0.0, 1.0)], rng=0, max_evals=400)
    steps = np.abs(np.diff(np.stack(rec.calls), axis=0))
    cap = fraction * (hi - lo)
    assert np.all(steps <= cap * (1 + 1e-12))
    assert np.any(steps > 0.9 * cap)  # the cap is reached, so it is what limits the step


def test_biased_start_with_reflection_leaves_the_wall():
    # The biased-initialisation case of docs/swarm.md, smaller: sphere in [-100, 100]^10 started in [50, 100]^10. With the absorbing
    # wall a coordinate whose velocity was zeroed there can stay frozen; reflection keeps it moving.
    lo, hi = -100.0 * np.ones(10), 100.0 * np.ones(10)
    opt = get_optimizer("pso", boundary="reflect", init_bounds=[(50.0, 100.0)] * 10)
    for seed in range(3):
        res = opt.minimize(sphere, (lo, hi), rng=seed, max_evals=10_000)
        assert not np.any((res.x == lo) | (res.x == hi))
        assert res.fun < 1.0, (seed, res.fun)  # one coordinate stuck at a wall would cost 100^2 = 1e4
