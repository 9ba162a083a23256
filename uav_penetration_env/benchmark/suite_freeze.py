"""Freezing a new suite version: every member built, its replay controls flown by the greedy floor.

A member's fingerprint (docs/suite.md §2) stores the controls of one replay episode, which the
env core's check (:func:`uav_penetration_env.suites.check_fingerprint`) replays open loop. Which
controls is decided here, once, when the suite is frozen: the greedy floor's episode
(:class:`~uav_penetration_env.benchmark.policies.GreedyPolicy`, default settings) from
``env.reset(seed=REPLAY_SEED)``. The check never flies the floor again, so improving it changes no
frozen suite; only a suite frozen afterwards stores the improved floor's controls.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from uav_penetration_env.scenario import Scenario
from uav_penetration_env.suites import (
    REPLAY_SEED,
    SUITE_FOLDER,
    Recipe,
    Suite,
    SuiteMember,
    fingerprint,
    fingerprint_rules,
    frozen_provenance,
    new_suite_path,
    write_suite,
)
from uav_penetration_env.types import FloatArray

GREEDY_REPLAY = f"the greedy floor (GreedyPolicy, default settings) from env.reset(seed={REPLAY_SEED})"


def greedy_replay_actions(scenario: Scenario) -> FloatArray:
    """(n, 3) the controls the greedy floor flies on ``scenario`` from ``env.reset(seed=REPLAY_SEED)``, to the episode's end."""
    from uav_penetration_env.benchmark.information import episode_env
    from uav_penetration_env.benchmark.policies import GreedyPolicy

    env = episode_env(scenario)  # the dynamic env for a dynamic member (docs/dynamic.md)
    observation, info = env.reset(seed=REPLAY_SEED)
    if env.model is None:  # reset() loads the scenario's model
        raise RuntimeError(f"scenario {scenario.name}: the env has no model after reset()")
    policy = GreedyPolicy()
    policy.reset(env.model, None)
    actions = []
    done = False
    while not done:
        actions.append(np.asarray(policy.act(observation, info), dtype=np.float64))
        observation, _, terminated, truncated, info = env.step(actions[-1])
        done = terminated or truncated
    return np.array(actions)


def freeze_suite(
    name: str,
    description: str,
    recipes: Sequence[Recipe],
    out_dir: str | Path = SUITE_FOLDER,
    *,
    progress: Callable[[str], Any] | None = None,
) -> Path:
    """Build every member, fly its greedy replay, fingerprint it and write ``out_dir/NAME.yaml``; never overwrite.

    Args:
        name: the new suite's versioned name (``uavpen-v2``).
        description: one paragraph for the file and ``uav-bench suite list``.
        recipes: the members, in order.
        out_dir: the folder (default: the package's suites, where ``suite_names`` looks).
        progress: called with each member's name after it is fingerprinted (a progress bar).

    Returns:
        The written file.

    Raises:
        SuiteError: a malformed or taken name (a shipped suite or an existing file), or two
            recipes giving one member.
    """
    from uav_penetration_env.benchmark.provenance import git_commit

    new_suite_path(name, out_dir)  # refuse a bad or taken name before building anything
    members = []
    for recipe in recipes:
        scenario = recipe.build()
        frozen = fingerprint(scenario, greedy_replay_actions(scenario))
        members.append(SuiteMember(recipe.member_name(name), recipe.group, recipe, scenario.name, frozen))
        if progress is not None:
            progress(members[-1].name)
    suite = Suite(
        name,
        description,
        tuple(members),
        frozen=frozen_provenance(git_commit()),
        fingerprint=fingerprint_rules(GREEDY_REPLAY),
    )
    return write_suite(suite, out_dir)


__all__ = ["GREEDY_REPLAY", "freeze_suite", "greedy_replay_actions"]
