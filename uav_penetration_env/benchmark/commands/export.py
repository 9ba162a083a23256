"""``uav-bench export``: the store's tables as CSV or Parquet files.

The episodes, runs and window-runs files are the rows ``uav-bench leaderboard --rows STEM``
recomputes the leaderboards from without the store (:mod:`~..rows`); with the steps and the
configurations by hash (scenarios, policies) they are the whole store, which ``uav-bench import``
rebuilds (:mod:`~..restore`).

With ``--tracks``: every episode's track points from step 0 (state, action, cost terms, detection,
altitude above terrain) as ``<stem>-tracks.<format>``, and ``<stem>-tracks.geojson`` (one
LineString per episode; longitude/latitude for DEM scenarios), :mod:`~..track_export`.

With ``--minari``: the stored episodes re-flown through the env and written as Farama Minari
datasets under a local root (``--out DIR``, default ``<store stem>-minari/``), one per policy
configuration and scenario set (:mod:`~..minari_export`, api.md §4.10; the ``offline`` extra).

With ``--ioh``: the store's window runs (``uav-bench windows``) in IOHprofiler's file format, one
folder per optimiser configuration under ``--out DIR`` (default ``<store stem>-ioh/``), for
IOHanalyzer (:mod:`~..blackbox.ioh_export`, docs/blackbox.md §3; the ``blackbox`` extra).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from uav_penetration_env.atomic import atomic_path
from uav_penetration_env.benchmark.commands.common import (
    CLIError,
    Command,
    add_store_argument,
    check_writable_folder,
    existing_store,
    int_at_least,
    path_argument,
    removed_if_failed,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench export``."""
    parser.add_argument(
        "--format", choices=["csv", "parquet"], help="the tables' format (required unless --minari)"
    )
    add_store_argument(parser)
    parser.add_argument(
        "--out",
        type=path_argument,
        help="output stem, e.g. rows/paper (default: the store path without suffix); a folder (DIR/) "
        "holds files named after the store; with --minari the datasets' root folder (default: STORE-minari/)",
    )
    parser.add_argument(
        "--tracks",
        action="store_true",
        help="write the track points of every episode (from step 0) and a GeoJSON file instead",
    )
    parser.add_argument(
        "--ioh",
        action="store_true",
        help="write the window runs (uav-bench windows) as IOHprofiler data for IOHanalyzer, one folder per "
        "optimiser configuration under --out DIR (default: STORE-ioh/; the blackbox extra; docs/blackbox.md)",
    )
    minari = parser.add_argument_group("Minari datasets (--minari; the offline extra)")
    minari.add_argument(
        "--minari",
        action="store_true",
        help="write the stored episodes, re-flown through the env and checked against the store, as Minari "
        "datasets: one per policy configuration and scenario set (api.md §4.10)",
    )
    minari.add_argument(
        "--policy",
        action="append",
        metavar="NAME",
        help="only this policy's episodes (repeatable; default: all)",
    )
    minari.add_argument(
        "--scenarios",
        nargs="+",
        metavar="NAME",
        help="only these stored scenarios, scenario sets (random-17 is in the set random) or name patterns "
        "('random-100*'); default: all",
    )
    minari.add_argument(
        "--dataset-id",
        metavar="NAMESPACE/NAME-vN",
        help="the id of the one dataset the selection makes (default: uav-penetration/SET-POLICY-vN)",
    )
    minari.add_argument(
        "--dataset-version",
        type=int_at_least(0),
        metavar="N",
        help="the -vN of the default dataset ids (default: 0)",
    )


def run(args: argparse.Namespace) -> int:
    """Write ``<stem>-{episodes,runs,window_runs,steps,scenarios,policies}.<format>``, then ``<stem>-manifest.json``; print their paths.

    The tables are read in one transaction (:meth:`~.store.ResultsStore.snapshot`), so an export
    taken while a ``run`` writes the store is consistent; the manifest, written last, lets
    ``uav-bench import`` refuse an export that stopped part-way (:mod:`~..export_manifest`).
    """
    import json

    import pandas as pd

    from uav_penetration_env.benchmark.export_manifest import write_manifest
    from uav_penetration_env.benchmark.rows import row_path, write_table
    from uav_penetration_env.benchmark.store import ResultsStore

    if args.ioh:
        return _export_ioh(args)
    if args.minari:
        return _export_minari(args)
    if args.format is None:
        raise CLIError("--format: expected csv or parquet (or --minari for Minari datasets)")
    for flag in ("policy", "scenarios", "dataset_id", "dataset_version"):
        if getattr(args, flag) is not None:
            raise CLIError(
                f"--{flag.replace('_', '-')}: selects the episodes of --minari; expected it with --minari"
            )
    store_path = existing_store(args.store)
    out = Path(args.out) if args.out else store_path.with_suffix("")
    if args.out and (args.out.endswith(("/", "\\")) or out.is_dir()):
        out = out / store_path.stem  # a folder: the rows go inside it, named after the store
    check_writable_folder(out.parent, "--out")  # --out is a file stem: <stem>-episodes.csv, ...
    with ResultsStore(store_path, create=False) as store, store.snapshot():  # one consistent read
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
    written = {}
    for name, frame in tables.items():
        path = row_path(out, name, args.format)
        write_table(frame, path, args.format)
        written[name] = (path, len(frame))
        print(path)
    print(write_manifest(out, written))  # last: its presence says the export is complete
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


def _export_minari(args: argparse.Namespace) -> int:
    """``--minari``: the planned datasets, re-flown and checked, under the local root; print their ids and folders."""
    from uav_penetration_env.benchmark.minari_export import (
        MINARI,
        MinariExportError,
        plan_datasets,
        write_datasets,
    )
    from uav_penetration_env.benchmark.store import ResultsStore

    for flag in ("format", "tracks"):
        if getattr(args, flag):
            raise CLIError(f"--{flag}: writes tables; expected no --{flag} with --minari")
    if args.dataset_id is not None and args.dataset_version is not None:
        raise CLIError(
            "--dataset-version: versions the default ids; expected it without --dataset-id (whose -vN is the version)"
        )
    MINARI.check("export --minari")  # one line naming the extra, before the store is read
    store_path = existing_store(args.store)
    # Absolute: Minari joins a relative dataset path to its root a second time (the export then failed).
    out = (Path(args.out) if args.out else store_path.with_name(f"{store_path.stem}-minari")).absolute()
    with removed_if_failed(out), ResultsStore(store_path, create=False) as store:
        check_writable_folder(out, "--out")
        try:
            plans = plan_datasets(
                store.episodes(),
                policies=args.policy,
                scenarios=args.scenarios,
                dataset_id=args.dataset_id,
                version=args.dataset_version or 0,
            )
            written = write_datasets(store, plans, out)
        except MinariExportError as error:
            raise CLIError(str(error)) from None
    for plan, folder in zip(plans, written, strict=True):
        print(f"{plan.dataset_id}: {len(plan.episodes)} episodes -> {folder}")
    print(f"load with MINARI_DATASETS_PATH={out} and minari.load_dataset(ID)")
    return 0


def _export_ioh(args: argparse.Namespace) -> int:
    """``--ioh``: the window runs as IOHprofiler data under ``--out``; print the folders written."""
    from uav_penetration_env.benchmark.blackbox.ioh_export import IOH, export_window_runs
    from uav_penetration_env.benchmark.store import ResultsStore

    for flag in ("format", "tracks", "minari", "policy", "scenarios", "dataset_id", "dataset_version"):
        if getattr(args, flag) not in (None, False):
            raise CLIError(
                f"--{flag.replace('_', '-')}: not an option of --ioh; expected --ioh with --store and --out"
            )
    IOH.check("export --ioh")  # one line naming the extra, before the store is read
    store_path = existing_store(args.store)
    out = Path(args.out) if args.out else store_path.with_name(f"{store_path.stem}-ioh")
    check_writable_folder(out, "--out")
    with ResultsStore(store_path, create=False) as store:
        try:
            written = export_window_runs(store, out)
        except ValueError as error:
            raise CLIError(f"--ioh: {error}") from None
    for folder in sorted({path.parent for path in written}):
        print(f"{folder}: {sum(path.parent == folder for path in written)} windows")
    print(f"load {out} in IOHanalyzer (docs/blackbox.md §3)")
    return 0


COMMAND = Command(
    name="export",
    help="write the store as tables (episodes, runs, window runs, steps, scenarios, policies), or the tracks (--tracks, also GeoJSON), as CSV or Parquet; or its episodes as Minari datasets (--minari), or its window runs as IOHprofiler data (--ioh)",
    add_arguments=add_arguments,
    run=run,
)
