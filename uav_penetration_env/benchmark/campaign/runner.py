"""Running a campaign: every part's commands not done yet, in order, on a clean tree, each attempt logged.

DECISION (docs/publishing.md §2, clean tree): a command runs only on a clean working tree (tracked
files as committed), so every run's provenance names a clean commit; a derived part that writes
tracked files (``best-known``) must be committed before the next part runs. The commands import
the package from this tree (checked once before the first command).
"""

from __future__ import annotations

import shutil
import sys
from collections.abc import Sequence
from pathlib import Path

from uav_penetration_env.benchmark.campaign import process
from uav_penetration_env.benchmark.campaign.agents import PendingSteps
from uav_penetration_env.benchmark.campaign.install import compare_rebuild
from uav_penetration_env.benchmark.campaign.log import (
    REBUILD_CHECK,
    append_attempt,
    command_key,
    done_commands,
    read_log,
)
from uav_penetration_env.benchmark.campaign.plan import Part, plan
from uav_penetration_env.benchmark.campaign.spec import CampaignSpec

WAITING = 3  # exit status while a part waits for the RL programme (not done, not failed)


def refusal(repo: Path) -> str:
    """Why no command may run now (``""``: none): a dirty tree, or a package imported from elsewhere."""
    dirty = process.dirty_files(repo)
    if dirty:
        return (f"tracked files differ from the commit ({', '.join(dirty[:5])}); commit them first, "
                "so the provenance names a clean commit")  # fmt: skip
    package = process.imported_from(repo)
    if not package.is_relative_to(repo.resolve()):
        return f"the commands would import {package}, not this tree ({repo})"
    return ""


def run_campaign(
    spec: CampaignSpec,
    repo: Path,
    *,
    only: Sequence[str] = (),
    dry_run: bool = False,
    pending: PendingSteps | None = None,
    parts: list[Part] | None = None,
) -> int:
    """Run (or, with ``dry_run``, list) every command not done yet, part by part; stop at the first failure.

    Prints ``[done]``, ``[plan]`` or ``[run]`` with each command, and ``[wait]`` where a part waits
    for the RL programme. A part with a rebuild check removes its output folder before its first
    command and the rebuild folder before the ``leaderboard`` command that writes it, and after its
    commands compares the two (:func:`~uav_penetration_env.benchmark.campaign.install.compare_rebuild`),
    logging the check as an attempt.

    Args:
        spec: the campaign.
        repo: the repository the commands run in.
        only: the parts to run (empty: all).
        dry_run: print every command and its state; run nothing.
        pending: the RL programme's unfinished steps (default: the file's ``agents.pending`` command).
        parts: the plan (default: :func:`~uav_penetration_env.benchmark.campaign.plan.plan`).

    Returns:
        0 when every selected command is done; :data:`WAITING` (3) when a part waits for the RL
        programme; 1 when refused (dirty tree, another package) or the rebuild check failed; else
        the failing command's exit status.
    """
    log = repo / spec.log
    parts = plan(spec, repo, pending) if parts is None else parts
    checked = False
    for part in parts:
        if only and part.name not in only:
            continue
        # Read again before each part: a run part that just added rows makes the derived parts
        # after it stale in this very invocation (log.current).
        done = done_commands(read_log(log), spec.derived)
        for index, command in enumerate(part.commands):
            key = command_key(command)
            if key in done:
                print(f"[done] {part.name}: {key}", flush=True)
                continue
            print(f"[{'plan' if dry_run else 'run'}] {part.name}: {key}", flush=True)
            if dry_run:
                continue
            if not checked:
                why = refusal(repo)
                if why:
                    print(f"refused: {why}", file=sys.stderr)
                    return 1
                checked = True
            elif process.dirty_files(repo):
                print(f"refused: {refusal(repo)}", file=sys.stderr)
                return 1
            if part.rebuild_check:  # no stale file may take part in the comparison
                _clear_rebuild_folders(spec, repo, first_command=index == 0, leaderboard=command[0] == "leaderboard")
            status = process.run_attempt(repo, part.name, command, log)
            if status != 0:
                print(
                    f"stopped at {part.name} (exit status {status}); run again to continue", file=sys.stderr
                )
                return status
        if part.waits:  # its commands so far are done; the rest, and the later parts, wait
            print(f"[wait] {part.name}: {part.waits}", flush=True)
            if not dry_run:
                return WAITING
            continue
        if part.rebuild_check and not dry_run and not _rebuild_matches(spec, repo, part, log):
            return 1
    return 0


def _clear_rebuild_folders(spec: CampaignSpec, repo: Path, *, first_command: bool, leaderboard: bool) -> None:
    """Remove the output folder before a rebuild-checked part's first command, the rebuild folder before its leaderboard."""
    for folder, now in ((spec.layout.out, first_command), (spec.layout.check, leaderboard)):
        if now and (repo / folder).is_dir():
            shutil.rmtree(repo / folder)


def _rebuild_matches(spec: CampaignSpec, repo: Path, part: Part, log: Path) -> bool:
    """Compare a part's tables with those rebuilt from its rows, log the check as an attempt; True when equal."""
    differing = compare_rebuild(repo / spec.layout.out, repo / spec.layout.check)
    append_attempt(log, {"part": part.name, "command": REBUILD_CHECK, "wall_s": 0.0, "cpu_s": 0.0,
                         "status": 1 if differing else 0, "commit": process.commit(repo)})  # fmt: skip
    if differing:
        print(f"the tables rebuilt from rows differ: {', '.join(differing)}", file=sys.stderr)
        if spec.install.rows is not None:
            print(f"(the rows are {spec.install.rows}: if the store holds rows the checkpoint lacks, run "
                  "--checkpoint and commit it before the tables part)", file=sys.stderr)  # fmt: skip
        return False
    print("tables rebuilt from the rows equal the store's (apart from the date line)")
    return True
