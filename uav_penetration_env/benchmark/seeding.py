"""Paired seeding (api.md): every policy meets the same start for a (seed, scenario) pair.

For seed ``s`` on a scenario, ``env_seed, policy_seed = SeedSequence([s, int(scenario_hash, 16)]).spawn(2)``.
The start state of an episode is therefore a function of (scenario, seed) alone:
:func:`start_info` recomputes it, as the store's migration does for stores written before the
step-0 row existed.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from uav_penetration_env.env import UAVPenetrationEnv
from uav_penetration_env.scenario import Scenario


def episode_seeds(seed: int, scenario_hash: str) -> tuple[int, np.random.SeedSequence]:
    """Paired seeding (api.md): the env's reset seed and the policy's SeedSequence for (seed, scenario)."""
    env_sequence, policy_sequence = np.random.SeedSequence([int(seed), int(scenario_hash, 16)]).spawn(2)
    return int(env_sequence.generate_state(1, dtype=np.uint32)[0]), policy_sequence


def start_info(scenario: Scenario, seed: int, scenario_hash: str | None = None) -> dict[str, Any]:
    """The env's reset info of the episode of ``seed`` on ``scenario`` (its start state and quantities).

    Args:
        scenario: the scenario flown.
        seed: the episode seed.
        scenario_hash: the hash the episode was seeded with (default: ``scenario.hash``); a store
            passes the hash it recorded, so a scenario read back from its YAML seeds as it did.

    Returns:
        The reset ``info`` of :class:`~uav_penetration_env.env.UAVPenetrationEnv`.
    """
    env_seed, _ = episode_seeds(seed, scenario_hash or scenario.hash)
    _, info = UAVPenetrationEnv(scenario).reset(seed=env_seed)
    return info
