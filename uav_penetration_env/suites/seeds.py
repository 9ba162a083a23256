"""The seed rule of a suite run: which episode seeds a policy flies on a member by default.

docs/suite.md §4: several seeds where they are the only replicates (a stochastic policy on a fixed
member), one where more would repeat an episode or the members themselves are the replicates.
"""

from __future__ import annotations

from uav_penetration_env.scenario import Scenario
from uav_penetration_env.suites.schema import FIXED_GROUP, SuiteMember

# A fixed member is one scenario, so a stochastic policy's replicates there are its own seeds.
FIXED_MEMBER_SEEDS = 5
PROCEDURAL_MEMBER_SEEDS = 1  # seeds of every policy on a procedural member


def random_start(scenario: Scenario) -> bool:
    """Whether the episode seed changes the scenario's start (jitter) or terrain (redraws)."""
    jitter = scenario.start.jitter
    return jitter.xy_km > 0 or jitter.heading_deg > 0 or scenario.terrain.randomize_terrain


def default_seeds(member: SuiteMember, scenario: Scenario, deterministic: bool) -> list[int]:
    """The episode seeds a policy flies on a member when ``--seeds`` is not given (docs/suite.md §4).

    Five seeds (0-4) on a fixed member (the paper scenario in both weightings, the DEM scenario)
    for a stochastic policy; one seed (0) for a deterministic policy there, since on a start
    without jitter every seed replicates one episode; one seed (0) on each procedural member, where
    the members themselves are the replicates.

    Args:
        member: the suite member.
        scenario: its built scenario.
        deterministic: whether the policy is deterministic
            (:func:`~uav_penetration_env.benchmark.policies.is_deterministic`).
    """
    if member.group != FIXED_GROUP:
        return list(range(PROCEDURAL_MEMBER_SEEDS))
    if deterministic and not random_start(scenario):
        return [0]
    return list(range(FIXED_MEMBER_SEEDS))
