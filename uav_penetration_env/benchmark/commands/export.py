"""``uav-bench export``: the store's episodes and steps tables as CSV or Parquet files."""

from __future__ import annotations

import argparse
from pathlib import Path

from uav_penetration_env.atomic import atomic_path
from uav_penetration_env.benchmark.commands.common import (
    Command,
    add_store_argument,
    check_writable_folder,
    existing_store,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench export``."""
    parser.add_argument("--format", choices=["csv", "parquet"], required=True)
    add_store_argument(parser)
    parser.add_argument("--out", help="output stem (default: the store path without suffix)")


def run(args: argparse.Namespace) -> int:
    """Write ``<stem>-episodes.<format>`` and ``<stem>-steps.<format>`` and print their paths."""
    from uav_penetration_env.benchmark.store import ResultsStore

    store_path = existing_store(args.store)
    out = Path(args.out) if args.out else store_path.with_suffix("")
    check_writable_folder(out.parent, "--out")  # --out is a file stem: <stem>-episodes.csv, ...
    with ResultsStore(store_path, create=False) as store:
        tables = {"episodes": store.episodes(), "steps": store.steps()}
    for name, frame in tables.items():
        path = out.parent / f"{out.name}-{name}.{args.format}"
        with atomic_path(path) as temporary:  # an interrupted export never looks complete
            if args.format == "csv":
                frame.to_csv(temporary, index=False)
            else:
                frame.to_parquet(temporary, index=False)
        print(path)
    return 0


COMMAND = Command(
    name="export",
    help="write the episodes and steps tables as CSV or Parquet",
    add_arguments=add_arguments,
    run=run,
)
