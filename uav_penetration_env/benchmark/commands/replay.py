"""``uav-bench replay``: animate one stored episode as a GIF or an MP4 (:mod:`~..replay`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from uav_penetration_env.benchmark.commands.common import (
    CLIError,
    Command,
    add_store_argument,
    check_writable_folder,
    existing_store,
    path_argument,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench replay``."""
    add_store_argument(parser)
    parser.add_argument("--policy", required=True, help="the policy's name in the store (e.g. ihpso)")
    parser.add_argument("--seed", required=True, type=int, help="the episode's seed")
    parser.add_argument("--scenario", help="the scenario's name (needed when the policy flew several)")
    parser.add_argument(
        "--out", type=path_argument, required=True, help="FILE.gif (Pillow) or FILE.mp4 (needs ffmpeg)"
    )
    parser.add_argument("--fps", type=float, default=4.0, help="track points per second (default: 4)")


def run(args: argparse.Namespace) -> int:
    """Find the episode, check the output, write the animation and print its path."""
    from uav_penetration_env.benchmark.replay import ReplayError, animate_episode, find_episode
    from uav_penetration_env.benchmark.store import ResultsStore

    if not args.fps > 0:
        raise CLIError(f"--fps: got {args.fps}, expected a number of frames per second > 0")
    store_path = existing_store(args.store)
    out = Path(args.out)
    check_writable_folder(out.parent, "--out")
    try:
        with ResultsStore(store_path, create=False) as store:
            stored = find_episode(store, args.policy, args.seed, args.scenario)
        path = animate_episode(stored, out, fps=args.fps)
    except ReplayError as error:
        raise CLIError(str(error)) from None
    print(path)
    return 0


COMMAND = Command(
    name="replay",
    help="animate one stored episode (GIF, or MP4 with ffmpeg)",
    add_arguments=add_arguments,
    run=run,
)
