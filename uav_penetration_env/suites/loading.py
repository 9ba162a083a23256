"""The shipped suites: finding and reading their files, and building their members guarded.

The suites are YAML files shipped beside this module (``uavpen-v1.yaml``, package data). A member
is rebuilt from its recipe and checked against its frozen fingerprint before it is used
(docs/suite.md §2): :func:`build_member`, :func:`suite_scenarios` (which ``uav-bench run --suite``
uses) and :func:`verify_suite` (``uav-bench suite verify``).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import yaml

from uav_penetration_env.scenario import Scenario
from uav_penetration_env.suggest import did_you_mean
from uav_penetration_env.suites.fingerprint import SuiteMismatchError, check_fingerprint
from uav_penetration_env.suites.schema import Suite, SuiteError, SuiteMember, suite_from_dict

SUITE_FOLDER = Path(__file__).resolve().parent
SUITE_SUFFIX = ".yaml"


def suite_names() -> list[str]:
    """The names of the suites shipped with the package, sorted (``uavpen-v1``)."""
    return sorted(path.name[: -len(SUITE_SUFFIX)] for path in SUITE_FOLDER.glob(f"*{SUITE_SUFFIX}"))


def suite_path(name: str) -> Path:
    """The file of a shipped suite.

    Raises:
        SuiteError: an unknown name (with a did-you-mean and the known names).
    """
    names = suite_names()
    if name not in names:
        raise SuiteError(
            f"unknown suite {name!r} — {did_you_mean(name, names)}known suites: {', '.join(names) or 'none'}"
        )
    return SUITE_FOLDER / f"{name}{SUITE_SUFFIX}"


def load_suite(name: str | Path) -> Suite:
    """Read a suite: a shipped name (``uavpen-v1``) or the path of a suite file.

    Raises:
        SuiteError: an unknown name, an unreadable file, or a malformed entry (naming it).
    """
    text = str(name)
    path = Path(text) if text.endswith(SUITE_SUFFIX) and Path(text).is_file() else suite_path(text)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as error:
        raise SuiteError(f"suite file {path}: cannot read it ({error.strerror})") from None
    except yaml.YAMLError as error:
        raise SuiteError(f"suite file {path}: not valid YAML ({error})") from None
    return suite_from_dict(data, path)



def build_member(suite: Suite | str, member: SuiteMember | str, *, verify: bool = True) -> Scenario:
    """The scenario of one member, checked against its frozen fingerprint.

    Args:
        suite: a :class:`Suite` or a suite name/path.
        member: a member or its name.
        verify: check the fingerprint (:func:`check_fingerprint`).

    Raises:
        SuiteError: an unknown suite or member.
        SuiteMismatchError: the member changed.
    """
    suite = suite if isinstance(suite, Suite) else load_suite(suite)
    member = member if isinstance(member, SuiteMember) else suite.member(member)
    scenario = member.recipe.build()
    if verify:
        check_fingerprint(suite.name, member, scenario)
    return scenario


def suite_scenarios(
    name: Suite | str, verify: bool = True, members: Sequence[str] | None = None
) -> list[Scenario]:
    """The scenarios of a suite's members (all, or those matching ``members`` patterns), verified.

    Raises:
        SuiteError: an unknown suite or a pattern matching no member.
        SuiteMismatchError: the first member that changed.
    """
    suite = name if isinstance(name, Suite) else load_suite(name)
    return [build_member(suite, member, verify=verify) for member in suite.select(members)]


@dataclass(frozen=True)
class MemberCheck:
    """The outcome of verifying one member: ``error`` is None when it reproduced."""

    member: SuiteMember
    seconds: float
    error: SuiteMismatchError | None = None


def verify_suite(suite: Suite | str, members: Sequence[str] | None = None) -> Iterable[MemberCheck]:
    """Check every selected member, yielding one :class:`MemberCheck` each (all are checked).

    Raises:
        SuiteError: an unknown suite or a pattern matching no member.
    """
    import time

    suite = suite if isinstance(suite, Suite) else load_suite(suite)
    for member in suite.select(members):
        started = time.perf_counter()
        try:
            build_member(suite, member)
            error = None
        except SuiteMismatchError as mismatch:
            error = mismatch
        yield MemberCheck(member, time.perf_counter() - started, error)
