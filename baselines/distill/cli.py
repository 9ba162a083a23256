"""``uav-bench distill``: imitate a planner with behaviour cloning and DAgger (docs/rl.md §4).

A plug-in command (:data:`baselines.plugin.DISTILL_COMMAND`). Every flag is generated from a field
of :class:`~baselines.distill.config.DistillConfig` (:mod:`uav_penetration_env.settings_fields`); bad input exits with status 2 and one line naming
the flag. Rerunning the same command continues from the last finished round; a larger
``--rounds`` extends a finished run.
"""

from __future__ import annotations

import argparse
import sys

from baselines.distill.config import DistillConfig
from uav_penetration_env.benchmark.commands.common import CLIError
from uav_penetration_env.settings_fields import add_flags, given_values, parse_values


def add_distill_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench distill``: one per :class:`DistillConfig` field (defaults: the dataclass's)."""
    add_flags(parser, DistillConfig)


def distill_command(args: argparse.Namespace) -> int:
    """Run ``uav-bench distill``; returns 0, or 130 when interrupted (rerun to continue).

    Raises:
        CLIError: invalid input, or a run folder made with other settings.
    """
    from baselines.distill.config import checked
    from baselines.distill.loop import run_distill

    try:
        config = checked(parse_values(DistillConfig, given_values(args, DistillConfig), label="flag"))
    except ValueError as error:
        raise CLIError(str(error)) from None
    print(
        f"uav-bench distill: expert {config.expert}, {len(config._scenario_objects or ())} scenarios, "
        f"{config.rounds} DAgger rounds -> {config.out}",
        flush=True,
    )
    try:
        result = run_distill(config, log=lambda line: print(line, flush=True))
    except ValueError as error:
        raise CLIError(str(error)) from None
    except KeyboardInterrupt:
        print(f"\ninterrupted: rerun the same command to continue from the last finished round in {config.out}",
              file=sys.stderr)  # fmt: skip
        return 130
    side = result.sidecar
    print(
        f"policy: {result.folder.policy} (round {side['round']}, fitted on {side['data_rows']} rows; the run: "
        f"{side['expert_labels']} expert labels, {side['train_cpu_seconds']:.1f} CPU s); "
        f"score it with: uav-bench run --policies distill:{config.out}"
    )
    return 0
