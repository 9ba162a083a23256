"""``uav-bench plot``: the figures (PNG + PDF) per scenario group, from a results store.

Plug-ins may add other figure sources through a :class:`CommandExtension` of ``plot`` (the ``rl``
extra's ``baselines`` adds ``--models``: learning curves of trained agents).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from uav_penetration_env.benchmark.commands.common import (
    DEFAULT_OUT,
    CLIError,
    Command,
    add_replace_out_argument,
    add_store_argument,
    check_out_folder,
    check_writable_folder,
    existing_store,
    int_at_least,
    path_argument,
    record_out_folder,
)


def add_altitude_argument(parser: argparse.ArgumentParser) -> None:
    """``--altitude M``: the radar-coverage altitude of the track figures (plot, report)."""
    parser.add_argument(
        "--altitude",
        type=float,
        help="altitude of the radar coverage in the track figures [m above datum] "
        "(default: the median altitude of the MPC planners' tracks)",
    )


def add_min_seeds_argument(parser: argparse.ArgumentParser) -> None:
    """``--min-seeds N``: per-scenario figures only for scenarios flown with N seeds or more (plot, report)."""
    parser.add_argument(
        "--min-seeds",
        type=int_at_least(1),
        default=1,
        help="draw per-scenario figures only for scenarios flown with at least N seeds (default: 1, all)",
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench plot``."""
    add_store_argument(parser)
    add_replace_out_argument(parser)
    parser.add_argument(
        "--out", type=path_argument, default=str(DEFAULT_OUT), help=f"output folder (default: {DEFAULT_OUT})"
    )
    parser.add_argument("--suite", help="aggregate figures over all the store's scenarios, named SUITE")
    add_altitude_argument(parser)
    add_min_seeds_argument(parser)


def run(args: argparse.Namespace) -> int:
    """Draw the store's figures and print their paths (and the scenarios ``--min-seeds`` left out)."""
    store = existing_store(args.store)  # first: a bad store creates no output folder
    if args.suite is not None and args.min_seeds != 1:
        raise CLIError(
            f"--min-seeds {args.min_seeds}: selects per-scenario figures, but with --suite every episode forms "
            "one group; expected the default 1 with --suite"
        )
    check_writable_folder(Path(args.out), "--out")
    check_out_folder(Path(args.out), store, replace=bool(args.replace_out))
    from uav_penetration_env.benchmark.figures import write_figures

    for path in write_figures(
        store, Path(args.out), suite=args.suite, altitude=args.altitude, min_seeds=args.min_seeds
    ):
        print(path)
    record_out_folder(Path(args.out), store)
    if args.min_seeds > 1:
        from uav_penetration_env.benchmark.rows import store_tables

        episodes = store_tables(store).episodes
        seeds = episodes.groupby("scenario")["seed"].nunique() if len(episodes) else []
        few = sorted(name for name, n in dict(seeds).items() if n < args.min_seeds)
        if few:
            print(
                f"no figures for {len(few)} of {len(seeds)} scenarios flown with fewer than {args.min_seeds} "
                f"seeds ({', '.join(few[:3])}{', ...' if len(few) > 3 else ''}; --min-seeds)"
            )
    return 0


COMMAND = Command(name="plot", help="figures (PNG + PDF) from a store", add_arguments=add_arguments, run=run)
