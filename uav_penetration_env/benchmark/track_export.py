"""Flown tracks out of a results store: one row per track point, and GeoJSON (api.md §4.4, §4.6).

:func:`track_rows` joins every stored episode's step rows, the start state (step 0) included, with
the episode's keys: the state, the action, every cost term, detection and the altitude above
terrain, per point. :func:`tracks_geojson` turns them into one GeoJSON ``LineString`` per episode.

DECISION (api.md §4.6): GeoJSON (RFC 7946) positions are longitude, latitude in WGS 84. A DEM
scenario's map is a projection of a geographic window (model.md §2.5), so its points are
projected back (:func:`uav_penetration_env.dem.local_to_lonlat`) and the file is standard. Other
scenarios have no place on Earth: their positions are the local ``[x km, y km, z m]``, and the
collection says so in its ``coordinates`` member, so a GIS never mistakes them for degrees.

DECISION (api.md §4.6): a geographic track that crosses the antimeridian is cut there into a
``MultiLineString`` (RFC 7946 §3.1.9), the crossing point's latitude and altitude interpolated
linearly in longitude and repeated at +180 and -180, so no segment spans the globe.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark.store import ResultsStore

EPISODE_KEYS = ("policy", "scenario", "scenario_hash", "seed", "outcome", "total_cost", "steps")
# Planner internals (per-iteration optimiser histories, JSON lists) stay in `export`'s steps table.
LEFT_OUT = ("history", "history_nfev")
LOCAL = "local x_km, y_km, z_m (the scenario's map frame; no geographic reference)"
WGS84 = "longitude, latitude [deg, WGS 84], z_m [m above datum]"


def track_rows(store: ResultsStore) -> pd.DataFrame:
    """Every stored episode's track points, step 0 (the start state) first, with the episode's keys.

    Error episodes (no steps) are left out. DEM scenarios gain ``longitude`` and ``latitude``
    columns (NaN for other scenarios).

    Returns:
        One row per (episode, step), sorted by episode id and step: ``episode_id``, the keys of
        :data:`EPISODE_KEYS`, then the step columns of the store (``columns.STEP``) except
        :data:`LEFT_OUT`, then ``longitude``, ``latitude``.
    """
    episodes = store.episodes()
    episodes = episodes[episodes["error"].fillna("") == ""]
    steps = store.steps(episodes["episode_id"].astype(int).tolist(), include_start=True)
    steps = steps.drop(columns=[c for c in LEFT_OUT if c in steps])
    keys = episodes[["episode_id", *EPISODE_KEYS]].rename(columns={"steps": "episode_steps"})
    frame = keys.merge(steps, on="episode_id", how="inner").sort_values(
        ["episode_id", "step"], kind="mergesort"
    )
    frame["longitude"], frame["latitude"] = np.nan, np.nan
    for scenario_hash, yaml_text in _scenario_yaml(store).items():
        config = _dem_config(yaml_text)
        if config is None:
            continue
        from uav_penetration_env.dem import local_to_lonlat

        rows = frame["scenario_hash"] == scenario_hash
        lon, lat = local_to_lonlat(
            config,
            frame.loc[rows, "x_km"].to_numpy(dtype=np.float64) * 1000.0,
            frame.loc[rows, "y_km"].to_numpy(dtype=np.float64) * 1000.0,
        )
        frame.loc[rows, "longitude"], frame.loc[rows, "latitude"] = lon, lat
    # A column no row fills (e.g. plan_cost of floors) is numeric NaN, not None, so CSV and
    # Parquet files read back into the same frame.
    empty = [column for column in frame.columns if frame[column].isna().all()]
    frame[empty] = frame[empty].astype(np.float64)
    return frame.reset_index(drop=True)


def tracks_geojson(rows: pd.DataFrame) -> dict[str, Any]:
    """One GeoJSON ``LineString`` feature per episode of :func:`track_rows`' output.

    Positions are ``[longitude, latitude, z_m]`` when the whole collection comes from DEM
    scenarios, else ``[x_km, y_km, z_m]`` (api.md §4.6, the module's decision). Properties: the episode id,
    its keys, the number of points and, per point, ``J`` and ``detection_prob`` lists.

    Returns:
        A GeoJSON ``FeatureCollection`` (a dict ready for ``json.dump``).
    """
    geographic = bool(len(rows)) and bool(rows["longitude"].notna().all())
    columns = ("longitude", "latitude", "z_m") if geographic else ("x_km", "y_km", "z_m")
    features = []
    for episode_id, points in rows.groupby("episode_id", sort=True):
        first = points.iloc[0]
        positions = points[list(columns)].to_numpy(dtype=np.float64)
        parts = split_at_antimeridian(positions) if geographic else [positions]
        properties = {
            "episode_id": int(episode_id),
            **{key: _plain(first[key]) for key in EPISODE_KEYS if key != "steps"},
            "episode_steps": _plain(first["episode_steps"]),
            "points": len(points),
            "J": points["J"].astype(float).round(9).tolist(),
            "detection_prob": points["detection_prob"].astype(float).round(9).tolist(),
        }
        features.append(
            {
                "type": "Feature",
                "geometry": (
                    {"type": "LineString", "coordinates": parts[0].round(7).tolist()}
                    if len(parts) == 1
                    else {
                        "type": "MultiLineString",
                        "coordinates": [part.round(7).tolist() for part in parts],
                    }
                ),
                "properties": properties,
            }
        )
    return {"type": "FeatureCollection", "coordinates": WGS84 if geographic else LOCAL, "features": features}


def split_at_antimeridian(positions: np.ndarray) -> list[np.ndarray]:
    """A track of ``[longitude, latitude, z]`` rows cut where it crosses the antimeridian (the module's decision).

    A step between consecutive points whose longitudes differ by more than 180 deg is the shorter
    way round, across +-180: the crossing's latitude and z are interpolated linearly in unwrapped
    longitude, ending one part at the side the step leaves and starting the next at the other.

    Args:
        positions: (n, 3) rows, longitudes in [-180, 180].

    Returns:
        The parts, in order, each (k, 3); one part (``positions`` itself) when nothing crosses.
    """
    longitude = positions[:, 0]
    crossings = np.flatnonzero(np.abs(np.diff(longitude)) > 180.0)
    if not crossings.size:
        return [positions]
    parts, start = [], positions[:1]
    for i in range(len(positions) - 1):
        a, b = positions[i], positions[i + 1]
        if i not in crossings:
            start = np.vstack([start, b[None]])
            continue
        edge = 180.0 if a[0] > 0 else -180.0  # the side the step leaves
        b_lon = b[0] + (360.0 if edge > 0 else -360.0)  # b seen from a's side
        t = (edge - a[0]) / (b_lon - a[0])
        cross = a + t * (np.array([b_lon, b[1], b[2]]) - a)
        parts.append(np.vstack([start, [[edge, cross[1], cross[2]]]]))
        start = np.vstack([[[-edge, cross[1], cross[2]]], b[None]])
    parts.append(start)
    return parts


def _plain(value: Any) -> Any:
    """A JSON-ready scalar (numpy numbers to Python ones, NaN to None)."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def _scenario_yaml(store: ResultsStore) -> Mapping[str, str]:
    return {scenario_hash: text for scenario_hash, (_, text) in store.scenarios().items()}


def _dem_config(yaml_text: str | None):
    """The DEM terrain settings of a stored scenario, or None (not DEM, or unreadable YAML)."""
    if not yaml_text:
        return None
    import yaml

    from uav_penetration_env.scenario import DEMTerrain, load_scenario

    try:
        natural = load_scenario(yaml.safe_load(yaml_text)).terrain.natural
    except (ValueError, KeyError, TypeError, yaml.YAMLError):  # ScenarioError is a ValueError
        return None
    return natural if isinstance(natural, DEMTerrain) else None
