"""Writing a new suite version: the recipe file, the provenance block, writing the file once.

A frozen suite is never edited (docs/suite.md §6): :func:`write_suite` writes ``NAME.yaml``
atomically, refusing a name that is taken. Building and fingerprinting the members, which needs a
planner to choose each member's replay controls, is the harness's
(:func:`uav_penetration_env.benchmark.suite_freeze.freeze_suite`).
"""

from __future__ import annotations

import datetime as dt
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from uav_penetration_env.suites.loading import SUITE_FOLDER, SUITE_SUFFIX, suite_names, suite_path
from uav_penetration_env.suites.schema import (
    NAME_PATTERN,
    Recipe,
    Suite,
    SuiteError,
    require_keys,
    suite_from_dict,
)


def recipes_from_dict(data: Any, where: str = "recipe") -> tuple[str, str, list[Recipe]]:
    """Parse a recipe file (``suite``, ``description``, ``members``) into the recipes of its members.

    Each member entry is ``{catalogue: NAME}``, ``{difficulty: D, seed: S}`` or
    ``{difficulty: D, seeds: A-B}`` (A..B inclusive).

    Raises:
        SuiteError: naming the bad entry.
    """
    keys = ("suite", "description", "members")
    if not isinstance(data, Mapping):
        raise SuiteError(f"{where}: expected a mapping with keys {', '.join(keys)}")
    require_keys(data, keys, where)
    recipes = []
    for index, entry in enumerate(data["members"] or []):
        at = f"{where}: members[{index}]"
        if isinstance(entry, Mapping) and "seeds" in entry:
            low, _, high = str(entry["seeds"]).partition("-")
            try:
                seeds = range(int(low), int(high or low) + 1)
            except ValueError:
                raise SuiteError(
                    f"{at}.seeds: got {entry['seeds']!r}, expected A-B (integers, inclusive)"
                ) from None
            rest = {k: v for k, v in entry.items() if k != "seeds"}
            recipes += [Recipe.from_dict({**rest, "seed": seed}, at) for seed in seeds]
        else:
            recipes.append(Recipe.from_dict(entry, at))
    if not recipes:
        raise SuiteError(f"{where}: members: expected at least one member")
    return str(data["suite"]), str(data["description"]), recipes


def new_suite_path(name: str, out_dir: str | Path = SUITE_FOLDER) -> Path:
    """The file a new suite ``name`` is written to, after checking that the name is versioned and free.

    Raises:
        SuiteError: a malformed name, or one that is taken (a shipped suite or an existing file).
    """
    if not NAME_PATTERN.match(name):
        raise SuiteError(
            f"suite name: got {name!r}, expected a versioned name like uavpen-v2 (a-z, 0-9, ., -)"
        )
    if name in suite_names():
        raise SuiteError(f"suite {name} already exists ({suite_path(name)}); a new version needs a new name")
    path = Path(out_dir) / f"{name}{SUITE_SUFFIX}"
    if path.exists():
        raise SuiteError(f"suite file {path} already exists; a frozen suite is never overwritten")
    return path


def frozen_provenance(commit: str) -> dict[str, Any]:
    """The ``frozen`` block of a suite written now: date, package version, ``commit``, library versions."""
    from uav_penetration_env import __version__

    return {
        "date": dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat(),
        "package_version": __version__,
        "commit": commit,
        "versions": _versions(),
    }


def suite_text(suite: Suite) -> str:
    """The suite file's text: a header, then the YAML of :meth:`Suite.to_dict` (controls as literal blocks)."""
    header = (
        f"# {suite.name}: a frozen benchmark suite (docs/suite.md). Written by `uav-bench suite freeze`;\n"
        "# never edit it: any change to a member is a new suite version.\n"
    )
    return header + yaml.dump(
        suite.to_dict(), Dumper=_SuiteDumper, sort_keys=False, width=100, allow_unicode=True
    )


def write_suite(suite: Suite, out_dir: str | Path = SUITE_FOLDER) -> Path:
    """Write a frozen suite to ``out_dir/NAME.yaml`` atomically; never overwrite.

    Producing the members' fingerprints (which planner chooses the replay controls) is the
    caller's: ``uav-bench suite freeze`` uses the harness's
    :func:`~uav_penetration_env.benchmark.suite_freeze.freeze_suite`.

    Returns:
        The written file.

    Raises:
        SuiteError: a malformed or taken name, or content that does not read back (two members
            with one name or scenario hash).
    """
    path = new_suite_path(suite.name, out_dir)
    suite_from_dict(suite.to_dict())  # the file must read back: names, hashes and recipes are distinct
    _write_new(path, suite_text(suite))
    return path


class _SuiteDumper(yaml.SafeDumper):
    """YAML's safe dumper, writing text with line breaks (the encoded controls) as a literal block."""


def _represent_text(dumper: yaml.SafeDumper, text: str) -> yaml.ScalarNode:
    return dumper.represent_scalar("tag:yaml.org,2002:str", text, style="|" if "\n" in text else None)


_SuiteDumper.add_representer(str, _represent_text)


def _versions() -> dict[str, str]:
    """The versions the fingerprints depend on: Python and the numerical libraries."""
    from uav_penetration_env._version import installed_versions

    return installed_versions(("numpy", "scipy", "numba", "matplotlib"))  # matplotlib ships the DEM raster


def _write_new(path: Path, text: str) -> None:
    """Write ``text`` to a NEW file atomically: a temporary file hard-linked into place.

    ``os.link`` fails when ``path`` exists, so two freezes of one name cannot both succeed and a
    reader never sees a half-written file.

    Raises:
        SuiteError: the file exists (or appeared meanwhile) or the folder is not writable.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    descriptor, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(descriptor, "w", encoding="utf-8") as stream:
            stream.write(text)
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temporary, 0o644)
        os.link(temporary, path)
    except FileExistsError:
        raise SuiteError(f"suite file {path} already exists; a frozen suite is never overwritten") from None
    except OSError as error:
        raise SuiteError(f"suite file {path}: cannot write it ({error.strerror or error})") from None
    finally:
        Path(temporary).unlink(missing_ok=True)
