"""`uav-bench export --minari`: stored episodes as Minari datasets, loaded back with Minari's own API (api.md §4.10)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import tiny_scenario

from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.minari_export import (
    MinariExportError,
    plan_datasets,
    scenario_set,
    slug,
)
from uav_penetration_env.benchmark.store import ResultsStore

minari = pytest.importorskip(
    "minari", reason="the Minari export needs the offline extra: pip install -e '.[offline]'"
)


def episode_metadata(dataset):
    """Each episode's metadata (the seed Minari keeps and the store's keys the export adds)."""
    return list(dataset.storage.get_episode_metadata(range(dataset.total_episodes)))


@pytest.fixture(scope="module")
def store(greedy_random_store):
    """greedy and random, two seeds each, on the tiny scenario cut to 6 steps (shared, read only)."""
    return greedy_random_store


@pytest.fixture(scope="module")
def exported(store, tmp_path_factory):
    out = tmp_path_factory.mktemp("datasets")
    assert cli.main(["export", "--minari", "--store", str(store), "--out", str(out)]) == 0
    return out


def test_each_dataset_loads_with_minari_and_replays_to_the_stored_totals(store, exported, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(exported))
    with ResultsStore(store, create=False) as opened:
        episodes = opened.episodes().set_index("episode_id")
    ids = sorted(minari.list_local_datasets())
    assert ids == ["uav-penetration/tiny-greedy-v0", "uav-penetration/tiny-random-v0"]
    for dataset_id, policy in zip(ids, ["greedy", "random"], strict=True):
        dataset = minari.load_dataset(dataset_id)
        env = dataset.recover_environment()
        assert dataset.total_episodes == 2 and dataset.storage.metadata["algorithm_name"] == policy
        assert dataset.total_steps == int(episodes.loc[episodes["policy"] == policy, "steps"].sum())
        meta = dataset.storage.metadata["uav_penetration"]
        assert meta["policy"]["name"] == policy and meta["scenario_set"] == "tiny"
        # Same machine, same code: the track is bit for bit the stored one; the return differs from
        # -total_cost (ΣJ + Σpenalty, summed apart) at most by the rounding of one addition per step.
        assert meta["replay"]["max_state_error"] == 0.0
        assert meta["replay"]["max_return_error"] <= 1e-12 * (1 + episodes["total_cost"].abs().max())
        assert env.unwrapped.scenario.hash in meta["scenarios"]
        assert dataset.observation_space == env.observation_space
        high = env.unwrapped.model.limits.action_high
        assert np.array_equal(dataset.action_space.high, high) and dataset.action_space.dtype == np.float64
        seeds = []
        for episode, extra in zip(dataset.iterate_episodes(), episode_metadata(dataset), strict=True):
            row = episodes.loc[extra["store_episode_id"]]
            steps = int(row["steps"])
            assert row["policy"] == policy and extra["scenario_hash"] == row["scenario_hash"]
            assert episode.observations.shape == (steps + 1, *env.observation_space.shape)
            assert episode.observations.dtype == env.observation_space.dtype
            assert episode.actions.shape == (steps, *env.action_space.shape)
            assert (
                episode.rewards.shape == episode.terminations.shape == episode.truncations.shape == (steps,)
            )
            assert bool(episode.terminations[-1] or episode.truncations[-1])
            assert not (episode.terminations[:-1].any() or episode.truncations[:-1].any())
            assert episode.infos["state"].shape == (steps + 1, 6)
            assert all(env.observation_space.contains(o) for o in episode.observations)
            assert all(dataset.action_space.contains(a) for a in episode.actions)
            # The episode's return is minus the stored total (J plus the failure penalty).
            assert float(np.sum(episode.rewards)) == pytest.approx(-row["total_cost"], rel=1e-12, abs=1e-12)
            assert np.allclose(-(episode.infos["J"][1:] + episode.infos["penalty"][1:]), episode.rewards)
            # The recovered env, reset with the episode's seed and fed its actions, flies the same episode.
            observation, _ = env.reset(seed=extra["seed"])
            assert np.array_equal(observation, episode.observations[0])
            total = 0.0
            for k, action in enumerate(episode.actions):
                observation, reward, *_, info = env.step(action)
                assert np.array_equal(info["state"], episode.infos["state"][k + 1])
                total += reward
            assert total == float(np.sum(episode.rewards))
            seeds.append(extra["episode_seed"])
        assert sorted(seeds) == [0, 1]
        env.close()


def test_the_stored_state_and_actions_are_the_datasets(store, exported, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(exported))
    dataset = minari.load_dataset("uav-penetration/tiny-greedy-v0")
    with ResultsStore(store, create=False) as opened:
        for episode, extra in zip(dataset.iterate_episodes(), episode_metadata(dataset), strict=True):
            steps = opened.steps([extra["store_episode_id"]], include_start=True).sort_values("step")
            stored = steps[["speed", "heading", "pitch"]].to_numpy()
            assert np.array_equal(episode.infos["state"][:, 3:], stored)
            actions = steps[steps["step"] > 0][["action_dv", "action_dphi", "action_dtheta"]].to_numpy()
            assert np.array_equal(episode.actions, actions)  # greedy stays inside the box: nothing clipped


def test_the_command_prints_ids_and_writes_nothing_else(store, tmp_path, capsys):
    out = tmp_path / "d"
    argv = ["export", "--minari", "--store", str(store), "--out", str(out), "--policy", "greedy"]
    assert cli.main([*argv, "--dataset-id", "mine/greedy-tiny-v3"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[0] == f"mine/greedy-tiny-v3: 2 episodes -> {out / 'mine' / 'greedy-tiny-v3'}"
    assert sorted(p.name for p in out.iterdir()) == ["mine"]  # the temporary root is gone
    assert json.loads((out / "mine" / "namespace_metadata.json").read_text()) == {}
    # The same id again is refused, and the dataset left as it was.
    before = sorted(str(p) for p in out.rglob("*"))
    assert cli.main([*argv, "--dataset-id", "mine/greedy-tiny-v3"]) == 2
    assert "exists; expected a new dataset id" in capsys.readouterr().err
    assert sorted(str(p) for p in out.rglob("*")) == before


@pytest.mark.parametrize(
    "flags, message",
    [
        (["--policy", "greedi"], "--policy: 'greedi' has no finished episode in the store"),
        (
            ["--scenarios", "paper"],
            "--scenarios: 'paper' is neither a stored scenario, a scenario set nor a pattern",
        ),
        (
            ["--dataset-id", "tiny-greedy"],
            "--dataset-id: got 'tiny-greedy', expected Minari's NAMESPACE/NAME-vN",
        ),
        (["--dataset-id", "ab/cd-v0"], "--dataset-id: the selection makes 2 datasets"),
        (["--format", "csv"], "--format: writes tables; expected no --format with --minari"),
        (
            ["--dataset-id", "ab/cd-v0", "--dataset-version", "1"],
            "--dataset-version: versions the default ids",
        ),
    ],
)
def test_bad_selections_are_one_line(store, tmp_path, capsys, flags, message):
    out = tmp_path / "d"
    assert cli.main(["export", "--minari", "--store", str(store), "--out", str(out), *flags]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not out.exists() or list(out.iterdir()) == []


@pytest.mark.parametrize(
    "change, message",
    [
        # greedy's first turn is 0: flying another one leaves the stored track
        ("UPDATE steps SET action_dphi = 0.1 WHERE step = 1", "re-flown leaves the stored track"),
        # the track is the stored one, the total is not
        ("UPDATE episodes SET total_cost = total_cost + 1e-6", "the store's -total_cost is"),
    ],
)
def test_a_store_that_does_not_replay_is_refused(store, tmp_path, capsys, change, message):
    """A copy of the store changed so that it no longer replays: one line naming the episode, nothing written."""
    import shutil
    import sqlite3

    copy = tmp_path / "changed.sqlite"
    shutil.copy(store, copy)
    connection = sqlite3.connect(copy)
    with connection:
        connection.execute(change)
    connection.close()
    out = tmp_path / "d"
    assert (
        cli.main(["export", "--minari", "--store", str(copy), "--out", str(out), "--policy", "greedy"]) == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and "nothing written" in err[0], err
    assert "episode 1 (greedy on tiny, seed 0)" in err[0]
    assert not out.exists()  # no empty folder left behind


def test_a_relative_out_folder_is_exported_where_it_names(store, tmp_path, capsys, monkeypatch):
    """The README's export (a relative --out, as the default is): Minari joined a relative dataset path
    to its root twice and the export failed with a traceback (repro_t4_minari_relative_out)."""
    monkeypatch.chdir(tmp_path)
    argv = ["export", "--minari", "--store", str(store), "--policy", "greedy"]
    assert cli.main([*argv, "--out", "datasets"]) == 0
    printed = capsys.readouterr().out
    assert f"MINARI_DATASETS_PATH={tmp_path / 'datasets'}" in printed
    (dataset_id,) = [line.split(":")[0] for line in printed.splitlines() if " episodes -> " in line]
    monkeypatch.setenv("MINARI_DATASETS_PATH", "datasets")
    assert minari.load_dataset(dataset_id).total_episodes == 2


def test_a_failed_export_leaves_no_empty_folder(store, tmp_path, capsys, monkeypatch):
    import uav_penetration_env.benchmark.minari_export as export_module

    def fail(*args, **kwargs):
        raise MinariExportError("--out: a failure after the folder was made")

    monkeypatch.setattr(export_module, "_create", fail)
    out = tmp_path / "new" / "datasets"
    assert cli.main(["export", "--minari", "--store", str(store), "--out", str(out), "--policy", "greedy"]) == 2
    assert "a failure after the folder was made" in capsys.readouterr().err
    assert not (tmp_path / "new").exists()


def test_without_minari_the_command_names_the_extra(store, tmp_path, capsys, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "minari", None)  # find_spec then reports it missing
    assert cli.main(["export", "--minari", "--store", str(store), "--out", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "minari" in err and "offline extra" in err


def test_the_layout_groups_by_configuration_and_scenario_set(store):
    assert scenario_set("random-10003") == "random" and scenario_set("paper") == "paper"
    assert slug("sb3:models/PPO run") == "sb3-models-ppo-run"
    with ResultsStore(store, create=False) as opened:
        episodes = opened.episodes()
    plans = plan_datasets(episodes, version=2)
    assert [p.dataset_id for p in plans] == [
        "uav-penetration/tiny-greedy-v2",
        "uav-penetration/tiny-random-v2",
    ]
    # Two configurations of one name: each its own dataset, told apart by the hash.
    renamed = episodes.copy()
    renamed.loc[renamed["policy"] == "random", "policy"] = "greedy"
    ids = [p.dataset_id for p in plan_datasets(renamed)]
    hashes = sorted(h[:8] for h in renamed["policy_hash"].unique())
    assert ids == sorted(f"uav-penetration/tiny-greedy-{h}-v0" for h in hashes)
    # Procedural scenarios of one family make one dataset.
    family = episodes.assign(scenario=[f"random-{i}" for i in range(len(episodes))])
    assert [len(p.episodes) for p in plan_datasets(family, policies=["greedy"], scenarios=["random"])] == [2]
    # A pattern picks by name: random-0 and random-2 are the even rows, one of each policy.
    chosen = plan_datasets(family, scenarios=["random-[02]"])
    assert sorted(s for p in chosen for s in p.episodes["scenario"]) == ["random-0", "random-2"]
    with pytest.raises(MinariExportError, match="no finished episode"):
        plan_datasets(episodes.assign(error="Boom"))


def test_a_set_of_several_scenarios_is_one_dataset_with_each_scenarios_env(tmp_path, monkeypatch):
    """tiny-1 and tiny-2 (two terrains) make the set tiny; each episode re-flies in its scenario's env."""
    import gymnasium as gym

    paths = []
    for seed in (1, 2):
        scenario = tiny_scenario(name=f"tiny-{seed}", time={"max_steps": 6}, terrain={"seed": seed})
        paths.append(str(scenario.to_yaml(tmp_path / f"tiny-{seed}.yaml")))
    store = tmp_path / "two.sqlite"
    argv = ["run", "--policies", "greedy", "--scenarios", *paths, "--seeds", "1", "--store", str(store)]
    assert cli.main([*argv, "--no-report", "--no-progress", "--jobs", "1"]) == 0
    out = tmp_path / "d"
    assert cli.main(["export", "--minari", "--store", str(store), "--out", str(out)]) == 0
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(out))
    dataset = minari.load_dataset("uav-penetration/tiny-greedy-v0")
    scenarios = dataset.storage.metadata["uav_penetration"]["scenarios"]
    assert sorted(s["name"] for s in scenarios.values()) == ["tiny-1", "tiny-2"]
    assert dataset.recover_environment().unwrapped.scenario.name == "tiny-1"  # the first episode's
    for episode, extra in zip(dataset.iterate_episodes(), episode_metadata(dataset), strict=True):
        env = gym.make(dataset.env_spec.id, **scenarios[extra["scenario_hash"]]["env_kwargs"])
        assert env.unwrapped.scenario.hash == extra["scenario_hash"]
        observation, _ = env.reset(seed=extra["seed"])
        assert np.array_equal(observation, episode.observations[0])
        rewards = [env.step(action)[1] for action in episode.actions]
        assert np.array_equal(rewards, episode.rewards)
        assert float(np.sum(rewards)) == pytest.approx(-extra["total_cost"], rel=1e-12, abs=1e-12)


@pytest.mark.slow
@pytest.mark.crossmachine
def test_the_published_planner_episodes_replay_to_their_committed_totals(tmp_path, monkeypatch):
    """leaderboard v2's rows (flown on other machines): ihpso and greedy on the paper scenario and
    ihpso on five held-out scenarios (one seed each), imported into a store, exported and loaded back."""
    from pathlib import Path

    import pandas as pd

    stem = Path(__file__).resolve().parents[2] / "leaderboards" / "rows" / "leaderboard"
    episodes = pd.read_parquet(f"{stem}-episodes.parquet")
    paper = episodes["scenario"].eq("paper-2022-sec5") & episodes["policy"].isin(["ihpso", "greedy"])
    held_out = episodes["scenario"].isin([f"random-1000{i}" for i in range(5)]) & episodes["policy"].eq(
        "ihpso"
    )
    chosen = episodes[paper | held_out]
    ids = chosen["episode_id"].tolist()
    rows = tmp_path / "rows"
    tables = {
        "episodes": chosen,
        "steps": pd.read_parquet(f"{stem}-steps.parquet", filters=[("episode_id", "in", ids)]),
        "runs": pd.read_parquet(f"{stem}-runs.parquet").query("run_id in @chosen.run_id"),
        "scenarios": pd.read_parquet(f"{stem}-scenarios.parquet").query(
            "scenario_hash in @chosen.scenario_hash"
        ),
        "policies": pd.read_parquet(f"{stem}-policies.parquet").query("policy_hash in @chosen.policy_hash"),
    }
    for name, table in tables.items():
        table.to_parquet(f"{rows}-{name}.parquet", index=False)
    store = tmp_path / "published.sqlite"
    assert cli.main(["import", "--rows", str(rows), "--store", str(store)]) == 0
    out = tmp_path / "d"
    assert cli.main(["export", "--minari", "--store", str(store), "--out", str(out)]) == 0
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(out))
    totals = chosen.set_index("episode_id")["total_cost"]
    expected = {"paper-2022-sec5-greedy-v0": 20, "paper-2022-sec5-ihpso-v0": 20, "random-ihpso-v0": 5}
    assert sorted(minari.list_local_datasets()) == sorted(f"uav-penetration/{n}" for n in expected)
    for name, count in expected.items():
        dataset = minari.load_dataset(f"uav-penetration/{name}")
        assert dataset.total_episodes == count
        for episode, extra in zip(dataset.iterate_episodes(), episode_metadata(dataset), strict=True):
            total = totals.loc[extra["store_episode_id"]]  # the committed total, not the imported store's
            assert float(np.sum(episode.rewards)) == pytest.approx(-total, rel=1e-9, abs=1e-9)
