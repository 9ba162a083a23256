"""``uav-bench import``: a new results store from the tables ``uav-bench export`` wrote (api.md §4.9).

The inverse of ``export``: every id is kept, so the store reads as the exported one did, and
``run``, ``windows`` and ``best-known`` carry on from it (a published leaderboard's committed rows
become a store new policies are added to). See :mod:`~..restore`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from uav_penetration_env.benchmark.commands.common import (
    CLIError,
    Command,
    check_writable_folder,
    path_argument,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench import``."""
    parser.add_argument(
        "--rows",
        type=path_argument,
        metavar="STEM",
        required=True,
        help="exported tables STEM-episodes/-runs/....parquet|csv",
    )
    parser.add_argument(
        "--store", type=path_argument, required=True, help="the new results store to write (must not exist)"
    )


def run(args: argparse.Namespace) -> int:
    """Write the store; print what it holds."""
    from uav_penetration_env.benchmark.restore import RestoreError, restore_store
    from uav_penetration_env.benchmark.rows import RowsError
    from uav_penetration_env.benchmark.store import StoreError

    store = Path(args.store)
    # An existing target (refused by restore_store) has its folder already: this creates nothing then.
    check_writable_folder(store.parent, "--store", args.store)
    try:
        restored = restore_store(args.rows, store)
    except (RowsError, RestoreError) as error:
        raise CLIError(str(error)) from None
    except StoreError as error:  # the target, not the rows: they are RestoreErrors naming --rows
        raise CLIError(f"--store {args.store}: {error.reason}") from None
    held = ", ".join(f"{count} {table}" for table, count in restored.counts.items())
    print(f"uav-bench import: {store}: {held}")
    if restored.rebuilt_scenarios:
        print(
            f"  {len(restored.rebuilt_scenarios)} scenarios rebuilt from this version's suites and catalogue "
            "(the rows had no scenarios table), each checked against its recorded hash"
        )
    return 0


COMMAND = Command(
    name="import",
    help="write a new results store from the tables `uav-bench export` wrote (every id kept)",
    add_arguments=add_arguments,
    run=run,
)
