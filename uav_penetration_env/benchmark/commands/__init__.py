"""The ``uav-bench`` commands: one module per command, each exposing a ``COMMAND``.

A new built-in command is one module here with a ``COMMAND = Command(...)`` and its module name
in :data:`BUILTIN_COMMANDS`. A plug-in package adds commands, or flags of an existing command
(:class:`~uav_penetration_env.benchmark.commands.common.CommandExtension`), through the
entry-point group ``uav_penetration.commands``; :func:`available_commands` gathers both.
"""

from __future__ import annotations

import argparse
import importlib

from uav_penetration_env.benchmark import plugins
from uav_penetration_env.benchmark.commands.common import CLIError, Command, CommandExtension
from uav_penetration_env.benchmark.plugins import COMMAND_GROUP

BUILTIN_COMMANDS = (
    "run",
    "leaderboard",
    "plot",
    "report",
    "export",
    "import_rows",
    "replay",
    "calibrate",
    "scenario",
    "windows",
    "best_known",
    "suite",
    "compile",
    "store",
    "protocol",
    "timing",
    "campaign",
)


def builtin_commands() -> dict[str, Command]:
    """The built-in commands by command name, in order (``best-known`` is in ``best_known.py``, ``import`` in ``import_rows.py``)."""
    commands = [importlib.import_module(f"{__name__}.{module}").COMMAND for module in BUILTIN_COMMANDS]
    return {command.name: command for command in commands}


def available_commands() -> tuple[dict[str, Command], list[CommandExtension]]:
    """Built-in and plug-in commands by name, and the plug-in extensions of commands.

    Returns:
        The commands (built-ins first) and the extensions. A plug-in that failed to load becomes
        a command of its entry-point name that only reports the failure.

    Raises:
        CLIError: a plug-in command reuses a name, or an extension names no command.
    """
    commands = builtin_commands()
    extensions = []
    for name, plugin in plugins.discover(COMMAND_GROUP).items():
        value = plugin.value if plugin.error is None else _unavailable(name, plugin.error)
        if isinstance(value, CommandExtension):
            extensions.append(value)
            continue
        if not isinstance(value, Command):
            value = _unavailable(name, f"entry point {name!r} of {COMMAND_GROUP} is not a Command")
        if value.name in commands:
            raise CLIError(f"plug-in command {value.name!r} ({COMMAND_GROUP}: {name}) clashes with a command")
        commands[value.name] = value
    for extension in extensions:
        if extension.command not in commands:
            raise CLIError(
                f"a plug-in extends the command {extension.command!r}, which does not exist "
                f"(known: {', '.join(commands)})"
            )
    return commands, extensions


def _unavailable(name: str, error: str) -> Command:
    """A command that swallows its arguments and reports why its plug-in cannot be used."""

    def add_arguments(parser: argparse.ArgumentParser) -> None:
        parser.set_defaults(accepts_any_arguments=True)  # whatever was typed, the answer is the error

    def run(args: argparse.Namespace) -> int:
        raise CLIError(f"{name}: the plug-in {error}")

    return Command(name=name, help=f"(unavailable: {error})", add_arguments=add_arguments, run=run)
