"""The results store's schema: step-0 rows, the migration of schema-1 stores, added columns.

``data/store-v1.sqlite`` was written by the schema-1 code (commit 9309f59: a tiny-scenario sweep of
pso, greedy and random over seeds 0-2, plus one error row), ``data/leaderboard-v1/`` is the
leaderboard that code made of it, and ``data/store-v1-starts.json`` the start states its figures
recovered by replaying each seed's env reset (float hex).
"""

from __future__ import annotations

import json
import re
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest import tiny_scenario

from uav_penetration_env import PenetrationModel, load_scenario
from uav_penetration_env.benchmark import figures
from uav_penetration_env.benchmark import leaderboard as lb
from uav_penetration_env.benchmark.columns import EPISODE, STEP
from uav_penetration_env.benchmark.evaluate import episode_seeds, evaluate
from uav_penetration_env.benchmark.policies import make_policy
from uav_penetration_env.benchmark.store import SCHEMA_VERSION, ResultsStore
from uav_penetration_env.env import UAVPenetrationEnv

DATA = Path(__file__).parent / "data"


def without_date(text: str) -> str:
    return re.sub(r"^- Date: .*$", "- Date:", text, flags=re.MULTILINE)


@pytest.fixture
def store_v1(tmp_path) -> Path:
    """A private copy of the schema-1 store (opening migrates it in place)."""
    path = tmp_path / "store-v1.sqlite"
    shutil.copy(DATA / "store-v1.sqlite", path)
    return path


def raw(path: Path, query: str) -> list[tuple]:
    connection = sqlite3.connect(path)
    try:
        return connection.execute(query).fetchall()
    finally:
        connection.close()


def test_the_fixture_is_a_schema_1_store_without_start_rows(store_v1):
    assert raw(store_v1, "SELECT version FROM schema_version") == [(1,)]
    assert raw(store_v1, "SELECT COUNT(*) FROM steps WHERE step = 0") == [(0,)]


def test_migration_adds_one_start_row_per_episode_with_steps_once(store_v1):
    with ResultsStore(store_v1) as store:
        episodes = store.episodes()
        steps = store.steps()
        everything = store.steps(include_start=True)
    assert raw(store_v1, "SELECT version FROM schema_version") == [(SCHEMA_VERSION,)]
    finished = episodes[episodes["error"] == ""]
    starts = everything[everything["step"] == 0]
    assert sorted(starts["episode_id"]) == sorted(finished["episode_id"])  # the error row has no steps
    assert len(steps) == int(finished["steps"].sum())  # the default read is the transitions only
    assert len(everything) == len(steps) + len(finished)
    with ResultsStore(store_v1) as store:  # a second open migrates nothing
        assert len(store.steps(include_start=True)) == len(everything)


def test_migrated_start_rows_are_the_starts_the_old_figures_replayed(store_v1):
    expected = {int(seed): [float.fromhex(v) for v in state] for seed, state in json.loads(
        (DATA / "store-v1-starts.json").read_text()
    ).items()}  # fmt: skip
    with ResultsStore(store_v1) as store:
        episodes = store.episodes()
        starts = store.steps(include_start=True).query("step == 0").merge(episodes[["episode_id", "seed"]])
    assert len(starts) == 9
    for row in starts.itertuples():
        state = expected[int(row.seed)]
        assert (row.x_km, row.y_km, row.z_m) == (state[0] / 1000.0, state[1] / 1000.0, state[2])
        assert (row.speed, row.heading, row.pitch) == tuple(state[3:])
        assert row.J == 0.0 and row.penalty == 0.0 and row.fuel_kg == 0.0
        assert row.action_dv is None or np.isnan(row.action_dv)


def test_a_start_row_stepped_with_the_first_action_gives_the_stored_step_1(store_v1):
    """Independent of how the migration computed it: the physics from step 0 reproduces step 1."""
    with ResultsStore(store_v1) as store:
        (scenario_yaml,) = [text for _, text in store.scenarios().values()]
        rows = store.steps(include_start=True)
    model = PenetrationModel(load_scenario(yaml.safe_load(scenario_yaml)))
    for _, episode in rows.groupby("episode_id"):
        start, first = episode.iloc[0], episode.iloc[1]
        assert (start["step"], first["step"]) == (0, 1)
        state = np.array(
            [start.x_km * 1e3, start.y_km * 1e3, start.z_m, start.speed, start.heading, start.pitch]
        )
        action = first[["action_dv", "action_dphi", "action_dtheta"]].to_numpy(dtype=np.float64)
        after = model.step(state[None], action[None], 0)
        np.testing.assert_allclose(
            after.state[0, :3] / [1e3, 1e3, 1.0],
            first[["x_km", "y_km", "z_m"]].to_numpy(dtype=np.float64),
            rtol=1e-12,
        )
        assert after.J[0] == pytest.approx(first["J"], rel=1e-9)


FAILURES_HEADER = "failures: goal pass/terrain/edge/ceiling/trunc"


def without_failure_kinds(markdown: str, csv: str) -> tuple[str, str]:
    """The Markdown and CSV of a leaderboard without the failure counts by kind (added since, api.md §4.11)."""
    import csv as csv_module
    import io

    lines = markdown.splitlines(keepends=True)
    header = next(line for line in lines if line.startswith("| policy"))
    index = [cell.strip() for cell in header.split("|")].index(FAILURES_HEADER)
    table = [
        "|".join(cell for i, cell in enumerate(line.split("|")) if i != index) if line.startswith("|") else line
        for line in lines
        if not line.startswith("- **failures**: ")
    ]
    rows = list(csv_module.reader(io.StringIO(csv)))
    kept = [i for i, name in enumerate(rows[0]) if not name.startswith("fail_")]
    out = io.StringIO()
    csv_module.writer(out, lineterminator="\n").writerows([[row[i] for i in kept] for row in rows])
    return "".join(table), out.getvalue()


def test_leaderboard_of_a_migrated_store_is_the_one_the_old_code_made(store_v1, tmp_path):
    paths = lb.write_leaderboards(
        store_v1, tmp_path, command="uav-bench leaderboard (fixture)", n_resamples=500, reference="greedy"
    )
    assert [p.name for p in paths] == ["tiny.md", "tiny.csv"]
    old = DATA / "leaderboard-v1"
    # Since then the statistics name the table's seed set first (api.md §4.5); nothing else moved.
    text = paths[0].read_text()
    seed_set = re.search(r"Every statistic of a ranked policy is over the same \d+ seeds \([^)]*\)\. ", text)
    assert seed_set is not None
    # And the failures are counted by kind, from the step rows (api.md §4.11).
    assert FAILURES_HEADER in text and "fail_goal_pass" in paths[1].read_text()
    text, csv = without_failure_kinds(text, paths[1].read_text())
    assert without_date(text.replace(seed_set.group(0), "")) == without_date((old / "tiny.md").read_text())
    assert csv == (old / "tiny.csv").read_text()


def test_figures_of_a_migrated_store_take_the_start_from_step_0(store_v1, tmp_path):
    with ResultsStore(store_v1) as store:
        rows = store.steps(include_start=True)
        (group,) = lb.scenario_groups(store.episodes())
    start = figures.start_state(group.episodes, rows[rows["step"] == 0], 1)
    expected = [float.fromhex(v) for v in json.loads((DATA / "store-v1-starts.json").read_text())["1"][:3]]
    np.testing.assert_allclose(start, expected, rtol=1e-15)
    paths = figures.write_figures(store_v1, tmp_path, formats=("png",))
    assert len(paths) == len(figures.FIGURES)


def test_a_store_lacking_declared_columns_gains_them_on_open(store_v1):
    connection = sqlite3.connect(store_v1)
    connection.execute("ALTER TABLE episodes DROP COLUMN train_seconds")
    connection.execute("ALTER TABLE steps DROP COLUMN history_nfev")
    connection.commit()
    connection.close()
    with ResultsStore(store_v1) as store:
        episodes = store.episodes()
        steps = store.steps()
    assert list(episodes.columns) == ["episode_id", *(c.name for c in EPISODE)]
    assert list(steps.columns) == ["episode_id", *(c.name for c in STEP)]
    assert episodes["train_seconds"].isna().all() and steps["history_nfev"].isna().all()
    assert len(episodes) == 10


def test_a_new_run_stores_the_start_state_the_env_reset_gives(tmp_path):
    scenario = tiny_scenario(start={"jitter": {"xy_km": 1.5, "heading_deg": 10.0}}, time={"max_steps": 10})
    store_path = tmp_path / "new.sqlite"
    frame = evaluate({"greedy": make_policy("greedy")}, [scenario], [4, 5], store=store_path, progress=False)
    with ResultsStore(store_path) as store:
        rows = store.steps(include_start=True).merge(store.episodes()[["episode_id", "seed"]])
    for seed in (4, 5):
        _, info = UAVPenetrationEnv(scenario).reset(seed=episode_seeds(seed, scenario.hash)[0])
        start = rows[(rows["seed"] == seed) & (rows["step"] == 0)].iloc[0]
        assert (start.x_km, start.y_km, start.z_m) == tuple(info["position"])
        assert start.radar_threat == info["radar_threat"] and start.detection_prob == info["detection_prob"]
        assert start.nfev is None or np.isnan(start.nfev)
        transitions = rows[(rows["seed"] == seed) & (rows["step"] > 0)]
        episode = frame[frame["seed"] == seed].iloc[0]
        # Episode totals are sums over the transitions alone: the step-0 row is in none of them.
        assert transitions["J"].sum() == pytest.approx(episode["total_J"], rel=1e-12)
        assert transitions["radar_threat"].sum() == pytest.approx(episode["radar_total"], rel=1e-12)
        assert len(transitions) == episode["steps"]


@pytest.mark.parametrize("stored", ["start:\n  x_km: 3\n", "", "radars: [unclosed"])
def test_episodes_whose_stored_scenario_is_not_the_one_flown_get_no_start_row(store_v1, tmp_path, stored):
    """A YAML that is missing, broken, or of another scenario (another hash) must not invent a start."""
    connection = sqlite3.connect(store_v1)
    connection.execute("UPDATE scenarios SET yaml = ?", (stored,))
    connection.commit()
    connection.close()
    with ResultsStore(store_v1) as store:
        assert len(store.steps(include_start=True)) == len(store.steps())
    assert raw(store_v1, "SELECT version FROM schema_version") == [(SCHEMA_VERSION,)]
    assert len(figures.write_figures(store_v1, tmp_path, formats=("png",))) == len(figures.FIGURES)
