"""Minari reference scores of exported datasets: the greedy floor scores 0, the best-known track 1 (api.md §4.10)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import tiny_scenario

from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.bestknown.compute import update_from_store
from uav_penetration_env.benchmark.minari_export import plan_datasets, reference_scores, write_datasets
from uav_penetration_env.benchmark.store import ResultsStore

minari = pytest.importorskip(
    "minari", reason="the Minari export needs the offline extra: pip install -e '.[offline]'"
)

SCENARIO = tiny_scenario(time={"max_steps": 6})


@pytest.fixture(scope="module")
def flown(tmp_path_factory):
    """greedy and a small MPC planner on the tiny scenario; the cheapest episode becomes the record of a folder."""
    folder = tmp_path_factory.mktemp("scores")
    path = folder / "run.sqlite"
    argv = ["run", "--policies", "greedy", "cem", "--scenarios", SCENARIO.to_yaml(folder / "tiny.yaml"), "--seeds", "2",
            "--horizon", "3", "--max-evals", "300", "--store", path, "--no-report", "--no-progress", "--jobs", "1"]  # fmt: skip
    assert cli.main([str(a) for a in argv]) == 0
    records = folder / "records"
    outcome = update_from_store(SCENARIO, path, folder=records)
    assert outcome.replaced
    return path, records


def export(store_path, out, records):
    with ResultsStore(store_path, create=False) as store:
        plans = plan_datasets(store.episodes())
        return write_datasets(store, plans, out, records=records)


def test_normalized_scores_put_the_floor_at_0_and_the_record_at_1(flown, tmp_path, monkeypatch):
    store_path, records = flown
    export(store_path, tmp_path, records)
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    with ResultsStore(store_path, create=False) as store:
        episodes = store.episodes()
    greedy_cost = float(episodes.loc[episodes["policy"] == "greedy", "total_cost"].iloc[0])
    best_cost = float(episodes["total_cost"].min())
    assert best_cost < greedy_cost  # the planner beat the floor, so the scores are defined
    for dataset_id in minari.list_local_datasets():
        dataset = minari.load_dataset(dataset_id)
        meta = dataset.storage.metadata
        assert meta["ref_min_score"] == pytest.approx(-greedy_cost, rel=1e-12)
        assert meta["ref_max_score"] == pytest.approx(-best_cost, rel=1e-12)
        scores = minari.get_normalized_score(dataset, np.array([-greedy_cost, -best_cost]))
        np.testing.assert_allclose(scores, [0.0, 1.0], rtol=0, atol=1e-9)
        returns = np.array([episode.rewards.sum() for episode in dataset.iterate_episodes()])
        normalized = minari.get_normalized_score(dataset, returns)
        assert np.all(normalized <= 1 + 1e-9)  # no stored episode beats the record made from the best of them
        entry = meta["uav_penetration"]["reference_scores"][SCENARIO.hash]
        assert entry["reason"] == "" and entry["best_known_total_cost"] == pytest.approx(best_cost, rel=1e-12)


def test_without_a_record_a_dataset_has_no_reference_scores_and_says_why(flown, tmp_path, monkeypatch):
    store_path, _ = flown
    export(store_path, tmp_path, tmp_path / "no-records")
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    dataset = minari.load_dataset(sorted(minari.list_local_datasets())[0])
    assert "ref_min_score" not in dataset.storage.metadata
    entry = dataset.storage.metadata["uav_penetration"]["reference_scores"][SCENARIO.hash]
    assert entry["reason"].startswith("no best-known record") and entry["greedy_total_cost"] > 0
    with pytest.raises(ValueError, match="Reference score not provided"):
        minari.get_normalized_score(dataset, np.zeros(1))


def test_a_jittered_start_or_a_record_no_better_than_greedy_gives_no_scores(tmp_path):
    jittered = tiny_scenario(time={"max_steps": 6}, start={"jitter": {"xy_km": 0.5}})
    assert reference_scores(jittered)["reason"].startswith("a jittered start")
    path = tmp_path / "greedy.sqlite"
    argv = ["run", "--policies", "greedy", "--scenarios", SCENARIO.to_yaml(tmp_path / "tiny.yaml"), "--seeds", "1",
            "--store", path, "--no-report", "--no-progress", "--jobs", "1"]  # fmt: skip
    assert cli.main([str(a) for a in argv]) == 0
    assert update_from_store(
        SCENARIO, path, folder=tmp_path / "records"
    ).replaced  # the record is greedy's own track
    scores = reference_scores(SCENARIO, tmp_path / "records")
    assert scores["best_known_total_cost"] == scores["greedy_total_cost"]
    assert "is not below the greedy floor's" in scores["reason"] and scores["ref_max_score"] is None


def test_a_relative_out_folder_is_written_where_it_names(flown, tmp_path, monkeypatch):
    store_path, _ = flown
    monkeypatch.chdir(tmp_path)
    assert cli.main(["export", "--minari", "--store", str(store_path), "--out", "relative-datasets"]) == 0
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "relative-datasets"))
    assert sorted(minari.list_local_datasets()) == ["uav-penetration/tiny-cem-v0", "uav-penetration/tiny-greedy-v0"]
