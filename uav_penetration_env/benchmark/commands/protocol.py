"""``uav-bench protocol FILE --rows STEM ...``: a publication's declared comparisons computed from its rows.

Reads a protocol (docs/publishing.md §6), computes every declared comparison and the success bar
from exported rows or a checkpoint folder (or a store), prints the answers and writes
``DIR/protocol-answers.md``, ``protocol-answers.csv`` and ``protocol-success.csv``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from uav_penetration_env.benchmark.commands.common import (
    CLIError,
    Command,
    add_store_argument,
    check_writable_folder,
    path_argument,
    result_tables,
    write_csv_tables,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench protocol``."""
    parser.add_argument("protocol", type=path_argument, help="the protocol YAML (e.g. leaderboards/protocols/v4.yaml)")
    add_store_argument(parser, default=None)
    parser.add_argument(
        "--rows",
        type=path_argument,
        nargs="+",
        metavar="STEM",
        help="exported rows or a checkpoint folder (as `leaderboard --rows` takes them) instead of a store",
    )
    parser.add_argument("--out", type=path_argument, default=None, help="folder of the answers' files (none: print only)")


def run(args: argparse.Namespace) -> int:
    """Compute, print and (with --out) write the answers."""
    from uav_penetration_env.benchmark.protocol import ProtocolError, load_protocol

    try:
        protocol = load_protocol(args.protocol)
    except ProtocolError as error:
        raise CLIError(str(error)) from None
    from uav_penetration_env.benchmark.protocol import primary_answers, success_bar
    from uav_penetration_env.benchmark.protocol_page import answers_markdown

    tables = result_tables(args)
    source = " ".join(str(r) for r in args.rows) if args.rows is not None else str(args.store)
    answers = primary_answers(protocol, tables.episodes, tables.window_runs)
    success = success_bar(protocol, tables.episodes)
    page = answers_markdown(protocol, answers, success, f"`{source}`")
    print(page)
    if args.out is not None:
        from uav_penetration_env.atomic import write_text_atomic

        out = Path(args.out)
        check_writable_folder(out, "--out")
        write_text_atomic(out / "protocol-answers.md", page + "\n")
        write_csv_tables(
            out, [("protocol-answers.csv", answers), ("protocol-success.csv", success)], ["protocol-answers.md"]
        )
    return 0


COMMAND = Command(
    name="protocol",
    help="a publication's declared comparisons and success bar, from its rows",
    add_arguments=add_arguments,
    run=run,
)
