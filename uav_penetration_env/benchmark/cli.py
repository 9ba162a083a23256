"""``uav-bench``: run sweeps, build leaderboards and figures, calibrate, inspect scenarios (api.md).

This module is the program: it builds the parser from the command registry
(:mod:`uav_penetration_env.benchmark.commands`, one module per command, plus the plug-in
commands of the entry-point group ``uav_penetration.commands``), dispatches, and turns every
:class:`~uav_penetration_env.benchmark.commands.common.CLIError` (bad input) and every missing
extra into one line ``uav-bench: error: ...`` with exit status 2. The exit statuses are
listed in :data:`EXIT_STATUS` (the epilog of ``uav-bench --help``).
"""

from __future__ import annotations

import argparse
import errno
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

from uav_penetration_env.atomic import NotRegularFileError
from uav_penetration_env.benchmark.commands import available_commands
from uav_penetration_env.benchmark.commands.common import CLIError, store_error
from uav_penetration_env.benchmark.plugins import PluginUnavailable

EXIT_STATUS = """exit status:
  0    all the work was done
  1    some work failed (e.g. `run` episodes that ended in an error: stored as error rows,
       counted in the summary line, retried by rerunning the same command; a disk that
       filled up: one line, finished work kept)
  2    bad arguments or inputs (one line `uav-bench: error: ...`; nothing written)
  130  interrupted (Ctrl-C); finished work is kept
  143  terminated (SIGTERM; 128 + the signal's number); finished work is kept"""


class UsageError(CLIError):
    """A command line argparse cannot parse (unknown flag, missing value, a value of the wrong type)."""


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (``uav-bench: error: PROG: MESSAGE``), not a usage dump.

    ``--help`` still prints the full usage; a parse error raises :class:`UsageError`, which
    :func:`main` prints as one line with exit status 2, like every other bad input.
    """

    def error(self, message: str) -> NoReturn:
        """Raise :class:`UsageError` naming the (sub-)command and pointing at its ``--help``.

        The top-level parser's own name is the line's prefix already (``uav-bench: error:``), so
        only a sub-command names itself (``uav-bench: error: uav-bench run: ...``).
        """
        where = "" if self.prog == "uav-bench" else f"{self.prog}: "
        raise UsageError(f"{where}{message} (see {self.prog} --help)")


def say_error(message: object) -> None:
    """Print ``uav-bench: error: MESSAGE`` on stderr as one line.

    A value the user typed may hold a line break or another control character (a carriage return
    pasted into ``--seeds``); it is shown escaped, as ``repr`` would, so the message stays one line.
    """
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(message))
    print(f"uav-bench: error: {text}", file=sys.stderr)


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The ``uav-bench`` argument parser: one sub-parser per built-in and installed plug-in command.

    Args:
        argv: the command line about to be parsed. When given, only the sub-command it names gets
            its arguments (each command's module imports what its flags need), so ``uav-bench
            --help`` and an argument error answer without importing the others. None: every
            sub-parser complete (for tests and documentation).
    """
    parser = OneLineParser(
        prog="uav-bench",
        description="UAV penetration benchmark: run planners; build leaderboards, figures and an HTML report; "
        "export and replay tracks.",
        epilog=EXIT_STATUS,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    from uav_penetration_env._version import __version__

    parser.add_argument("--version", action="version", version=f"uav-bench {__version__}")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    commands, extensions = available_commands()
    selected = None if argv is None else next((a for a in argv if not a.startswith("-")), "")
    for command in commands.values():
        sub = subparsers.add_parser(command.name, help=command.help, description=command.help)
        mine = tuple(e for e in extensions if e.command == command.name)
        if selected is None or selected == command.name:
            command.add_arguments(sub)
            for extension in mine:
                extension.add_arguments(sub)
        sub.set_defaults(handler=command, extensions=mine)
    parser.commands = subparsers.choices  # type: ignore[attr-defined]  # for the unknown-flag hint
    return parser


def unrecognized(parser: argparse.ArgumentParser, command: str, unknown: Sequence[str]) -> str:
    """The message for arguments the sub-command does not take, with the closest flags it does take."""
    from uav_penetration_env.suggest import did_you_mean

    sub = parser.commands.get(command) if hasattr(parser, "commands") else None
    flags = sorted({s for action in sub._actions for s in action.option_strings}) if sub is not None else []
    typed = next((word for word in unknown if word.startswith("-")), "")
    name = typed.split("=", 1)[0]
    hint = did_you_mean(name, flags).rstrip() if name else ""
    where = f"uav-bench {command}" if sub is not None else "uav-bench"
    return f"{where}: unrecognized arguments: {' '.join(unknown)}{' — ' + hint if hint else ''} (see {where} --help)"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``uav-bench`` console script; returns the exit status.

    Standard output is the one place names from plug-ins and stores reach the terminal: for the
    whole command it escapes control characters (an escape sequence in a policy name would
    recolour or retitle the terminal; :mod:`~.safe_text`).
    """
    from uav_penetration_env.benchmark.safe_text import safe_stdout

    with safe_stdout():
        return _main(list(sys.argv[1:] if argv is None else argv))


def _main(argv: list[str]) -> int:
    try:
        parser = build_parser(argv)
    except CLIError as error:  # a clashing plug-in: say so even for --help
        say_error(error)
        return 2
    try:
        args, unknown = parser.parse_known_args(argv)
        if unknown and not getattr(args, "accepts_any_arguments", False):
            raise UsageError(unrecognized(parser, args.command, unknown))
    except UsageError as error:
        say_error(error)
        return 2
    args.argv = argv
    from uav_penetration_env.threads import limit_blas_threads

    limit_blas_threads(1, respect_environment=True)  # small matrices: one BLAS thread (model.md §8)
    try:
        for extension in args.extensions:
            if extension.selected(args):
                extension.needs.check(f"uav-bench {args.command} (plug-in flags)")
                return int(extension.run(args) or 0)
        args.handler.needs.check(f"uav-bench {args.command}")
        return int(args.handler.run(args) or 0)
    except (CLIError, PluginUnavailable) as error:
        say_error(error)
        return 2
    except Exception as error:
        failure = _failure(error, args)
        if failure is None:
            raise
        message, status = failure
        say_error(message)
        return status


# A write the machine refuses: failed work (exit 1), said in one line, not a bug's traceback.
FULL_OR_READ_ONLY = (errno.ENOSPC, errno.EDQUOT, errno.EROFS)


def _failure(error: Exception, args: argparse.Namespace) -> tuple[str, int] | None:
    """The one line and exit status of an error met while a command worked; None: a bug (its traceback).

    A store that goes bad while a command reads it (a damaged page met mid-way) is an input problem
    like one refused up front (2); a write that fails on a full or read-only disk is failed work (1),
    named by the flag whose folder it was writing. The store module (pandas) is imported only if needed.
    """
    if isinstance(error, OSError) and error.errno in FULL_OR_READ_ONLY:
        return f"{_written_by(error.filename, args)}: {error.strerror}", 1
    if isinstance(error, NotRegularFileError):  # --out /dev/null: an output that is no file (input, 2)
        return f"{_written_by(error.filename, args)}: {error.strerror}", 2
    if "StoreError" not in {kind.__name__ for kind in type(error).__mro__}:
        return None
    from uav_penetration_env.benchmark.store import StoreError, StoreWriteError

    if not isinstance(error, StoreError):
        return None
    return str(store_error(error)), 1 if isinstance(error, StoreWriteError) else 2


def _written_by(filename: object, args: argparse.Namespace) -> str:
    """``--out DIR: cannot write FILE`` naming the path flag ``filename`` lies under, else ``cannot write FILE``.

    A flag's value that is a stem (``--out results/dump`` writing ``dump-episodes.csv``) counts too.
    """
    if filename is None:
        return "cannot write an output"
    path = Path(str(filename)).absolute()
    for flag, value in sorted(vars(args).items()):
        if isinstance(value, (str, Path)) and value and flag not in ("command", "argv"):
            folder = Path(value).absolute()
            stem = path.parent == folder.parent and path.name.startswith(folder.name)  # --out STEM
            if path == folder or folder in path.parents or stem:
                return f"--{flag.replace('_', '-')} {value}: cannot write {path}"
    return f"cannot write {path}"


if __name__ == "__main__":
    sys.exit(main())
