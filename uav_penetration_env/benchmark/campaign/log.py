"""A campaign's compute log: one JSON line per attempt of a command, and what it says is done.

DECISION (docs/publishing.md §2, compute log): each attempt of a command appends a line to
``ROOT/compute.jsonl`` (part, command, start, wall seconds, CPU seconds of its process tree, exit
status, commit); a command is done when one attempt exited 0 and is :func:`current`. The RL
programme logs its steps' attempts the same way (``ROOT/compute.jsonl`` of its folder).
"""

from __future__ import annotations

import json
import shlex
from collections.abc import Sequence
from pathlib import Path

REBUILD_CHECK = "rebuild check: tables from rows equal the store's"


def command_key(argv: Sequence[str]) -> str:
    """The command as logged and printed: ``uav-bench ...``, or ``python SCRIPT.py ...`` for a script."""
    return shlex.join(["python", *argv] if argv and argv[0].endswith(".py") else ["uav-bench", *argv])


def read_log(log: Path) -> list[dict]:
    """The attempts recorded so far (an unreadable line is reported, not skipped silently).

    Raises:
        SystemExit: a line that is not JSON (its file and line number named).
    """
    if not log.is_file():
        return []
    attempts = []
    for number, line in enumerate(log.read_text().splitlines(), 1):
        try:
            attempts.append(json.loads(line))
        except json.JSONDecodeError as error:
            raise SystemExit(
                f"{log}:{number}: not a JSON line ({error}); expected one attempt per line"
            ) from None
    return attempts


def append_attempt(log: Path, attempt: dict) -> None:
    """Append one attempt (one short line: an append is atomic enough here)."""
    log.parent.mkdir(parents=True, exist_ok=True)
    with log.open("a") as handle:
        handle.write(json.dumps(attempt) + "\n")


def current(attempts: list[dict], index: int, derived: Sequence[str]) -> bool:
    """Whether attempt ``index`` saw every earlier part's output: no attempt of an earlier part came after it.

    DECISION (docs/publishing.md §2, staleness): a derived part (best-known, tables) done before a
    run part added rows is stale and runs again; run parts skip what the store holds, so they are
    never stale. ``derived``: the campaign's derived parts, in order (they are its last parts).
    """
    part = str(attempts[index].get("part"))
    if part not in derived:
        return True
    later = tuple(derived[list(derived).index(part) :])
    return not any(a.get("part") not in later for a in attempts[index + 1 :])


def done_commands(attempts: list[dict], derived: Sequence[str] = ()) -> set[str]:
    """The commands with a successful attempt that is :func:`current`."""
    return {
        a["command"] for i, a in enumerate(attempts) if a.get("status") == 0 and current(attempts, i, derived)
    }


def rebuild_checked(attempts: list[dict], part: str, commands: Sequence[str], derived: Sequence[str]) -> bool:
    """Whether the last thing ``part`` recorded is a passed rebuild check of current tables.

    Args:
        attempts: the compute log.
        part: the part with the rebuild check (``tables``).
        commands: its commands (keys); each must have succeeded after the last attempt of an
            earlier part and before the check, so that the check compared tables built from every
            row (a check alone, after new rows, proves nothing about the tables it read).
        derived: the campaign's derived parts.
    """
    own = [i for i, a in enumerate(attempts) if a.get("part") == part]
    if not own:
        return False
    check = own[-1]
    last = attempts[check]
    if not (
        last.get("command") == REBUILD_CHECK and last.get("status") == 0 and current(attempts, check, derived)
    ):
        return False
    since = max((i for i, a in enumerate(attempts[:check]) if a.get("part") != part), default=-1)
    rebuilt = {
        a["command"] for a in attempts[since + 1 : check] if a.get("part") == part and a.get("status") == 0
    }
    return all(command in rebuilt for command in commands)
