"""The MPC flags of ``uav-bench run`` and ``windows``, built from :class:`~uav_penetration_env.mpc.MPCSettings`' fields.

Each settings key gives one flag (``max_evals`` -> ``--max-evals``) with its help text and
default, and one ``--config`` key (the key itself): one key per field, and two for the terminal
cost (``--terminal``, its form, and ``--terminal-cost``, its c_T; one ``Terminal``);
:func:`mpc_settings` turns what was given into one :class:`MPCSettings`, refusing a bad value in
one line that names the flag. A new setting is a new field of the dataclass: both commands and
the config file gain it.
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Mapping
from typing import Any

from uav_penetration_env.benchmark.commands.common import CLIError
from uav_penetration_env.mpc import (
    MPC_DEFAULTS,
    SETTING_FIELDS,
    MPCSettings,
    SettingError,
    parse_settings,
    setting_keys,
)

__all__ = ["SETTING_FIELDS", "add_mpc_arguments", "flag_name", "mpc_settings", "setting_error"]


def flag_name(field: str) -> str:
    """The command-line flag of a settings field: ``max_evals`` -> ``--max-evals``."""
    return "--" + field.replace("_", "-")


def add_mpc_arguments(parser: argparse.ArgumentParser) -> None:
    """One flag per :class:`MPCSettings` key, each with no parser default (None: not given).

    A flag's text is parsed by the key's kind (``--horizon x`` is argparse's usage error); its
    domain is checked by :func:`mpc_settings`, which fills what was not given from the defaults
    (:data:`~uav_penetration_env.mpc.MPC_DEFAULTS`).
    """
    for field in dataclasses.fields(MPCSettings):
        for key, kind, help_text, default in setting_keys(field):
            parser.add_argument(
                flag_name(key),
                dest=key,
                type=None if kind is str else kind,
                help=f"{help_text} (default: {default})",
            )


def setting_error(error: SettingError) -> CLIError:
    """A settings error as the command line words it: ``--max-evals: got 0, expected an integer >= 1``."""
    return CLIError(f"{flag_name(error.field)}: {error.body}")


def mpc_settings(
    given: Mapping[str, Any] | argparse.Namespace, base: MPCSettings = MPC_DEFAULTS
) -> MPCSettings:
    """The settings from flags or ``--config`` values (None: not given, ``base``'s value kept).

    Args:
        given: field name -> value (a ``--config`` mapping, or the parsed namespace itself).
        base: the settings the given values change.

    Raises:
        CLIError: ``--FLAG: got VALUE, expected DOMAIN`` for the first bad value.
    """
    values = vars(given) if isinstance(given, argparse.Namespace) else given
    try:
        return parse_settings(values, base)
    except SettingError as error:
        raise setting_error(error) from None
