"""Failed episodes counted by kind: goal pass, terrain, edge, ceiling, truncation (api.md §4.11)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import yaml
from conftest import tiny_scenario

from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark import leaderboard as lb
from uav_penetration_env.benchmark.columns import STATISTICS
from uav_penetration_env.benchmark.failure_kinds import (
    FAILURE_COLUMNS,
    FailureGeometry,
    classify_failure,
    with_failure_kinds,
)
from uav_penetration_env.benchmark.rows import read_rows, store_tables
from uav_penetration_env.benchmark.store import ResultsStore

# The tiny scenario: a [-25, 50] km map, goal (25, 25) km of radius 3 km, ceiling 3000 m, and a
# pass distance of two turn radii at v_max (3 km steps, 15 degree turns): 22.9 km.
GEOMETRY = FailureGeometry.of(tiny_scenario())
ALTITUDE = 500.0  # [m], below the ceiling


def line(start, end, points=6, z=ALTITUDE):
    """(x, y, z) of ``points`` evenly spaced track points from ``start`` to ``end`` [km, km, m]."""
    t = np.linspace(0.0, 1.0, points)
    x = start[0] + t * (end[0] - start[0])
    y = start[1] + t * (end[1] - start[1])
    return x, y, np.full(points, z) if np.isscalar(z) else np.asarray(z, dtype=np.float64)


# A track that passes 50 m outside the goal's radius (closest approach 3.05 km, on a segment
# between two points farther out) and flies on east out of the map.
BESIDE = 25.0 - GEOMETRY.goal_radius_km - 0.05
TRACKS = {
    "goal pass, then out of the map": ("out_of_area", line((-10.0, BESIDE), (50.7, BESIDE), 8), "goal_pass"),
    "goal pass, then into the terrain": ("collided", line((0.0, BESIDE), (40.0, BESIDE)), "goal_pass"),
    "goal pass, then out of steps": ("truncated", line((0.0, 10.0), (45.0, 10.0)), "goal_pass"),
    "crash while still closing on the goal": ("collided", line((0.0, 0.0), (20.0, 20.0)), "terrain"),
    "crash far from the goal": ("collided", line((0.0, -20.0), (30.0, -20.0)), "terrain"),
    "x edge far from the goal": ("out_of_area", line((0.0, -20.0), (50.4, -20.0)), "edge"),
    "y edge far from the goal": ("out_of_area", line((-20.0, 0.0), (-20.0, -25.3)), "edge"),
    "above the ceiling, inside the map": (
        "out_of_area", line((0.0, -20.0), (20.0, -20.0), 4, z=[500.0, 1500.0, 2500.0, 3100.0]), "ceiling"
    ),
    "above the ceiling and over the edge": (
        "out_of_area", line((30.0, -20.0), (50.2, -20.0), 3, z=[2000.0, 2800.0, 3100.0]), "edge"
    ),
    "out of steps far from the goal": ("truncated", line((-20.0, -20.0), (-20.0, 20.0)), "truncation"),
}  # fmt: skip


@pytest.mark.parametrize("case", list(TRACKS))
def test_each_hand_made_track_has_its_kind(case):
    outcome, (x, y, z), kind = TRACKS[case]
    assert classify_failure(outcome, x, y, z, GEOMETRY) == kind


def test_the_goal_pass_is_the_segment_closest_approach_not_the_points():
    # Points 6 km apart on y = 25 - 20 km: every point is >= 20 km from the goal, the segment's
    # closest point 20 km; with a pass distance of 20.5 km that is a pass, by the points it is not.
    x, y, z = line((-5.0, 5.0), (55.0, 5.0), 11)
    geometry = FailureGeometry((25.0, 25.0), 3.0, (-25.0, 50.0), (-25.0, 50.0), 3000.0, 20.5)
    x, y, z = x[[0, 4, 6, 10]], y[[0, 4, 6, 10]], z[[0, 4, 6, 10]]  # 19 and 31 km: no point within 20.5
    assert min(np.hypot(x - 25.0, y - 25.0)) > 20.5
    assert classify_failure("out_of_area", x, y, z, geometry) == "goal_pass"


def test_the_pass_distance_is_two_turn_radii_at_v_max():
    scenario = tiny_scenario()
    v_max, dt, turn = scenario.uav.speed_m_s[1], scenario.time.dt_s, np.radians(scenario.uav.dheading_max_deg)
    assert GEOMETRY.pass_distance_km == pytest.approx(2.0 * v_max * dt / turn / 1000.0)
    assert GEOMETRY.pass_distance_km == pytest.approx(22.918, abs=1e-3)


@pytest.mark.parametrize(
    ("arguments", "field"),
    [
        (("success", [0.0], [0.0], [0.0]), "outcome"),
        (("collided", [0.0, 1.0], [0.0], [0.0, 0.0]), "y_km"),
        (("collided", [0.0, 1.0], [0.0, 1.0], [0.0, np.nan]), "z_m"),
        (("collided", [], [], []), "x_km"),
    ],
)
def test_bad_tracks_are_refused_in_one_line_naming_the_field(arguments, field):
    with pytest.raises(ValueError, match=rf"^{field}: got "):
        classify_failure(*arguments, GEOMETRY)


def test_a_pass_distance_below_the_goal_radius_is_refused():
    with pytest.raises(ValueError, match=r"^FailureGeometry.pass_distance_km: got 2"):
        FailureGeometry((25.0, 25.0), 3.0, (-25.0, 50.0), (-25.0, 50.0), 3000.0, 2.0)


# --- the counts in the leaderboard -------------------------------------------------------------------

HASH = "f" * 16
# policy -> the cases of its failed seeds (the others succeed); "floor" fails once without steps.
FLOWN = {
    "mpc": ["goal pass, then out of the map", "goal pass, then out of steps", "x edge far from the goal",
            "above the ceiling, inside the map", "crash far from the goal"],
    "greedy": ["out of steps far from the goal", "crash while still closing on the goal"],
    "floor": [None],
}  # fmt: skip
SEEDS = range(6)


def _episode(policy: str, seed: int, outcome: str, cost: float) -> dict:
    return {
        "policy": policy, "policy_hash": f"{policy:x<16}"[:16], "scenario": "tiny", "scenario_hash": HASH,
        "seed": seed, "outcome": outcome, "total_J": cost, "total_penalty": 0.0, "total_cost": cost,
        "steps": 5, "error": "",
    }  # fmt: skip


def write_store(path, with_steps=True):
    with ResultsStore(path) as store:
        store.register({}, {HASH: ("tiny", yaml.safe_dump(tiny_scenario().to_dict()))})
        for policy, cases in FLOWN.items():
            for seed in SEEDS:
                case = cases[seed] if seed < len(cases) else "success"
                if case is None:  # a failure whose steps were not stored
                    store.write_episode(_episode(policy, seed, "collided", 30.0 + seed), [])
                    continue
                outcome, (x, y, z), _ = TRACKS.get(case, ("success", line((0.0, 0.0), (25.0, 25.0)), None))
                steps = [
                    {"step": k, "x_km": float(a), "y_km": float(b), "z_m": float(c)}
                    for k, (a, b, c) in enumerate(zip(x, y, z, strict=True))
                ]  # step 0: the start, which the kinds leave out (an export has none)
                store.write_episode(
                    _episode(policy, seed, outcome, 10.0 + seed + len(policy)), steps if with_steps else []
                )
        # A harness error: no kind, no count.
        store.write_episode(_episode("mpc", 9, "error", 0.0) | {"error": "RuntimeError: boom"}, [])
    return path


@pytest.fixture(scope="module")
def store_path(tmp_path_factory):
    return write_store(tmp_path_factory.mktemp("kinds") / "kinds.sqlite")


def test_each_stored_failure_gets_its_kind_and_the_others_none(store_path):
    episodes = with_failure_kinds(store_tables(store_path)).set_index(["policy", "seed"])
    kinds = episodes["failure_kind"]
    for policy, cases in FLOWN.items():
        for seed, case in enumerate(cases):
            assert kinds.loc[(policy, seed)] == (TRACKS[case][2] if case is not None else None), (
                policy,
                seed,
            )
    assert kinds[episodes["outcome"] == "success"].isna().all()
    assert kinds.loc[("mpc", 9)] is None  # the error row


def test_the_table_counts_failures_by_kind(store_path):
    table = lb.leaderboard_table(with_failure_kinds(store_tables(store_path)), n_resamples=200).set_index(
        "policy"
    )
    assert table.loc["mpc", list(FAILURE_COLUMNS)].tolist() == [
        2,
        1,
        1,
        1,
        0,
    ]  # goal pass, terrain, edge, ceiling, trunc
    assert table.loc["mpc", "errors"] == 1
    assert table.loc["greedy", list(FAILURE_COLUMNS)].tolist() == [0, 1, 0, 0, 1]
    assert table.loc["floor", list(FAILURE_COLUMNS)].isna().all()  # its one failure has no track
    # The counts add up to the outcome counts they refine.
    mpc = table.loc["mpc"]
    assert sum(mpc[list(FAILURE_COLUMNS)]) == mpc["collided"] + mpc["out_of_area"] + mpc["truncated"]
    header, rows, _ = lb.markdown_rows(table.reset_index(), None)
    cells = {row[0]: dict(zip(header, row, strict=True)) for row in rows}
    column = "failures: goal pass/terrain/edge/ceiling/trunc"
    assert (cells["mpc"][column], cells["greedy"][column], cells["floor"][column]) == (
        "2/1/1/1/0",
        "0/1/0/0/1",
        "",
    )


def test_the_failure_counts_are_one_registration():
    (column,) = [c for c in STATISTICS if c.name == "failure_kinds"]
    assert column.csv == FAILURE_COLUMNS
    assert column.board.recorded_only


def test_without_steps_there_are_no_failure_counts(tmp_path):
    path = write_store(tmp_path / "stepless.sqlite", with_steps=False)
    table = lb.leaderboard_table(with_failure_kinds(store_tables(path)), n_resamples=200)
    assert not set(FAILURE_COLUMNS) & set(table.columns)
    assert "failures: goal pass/terrain/edge/ceiling/trunc" not in lb.markdown_rows(table, None)[0]


def _stable(path):
    return [line for line in path.read_text().splitlines() if not line.startswith("- Date: ")]


def test_the_tables_rebuild_from_exported_rows_byte_for_byte(store_path, tmp_path):
    from_store = lb.write_leaderboards(store_path, tmp_path / "store", n_resamples=200)
    csv = pd.read_csv(next(p for p in from_store if p.suffix == ".csv"))
    assert list(csv.columns[csv.columns.get_loc("truncated") + 1 :][:5]) == list(FAILURE_COLUMNS)
    assert csv.set_index("policy").loc["mpc", list(FAILURE_COLUMNS)].tolist() == [2, 1, 1, 1, 0]
    for fmt in ("parquet", "csv"):
        stem = tmp_path / fmt / "rows"
        assert cli.main(["export", "--format", fmt, "--store", str(store_path), "--out", str(stem)]) == 0
        rebuilt = lb.write_leaderboards(read_rows(stem), tmp_path / f"from-{fmt}", n_resamples=200)
        assert [p.name for p in rebuilt] == [p.name for p in from_store]
        for got, expected in zip(rebuilt, from_store, strict=True):
            if got.suffix == ".csv":
                assert got.read_bytes() == expected.read_bytes(), (fmt, got.name)
            else:
                assert _stable(got) == _stable(expected), (fmt, got.name)
    # Rows exported without their steps: the tables as before the failure kinds.
    (tmp_path / "parquet" / "rows-steps.parquet").unlink()
    bare = lb.write_leaderboards(read_rows(tmp_path / "parquet" / "rows"), tmp_path / "bare", n_resamples=200)
    assert not set(FAILURE_COLUMNS) & set(pd.read_csv(next(p for p in bare if p.suffix == ".csv")).columns)
