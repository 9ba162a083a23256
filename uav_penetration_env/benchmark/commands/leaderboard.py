"""``uav-bench leaderboard``: Markdown + CSV leaderboards per scenario group, from a results store.

``--rows STEM`` computes them from exported rows instead (``uav-bench export``; :mod:`~..rows`):
the same rows give the same files, byte for byte apart from the date line, with no store at all.
Several stems are exports of one store in pieces (a publication's checkpoint chunks), read as one
(:func:`~..rows.read_chunks`).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from uav_penetration_env.benchmark.commands.common import (
    DEFAULT_OUT,
    DEFAULT_STORE,
    CLIError,
    Command,
    add_fixed_target_rule_argument,
    add_replace_out_argument,
    add_store_argument,
    check_out_folder,
    check_reference,
    check_writable_folder,
    command_line,
    fixed_target_rule,
    path_argument,
    record_out_folder,
    reference_names,
    result_tables,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench leaderboard``."""
    add_store_argument(parser, default=None)
    add_replace_out_argument(parser)
    parser.add_argument(
        "--rows",
        type=path_argument,
        nargs="+",
        metavar="STEM",
        help="compute from exported rows STEM-episodes/-runs[/-window_runs].parquet|csv instead of a store; "
        "several stems: pieces of one store's export (checkpoint chunks), read as one",
    )
    parser.add_argument(
        "--out", type=path_argument, default=str(DEFAULT_OUT), help=f"output folder (default: {DEFAULT_OUT})"
    )
    parser.add_argument(
        "--reference", help="policy the paired tests compare against (default: ihpso, where stored)"
    )
    parser.add_argument(
        "--suite", help="one table over all the store's scenarios, named SUITE (blocks = scenario x seed)"
    )
    add_fixed_target_rule_argument(parser)


def run(args: argparse.Namespace) -> int:
    """Write the tables; print a compact summary of each and their paths."""
    from uav_penetration_env.benchmark.leaderboard import write_leaderboards

    rule = fixed_target_rule(args)
    tables = result_tables(args, DEFAULT_STORE)
    if args.reference is not None:  # an explicit name must exist; the default may be absent
        check_reference(args.reference, reference_names(tables))
    store = tables  # read once: the tables below are computed from these rows
    from uav_penetration_env.suites import suite_names

    if args.suite in suite_names():
        # A pooled table under a frozen suite's name would contradict the suite's own tables.
        raise CLIError(
            f"--suite {args.suite}: names a frozen suite, whose member-weighted tables are written without "
            "--suite when the store holds a `run --suite` (docs/suite.md §5); give the pooled table another name"
        )

    check_writable_folder(Path(args.out), "--out")
    # Pieces of one export are recorded as their common folder (a checkpoint), one stem as itself.
    source = (
        (args.rows[0] if len(args.rows) == 1 else os.path.commonpath([os.path.abspath(r) for r in args.rows]))
        if args.rows
        else args.store or DEFAULT_STORE
    )
    check_out_folder(Path(args.out), source, replace=bool(args.replace_out))
    written = write_leaderboards(
        store,
        Path(args.out),
        reference=args.reference or "ihpso",
        command=command_line(args),
        suite=args.suite,
    )
    from uav_penetration_env.benchmark.fixedtarget import write_fixed_target
    from uav_penetration_env.benchmark.summary import print_summary

    # Window runs (uav-bench windows): the fixed-target and fixed-budget tables per scenario (api.md §4.8).
    fixed = (
        []
        if args.suite
        else write_fixed_target(
            store,
            Path(args.out),
            reference=args.reference or "ihpso",
            command=command_line(args),
            rule=rule,
        )
    )
    record_out_folder(Path(args.out), source)
    print_summary(written)  # the reference of each table is read from it (a label may differ)
    for path in fixed:
        print(f"fixed target: {path}")
    return 0


COMMAND = Command(
    name="leaderboard",
    help="Markdown + CSV leaderboards from a store",
    add_arguments=add_arguments,
    run=run,
)
