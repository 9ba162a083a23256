"""Freezing a new suite version: the recipe file, fingerprinting every member, writing the file once.

A frozen suite is never edited (docs/suite.md §6): :func:`freeze_suite` builds and fingerprints
every member of a recipe and writes ``NAME.yaml`` atomically, refusing a name that is taken.
"""

from __future__ import annotations

import datetime as dt
import os
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from uav_penetration_env.suites.fingerprint import fingerprint, fingerprint_rules
from uav_penetration_env.suites.loading import SUITE_FOLDER, SUITE_SUFFIX, suite_names, suite_path
from uav_penetration_env.suites.schema import (
    NAME_PATTERN,
    Recipe,
    Suite,
    SuiteError,
    SuiteMember,
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


def freeze_suite(
    name: str,
    description: str,
    recipes: Sequence[Recipe],
    out_dir: str | Path = SUITE_FOLDER,
    *,
    progress: Any = None,
) -> Path:
    """Build every member, fingerprint it and write ``out_dir/NAME.yaml``; never overwrite.

    Args:
        name: the new suite's versioned name (``uavpen-v2``).
        description: one paragraph for the file and ``uav-bench suite list``.
        recipes: the members, in order.
        out_dir: the folder (default: the package's suites, where :func:`suite_names` looks).
        progress: called with each member's name after it is fingerprinted (a progress bar).

    Returns:
        The written file.

    Raises:
        SuiteError: a malformed or taken name (a shipped suite or an existing file), or two
            recipes giving one member.
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
    from uav_penetration_env import __version__
    from uav_penetration_env.benchmark.provenance import git_commit

    members = []
    for recipe in recipes:
        scenario = recipe.build()
        members.append(
            SuiteMember(recipe.member_name(name), recipe.group, recipe, scenario.name, fingerprint(scenario))
        )
        if progress is not None:
            progress(members[-1].name)
    suite = Suite(
        name,
        description,
        tuple(members),
        frozen={
            "date": dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat(),
            "package_version": __version__,
            "commit": git_commit(),
            "versions": _versions(),
        },
        fingerprint=fingerprint_rules(),
    )
    suite_from_dict(suite.to_dict())  # the file must read back: names, hashes and recipes are distinct
    header = (
        f"# {name}: a frozen benchmark suite (docs/suite.md). Written by `uav-bench suite freeze`;\n"
        "# never edit it: any change to a member is a new suite version.\n"
    )
    text = header + yaml.safe_dump(suite.to_dict(), sort_keys=False, width=100, allow_unicode=True)
    _write_new(path, text)
    return path


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
