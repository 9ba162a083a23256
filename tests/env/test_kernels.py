"""Compiled physics (kernels.py) against the numpy oracle (tests/numpy_model.py), every option.

The compiled model must reproduce the numpy formulation to 1e-12 relative for every
profile and option, at hand-picked states that exercise every event of a window (start, near a
radar, inside the minimum radar range, near the goal, low over a mountain, near the map edge,
near the ceiling, a window cut short by K_max). The two are not bit-identical only because numpy
evaluates exp / arctan2 / tanh / ** with its own SIMD routines (kernels.py module docstring), so
a last-ulp difference per transcendental call, ~1e-16 relative, is what remains.
"""

from __future__ import annotations

import math
import os

import numba
import numpy as np
import pytest
from numpy_model import NumpyPenetrationModel

from uav_penetration_env import PenetrationModel, paper_scenario, random_scenario
from uav_penetration_env.model import StepResult
from uav_penetration_env.mpc import Terminal
from uav_penetration_env.terminal import terminal_cost as build_terminal_cost

RTOL = 1e-12

BENCHMARK = {"profile": "benchmark"}
PAPER = {"profile": "paper"}
VARIANTS = {
    # name: changes to the paper scenario (file units)
    "paper (ratio, masking off, payoff, max)": PAPER,
    "paper, hard masking": {**PAPER, "radar_model": {"masking": "hard"}},
    "paper, soft masking": {**PAPER, "radar_model": {"masking": "soft"}},
    "benchmark (swerling1, soft, analytic, max)": BENCHMARK,
    "benchmark, hard masking": {**BENCHMARK, "radar_model": {"masking": "hard"}},
    "benchmark, masking off": {**BENCHMARK, "radar_model": {"masking": "off"}},
    "benchmark, or fusion": {**BENCHMARK, "radar_model": {"fusion": "or"}},
    "benchmark, length third term": {**BENCHMARK, "cost": {"third_term": "length"}},
    "benchmark, threat altitude scale": {**BENCHMARK, "terrain": {"threat_altitude_scale_m": 300.0}},
    "benchmark, payoff normalisation": {**BENCHMARK, "normalisation": {"mode": "payoff"}},
    "paper, length third term, analytic": {
        **PAPER,
        "cost": {"third_term": "length"},
        "normalisation": {"mode": "analytic"},
    },
}


@pytest.fixture(scope="module", params=list(VARIANTS), ids=list(VARIANTS))
def pair(request):
    scenario = paper_scenario().updated(VARIANTS[request.param])
    compiled = PenetrationModel(scenario)
    return compiled, NumpyPenetrationModel(compiled.built)


def at(model, x, y, agl, heading, pitch=0.0, speed=10.0):
    """A state at (x, y) [m], ``agl`` metres above the terrain."""
    z = float(model.height(np.array([x]), np.array([y]))[0]) + agl
    return np.array([x, y, z, speed, heading, pitch])


def hand_picked(model) -> dict[str, tuple[np.ndarray, int]]:
    """The issue's eight states (with their step index k) on the paper map."""
    radar = model.radar_xyz[0, 1]  # R2, between the mountains
    goal = model.goal[0]
    mountain = model.mountain_centres[0, 2] * 1000.0
    x_max = model.bounds[1]
    toward_goal = math.atan2(goal[1] - radar[1], goal[0] - radar[0])
    start = model.initial_state()
    return {
        "start": (start, 0),
        "near a radar": (at(model, radar[0] + 2000.0, radar[1] + 1500.0, 250.0, toward_goal), 5),
        "inside the minimum range": (
            np.array([radar[0] + 30.0, radar[1] + 40.0, radar[2] + 20.0, 8.0, 1.0, 0.1]),
            6,
        ),
        "near the goal": (at(model, goal[0] - 2500.0, goal[1] - 2000.0, 200.0, math.radians(40.0)), 20),
        "low over a mountain": (at(model, mountain[0] - 1500.0, mountain[1], 60.0, 0.0, -0.1), 8),
        "near the map edge": (at(model, x_max - 1500.0, 20000.0, 300.0, 0.1), 10),
        "near the ceiling": (
            np.array([30000.0, 30000.0, model.ceiling - 150.0, 10.0, 0.8, 0.2]),
            12,
        ),
        "window cut by K_max": (
            start + np.array([15000.0, 15000.0, 300.0, 0.0, 0.0, 0.0]),
            model.max_steps - 2,
        ),
    }


def control_sequences(model, batch: int = 300, horizon: int = 5, seed: int = 0) -> np.ndarray:
    """Sequences over the whole action box, plus a little beyond it (the kernels clip)."""
    high = model.limits.action_high
    return np.random.default_rng(seed).uniform(-1.1 * high, 1.1 * high, size=(batch, horizon, 3))


def test_hand_picked_windows_cover_every_event(pair):
    """The chosen windows do reach the goal, crash, leave the area and hit K_max (else the test is weak)."""
    compiled, _ = pair
    events = set()
    for state, step in hand_picked(compiled).values():
        controls = control_sequences(compiled, batch=60)
        states = np.repeat(state[None], len(controls), axis=0)
        for j in range(controls.shape[1]):
            if step + j >= compiled.max_steps:  # the episode ended at K_max: no transition from there
                break
            result = compiled.step(states, controls[:, j], step + j)
            events |= {
                name
                for name in ("reached_goal", "collided", "out_of_area", "truncated")
                if getattr(result, name).any()
            }
            states = result.state
    assert events == {"reached_goal", "collided", "out_of_area", "truncated"}


@pytest.mark.parametrize(("discount", "c_t"), [(1.0, 0.0), (0.9, 2.5)])
def test_rollout_cost_matches_the_numpy_oracle(pair, discount, c_t):
    compiled, oracle = pair
    controls = control_sequences(compiled)
    terminal_cost = build_terminal_cost(compiled, Terminal("distance", c_t))  # the oracle prices c_t itself
    for name, (state, step) in hand_picked(compiled).items():
        got = compiled.rollout_cost(
            state, controls, step=step, discount=discount, terminal_cost=terminal_cost
        )
        want = oracle.rollout_cost(state, controls, step=step, discount=discount, terminal_cost=c_t)
        np.testing.assert_allclose(got, want, rtol=RTOL, atol=0.0, err_msg=name)


def assert_close(got: np.ndarray, want: np.ndarray, name: str) -> None:
    """1e-12 relative to the quantity's own scale (at least 1, the scale of a probability).

    A value far below its scale (a visibility of 1e-9 from 0.5 + 0.5 tanh(x) near tanh = -1, a
    progress change near 0) carries the absolute ulp error of the O(1) terms it came from.
    """
    floor = RTOL * max(1.0, float(np.max(np.abs(want), initial=0.0)))
    np.testing.assert_allclose(got, want, rtol=RTOL, atol=floor, err_msg=name)


def assert_results_match(got: StepResult, want: StepResult) -> None:
    for field in StepResult.__dataclass_fields__:
        a, b = getattr(got, field), getattr(want, field)
        if b.dtype == bool or field == "step_index":
            np.testing.assert_array_equal(a, b, err_msg=field)
        else:
            assert_close(a, b, field)


def test_step_costs_threats_and_observe_match_the_numpy_oracle(pair):
    compiled, oracle = pair
    picked = hand_picked(compiled)
    states = np.array([state for state, _ in picked.values()])
    steps = np.array([step for _, step in picked.values()])
    controls = control_sequences(compiled, batch=len(states), horizon=1)[:, 0]

    got, want = compiled.step(states, controls, steps), oracle.step(states, controls, steps)
    assert_results_match(got, want)
    assert_results_match(compiled.costs(states, want.state, steps), oracle.costs(states, want.state, steps))
    for name, a, b in zip(
        ("terrain", "per radar", "visibility", "detection"),
        compiled.state_threats(states),
        oracle.state_threats(states),
        strict=True,
    ):
        assert_close(a, b, name)
    # float32 observations: a last-ulp float64 difference may round to the neighbouring float32.
    for result in (None, want):
        source = states if result is None else want.state
        np.testing.assert_allclose(
            compiled.observe(source, steps, result),
            oracle.observe(source, steps, result),
            rtol=1e-6,
            atol=1e-7,
        )


def test_scenario_pool_with_scenario_index_matches_the_oracle():
    """The Random id's pool: radars padded to 8 slots, each row reads its own scenario."""
    scenarios = [
        random_scenario(np.random.default_rng(seed), difficulty=d) for seed, d in ((1, 0.2), (2, 0.9))
    ]
    compiled = PenetrationModel(scenarios, radar_slots=8)
    oracle = NumpyPenetrationModel(compiled.built, radar_slots=8)
    controls = control_sequences(compiled, batch=200)
    distance = build_terminal_cost(compiled, Terminal("distance", 1.0))
    for p in range(2):
        state = compiled.initial_states([None], [p])[0]
        np.testing.assert_allclose(
            compiled.rollout_cost(state, controls, step=3, terminal_cost=distance, scenario_index=p),
            oracle.rollout_cost(state, controls, step=3, terminal_cost=1.0, scenario_index=p),
            rtol=RTOL,
            atol=0.0,
        )
    index = np.array([0, 1, 1, 0])
    states = compiled.initial_states([None] * 4, index)
    assert_results_match(
        compiled.step(states, controls[:4, 0], 2, index), oracle.step(states, controls[:4, 0], 2, index)
    )
    np.testing.assert_allclose(
        compiled.observe(states, 2, None, index), oracle.observe(states, 2, None, index), rtol=1e-6, atol=1e-7
    )


def test_results_do_not_depend_on_the_thread_count():
    compiled = PenetrationModel(paper_scenario())
    controls = control_sequences(compiled, batch=500)
    state = compiled.initial_state()
    distance = build_terminal_cost(compiled, Terminal("distance", 1.0))
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = compiled.rollout_cost(state, controls, step=0, terminal_cost=distance)
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = compiled.rollout_cost(state, controls, step=0, terminal_cost=distance)
    finally:
        numba.set_num_threads(threads)
    np.testing.assert_array_equal(one, many)


def test_pool_model_requires_a_valid_scenario_index():
    scenarios = [random_scenario(np.random.default_rng(seed)) for seed in (1, 2)]
    model = PenetrationModel(scenarios, radar_slots=8)
    states = model.initial_states([None, None], [0, 1])
    with pytest.raises(ValueError, match="scenario_index: required"):
        model.step(states, np.zeros((2, 3)), 0)
    with pytest.raises(ValueError, match=r"scenario_index: got values in \[0, 2\], expected \[0, 2\)"):
        model.step(states, np.zeros((2, 3)), 0, np.array([0, 2]))
    with pytest.raises(ValueError, match="scenario_index: got 5"):
        model.rollout_cost(states[0], np.zeros((1, 2, 3)), step=0, scenario_index=5)


def test_compile_cache_falls_back_to_the_project_cache_folder(monkeypatch, tmp_path):
    """A read-only package folder sends numba's cache to $UAV_PENETRATION_CACHE/numba/DIGEST."""
    from uav_penetration_env import compile_cache

    monkeypatch.setenv("UAV_PENETRATION_CACHE", str(tmp_path))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setattr(numba.config, "CACHE_DIR", numba.config.CACHE_DIR)
    monkeypatch.setattr(compile_cache, "_package_cache_writable", lambda folder: False)
    (tmp_path / "numba" / "0123456789abcdef").mkdir(parents=True)  # another version's cache
    folder = compile_cache.configure_compile_cache()
    assert folder == str(tmp_path / "numba" / compile_cache.source_digest())
    assert numba.config.CACHE_DIR == folder
    assert (tmp_path / "numba" / "0123456789abcdef").exists()  # a shared folder: nothing removed
    # A user's own NUMBA_CACHE_DIR is the parent, still keyed by the sources.
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    digest = compile_cache.source_digest()
    assert compile_cache.configure_compile_cache() == str(tmp_path / "mine" / f"uav-penetration-{digest}")


def test_the_cache_digest_follows_every_compiled_source(tmp_path):
    """A change to a compiled function's file, even one only called from another file, moves the cache."""
    from uav_penetration_env import compile_cache

    (tmp_path / "a.py").write_text("import numba\n@numba.njit\ndef f(x):\n    return x\n")
    (tmp_path / "b.py").write_text("x = 1\n")  # no numba: not part of the digest
    before = compile_cache.source_digest(tmp_path)
    (tmp_path / "b.py").write_text("x = 2\n")
    assert compile_cache.source_digest(tmp_path) == before
    (tmp_path / "a.py").write_text("import numba\n@numba.njit\ndef f(x):\n    return x + 1\n")
    assert compile_cache.source_digest(tmp_path) != before


def test_package_cache_probe_detects_an_unwritable_folder(tmp_path):
    from uav_penetration_env import compile_cache

    assert compile_cache._package_cache_writable(tmp_path)
    blocked = tmp_path / "blocked"
    blocked.write_text("a file where the package folder should be")
    assert not compile_cache._package_cache_writable(blocked)


def test_the_parallel_kernels_equal_their_serial_twins_row_for_row():
    """A batch at the threshold runs in parallel, below it on the calling thread: the rows must agree bitwise."""
    from uav_penetration_env import kernels

    model = PenetrationModel(paper_scenario())
    state = model.initial_state()
    high = model.limits.action_high
    rows = kernels.SERIAL_BELOW_ROWS
    controls = np.random.default_rng(3).uniform(-high, high, size=(rows, 4, 3)) * [1.0, 1.0, 0.3]
    distance = build_terminal_cost(model, Terminal("distance", 0.06))
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        parallel = model.rollout_cost(state, controls, step=2, terminal_cost=distance)  # rows == threshold
        serial = np.concatenate([model.rollout_cost(state, controls[i : i + rows // 2], step=2, terminal_cost=distance)
                                 for i in (0, rows // 2)])  # fmt: skip
    finally:
        numba.set_num_threads(before)
    assert np.array_equal(parallel, serial)
    states = np.repeat(state[None], rows, axis=0)
    stepped = model.step(states, controls[:, 0], 0)
    halves = [model.step(states[i : i + rows // 2], controls[i : i + rows // 2, 0], 0) for i in (0, rows // 2)]
    assert np.array_equal(stepped.state, np.concatenate([h.state for h in halves]))
    assert np.array_equal(stepped.J, np.concatenate([h.J for h in halves]))


def test_a_models_threads_setting_runs_its_kernels_on_that_many_threads_and_restores_the_count(monkeypatch):
    from uav_penetration_env import kernels

    seen = []
    for name in ("rollout_batch", "transition_batch", "transition_rows"):
        original = getattr(kernels, name)

        def spy(*args, _original=original, _name=name):
            seen.append((_name, numba.get_num_threads()))
            return _original(*args)

        monkeypatch.setattr(kernels, name, spy)
    before = numba.get_num_threads()
    default, one = PenetrationModel(paper_scenario()), PenetrationModel(paper_scenario(), threads=1)
    state = default.initial_state()
    high = default.limits.action_high
    rows = kernels.SERIAL_BELOW_ROWS
    controls = np.random.default_rng(5).uniform(-high, high, size=(rows, 3, 3)) * [1.0, 1.0, 0.3]
    states = np.repeat(state[None], rows, axis=0)
    assert np.array_equal(default.rollout_cost(state, controls, step=1), one.rollout_cost(state, controls, step=1))
    assert np.array_equal(default.step(states, controls[:, 0], 0).J, one.step(states, controls[:, 0], 0).J)
    assert seen == [
        ("rollout_batch", before), ("rollout_batch", 1), ("transition_batch", before), ("transition_rows", before)
    ]  # fmt: skip  # threads=1 runs the 512-row step on the calling thread, the serial twin
    assert numba.get_num_threads() == before


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "2"])
def test_threads_must_be_none_or_a_positive_integer(bad):
    with pytest.raises(ValueError, match=r"threads: got .*, expected None or an integer >= 1"):
        PenetrationModel(paper_scenario(), threads=bad)


def test_the_envs_pass_threads_to_their_model():
    import gymnasium as gym

    env = gym.make("UAVPenetration-v0", threads=1)
    assert env.unwrapped.model.threads == 1
    vector = gym.make_vec("UAVPenetration-v0", num_envs=2, vectorization_mode="vector_entry_point", threads=2)
    vector.reset(seed=0)
    assert vector.unwrapped.model.threads == 2
    with pytest.raises(ValueError, match="threads: got 0"):
        gym.make("UAVPenetrationRandom-v0", threads=0)


def cache_files(folder, *, cut: bool) -> None:
    """A numba-like cache: an index (version pickle, then the index pickle) and a data file, maybe cut."""
    import pickle

    folder.mkdir(parents=True)
    (folder / "kernels.f-1.py311.nbi").write_bytes(pickle.dumps("0.60") + pickle.dumps((("stamp", 1), {})))
    data = pickle.dumps({"library": bytes(range(256)) * 40, "types": ("float64",)})
    (folder / "kernels.f-1.py311.1.nbc").write_bytes(data[: len(data) // 2] if cut else data)


def test_a_damaged_compile_cache_is_cleared_with_a_warning_naming_it(tmp_path):
    from uav_penetration_env import compile_cache

    intact, damaged = tmp_path / "intact", tmp_path / "damaged"
    cache_files(intact, cut=False)
    cache_files(damaged, cut=True)
    assert compile_cache.damaged_files(intact) == []
    assert not compile_cache.repair_compile_cache(intact) and len(list(intact.iterdir())) == 2
    assert compile_cache.damaged_files(damaged) == [damaged / "kernels.f-1.py311.1.nbc"]
    with pytest.warns(RuntimeWarning, match=f"the compile cache {damaged} was damaged"):
        assert compile_cache.repair_compile_cache(damaged)
    assert not damaged.exists()  # compiled again on first use


def test_setting_the_compile_cache_repairs_a_damaged_one(tmp_path, monkeypatch):
    from uav_penetration_env import compile_cache

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(numba.config, "CACHE_DIR", numba.config.CACHE_DIR)
    folder = tmp_path / f"uav-penetration-{compile_cache.source_digest()}"
    cache_files(folder / "uav_penetration_env_0123", cut=True)
    with pytest.warns(RuntimeWarning, match="cleared it: the physics is compiled again"):
        assert compile_cache.configure_compile_cache() == str(folder)
    assert not folder.exists()


@pytest.mark.slow
def test_a_process_after_a_cut_compile_cache_recompiles_instead_of_dying(tmp_path):
    """The real thing: every .nbc file of a filled cache cut to half; the next process still steps the env."""
    import subprocess
    import sys

    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    code = ("import numpy as np, gymnasium as gym, uav_penetration_env; e = gym.make('UAVPenetration-v0'); "
            "e.reset(seed=0); print('reward', e.step(np.array([0.0, 0.0, 0.1]))[1])")  # fmt: skip
    first = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert first.returncode == 0, first.stderr[-500:]
    cut = list(tmp_path.rglob("*.nbc"))
    for path in cut:
        os.truncate(path, path.stat().st_size // 2)
    second = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert second.returncode == 0, second.stderr[-500:]
    assert second.stdout == first.stdout and "was damaged" in second.stderr and cut


def test_the_shared_compile_cache_keeps_recent_digests_and_drops_long_unused_ones(tmp_path):
    import os

    from uav_penetration_env.compile_cache import SHARED_IDLE_DAYS, SHARED_KEEP, prune_shared

    now = 1_000_000_000.0
    day = 86_400.0
    ages = {"a": 1, "b": 2, "c": 40, "d": 50, "e": 60, "f": 5}  # days since a process last used each
    for name, age in ages.items():
        (tmp_path / name).mkdir()
        os.utime(tmp_path / name, (now - age * day, now - age * day))
    keep = tmp_path / "mine"
    removed = prune_shared(tmp_path, keep, now=now)
    # "mine" (touched now) and the three most recent others stay; of the rest only those idle > 30 days go
    assert SHARED_KEEP == 4 and SHARED_IDLE_DAYS == 30
    assert sorted(path.name for path in removed) == ["c", "d", "e"]
    assert sorted(path.name for path in tmp_path.iterdir()) == ["a", "b", "f", "mine"]
