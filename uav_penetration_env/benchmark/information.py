"""What a planner may know: the env an episode flies, the model a policy plans on, oracles (docs/dynamic.md §4).

On a dynamic scenario the env scores the truth and hands planners the belief (``env.model``,
:mod:`uav_penetration_env.dynamic_env`). The harness binds a policy to the belief at reset and, when
the belief changes (a threat revealed, a tracked one moved), hands it the new belief through the
policy's ``update_model(model)`` method, inside the timed decision of the next step, so a planner's
belief updates (a rebuilt value function) count in its ``planning_cpu_seconds``.

A policy that declares ``oracle = True`` plans on the truth instead (``env.truth_model``, updated
whenever the threats that are on change): the reference for the price of information, labelled
``oracle`` in every table (:func:`oracle_label`).

DECISION (docs/dynamic.md §4): a policy without ``update_model`` keeps the belief it was reset with
(an RL agent reads the observation, which is always the current belief's); no policy is ever
handed the truth unless it declares itself an oracle.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from uav_penetration_env.dynamic_env import UAVPenetrationDynamicEnv
from uav_penetration_env.env import UAVPenetrationEnv
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.scenario import Scenario
from uav_penetration_env.types import FloatArray

ORACLE_PREFIX = "oracle:"  # the label of a planner given the truth (oracle:ihpso)


def episode_env(scenario: Scenario) -> UAVPenetrationEnv:
    """The env an episode of ``scenario`` flies: the dynamic env for a dynamic scenario, else the static one."""
    return UAVPenetrationDynamicEnv(scenario) if scenario.is_dynamic else UAVPenetrationEnv(scenario)


def is_oracle(policy: Any) -> bool:
    """Whether ``policy`` declared itself an oracle (``oracle = True``): it plans on the truth."""
    return getattr(policy, "oracle", False) is True


def planning_model(env: UAVPenetrationEnv, policy: Any) -> PenetrationModel:
    """The model ``policy`` may plan on now: the truth for an oracle, else the belief (``env.model``)."""
    model = getattr(env, "truth_model", None) if is_oracle(policy) else env.model
    model = env.model if model is None else model
    assert model is not None
    return model


@dataclass
class BeliefFeed:
    """Hands a policy each new model it may plan on, once per change (see the module docstring).

    Args:
        env: the episode's env.
        policy: the episode's policy (already reset on :attr:`bound`).
    """

    env: UAVPenetrationEnv
    policy: Any
    bound: PenetrationModel | None = None
    updates: int = field(default=0)

    def __post_init__(self) -> None:
        self.bound = planning_model(self.env, self.policy)

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """The policy's action, after handing it the current model if it changed (timed together)."""
        model = planning_model(self.env, self.policy)
        if model is not self.bound:
            update = getattr(self.policy, "update_model", None)
            if callable(update):
                update(model)
                self.updates += 1
            self.bound = model
        return self.policy.act(observation, info)


@dataclass
class OraclePolicy:
    """A policy given the truth: ``inner`` planned on ``env.truth_model`` (docs/dynamic.md §4).

    Its config is the inner policy's with ``oracle: True``, so its results are stored under their
    own key and labelled :data:`ORACLE_PREFIX` + the inner name.

    Raises:
        TypeError: ``inner`` without ``reset`` and ``act``.
    """

    inner: Any
    oracle: bool = dataclasses.field(default=True, init=False)

    def __post_init__(self) -> None:
        if not (callable(getattr(self.inner, "reset", None)) and callable(getattr(self.inner, "act", None))):
            raise TypeError(f"inner: got {self.inner!r}, expected a policy with reset(model, seed) and act(observation, info)")

    @property
    def deterministic(self) -> bool:
        """The inner policy's determinism."""
        return getattr(self.inner, "deterministic", False) is True

    @property
    def last_record(self) -> dict[str, Any]:
        """The inner policy's per-step diagnostics."""
        return getattr(self.inner, "last_record", None) or {}

    def config(self) -> dict[str, Any]:
        """The inner policy's config (its own ``config()``, or its repr) with ``oracle: True``."""
        config = self.inner.config() if callable(getattr(self.inner, "config", None)) else {"policy": repr(self.inner)}
        return {**config, "oracle": True}

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None = None) -> None:
        """Reset the inner policy on ``model`` (the truth: the harness hands it)."""
        self.inner.reset(model, seed)

    def update_model(self, model: PenetrationModel) -> None:
        """Hand the inner policy the new truth (through its ``update_model``; nothing for a policy without one)."""
        update = getattr(self.inner, "update_model", None)
        if callable(update):
            update(model)

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """The inner policy's action."""
        return self.inner.act(observation, info)
