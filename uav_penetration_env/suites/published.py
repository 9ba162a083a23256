"""The maps of every published table, and the check that a learned planner's maps are not among them.

A learned planner evaluated on a map it was trained, validated or designed on is evaluated in
sample (docs/publishing.md §6). The published tables are the frozen suites' members (the paper
scenario in both weightings and the DEM member are members of ``uavpen-v1``); maps are compared by
:attr:`~uav_penetration_env.scenario.Scenario.map_hash`, the map alone (name and weights removed).
"""

from __future__ import annotations

import functools
from collections.abc import Iterable

from uav_penetration_env.scenario import Scenario


@functools.lru_cache(maxsize=1)
def published_maps() -> dict[str, str]:
    """Map hash -> ``SUITE/MEMBER`` of every member of every frozen suite shipped with the package.

    Built once per process (the suite files never change: a changed member is a new suite).
    """
    from uav_penetration_env.suites import load_suite, suite_names, suite_scenarios

    out: dict[str, str] = {}
    for name in suite_names():
        suite = load_suite(name)
        for member, scenario in zip(suite.members, suite_scenarios(suite, verify=False), strict=True):
            out.setdefault(scenario.map_hash, member.name)
    return out


def published_overlap(scenarios: Iterable[Scenario]) -> list[tuple[str, str]]:
    """(scenario name, the published member sharing its map) for every scenario on a published map."""
    maps = dict(published_maps())
    return [(s.name, maps[s.map_hash]) for s in scenarios if s.map_hash in maps]


def check_unpublished(scenarios: Iterable[Scenario], flag: str) -> None:
    """Refuse scenarios that share a map with a published table.

    Raises:
        ValueError: one line naming ``flag``, the first scenario and the member whose map it shares.
    """
    clash = published_overlap(scenarios)
    if clash:
        name, member = clash[0]
        raise ValueError(
            f"{flag}: {name!r} is the map of the published {member} ({len(clash)} such scenario(s)); expected "
            "maps apart from every published table (e.g. random:50000-50039; docs/publishing.md §6)"
        )


__all__ = ["check_unpublished", "published_maps", "published_overlap"]
