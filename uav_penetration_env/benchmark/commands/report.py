"""``uav-bench report``: the leaderboards, the figures and one self-contained HTML page of a store.

``uav-bench run`` ends with the same :func:`write_results` unless ``--no-report``; this command
writes them again from any store (e.g. after adding episodes, or on another machine).

DECISION (api.md §4.6): the page is written together with the tables and figures it shows, so it
never shows stale files left in ``--out`` by an earlier run; the figures are PNG only here (the
page embeds PNGs; ``uav-bench plot`` writes the PDFs).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from uav_penetration_env.benchmark.commands.common import (
    DEFAULT_OUT,
    CLIError,
    Command,
    add_fixed_target_rule_argument,
    add_replace_out_argument,
    add_store_argument,
    check_out_folder,
    check_reference,
    check_writable_folder,
    command_line,
    existing_store,
    fixed_target_rule,
    path_argument,
    record_out_folder,
    reference_names,
)
from uav_penetration_env.benchmark.commands.plot import add_altitude_argument, add_min_seeds_argument


@dataclass(frozen=True)
class Written:
    """What :func:`write_results` wrote: leaderboard files, figure files and the HTML page."""

    tables: list[Path] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)
    report: Path | None = None
    fixed_target: list[Path] = field(default_factory=list)  # Markdown + CSV per scenario with window runs


def write_results(
    store: Path,
    out: Path,
    *,
    command: str,
    reference: str = "ihpso",
    formats: Sequence[str] = ("png",),
    altitude: float | None = None,
    min_seeds: int = 1,
    extra_figures: Sequence[Path] = (),
    fixed_target_rule: str = "coco",
) -> Written:
    """Write the leaderboards, the figures and ``out/index.html`` of ``store``.

    Args:
        store: an existing results store.
        out: the output folder (created if needed).
        command: the command line recorded in the tables' provenance.
        reference: the policy the paired tests compare against.
        formats: figure file types (the page embeds the PNGs).
        altitude: the radar-coverage altitude of the track figures [m] (default: the MPC
            planners' median).
        min_seeds: per-scenario figures and 3-D views only for scenarios flown with at least this
            many seeds (``write_figures``).
        extra_figures: PNG files drawn elsewhere (e.g. learning curves, ``plot --models``) to embed too.
        fixed_target_rule: the window comparisons' rule (:data:`~..fixedtarget.FIXED_TARGET_RULES`).

    Returns:
        The written paths.
    """
    from uav_penetration_env.benchmark.figures import write_figures
    from uav_penetration_env.benchmark.fixedtarget import write_fixed_target
    from uav_penetration_env.benchmark.leaderboard import write_leaderboards
    from uav_penetration_env.benchmark.report import write_report

    tables = write_leaderboards(store, out, reference=reference, command=command)
    # Window runs (uav-bench windows): the fixed-target pages beside the leaderboards (api.md §4.8).
    fixed_target = write_fixed_target(store, out, reference=reference, command=command, rule=fixed_target_rule)
    figures = write_figures(store, out, formats=formats, altitude=altitude, min_seeds=min_seeds)
    page = write_report(
        store,
        out,
        tables=tables,
        figures=[*figures, *extra_figures],
        reference=reference,
        min_seeds=min_seeds,
        fixed_target_rule=fixed_target_rule,
    )
    return Written(tables=tables, figures=figures, report=page, fixed_target=fixed_target)


def print_written(written: Written, out: Path, reference: str | None = None) -> None:
    """The terminal summary of each table, then the paths of the full tables and the report."""
    from uav_penetration_env.benchmark.summary import print_summary

    print_summary(
        written.tables,
        report=written.report,
        figures=out if written.figures else None,
        reference=reference,
    )
    for path in written.fixed_target:
        print(f"fixed target: {path}")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench report``."""
    add_store_argument(parser)
    add_replace_out_argument(parser)
    parser.add_argument(
        "--out",
        type=path_argument,
        default=str(DEFAULT_OUT),
        help=f"folder of index.html and its files (default: {DEFAULT_OUT})",
    )
    parser.add_argument(
        "--reference", help="policy the paired tests compare against (default: ihpso, where stored)"
    )
    add_altitude_argument(parser)
    add_min_seeds_argument(parser)
    add_fixed_target_rule_argument(parser)
    parser.add_argument(
        "--figures",
        nargs="+",
        default=(),
        metavar="PNG",
        help="more PNG figures to embed (e.g. the learning curves of `uav-bench plot --models`)",
    )


def _readable_png(path: Path) -> bool:
    """Whether ``path`` decodes as a PNG image (the page re-encodes it, ``report.embedded_png``)."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as image:
            image.load()
            return image.format == "PNG"
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError):
        return False


def run(args: argparse.Namespace) -> int:
    """Write the tables, figures and page; print the summary and where they are."""
    rule = fixed_target_rule(args)
    store = existing_store(args.store)
    from uav_penetration_env.benchmark.rows import store_tables

    if args.reference is not None:  # an explicit name must exist; the default may be absent
        check_reference(args.reference, reference_names(store_tables(store)))
    extra = [Path(f) for f in args.figures]
    for path in extra:
        if path.suffix != ".png" or not path.is_file() or not _readable_png(path):
            raise CLIError(
                f"--figures {path}: not a PNG file; expected figures such as those `uav-bench plot` writes"
            )
    out = Path(args.out)
    check_writable_folder(out, "--out")
    check_out_folder(out, store, replace=bool(args.replace_out))
    written = write_results(
        store,
        out,
        command=command_line(args),
        reference=args.reference or "ihpso",
        altitude=args.altitude,
        min_seeds=args.min_seeds,
        extra_figures=extra,
        fixed_target_rule=rule,
    )
    record_out_folder(out, store)
    print_written(written, out)
    return 0


COMMAND = Command(
    name="report",
    help="one self-contained HTML page (tables, figures, 3-D tracks) from a store",
    add_arguments=add_arguments,
    run=run,
)
