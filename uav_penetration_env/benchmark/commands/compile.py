"""``uav-bench compile``: fill the compile cache now (for images and CI), or clear it (model.md §8)."""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

from uav_penetration_env.benchmark.commands.common import Command
from uav_penetration_env.benchmark.plugins import Needs


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench compile``."""
    parser.add_argument("--clear", action="store_true", help="remove this version's compiled code first")


def run(args: argparse.Namespace) -> int:
    """Compile (or load) every compiled entry point; print where the machine code is and its size."""
    from uav_penetration_env import compile_cache, warmup

    folder = Path(compile_cache.COMPILE_CACHE_DIR)
    if args.clear and folder.is_dir():
        shutil.rmtree(folder, ignore_errors=True)
        print(f"uav-bench compile: cleared {folder}")
    cold = warmup.is_cold()
    seconds = warmup.compile_physics()
    verb = "compiled" if cold else "loaded (already compiled)"
    print(f"uav-bench compile: {verb} the physics in {seconds:.1f} s; {folder} holds "
          f"{warmup.cache_size_bytes() / 1e6:.1f} MB")  # fmt: skip
    return 0


COMMAND = Command(
    name="compile",
    help="compile the physics now (a first run's 25-60 s on 2 idle cores, minutes on a busy machine), or --clear the compiled code",
    add_arguments=add_arguments,
    run=run,
    needs=Needs(),  # the physics alone: works in a core-only install (images, CI warm-up)
)
