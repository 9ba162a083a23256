"""``uav-bench campaign FILE.yaml``: run a publication from its campaign file, resumably (docs/publishing.md).

```bash
uav-bench campaign leaderboards/campaigns/v2.yaml --dry-run           # every command and whether it is done
nice -n 10 uav-bench campaign leaderboards/campaigns/v2.yaml          # run what is not done
uav-bench campaign leaderboards/campaigns/v2.yaml --only tables       # some parts only
uav-bench campaign leaderboards/campaigns/v2.yaml --compute           # wall, CPU and worker time per part
uav-bench campaign leaderboards/campaigns/v2.yaml --install           # copy the output into the tracked tree
uav-bench campaign leaderboards/campaigns/v2.yaml --from-published    # a new machine: store and log from the install
uav-bench campaign leaderboards/campaigns/v3.yaml --checkpoint        # v3: commit the rows flown so far
```

Run it from the repository's root: the file's paths, and the commands, are relative to it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from uav_penetration_env.benchmark.commands.common import CLIError, Command


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench campaign``."""
    parser.add_argument(
        "file", type=Path, metavar="FILE", help="the campaign's YAML file (leaderboards/campaigns/v3.yaml)"
    )
    parser.add_argument("--only", nargs="+", default=(), metavar="PART", help="run only these parts")
    actions = parser.add_mutually_exclusive_group()
    actions.add_argument(
        "--dry-run", action="store_true", help="print every command and its state; run nothing"
    )
    actions.add_argument("--compute", action="store_true",
                         help="print the compute table (wall, CPU, worker time); run nothing")  # fmt: skip
    actions.add_argument("--install", action="store_true",
                         help="copy the output into the file's install target (after a passed rebuild check)")  # fmt: skip
    actions.add_argument("--from-published", action="store_true",
                         help="rebuild a missing store and compute log from the installed leaderboard")  # fmt: skip
    actions.add_argument("--checkpoint", action="store_true",
                         help="export the rows flown since the last checkpoint and the log into the file's carry.checkpoint")  # fmt: skip
    actions.add_argument("--resume", action="store_true",
                         help="rebuild a missing store and log from the checkpoint")  # fmt: skip
    actions.add_argument("--seed-from", nargs="*", type=Path, metavar="STEM",
                         help="start a new store from earlier exports (default: the file's carry.seed_rows)")  # fmt: skip


def run(args: argparse.Namespace) -> int:
    """Read the campaign file and do what the flags ask."""
    from uav_penetration_env.benchmark.campaign.spec import CampaignFileError, load_campaign_file

    try:
        spec = load_campaign_file(args.file)
    except CampaignFileError as error:
        raise CLIError(str(error)) from None
    known = [part.name for part in spec.parts]
    unknown = [name for name in args.only if name not in known]
    if unknown:
        raise CLIError(f"--only {' '.join(unknown)}: unknown part; expected some of {', '.join(known)}")
    from uav_penetration_env.benchmark.campaign import actions

    repo = Path.cwd()
    carry = [
        flag for flag in ("checkpoint", "resume", "seed_from") if getattr(args, flag) not in (False, None)
    ]
    if carry and spec.carry is None:
        raise CLIError(
            f"--{carry[0].replace('_', '-')}: {args.file} has no carry section (a checkpoint folder)"
        )
    if args.from_published and spec.install.mode != "replace":
        raise CLIError(
            f"--from-published: {args.file} installs a folder of its own; it carries on with --resume"
        )
    try:
        if args.seed_from is not None:
            return actions.seed(repo, spec, args.seed_from)
        if args.resume:
            return actions.resume_from_checkpoint(repo, spec)
        if args.checkpoint:
            return actions.write_checkpoint(repo, spec)
        if args.from_published:
            return actions.rebuild_from_published(repo, spec)
    except (FileExistsError, FileNotFoundError) as error:
        print(f"refused: {error}", file=sys.stderr)
        return 1
    if args.compute:
        print(actions.compute(repo, spec))
        return 0
    if args.install:
        return actions.install(repo, spec)
    from uav_penetration_env.benchmark.campaign.runner import run_campaign

    return run_campaign(spec, repo, only=args.only, dry_run=args.dry_run)


COMMAND = Command(
    name="campaign",
    help="run a publication from its campaign file: resumable, logged, on a clean tree (docs/publishing.md)",
    add_arguments=add_arguments,
    run=run,
)
