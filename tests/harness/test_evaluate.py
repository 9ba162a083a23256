"""The evaluator: paired seeds, resumable store, error rows, interruption, parallel backends."""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_scenario

from uav_penetration_env.benchmark.columns import MEASURED
from uav_penetration_env.benchmark.evaluate import episode_seeds, evaluate, policy_hash
from uav_penetration_env.benchmark.policies import GreedyPolicy, make_policy
from uav_penetration_env.benchmark.store import SCHEMA_VERSION, ResultsStore, StoreError

TIMING = [*MEASURED, "run_id", "episode_id"]  # what another run of the same seeds may change


def policies(max_evals=200):
    return {
        "pso": make_policy("pso", max_evals=max_evals),
        "greedy": make_policy("greedy"),
        "random": make_policy("random"),
    }


def comparable(frame: pd.DataFrame) -> pd.DataFrame:
    frame = frame.drop(columns=[c for c in TIMING if c in frame]).sort_values(
        ["policy", "scenario_hash", "seed"]
    )
    return frame.reset_index(drop=True)


@pytest.fixture(scope="module")
def scenario():
    return tiny_scenario(start={"jitter": {"xy_km": 1.5, "heading_deg": 10.0}}, time={"max_steps": 20})


@pytest.fixture(scope="module")
def reference(scenario):
    """An uninterrupted sequential run, the yardstick of the resumption tests."""
    return evaluate(policies(), [scenario], range(4), n_jobs=1, progress=False)


def test_one_row_per_episode_with_the_api_columns(reference):
    assert len(reference) == 12
    required = {
        "policy", "policy_hash", "scenario", "scenario_hash", "seed", "outcome", "total_J", "total_penalty", "mean_J",
        "terrain_total", "radar_total", "third_total", "fuel_kg", "p_detected", "detected_steps", "path_length_km", "steps",
        "nfev", "planning_seconds", "error",
    }  # fmt: skip
    assert required <= set(reference.columns)
    assert set(reference["outcome"]) <= {"success", "collided", "out_of_area", "truncated"}
    assert (reference["error"] == "").all()
    assert np.allclose(reference["total_cost"], reference["total_J"] + reference["total_penalty"])
    assert np.allclose(reference["mean_J"], reference["total_J"] / reference["steps"])
    pso = reference[reference["policy"] == "pso"]
    assert (pso["nfev"] == pso["steps"] * 200).all()
    assert (reference.loc[reference["policy"] != "pso", "nfev"] == 0).all()


@dataclass
class HoldCourse:
    """Always zero control; ``label`` only makes two configurations distinct."""

    label: str

    def config(self):
        return {"kind": "hold", "label": self.label}

    def reset(self, model, seed):
        pass

    def act(self, observation, info):
        return np.zeros(3)


def test_seeds_are_paired_across_policies(scenario, tmp_path):
    """Every policy meets the same (jittered) start for a seed, and another seed moves it."""
    env_seed, policy_seed = episode_seeds(3, scenario.hash)
    again = episode_seeds(3, scenario.hash)
    assert env_seed == again[0] and policy_seed.entropy == again[1].entropy
    assert env_seed != episode_seeds(4, scenario.hash)[0]
    assert env_seed != episode_seeds(3, tiny_scenario().hash)[0]
    store = tmp_path / "paired.sqlite"
    evaluate({"a": HoldCourse("a"), "b": HoldCourse("b")}, [scenario], [3, 4], store=store, progress=False)
    with ResultsStore(store) as results:
        first = results.steps().merge(results.episodes()[["episode_id", "policy", "seed"]], on="episode_id")
    first = first[first["step"] == 1].set_index(["seed", "policy"])[["x_km", "y_km", "z_m", "heading"]]
    pd.testing.assert_series_equal(first.loc[(3, "a")], first.loc[(3, "b")], check_names=False)
    assert not np.allclose(first.loc[(3, "a")].to_numpy(), first.loc[(4, "a")].to_numpy())


def test_sequential_and_parallel_runs_agree(scenario, reference):
    parallel = evaluate(policies(), [scenario], range(4), n_jobs=2, progress=False)
    pd.testing.assert_frame_equal(comparable(parallel), comparable(reference))


def test_rerun_skips_done_episodes(scenario, reference, tmp_path):
    store = tmp_path / "store.sqlite"
    first = evaluate(policies(), [scenario], range(4), store=store, progress=False)
    again = evaluate(policies(), [scenario], range(4), store=store, progress=False)
    pd.testing.assert_frame_equal(comparable(first), comparable(reference))
    pd.testing.assert_frame_equal(comparable(again), comparable(first))
    with ResultsStore(store) as results:
        assert len(results.episodes()) == 12
        assert results.runs()["run_id"].tolist() == [1, 2]
        steps = results.steps()
        assert len(steps) == int(first["steps"].sum())
    more = evaluate(policies(), [scenario], range(6), store=store, progress=False)
    assert len(more) == 18


def interrupt_after(monkeypatch, episodes: int) -> None:
    """Ctrl-C as a user would press it, once ``episodes`` episodes are in the store."""
    write, written = ResultsStore.write_episode, []

    def write_then_interrupt(self, row, steps):
        write(self, row, steps)
        written.append(row)
        if len(written) >= episodes:
            raise KeyboardInterrupt(f"after {episodes} stored episodes")

    monkeypatch.setattr(ResultsStore, "write_episode", write_then_interrupt)


def test_deterministic_kill_and_resume_matches_an_uninterrupted_run(scenario, reference, tmp_path, monkeypatch):
    store = tmp_path / "killed.sqlite"
    with monkeypatch.context() as patch:
        interrupt_after(patch, 5)
        with pytest.raises(KeyboardInterrupt):
            evaluate(policies(), [scenario], range(4), store=store, progress=False)
    with ResultsStore(store) as results:
        assert len(results.episodes()) == 5
        assert len(results.steps()) == int(results.episodes()["steps"].sum())  # no partial episode
    resumed = evaluate(policies(), [scenario], range(4), store=store, progress=False)
    with ResultsStore(store) as results:
        stored = results.episodes()
    assert len(stored) == 12 and not stored.duplicated(["policy_hash", "scenario_hash", "seed"]).any()
    pd.testing.assert_frame_equal(comparable(resumed), comparable(reference))


@dataclass
class FlakyPolicy:
    """Raises on the configured seeds' episodes; its configuration (hash) never changes."""

    fail: bool = True

    def config(self):
        return {"kind": "flaky"}

    def reset(self, model, seed):
        self.inner = GreedyPolicy()
        self.inner.reset(model, seed)

    def act(self, observation, info):
        if self.fail and info["step"] == 2:
            raise RuntimeError("planner exploded")
        return self.inner.act(observation, info)


def test_a_raising_planner_becomes_an_error_row_and_is_retried(scenario, tmp_path):
    store = tmp_path / "errors.sqlite"
    frame = evaluate(
        {"flaky": FlakyPolicy(), "greedy": GreedyPolicy()}, [scenario], range(2), store=store, progress=False
    )
    flaky = frame[frame["policy"] == "flaky"]
    assert (flaky["outcome"] == "error").all() and flaky["error"].str.contains("planner exploded").all()
    assert (frame.loc[frame["policy"] == "greedy", "error"] == "").all()
    with ResultsStore(store) as results:
        assert len(results.done_keys()) == 2  # error rows are not "done"
    fixed = evaluate(
        {"flaky": FlakyPolicy(fail=False), "greedy": GreedyPolicy()},
        [scenario],
        range(2),
        store=store,
        progress=False,
    )
    assert policy_hash(FlakyPolicy()) == policy_hash(FlakyPolicy(fail=False))
    assert (fixed["error"] == "").all() and len(fixed) == 4
    with ResultsStore(store) as results:
        assert len(results.episodes()) == 4


def test_plugins_imported_in_workers(scenario):
    plugin = pytest.importorskip("plugin_optimizer")
    from optimizers import get_optimizer
    from uav_penetration_env.benchmark.policies import MPCPolicy, MPCSettings

    policy = MPCPolicy(get_optimizer("test-random-search"), MPCSettings(max_evals=100))
    frame = evaluate(
        {"plugin": policy}, [scenario], range(2), n_jobs=2, imports=("plugin_optimizer",), progress=False
    )
    assert (frame["error"] == "").all() and (frame["nfev"] > 0).all()
    assert plugin.RandomSearch.__name__ == "RandomSearch"


def test_dask_local_cluster_gives_the_same_numbers(scenario, reference):
    pytest.importorskip("dask.distributed")
    frame = evaluate(policies(), [scenario], range(4), n_jobs=2, backend="dask", progress=False)
    pd.testing.assert_frame_equal(comparable(frame), comparable(reference))


def test_bad_backend_and_duplicate_configurations(scenario):
    with pytest.raises(ValueError, match="backend"):
        evaluate({"greedy": GreedyPolicy()}, [scenario], [0], n_jobs=2, backend="spark", progress=False)
    with pytest.raises(ValueError, match="configuration"):
        evaluate({"a": GreedyPolicy(), "b": GreedyPolicy()}, [scenario], [0], progress=False)


def test_store_rejects_unwritable_paths_and_foreign_schemas(tmp_path):
    with pytest.raises(StoreError, match="writable"):
        ResultsStore("/proc/definitely/not/here.sqlite")
    path = tmp_path / "old.sqlite"
    connection = sqlite3.connect(path)
    connection.execute("CREATE TABLE schema_version (version INTEGER)")
    connection.execute("INSERT INTO schema_version VALUES (?)", (SCHEMA_VERSION + 1,))
    connection.commit()
    connection.close()
    with pytest.raises(StoreError, match="schema version"):
        ResultsStore(path)


def test_store_uses_wal_and_records_provenance(scenario, tmp_path):
    store = tmp_path / "wal.sqlite"
    evaluate(
        {"greedy": GreedyPolicy()},
        [scenario],
        [0],
        store=store,
        progress=False,
        command="uav-bench run --test",
    )
    connection = sqlite3.connect(store)
    assert connection.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    with ResultsStore(store) as results:
        import json

        provenance = json.loads(results.runs()["provenance"].iloc[0])
        assert provenance["command"] == "uav-bench run --test"
        assert {"commit", "versions", "cpu", "cores", "date"} <= set(provenance)
        assert scenario.hash in results.scenarios()
