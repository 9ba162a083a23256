"""Failed episodes by kind: goal pass, terrain, edge, ceiling, truncation (api.md §4.11).

The env's ``outcome`` says how an episode ended (``collided``, ``out_of_area``, ``truncated``);
it merges leaving the map with climbing above its ceiling, and it does not say whether the UAV
had been at the goal before it failed. This module classifies each failed episode into exactly
one kind from its stored track (the ``x_km``, ``y_km``, ``z_m`` of its step rows) and the
scenario's geometry (:class:`FailureGeometry`):

* ``goal_pass``: the track came within ``pass_distance_km`` of the goal (the closest horizontal
  approach of its segments, as the env's goal test measures it) and then moved away again, and
  the episode ended without success, whichever way;
* otherwise the physical end: ``terrain`` (``collided``), ``edge`` (``out_of_area`` with the last
  position outside the map's x/y bounds), ``ceiling`` (``out_of_area`` above the ceiling) or
  ``truncation`` (``truncated``: K_max steps flown).

:func:`classify_failure` is the pure classifier of one track; :func:`failure_kinds` applies it to
the episodes of a store's row tables (:class:`~.rows.ResultTables`), which the leaderboard counts
per policy (``fail_goal_pass`` ... ``fail_truncation``, :func:`failure_counts`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

if TYPE_CHECKING:
    from uav_penetration_env.benchmark.rows import ResultTables
    from uav_penetration_env.scenario import Scenario

FAILURE_KINDS = ("goal_pass", "terrain", "edge", "ceiling", "truncation")  # the counts' order
FAILURE_COLUMNS = tuple(f"fail_{kind}" for kind in FAILURE_KINDS)  # the leaderboard CSV's columns
FAILED_OUTCOMES = ("collided", "out_of_area", "truncated")  # the outcomes that are failures
# The track must recede from its closest approach by more than this to have passed the goal [km]:
# 1 mm, far below any step (>= v_min dt) and far above float rounding of kilometre coordinates.
RECEDE_TOLERANCE_KM = 1e-6


@dataclass(frozen=True)
class FailureGeometry:
    """The scenario quantities a failure's kind depends on.

    Attributes:
        goal_km: (x, y) of the goal [km].
        goal_radius_km: the goal radius [km] (the env's success test).
        x_km: (low, high) map bounds in x [km].
        y_km: (low, high) map bounds in y [km].
        ceiling_m: the map's ceiling [m above the datum].
        pass_distance_km: a closest approach within this distance of the goal point is a goal
            pass [km]; at least ``goal_radius_km``.

    Raises:
        ValueError: a non-finite value, an empty bound interval, a radius <= 0 or a pass
            distance below the radius (the message names the field).
    """

    goal_km: tuple[float, float]
    goal_radius_km: float
    x_km: tuple[float, float]
    y_km: tuple[float, float]
    ceiling_m: float
    pass_distance_km: float

    def __post_init__(self) -> None:
        for name in ("goal_km", "x_km", "y_km"):
            pair = getattr(self, name)
            if len(pair) != 2 or not all(np.isfinite(v) for v in pair):
                raise ValueError(f"FailureGeometry.{name}: got {pair!r}, expected two finite kilometres")
        for name in ("x_km", "y_km"):
            low, high = getattr(self, name)
            if not low < high:
                raise ValueError(f"FailureGeometry.{name}: got {(low, high)!r}, expected low < high")
        if not (np.isfinite(self.goal_radius_km) and self.goal_radius_km > 0):
            raise ValueError(
                f"FailureGeometry.goal_radius_km: got {self.goal_radius_km!r}, expected a radius > 0 km"
            )
        if not np.isfinite(self.ceiling_m):
            raise ValueError(
                f"FailureGeometry.ceiling_m: got {self.ceiling_m!r}, expected a finite altitude [m]"
            )
        if not (np.isfinite(self.pass_distance_km) and self.pass_distance_km >= self.goal_radius_km):
            raise ValueError(
                f"FailureGeometry.pass_distance_km: got {self.pass_distance_km!r}, expected a distance >= the goal "
                f"radius {self.goal_radius_km!r} km"
            )

    @classmethod
    def of(cls, scenario: Scenario) -> FailureGeometry:
        """The geometry of a scenario; the pass distance is its goal edge margin (api.md §4.11).

        DECISION (api.md §4.11): a goal pass is a closest approach within two turn radii at v_max,
        2 v_max dt / Δφ_max (``Scenario.goal_edge_margin_km``, 22.9 km on the paper scenario), the
        room the scenario schema keeps around the goal so that a planner can always turn onto it;
        a UAV that was inside it had reached the goal's neighbourhood and failed to close.
        """
        return cls(
            goal_km=(float(scenario.goal.x_km), float(scenario.goal.y_km)),
            goal_radius_km=float(scenario.goal.radius_km),
            x_km=(float(scenario.map.x_km[0]), float(scenario.map.x_km[1])),
            y_km=(float(scenario.map.y_km[0]), float(scenario.map.y_km[1])),
            ceiling_m=float(scenario.map.ceiling_m),
            pass_distance_km=max(float(scenario.goal_edge_margin_km), float(scenario.goal.radius_km)),
        )


def closest_approach_km(
    x_km: np.ndarray, y_km: np.ndarray, goal_km: tuple[float, float]
) -> tuple[float, float]:
    """The closest horizontal approach of a track's segments to the goal, and the track's last distance.

    Args:
        x_km: (K,) x of the track points in flight order [km], K >= 1; a single point is its own
            closest approach.
        y_km: (K,) y of the track points [km].
        goal_km: (x, y) of the goal [km].

    Returns:
        (closest distance over every segment [km], distance of the last point [km]); the
        segments are measured as the env's goal test measures them (the closest point of each
        straight segment, model.md §7a).
    """
    dx_goal = float(goal_km[0]) - x_km
    dy_goal = float(goal_km[1]) - y_km
    last = float(np.hypot(dx_goal[-1], dy_goal[-1]))
    if x_km.size == 1:
        return last, last
    seg_x, seg_y = np.diff(x_km), np.diff(y_km)
    travel_sq = seg_x * seg_x + seg_y * seg_y
    # where along each segment the goal is closest (0 = its start, 1 = its end), as segment_events
    t = np.clip((dx_goal[:-1] * seg_x + dy_goal[:-1] * seg_y) / np.maximum(travel_sq, 1e-18), 0.0, 1.0)
    miss = np.hypot(dx_goal[:-1] - t * seg_x, dy_goal[:-1] - t * seg_y)
    return float(miss.min()), last


def classify_failure(
    outcome: str, x_km: np.ndarray, y_km: np.ndarray, z_m: np.ndarray, geometry: FailureGeometry
) -> str:
    """The kind of one failed episode (one of :data:`FAILURE_KINDS`).

    DECISION (api.md §4.11): a goal pass takes precedence over the physical end: an episode that
    came within ``geometry.pass_distance_km`` of the goal and then moved away (its last point
    more than :data:`RECEDE_TOLERANCE_KM` farther than its closest approach) is a ``goal_pass``
    whether it then hit the terrain, left the map or ran out of steps, since the failure that
    decided it was not closing on the goal; one that ended at its closest approach (still closing)
    is counted by how it ended. ``out_of_area`` is ``edge`` when the last point is outside the
    map's x/y bounds (whatever its altitude), else ``ceiling`` when it is above the ceiling; a
    last point inside both (only by rounding the stored kilometres at a bound) takes the bound it
    is nearer to.

    Args:
        outcome: the episode's outcome, one of :data:`FAILED_OUTCOMES`.
        x_km: (K,) x of the track's points in flight order [km], K >= 1.
        y_km: (K,) y of the track's points [km].
        z_m: (K,) its altitudes above the datum [m].
        geometry: the scenario's :class:`FailureGeometry`.

    Returns:
        ``goal_pass``, ``terrain``, ``edge``, ``ceiling`` or ``truncation``.

    Raises:
        ValueError: an outcome that is not a failure, tracks of different lengths, an empty
            track or a non-finite position (the message names the field).
    """
    if outcome not in FAILED_OUTCOMES:
        raise ValueError(f"outcome: got {outcome!r}, expected a failure: {', '.join(FAILED_OUTCOMES)}")
    track = {
        name: np.asarray(values, dtype=np.float64)
        for name, values in (("x_km", x_km), ("y_km", y_km), ("z_m", z_m))
    }
    for name, values in track.items():
        if values.ndim != 1 or values.size == 0:
            raise ValueError(f"{name}: got shape {values.shape}, expected (K,) track points with K >= 1")
        if values.shape != track["x_km"].shape:
            raise ValueError(f"{name}: got {values.size} points, expected {track['x_km'].size} as x_km has")
        if not np.all(np.isfinite(values)):
            raise ValueError(f"{name}: got a non-finite position, expected finite track points")
    x, y, z = track["x_km"], track["y_km"], track["z_m"]
    closest, last = closest_approach_km(x, y, geometry.goal_km)
    if closest <= geometry.pass_distance_km and last - closest > RECEDE_TOLERANCE_KM:
        return "goal_pass"
    if outcome == "collided":
        return "terrain"
    if outcome == "truncated":
        return "truncation"
    (x_lo, x_hi), (y_lo, y_hi) = geometry.x_km, geometry.y_km
    outside_m = 1000.0 * max(x_lo - x[-1], x[-1] - x_hi, y_lo - y[-1], y[-1] - y_hi)
    above_m = float(z[-1]) - geometry.ceiling_m
    if outside_m > 0 or (above_m <= 0 and outside_m >= above_m):
        return "edge"
    return "ceiling"


def failure_kinds(
    episodes: pd.DataFrame, tracks: pd.DataFrame, geometries: Mapping[str, FailureGeometry | None]
) -> pd.Series:
    """Each episode's failure kind: a kind for a failed episode, ``None`` for the others.

    Args:
        episodes: episode rows with ``episode_id``, ``scenario_hash``, ``outcome`` (and ``error``).
        tracks: step rows with :data:`~.store.TRACK_COLUMNS`; only steps >= 1 are read (see
            :meth:`~.store.ResultsStore.tracks`).
        geometries: scenario hash -> its geometry, or ``None`` when its scenario could not be read.

    Returns:
        (episodes,) object Series on ``episodes.index``: :data:`FAILURE_KINDS` for a failed
        episode without an error whose track and scenario are known; ``None`` for a success, an
        error row, and a failure that cannot be classified (no step rows, or an unknown scenario).
    """
    kinds = pd.Series([None] * len(episodes), index=episodes.index, dtype=object)
    error = (
        episodes["error"].fillna("").astype(str)
        if "error" in episodes
        else pd.Series("", index=episodes.index)
    )
    failed = episodes[episodes["outcome"].isin(FAILED_OUTCOMES) & (error == "")]
    if failed.empty or tracks.empty:
        return kinds
    ids = set(failed["episode_id"].astype(int))
    rows = tracks[tracks["episode_id"].isin(ids) & (tracks["step"] > 0)].sort_values(
        ["episode_id", "step"], kind="mergesort"
    )
    by_episode = {int(i): group for i, group in rows.groupby("episode_id", sort=False)}
    for index, row in failed.iterrows():
        track = by_episode.get(int(row["episode_id"]))
        geometry = geometries.get(str(row["scenario_hash"]))
        if track is None or geometry is None:
            continue
        kinds[index] = classify_failure(
            str(row["outcome"]),
            track["x_km"].to_numpy(dtype=np.float64),
            track["y_km"].to_numpy(dtype=np.float64),
            track["z_m"].to_numpy(dtype=np.float64),
            geometry,
        )
    return kinds


def scenario_geometries(scenarios: Mapping[str, str]) -> dict[str, FailureGeometry | None]:
    """Scenario hash -> :class:`FailureGeometry` of its stored YAML; ``None`` where it no longer loads."""
    import yaml

    from uav_penetration_env.scenario import load_scenario

    geometries: dict[str, FailureGeometry | None] = {}
    for scenario_hash, text in sorted(scenarios.items()):
        try:
            geometries[scenario_hash] = (
                FailureGeometry.of(load_scenario(yaml.safe_load(text))) if text else None
            )
        except (ValueError, KeyError, TypeError, yaml.YAMLError):  # ScenarioError is a ValueError
            geometries[scenario_hash] = None
    return geometries


def with_failure_kinds(tables: ResultTables) -> pd.DataFrame:
    """The tables' episodes with a ``failure_kind`` column, or as they are when no track is known.

    DECISION (api.md §4.11): the kinds are computed from the step rows and scenario YAML the
    tables carry (a store's, or an export's ``-steps`` and ``-scenarios`` tables), steps >= 1
    alone, as an export writes them, so the tables of a store and of its exported rows are the
    same bytes. Without step rows (an export of the episodes alone) the episodes get no column
    and the leaderboard no failure counts, as before.
    """
    if tables.tracks is None or tables.tracks.empty or tables.scenarios is None:
        return tables.episodes
    if "episode_id" not in tables.episodes:
        return tables.episodes
    kinds = failure_kinds(tables.episodes, tables.tracks, scenario_geometries(tables.scenarios))
    return tables.episodes.assign(failure_kind=kinds)


def failure_counts(valid: pd.DataFrame) -> dict[str, Any]:
    """One policy's failures by kind over its finished episodes: ``fail_<kind>`` -> count.

    Returns:
        An empty dict when the episodes carry no ``failure_kind`` (no track rows); counts of every
        kind; or ``pd.NA`` for each when one of the policy's failures could not be classified (a
        partial count would read as a complete one).
    """
    if "failure_kind" not in valid:
        return {}
    failed = valid[valid["outcome"].isin(FAILED_OUTCOMES)]
    if failed["failure_kind"].isna().any():
        return dict.fromkeys(FAILURE_COLUMNS, pd.NA)
    return {
        column: int((failed["failure_kind"] == kind).sum())
        for kind, column in zip(FAILURE_KINDS, FAILURE_COLUMNS, strict=True)
    }
