"""Tracks out of a store: `export --tracks` (CSV/Parquet round trip, GeoJSON, DEM longitudes) and `replay`."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
import yaml

from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.store import ResultsStore
from uav_penetration_env.benchmark.track_export import LOCAL, WGS84, track_rows, tracks_geojson
from uav_penetration_env.catalogue import dem_scenario
from uav_penetration_env.dem import EARTH_RADIUS_M, local_to_lonlat

STATE = ["x_km", "y_km", "z_m", "speed", "heading", "pitch"]
ACTION = ["action_dv", "action_dphi", "action_dtheta"]
COSTS = ["J", "penalty", "terrain_threat", "radar_threat", "third_term", "fuel_kg"]


@pytest.fixture(scope="module")
def store(greedy_random_store):
    """greedy and random, two seeds each, on the tiny scenario cut to 6 steps (shared, read only)."""
    return greedy_random_store


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_export_tracks_round_trips_through_pandas(store, tmp_path, fmt, capsys):
    assert (
        cli.main(["export", "--tracks", "--format", fmt, "--store", str(store), "--out", str(tmp_path / "t")])
        == 0
    )
    table = tmp_path / f"t-tracks.{fmt}"
    assert capsys.readouterr().out.split() == [str(table), str(tmp_path / "t-tracks.geojson")]
    read = pd.read_csv(table) if fmt == "csv" else pd.read_parquet(table)
    with ResultsStore(store) as opened:
        expected = track_rows(opened)
        episodes = opened.episodes()
    pd.testing.assert_frame_equal(read, expected, check_dtype=False)
    for column in ["policy", "seed", "step", *STATE, *ACTION, *COSTS, "detection_prob", "altitude_agl"]:
        assert column in read
    # One row per track point, the start state (step 0) included: K + 1 rows per episode.
    assert len(read) == int((episodes["steps"] + 1).sum()) == read.groupby("episode_id").size().sum()
    starts = read[read["step"] == 0]
    assert len(starts) == 4 and starts["J"].eq(0).all() and starts["action_dv"].isna().all()
    assert read["longitude"].isna().all()  # the tiny scenario is not on Earth
    # The sum over the transitions is the episode's stored total J.
    sums = read[read["step"] > 0].groupby("episode_id")["J"].sum()
    totals = episodes.set_index("episode_id")["total_J"]
    assert np.allclose(sums.to_numpy(), totals.loc[sums.index].to_numpy())


def test_geojson_has_one_linestring_per_episode(store, tmp_path):
    assert (
        cli.main(
            ["export", "--tracks", "--format", "csv", "--store", str(store), "--out", str(tmp_path / "t")]
        )
        == 0
    )
    collection = json.loads((tmp_path / "t-tracks.geojson").read_text())
    with ResultsStore(store) as opened:
        episodes = opened.episodes()
    assert collection["type"] == "FeatureCollection" and collection["coordinates"] == LOCAL
    assert len(collection["features"]) == len(episodes) == 4
    for feature in collection["features"]:
        row = episodes.set_index("episode_id").loc[feature["properties"]["episode_id"]]
        coordinates = feature["geometry"]["coordinates"]
        assert feature["geometry"]["type"] == "LineString"
        assert len(coordinates) == row["steps"] + 1 == feature["properties"]["points"]
        assert all(len(position) == 3 for position in coordinates)
        assert (
            feature["properties"]["policy"] == row["policy"] and feature["properties"]["seed"] == row["seed"]
        )


def test_local_to_lonlat_inverts_the_dem_projection():
    config = dem_scenario().terrain.natural
    west, south = config.lon_deg[0], config.lat_deg[0]
    lat_c = math.radians(0.5 * sum(config.lat_deg))
    # The forward projection of dem.py: x = R cos(lat_c) (lon - west), y = R (lat - south), radians.
    lon = np.array([west, -122.5, config.lon_deg[1]])
    lat = np.array([south, 49.5, config.lat_deg[1]])
    x = EARTH_RADIUS_M * math.cos(lat_c) * np.radians(lon - west)
    y = EARTH_RADIUS_M * np.radians(lat - south)
    back_lon, back_lat = local_to_lonlat(config, x, y)
    assert np.allclose(back_lon, lon, atol=1e-9) and np.allclose(back_lat, lat, atol=1e-9)


def test_dem_tracks_get_longitude_and_latitude(tmp_path):
    scenario = dem_scenario()
    config = scenario.terrain.natural
    path = tmp_path / "dem.sqlite"
    with ResultsStore(path) as opened:
        opened.register({}, {scenario.hash: ("dem", yaml.safe_dump(scenario.to_dict(), sort_keys=False))})
        episode = {
            "policy": "greedy", "policy_hash": "g" * 16, "scenario": "dem", "scenario_hash": scenario.hash,
            "seed": 0, "outcome": "success", "total_J": 1.0, "total_cost": 1.0, "steps": 2, "error": "",
        }  # fmt: skip
        points = [
            {"step": k, "x_km": 10.0 * k, "y_km": 5.0 * k, "z_m": 500.0, "J": 0.5 * (k > 0)} for k in range(3)
        ]
        opened.write_episode(episode, points)
        rows = track_rows(opened)
    assert rows["longitude"].iloc[0] == pytest.approx(config.lon_deg[0])
    assert rows["latitude"].iloc[0] == pytest.approx(config.lat_deg[0])
    # 10 km east at the window's centre latitude is 10 / (R cos lat_c) radians of longitude.
    lat_c = math.radians(0.5 * sum(config.lat_deg))
    expected = config.lon_deg[0] + math.degrees(10_000.0 / (EARTH_RADIUS_M * math.cos(lat_c)))
    assert rows["longitude"].iloc[1] == pytest.approx(expected)
    collection = tracks_geojson(rows)
    assert collection["coordinates"] == WGS84
    (feature,) = collection["features"]
    assert feature["geometry"]["coordinates"][1][0] == pytest.approx(expected)


def test_replay_writes_a_gif_of_the_episode(store, tmp_path, capsys):
    from PIL import Image

    out = tmp_path / "greedy.gif"
    assert (
        cli.main(["replay", "--store", str(store), "--policy", "greedy", "--seed", "1", "--out", str(out)])
        == 0
    )
    assert capsys.readouterr().out.strip() == str(out)
    with ResultsStore(store) as opened:
        episodes = opened.episodes()
    steps = int(episodes.loc[(episodes["policy"] == "greedy") & (episodes["seed"] == 1), "steps"].iloc[0])
    with Image.open(out) as image:
        assert image.n_frames == steps + 1 > 1  # one frame per track point, from the start state
        image.seek(0)
        first = np.asarray(image.convert("RGB"))
        image.seek(image.n_frames - 1)
        last = np.asarray(image.convert("RGB"))
    assert not np.array_equal(first, last)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["--policy", "gredy", "--seed", "0", "--out", "x.gif"],
            "--policy: 'gredy' is not in the store — did you mean 'greedy'?",
        ),
        (
            ["--policy", "greedy", "--seed", "7", "--out", "x.gif"],
            "--seed: 'greedy' has no episode with seed 7; stored seeds: [0, 1]",
        ),
        (["--policy", "greedy", "--seed", "0", "--out", "x.avi"], "--out: got"),
        (["--policy", "greedy", "--seed", "0", "--out", "x.gif", "--fps", "0"], "--fps: got 0.0"),
    ],
)
def test_replay_errors_name_the_argument(store, tmp_path, argv, message, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["replay", "--store", str(store), *argv]) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_replay_mp4_without_ffmpeg_says_so(store, tmp_path, capsys, monkeypatch):
    from matplotlib import animation

    monkeypatch.setattr(animation.writers, "is_available", lambda name: False)
    out = tmp_path / "x.mp4"
    assert (
        cli.main(["replay", "--store", str(store), "--policy", "greedy", "--seed", "0", "--out", str(out)])
        == 2
    )
    assert "needs ffmpeg on the PATH" in capsys.readouterr().err and not out.exists()


def test_a_track_across_the_antimeridian_is_cut_into_a_multilinestring():
    from uav_penetration_env.benchmark.track_export import split_at_antimeridian

    # East across +180 between points 1 and 2, back west between 3 and 4.
    track = np.array(
        [
            [179.0, 10.0, 100.0],
            [179.5, 11.0, 200.0],
            [-179.5, 13.0, 400.0],
            [-179.0, 14.0, 500.0],
            [179.8, 15.0, 0.0],
        ]
    )
    parts = split_at_antimeridian(track)
    assert [len(p) for p in parts] == [3, 4, 2]  # each part gains the crossing point(s) at its ends
    # Halfway in longitude from 179.5 to 180.5: latitude 12, z 300, on both sides of the cut.
    np.testing.assert_allclose(parts[0][-1], [180.0, 12.0, 300.0])
    np.testing.assert_allclose(parts[1][0], [-180.0, 12.0, 300.0])
    # From -179 west to 179.8 (1.2 deg): the cut is 1/1.2 of the way, at latitude 14 + 1 / 1.2.
    np.testing.assert_allclose(parts[1][-1], [-180.0, 14.0 + 1.0 / 1.2, 500.0 - 500.0 / 1.2])
    np.testing.assert_allclose(parts[2][0], [180.0, 14.0 + 1.0 / 1.2, 500.0 - 500.0 / 1.2])
    for part in parts:
        assert np.all(np.abs(np.diff(part[:, 0])) < 180.0)
    assert len(split_at_antimeridian(track[:2])) == 1

    rows = pd.DataFrame(
        {"episode_id": 1, "longitude": track[:, 0], "latitude": track[:, 1], "z_m": track[:, 2],
         "x_km": 0.0, "y_km": 0.0, "J": 0.0, "detection_prob": 0.0, "episode_steps": 4,
         **{key: "k" for key in ("policy", "scenario", "scenario_hash", "outcome")}, "seed": 0, "total_cost": 1.0}
    )  # fmt: skip
    geometry = tracks_geojson(rows)["features"][0]["geometry"]
    assert geometry["type"] == "MultiLineString" and len(geometry["coordinates"]) == 3
    assert geometry["coordinates"][0][-1] == [180.0, 12.0, 300.0]
