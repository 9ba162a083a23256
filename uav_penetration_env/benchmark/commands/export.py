"""``uav-bench export``: the store's tables as CSV or Parquet files.

The episodes, runs and window-runs files are the rows ``uav-bench leaderboard --rows STEM``
recomputes the leaderboards from without the store (:mod:`~..rows`); with the steps and the
configurations by hash (scenarios, policies) they are the whole store, which ``uav-bench import``
rebuilds (:mod:`~..restore`).

With ``--tracks``: every episode's track points from step 0 (state, action, cost terms, detection,
altitude above terrain) as ``<stem>-tracks.<format>``, and ``<stem>-tracks.geojson`` (one
LineString per episode; longitude/latitude for DEM scenarios), :mod:`~..track_export`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from uav_penetration_env.atomic import atomic_path
from uav_penetration_env.benchmark.commands.common import (
    Command,
    add_store_argument,
    check_writable_folder,
    existing_store,
    path_argument,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench export``."""
    parser.add_argument("--format", choices=["csv", "parquet"], required=True)
    add_store_argument(parser)
    parser.add_argument(
        "--out",
        type=path_argument,
        help="output stem, e.g. rows/paper (default: the store path without suffix); a folder (DIR/) "
        "holds files named after the store",
    )
    parser.add_argument(
        "--tracks",
        action="store_true",
        help="write the track points of every episode (from step 0) and a GeoJSON file instead",
    )


def run(args: argparse.Namespace) -> int:
    """Write ``<stem>-{episodes,runs,window_runs,steps,scenarios,policies}.<format>``; print their paths."""
    import json

    import pandas as pd

    from uav_penetration_env.benchmark.rows import row_path, write_table
    from uav_penetration_env.benchmark.store import ResultsStore

    store_path = existing_store(args.store)
    out = Path(args.out) if args.out else store_path.with_suffix("")
    if args.out and (args.out.endswith(("/", "\\")) or out.is_dir()):
        out = out / store_path.stem  # a folder: the rows go inside it, named after the store
    check_writable_folder(out.parent, "--out")  # --out is a file stem: <stem>-episodes.csv, ...
    with ResultsStore(store_path, create=False) as store:
        if args.tracks:
            return _export_tracks(store, out, args.format)
        tables = {
            "episodes": store.episodes(),
            "runs": store.runs(),
            "window_runs": store.window_runs(),
            "steps": store.steps(),
            "scenarios": pd.DataFrame(
                [(h, name, text) for h, (name, text) in sorted(store.scenarios().items())],
                columns=["scenario_hash", "scenario", "yaml"],
            ),
            "policies": pd.DataFrame(
                [
                    (h, name, json.dumps(config, sort_keys=True))
                    for h, (name, config) in sorted(store.policies().items())
                ],
                columns=["policy_hash", "policy", "config"],
            ),
        }
    for name, frame in tables.items():
        path = row_path(out, name, args.format)
        write_table(frame, path, args.format)
        print(path)
    return 0


def _export_tracks(store, out: Path, extension: str) -> int:
    """``--tracks``: the track table and its GeoJSON twin; print their paths."""
    import json

    from uav_penetration_env.benchmark.track_export import track_rows, tracks_geojson

    rows = track_rows(store)
    table = out.parent / f"{out.name}-tracks.{extension}"
    with atomic_path(table) as temporary:  # an interrupted export never looks complete
        if extension == "csv":
            rows.to_csv(temporary, index=False)
        else:
            rows.to_parquet(temporary, index=False)
    geojson = out.parent / f"{out.name}-tracks.geojson"
    with atomic_path(geojson) as temporary:
        temporary.write_text(json.dumps(tracks_geojson(rows)))
    print(table)
    print(geojson)
    return 0


COMMAND = Command(
    name="export",
    help="write the store as tables (episodes, runs, window runs, steps, scenarios, policies), or the tracks (--tracks, also GeoJSON), as CSV or Parquet",
    add_arguments=add_arguments,
    run=run,
)
