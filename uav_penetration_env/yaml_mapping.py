"""A settings file: one YAML mapping (a CLI's ``--config``, a hyper-parameter file)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml


def read_yaml_mapping(path: Path, what: str, keys: str) -> dict[str, Any]:
    """The mapping the YAML file ``path`` holds; an empty file holds ``{}``.

    Args:
        path: the file.
        what: the name each error starts with (the flag or setting that named the file).
        keys: what the mapping's keys name, for the error on a file that is no mapping ("flag names").

    Returns:
        The mapping, its keys unchecked.

    Raises:
        FileNotFoundError: the file cannot be read.
        ValueError: the file is not valid YAML, or holds something other than a mapping.
    """
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except OSError as error:
        raise FileNotFoundError(f"{what}: cannot read {path} ({error.strerror})") from None
    except yaml.YAMLError as error:
        raise ValueError(f"{what}: {path} is not valid YAML ({error})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{what}: {path} must hold a mapping of {keys} to values")
    return data
