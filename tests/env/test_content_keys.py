"""Every cache and identity keyed by content: files rewritten in place, at once.

The rewrites here keep the file's name and size and happen within milliseconds of the first
read, with no help from ``os.utime``: the case a (path, size, mtime) memo alone gets wrong when
the clock has not ticked (:func:`uav_penetration_env.files.file_digest`).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import tiny_scenario

from uav_penetration_env import cache, files
from uav_penetration_env.benchmark.evaluate import evaluate
from uav_penetration_env.benchmark.policies import GreedyPolicy
from uav_penetration_env.benchmark.store import ResultsStore
from uav_penetration_env.build import build_scenario, terrain_heights
from uav_penetration_env.catalogue import dem_scenario
from uav_penetration_env.scenario import ScenarioError, load_scenario

LON = np.arange(-123.6, -121.8, 0.02)
LAT = np.arange(48.9, 50.2, 0.02)


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENV_VAR, str(tmp_path / "cache"))
    cache.clear_memory()
    yield
    cache.clear_memory()


def write_raster(path, height_m: float) -> str:
    heights = np.full((LAT.size, LON.size), height_m)
    np.savez(path, topo=heights, latitude=LAT, longitude=LON)
    return str(path)


def flat_dem_scenario(path):
    return dem_scenario().updated({"terrain": {"natural": {"file": str(path)}}, "time": {"max_steps": 4}})


def test_a_dem_rewritten_at_once_gets_a_new_hash_and_terrain(tmp_path):
    path = tmp_path / "terrain.npz"
    write_raster(path, 200.0)
    first = flat_dem_scenario(path)
    first_hash = first.hash
    np.testing.assert_allclose(terrain_heights(first), 200.0)
    size = path.stat().st_size
    write_raster(path, 1000.0)  # same name, same size, same clock tick, 800 m higher
    assert path.stat().st_size == size
    second = flat_dem_scenario(path)
    assert second.hash != first_hash
    np.testing.assert_allclose(terrain_heights(second), 1000.0)
    np.testing.assert_allclose(build_scenario(second).terrain, 1000.0)


def test_an_rcs_table_rewritten_at_once_gets_a_new_hash_and_table(tmp_path):
    path = tmp_path / "airframe.npy"
    np.save(path, np.full((181, 361), -10.0))
    first = tiny_scenario().updated({"uav": {"rcs": {"model": "table", "path": str(path)}}})
    first_hash = first.hash
    np.testing.assert_array_equal(build_scenario(first).rcs_table, -10.0)
    np.save(path, np.full((181, 361), -3.0))
    second = tiny_scenario().updated({"uav": {"rcs": {"model": "table", "path": str(path)}}})
    assert second.hash != first_hash
    np.testing.assert_array_equal(build_scenario(second).rcs_table, -3.0)


def test_an_rcs_table_rewritten_after_the_hash_is_refused(tmp_path):
    path = tmp_path / "airframe.npy"
    np.save(path, np.full((181, 361), -10.0))
    scenario = tiny_scenario().updated({"uav": {"rcs": {"model": "table", "path": str(path)}}})
    assert len(scenario.hash) == 16  # the identity (and the digest) is taken now
    np.save(path, np.full((181, 361), -3.0))
    with pytest.raises(ScenarioError, match="changed since") as info:
        build_scenario(scenario)
    assert info.value.field == "uav.rcs.path"


def test_a_store_key_follows_the_rasters_content(tmp_path):
    raster, store = tmp_path / "terrain.npz", tmp_path / "s.sqlite"
    write_raster(raster, 200.0)
    scenario_file = flat_dem_scenario(raster).to_yaml(tmp_path / "dem.yaml")
    policies = {"greedy": GreedyPolicy()}
    first = evaluate(policies, [load_scenario(scenario_file)], [0], store=store, progress=False)
    again = evaluate(policies, [load_scenario(scenario_file)], [0], store=store, progress=False)
    assert again["scenario_hash"].tolist() == first["scenario_hash"].tolist()
    write_raster(raster, 150.0)  # the same YAML file, another terrain
    changed = evaluate(policies, [load_scenario(scenario_file)], [0], store=store, progress=False)
    assert changed["scenario_hash"].iloc[0] != first["scenario_hash"].iloc[0]
    with ResultsStore(store) as results:
        episodes = results.episodes()
        assert len(episodes) == 2  # the rerun on unchanged content was skipped; the new terrain was not
        assert set(episodes["scenario_hash"]) == {
            first["scenario_hash"].iloc[0],
            changed["scenario_hash"].iloc[0],
        }
        assert len(results.scenarios()) == 2


def test_a_settled_file_is_hashed_once(tmp_path, monkeypatch):
    path = tmp_path / "old.npz"
    write_raster(path, 10.0)
    later = path.stat().st_ctime_ns + 10_000_000_000
    monkeypatch.setattr(files.time, "time_ns", lambda: later)  # hashed 10 s after its last change
    digest = files.file_digest(str(path))
    reads = []
    real_open = type(path).open

    def counting_open(self, *args, **kwargs):
        reads.append(self)
        return real_open(self, *args, **kwargs)

    monkeypatch.setattr(type(path), "open", counting_open)
    assert files.file_digest(str(path)) == digest and reads == []  # settled: the memo is trusted
    write_raster(path, 20.0)  # rewritten in place: new change time, so a fresh digest
    assert files.file_digest(str(path)) != digest and len(reads) == 1
