"""Scenario YAML files on disk: read and write plain data, file problems as :class:`ScenarioError`.

Both functions report a problem with the file itself on the field ``path`` (the file's name as the
value), so a missing, unreadable, unwritable or malformed file reads like any other bad field.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from uav_penetration_env.atomic import write_text_atomic
from uav_penetration_env.scenario.errors import ScenarioError

__all__ = ["read_yaml", "write_yaml"]


def read_yaml(path: Path) -> Any:
    """The plain data of the YAML file ``path`` (``None`` for an empty file).

    Raises:
        ScenarioError: the file is missing or unreadable, or is not valid YAML.
    """
    try:
        text = path.read_text()
    except OSError as error:
        raise ScenarioError("path", str(path), f"a readable scenario file ({error.strerror})") from error
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise ScenarioError("path", str(path), f"valid YAML ({error})") from error


def write_yaml(data: Any, path: Path) -> Path:
    """Write plain ``data`` to ``path`` as YAML, keys in their given order (lists of scalars inline); returns ``path``.

    Raises:
        ScenarioError: the path (or its folder) cannot be written.
    """
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(path, yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=110))
    except OSError as error:
        raise ScenarioError("path", str(path), f"a writable file path ({error.strerror})") from error
    return path
