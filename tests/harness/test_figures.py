"""Figures: every file for every scenario group, non-blank, with and without optimiser histories."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import yaml
from conftest import tiny_scenario
from scipy import stats as scipy_stats

from uav_penetration_env.benchmark import figures
from uav_penetration_env.benchmark.leaderboard import prepare_episodes
from uav_penetration_env.benchmark.store import ResultsStore


def assert_images(paths, stems, formats=("png", "pdf")):
    from matplotlib.image import imread

    names = {p.name for p in paths}
    expected = {f"{stem}-{name}.{ext}" for stem in stems for name in figures.FIGURES for ext in formats}
    assert names == expected
    for path in paths:
        assert path.is_file()
        if path.suffix == ".pdf":
            assert path.read_bytes()[:5] == b"%PDF-"
            continue
        image = imread(path)[..., :3]
        assert image.shape[0] >= 400 and image.shape[1] >= 400
        drawn = (image < 0.9).any(axis=-1).mean()  # share of pixels that are not (near) white
        assert drawn > 0.01, f"{path.name} looks blank"
        packed = np.round(image[::5, ::5] * 255).astype(np.uint32) @ np.array(
            [1, 256, 65536], dtype=np.uint32
        )
        assert np.unique(packed).size > 20, f"{path.name} looks blank"


# --- a store from a real sweep -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def real_store(tmp_path_factory):
    from uav_penetration_env.benchmark.evaluate import evaluate
    from uav_penetration_env.benchmark.policies import make_policy

    path = tmp_path_factory.mktemp("fig") / "real.sqlite"
    policies = {"pso": make_policy("pso", max_evals=200), "greedy": make_policy("greedy")}
    policies["random"] = make_policy("random")
    evaluate(policies, [tiny_scenario(time={"max_steps": 15})], range(2), store=path, progress=False)
    return path


def test_every_figure_of_a_real_sweep(real_store, tmp_path):
    paths = figures.write_figures(real_store, tmp_path)
    assert_images(paths, ["tiny"])
    assert paths[0].name == "tiny-tracks-top.png"


# --- a synthetic store: two groups, one without its scenario YAML, an error row -------------------------


def synthetic_steps(seed: int, n: int, history: bool) -> list[dict]:
    rows = []
    for k in range(1, n + 1):
        row = {
            "step": k,
            "x_km": 2.5 * k,
            "y_km": 2.0 * k + seed,
            "z_m": 150.0 + 20 * k,
            "altitude_agl": 100.0 + 10 * (k % 3),
            "J": 0.3 + 0.05 * ((k + seed) % 4),
            "penalty": 0.0,
            "detection_prob": 0.1 * (k % 5),
        }
        if history:
            best = 3.0 - 0.5 * np.arange(4) - 0.1 * k
            row |= {"history": best.tolist(), "history_nfev": [50, 100, 150, 200]}
        rows.append(row)
    return rows


def synthetic_episode(
    policy: str, seed: int, scenario: str, scenario_hash: str, cost: float, **changes
) -> dict:
    return {
        "policy": policy,
        "policy_hash": f"{policy:0<16}"[:16],
        "scenario": scenario,
        "scenario_hash": scenario_hash,
        "seed": seed,
        "outcome": "success",
        "total_J": cost,
        "total_penalty": 0.0,
        "total_cost": cost,
        "steps": 8,
        "error": "",
    } | changes


@pytest.fixture(scope="module")
def synthetic_store(tmp_path_factory):
    path = tmp_path_factory.mktemp("fig") / "synthetic.sqlite"
    tiny = tiny_scenario()
    with ResultsStore(path) as store:
        # Only the first group's scenario is stored: the second draws its tracks without terrain.
        store.register({}, {tiny.hash: ("tiny", yaml.safe_dump(tiny.to_dict(), sort_keys=False))})
        for seed in range(3):
            for policy, history, cost in (("ihpso", True, 5.0 + seed), ("greedy", False, 6.0)):
                episode = synthetic_episode(policy, seed, "tiny", tiny.hash, cost)
                store.write_episode(episode, synthetic_steps(seed, 8 - seed, history))
            # The second group holds floors only: no optimiser history anywhere.
            for policy, cost in (("greedy", 6.0), ("random", 9.0 + seed)):
                episode = synthetic_episode(policy, seed, "other map", "f" * 16, cost)
                store.write_episode(episode, synthetic_steps(seed, 6, False))
        error = synthetic_episode("random", 0, "tiny", tiny.hash, 0.0, outcome="error", error="boom")
        store.write_episode(error, [])
    return path


def test_two_groups_floors_only_and_no_stored_scenario(synthetic_store, tmp_path):
    paths = figures.write_figures(synthetic_store, tmp_path, formats=("png",))
    assert_images(paths, ["other-map", "tiny"], formats=("png",))
    assert paths[0].name.startswith("other-map-")  # groups sorted by name


def test_unknown_format(synthetic_store, tmp_path):
    with pytest.raises(ValueError, match="formats"):
        figures.write_figures(synthetic_store, tmp_path, formats=("png", "gif"))


def test_missing_store_is_an_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="results store"):
        figures.write_figures(tmp_path / "nothing.sqlite", tmp_path)


# --- the pure helpers, by hand ------------------------------------------------------------------------


def test_mean_band_by_hand():
    mean, low, high, count = figures.mean_band(np.array([[1.0, 2.0, np.nan], [3.0, np.nan, np.nan]]))
    assert np.allclose(mean[:2], [2.0, 2.0]) and np.isnan(mean[2])
    assert count.tolist() == [2, 1, 0]
    half = scipy_stats.t.ppf(0.975, 1) * np.sqrt(2.0) / np.sqrt(2.0)
    assert low[0] == pytest.approx(2.0 - half) and high[0] == pytest.approx(2.0 + half)
    assert np.isnan(low[1:]).all() and np.isnan(high[1:]).all()


def test_performance_profile_by_hand():
    table = pd.DataFrame({"a": [1.0, 2.0], "b": [2.0, 2.0], "c": [4.0, np.nan], "gone": [np.nan, np.nan]})
    ratios, shift = figures.performance_profile(table)
    assert shift == 0.0
    assert {k: v.tolist() for k, v in ratios.items()} == {"a": [1.0], "b": [2.0], "c": [4.0]}
    ratios, shift = figures.performance_profile(pd.DataFrame({"a": [0.0, 1.0], "b": [1.0, 1.0]}))
    assert shift == 1.0  # costs 0 and 1 become 1 and 2
    assert ratios["a"].tolist() == [1.0, 1.0] and ratios["b"].tolist() == [2.0, 1.0]
    assert figures.performance_profile(pd.DataFrame({"a": [1.0, np.nan], "b": [np.nan, 1.0]})) == ({}, 0.0)


def test_convergence_curves_by_hand():
    steps = pd.DataFrame(
        {
            "history": [json.dumps([10.0, 6.0, 2.0]), json.dumps([5.0, 5.0]), None, "[]"],
            "history_nfev": [json.dumps([100, 200, 300]), json.dumps([100, 200]), None, "[]"],
        }
    )
    grid = np.array([0.0, 100.0, 150.0, 250.0, 300.0, 400.0])
    curves, flat = figures.convergence_curves(steps, grid)
    assert flat == 1  # [5, 5] never improved
    assert curves.shape == (1, 6)
    assert np.isnan(curves[0, 0])
    assert curves[0, 1:].tolist() == [1.0, 1.0, 0.5, 0.0, 0.0]


def test_track_seed_is_the_smallest_seed_every_planner_finished():
    episodes = prepare_episodes(
        pd.DataFrame(
            {
                "episode_id": [1, 2, 3, 4, 5, 6],
                "policy": ["a", "a", "a", "b", "b", "b"],
                "policy_hash": ["ha"] * 3 + ["hb"] * 3,
                "scenario_hash": ["s"] * 6,
                "seed": [0, 1, 2, 0, 1, 2],
                "outcome": ["success", "success", "success", "error", "collided", "success"],
                "error": ["", "", "", "boom", "", ""],
            }
        )
    )
    steps = pd.DataFrame({"episode_id": [1, 2, 3, 4, 5, 6]})
    assert figures.track_seed(episodes, steps) == 1
    assert figures.track_seed(episodes, steps[steps["episode_id"] != 5]) == 2
    assert figures.track_seed(episodes, steps[steps["episode_id"] == 1]) == 0  # fallback: most planners


def test_policy_colours_are_stable_and_never_red():
    colours = figures.policy_colours(["pso", "greedy", "ihpso", "random"])
    assert colours == figures.policy_colours(["random", "ihpso", "greedy", "pso"])
    assert len(set(colours.values())) == 4
    from matplotlib import colormaps

    assert colormaps["tab10"].colors[3] not in colours.values()


@pytest.mark.slow
def test_figures_of_the_paper_scenario(tmp_path):
    from uav_penetration_env import paper_scenario
    from uav_penetration_env.benchmark.evaluate import evaluate
    from uav_penetration_env.benchmark.policies import make_policy

    policies = {"ihpso": make_policy("ihpso", max_evals=500), "greedy": make_policy("greedy")}
    evaluate(policies, [paper_scenario()], range(2), store=tmp_path / "paper.sqlite", progress=False)
    paths = figures.write_figures(tmp_path / "paper.sqlite", tmp_path / "out")
    assert_images(paths, ["paper-2022-sec5"])
