"""The restart schedule of separable CMA-ES (optimizers/sep_cma_restarts.py; docs/best-known.md §1)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from optimizers.sep_cma_restarts import RestartState, SepCMARestarts, Start

# An asymmetric box: the optimiser's [-1, 1]^d coordinates differ from the caller's.
LO, HI = np.array([-5.0, -2.0, 0.0, -10.0]), np.array([5.0, 6.0, 3.0, 0.0])
BOUNDS = np.column_stack([LO, HI])
TARGET = np.array([1.5, -1.0, 2.5, -7.0])  # inside the box
FAST = SepCMARestarts(population=6, stall_generations=4)


def sphere(x: np.ndarray) -> np.ndarray:
    return ((x - TARGET) ** 2).sum(axis=1)


class Counter:
    """``sphere`` that counts its rows and checks they lie in the box."""

    def __init__(self) -> None:
        self.rows = 0

    def __call__(self, x: np.ndarray) -> np.ndarray:
        assert x.ndim == 2 and x.shape[1] == LO.size and np.all(x >= LO) and np.all(x <= HI)
        self.rows += len(x)
        return sphere(x)


def started(optimizer: SepCMARestarts = FAST, seed: int = 0, starts=None) -> RestartState:
    starts = starts or [Start("corner", LO.copy())]
    return optimizer.begin(sphere, BOUNDS, starts, np.random.default_rng(seed))


def outcome(state: RestartState) -> tuple:
    """Everything a run decides (not the wall seconds)."""
    return (
        state.best_x.tobytes(),
        state.best_f,
        state.best_label,
        state.evals,
        state.generations,
        [tuple(r.values()) for r in state.runs],
        [(e, f) for e, _, f in state.trace],
    )


# --- minimize: the package's interface ----------------------------------------------------------------


def test_minimize_finds_the_minimum_of_a_shifted_sphere_in_an_asymmetric_box():
    for seed in range(3):
        result = SepCMARestarts().minimize(sphere, BOUNDS, rng=seed, max_evals=6_000)
        assert result.fun <= 1e-6, seed
        assert np.allclose(result.x, TARGET, atol=1e-3)


def test_minimize_keeps_the_result_contract():
    fun = Counter()
    x0 = np.array([9.0, 0.0, 1.0, -1.0])  # outside the box: clipped
    result = FAST.minimize(fun, BOUNDS, rng=1, max_evals=500, x0=x0)
    assert (
        result.nfev == fun.rows <= 500 and result.nfev + 6 > 500
    )  # stops before a generation that does not fit
    assert len(result.history) == result.nit + 1 == len(result.history_nfev)
    assert np.all(np.diff(result.history) <= 0) and result.history[-1] == result.fun
    assert result.fun == sphere(result.x[None])[0] <= sphere(np.clip(x0, LO, HI)[None])[0]
    assert result.history_nfev[0] == 1 and result.history_nfev[-1] == result.nfev


def test_minimize_gives_cmaes_finite_costs_only():
    def half_nan(x: np.ndarray) -> np.ndarray:
        f = sphere(x)
        f[x[:, 0] > 0] = np.nan  # the target's half of the box is NaN
        return f

    with np.errstate(all="raise"):  # an inf or NaN told to CMA-ES would warn in its update
        result = FAST.minimize(half_nan, BOUNDS, rng=0, max_evals=600)
    assert np.isfinite(result.fun) and result.x[0] <= 0


# --- the schedule ---------------------------------------------------------------------------------------


def test_the_schedule_runs_each_start_then_alternates_then_refines():
    starts = [Start("corner", LO.copy()), Start("other", HI.copy())]
    state = FAST.run(started(starts=starts), sphere, max_evals=2_000)
    labels = [r["label"] for r in state.runs]
    assert labels[:4] == ["start:corner", "start:other", "start:corner", "start:other"]
    explore = labels[2 : labels.index("refine(sigma=0.005)")]
    assert explore[2:6] == ["incumbent", "random", "incumbent", "random"]
    refine = labels[len(explore) + 2 :]
    assert refine[:4] == [
        "refine(sigma=0.005)",
        "refine(sigma=0.002)",
        "refine(sigma=0.001)",
        "refine(sigma=0.005)",
    ]
    # The refinement begins once 80 % of the budget is spent, not before.
    before_refine = sum(r["evals"] for r in state.runs[: len(explore) + 2])
    assert 0.8 * 2_000 <= before_refine < 0.8 * 2_000 + 6
    assert sum(r["evals"] for r in state.runs) == state.evals
    assert state.finished and state.best_f == min(r["best"] for r in state.runs)


def test_starts_are_evaluated_first_and_clipped_into_the_box():
    outside = Start("outside", np.array([10.0, 10.0, 10.0, 10.0]))
    state = started(starts=[Start("corner", LO.copy()), outside])
    assert state.evals == 2 and np.array_equal(state.starts[1].x, HI)
    assert [r["best"] for r in state.runs] == sphere(np.stack([LO, HI])).tolist()
    assert state.trace == [(2, 0.0, state.best_f)] and state.best_label == "start:corner"


def test_step_sizes_are_fractions_of_each_variables_half_width():
    points = []

    def recording(x: np.ndarray) -> np.ndarray:
        points.append(x.copy())
        return sphere(x)

    centre, half = (LO + HI) / 2, (HI - LO) / 2
    optimizer = SepCMARestarts(population=400, start_sigma=0.01)
    state = optimizer.begin(recording, BOUNDS, [Start("centre", centre)], np.random.default_rng(0))
    optimizer.run(state, recording, max_evals=401)  # the start, then one generation around it
    spread = (points[1] - centre).std(axis=0)
    assert np.allclose(spread / half, 0.01, rtol=0.15)  # 0.05, 0.04, 0.015, 0.05 in the caller's units
    assert np.array_equal(state.to_unit(np.stack([LO, HI, centre])), [[-1.0] * 4, [1.0] * 4, [0.0] * 4])


# --- budgets ----------------------------------------------------------------------------------------------


def test_the_evaluation_budget_is_never_exceeded_and_a_larger_one_continues():
    fun = Counter()
    state = FAST.begin(fun, BOUNDS, [Start("corner", LO.copy())], np.random.default_rng(0))
    FAST.run(state, fun, max_evals=301)
    assert state.finished and state.evals == fun.rows and 301 - 6 < state.evals <= 301
    FAST.run(state, fun, max_evals=601)  # a finished search given a larger budget continues
    assert state.finished and 601 - 6 < state.evals == fun.rows <= 601


def test_a_wall_second_budget_stops_the_run_and_is_counted_across_calls():
    state = started()
    FAST.run(state, sphere, seconds=0.05)
    first = state.seconds
    assert state.finished and first >= 0.05 and state.evals > 1
    FAST.run(state, sphere, seconds=first + 0.05)
    assert state.seconds >= first + 0.05 and state.trace == sorted(state.trace)
    with pytest.raises(ValueError, match="budget: got neither max_evals nor seconds"):
        FAST.run(state, sphere)


def test_a_callback_sees_every_generation_and_may_stop_the_run():
    seen = []

    def callback(state: RestartState, share: float) -> bool:
        seen.append((state.generations, share))
        return state.generations == 5

    state = FAST.run(started(), sphere, max_evals=1_000, callback=callback)
    assert [g for g, _ in seen] == [1, 2, 3, 4, 5] and not state.finished
    assert [s for _, s in seen] == [(1 + 6 * g) / 1_000 for g in range(1, 6)]


# --- determinism and resuming ---------------------------------------------------------------------------


def test_the_same_seed_gives_the_same_search_and_another_seed_another():
    first = outcome(FAST.run(started(seed=3), sphere, max_evals=800))
    assert outcome(FAST.run(started(seed=3), sphere, max_evals=800)) == first
    assert outcome(FAST.run(started(seed=4), sphere, max_evals=800)) != first


@pytest.mark.parametrize("stops", [(7,), (3, 40, 41)])
def test_a_pickled_state_continues_to_the_uninterrupted_result(stops):
    whole = outcome(FAST.run(started(seed=2), sphere, max_evals=900))
    state = started(seed=2)
    for stop in stops:
        FAST.run(state, sphere, max_evals=900, callback=lambda s, _share, at=stop: s.generations == at)
        assert state.generations == stop and state.optimizer is not None  # stopped inside a CMA-ES run
        state = pickle.loads(pickle.dumps(state))
    FAST.run(state, sphere, max_evals=900)
    assert outcome(state) == whole


# --- bad input --------------------------------------------------------------------------------------------


def test_bad_settings_and_starts_are_refused_naming_the_field():
    with pytest.raises(
        ValueError, match=r"SepCMARestarts\.start_sigma: got 0, expected a number in \(0, 1\]"
    ):
        SepCMARestarts(start_sigma=0)
    with pytest.raises(ValueError, match=r"SepCMARestarts\.refine_sigmas: got \(\)"):
        SepCMARestarts(refine_sigmas=())
    with pytest.raises(ValueError, match=r"SepCMARestarts\.population: got 1"):
        SepCMARestarts(population=1)
    with pytest.raises(ValueError, match=r"SepCMARestarts\.refine_fraction: got 1\.0"):
        SepCMARestarts(refine_fraction=1.0)
    with pytest.raises(ValueError, match="starts: got none"):
        FAST.begin(sphere, BOUNDS, [], np.random.default_rng(0))
    with pytest.raises(ValueError, match=r"starts\['short'\]: got shape \(3,\), expected \(4,\)"):
        started(starts=[Start("short", np.zeros(3))])
    with pytest.raises(ValueError, match=r"objective returned shape \(6, 1\), expected \(6,\)"):
        FAST.run(started(), lambda x: sphere(x)[:, None], max_evals=100)
