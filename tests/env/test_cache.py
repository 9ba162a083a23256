"""Disk cache for scenario precomputation (model.md §7a "Disk cache")."""

from __future__ import annotations

import numpy as np
import pytest

from uav_penetration_env import cache


@pytest.fixture
def cache_folder(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv(cache.ENV_VAR, str(folder))
    cache.clear_memory()
    yield folder
    cache.clear_memory()


class CountingBuild:
    """A build function that counts its calls and returns fresh arrays."""

    def __init__(self, value: float = 1.5) -> None:
        self.calls = 0
        self.value = value

    def __call__(self) -> dict[str, np.ndarray]:
        self.calls += 1
        return {"grid": np.full((3, 4), self.value), "vector": np.arange(5.0)}


def test_cache_dir_follows_the_environment_variable(cache_folder):
    assert cache.cache_dir() == cache_folder


def test_builds_once_then_loads_from_memory_and_disk(cache_folder):
    build = CountingBuild()
    first = cache.cached_arrays("terrain", {"seed": 1}, build)
    assert build.calls == 1
    np.testing.assert_array_equal(first["grid"], np.full((3, 4), 1.5))
    files = list(cache_folder.glob("*.npz"))
    assert [f.name for f in files] == [cache.cache_key("terrain", {"seed": 1}) + ".npz"]
    assert not list(cache_folder.glob("*.tmp"))  # the temporary file was renamed

    again = cache.cached_arrays("terrain", {"seed": 1}, build)  # from memory
    assert build.calls == 1 and again is first

    cache.clear_memory()  # a new process: the arrays come from disk
    loaded = cache.cached_arrays("terrain", {"seed": 1}, build)
    assert build.calls == 1
    np.testing.assert_array_equal(loaded["grid"], first["grid"])
    np.testing.assert_array_equal(loaded["vector"], np.arange(5.0))
    assert not loaded["grid"].flags.writeable  # shared arrays are read-only

    cache.cached_arrays("terrain", {"seed": 2}, build)  # other inputs: another build
    assert build.calls == 2
    assert len(list(cache_folder.glob("*.npz"))) == 2


def test_a_corrupt_file_is_rebuilt(cache_folder):
    build = CountingBuild()
    cache.cached_arrays("floor", {"radar": [1, 2, 3]}, build)
    path = cache_folder / (cache.cache_key("floor", {"radar": [1, 2, 3]}) + ".npz")
    path.write_bytes(b"this is not an npz archive")
    cache.clear_memory()
    arrays = cache.cached_arrays("floor", {"radar": [1, 2, 3]}, build)
    assert build.calls == 2
    np.testing.assert_array_equal(arrays["grid"], np.full((3, 4), 1.5))
    # The rebuilt arrays were written back: the next process loads them.
    cache.clear_memory()
    cache.cached_arrays("floor", {"radar": [1, 2, 3]}, build)
    assert build.calls == 2


def test_a_truncated_file_is_rebuilt(cache_folder):
    # The first 40 bytes of a real archive: a zip header without its central directory.
    build = CountingBuild()
    cache.cached_arrays("rcs", {"f": 3}, build)
    path = cache_folder / (cache.cache_key("rcs", {"f": 3}) + ".npz")
    path.write_bytes(path.read_bytes()[:40])
    cache.clear_memory()
    cache.cached_arrays("rcs", {"f": 3}, build)
    assert build.calls == 2


def test_an_unwritable_cache_folder_warns_and_still_returns_the_arrays(tmp_path, monkeypatch):
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the cache folder should be")
    monkeypatch.setenv(cache.ENV_VAR, str(blocker / "cache"))
    monkeypatch.setattr(cache, "_warned", False)
    cache.clear_memory()
    build = CountingBuild(2.0)
    with pytest.warns(cache.CacheWarning, match=cache.ENV_VAR):
        arrays = cache.cached_arrays("terrain", {"seed": 9}, build)
    np.testing.assert_array_equal(arrays["grid"], np.full((3, 4), 2.0))
    assert build.calls == 1
    cache.clear_memory()


def test_keys_change_with_inputs_kind_and_package_version(monkeypatch):
    key = cache.cache_key("terrain", {"seed": 1, "map": {"grid_m": 500}})
    assert key == cache.cache_key("terrain", {"map": {"grid_m": 500}, "seed": 1})  # order-independent
    assert key.startswith("terrain-")
    assert key != cache.cache_key("terrain", {"seed": 2, "map": {"grid_m": 500}})
    assert key != cache.cache_key("terrain", {"seed": 1, "map": {"grid_m": 1000}})
    assert key != cache.cache_key("floor", {"seed": 1, "map": {"grid_m": 500}})
    monkeypatch.setattr(cache, "__version__", "999.0.0")
    assert key != cache.cache_key("terrain", {"seed": 1, "map": {"grid_m": 500}})


def test_a_new_package_version_rebuilds(cache_folder, monkeypatch):
    build = CountingBuild()
    cache.cached_arrays("terrain", {"seed": 1}, build)
    monkeypatch.setattr(cache, "__version__", "999.0.0")
    cache.clear_memory()
    cache.cached_arrays("terrain", {"seed": 1}, build)
    assert build.calls == 2
