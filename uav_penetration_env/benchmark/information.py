"""What a planner may know: the env an episode flies, the model a policy plans on, oracles (docs/dynamic.md §4).

On a dynamic scenario the env scores the truth and hands planners the belief (``env.model``,
:mod:`uav_penetration_env.dynamic_env`). The harness binds a policy to the belief at reset and, when
the belief changes (a threat revealed, a tracked one moved), hands it the new belief through the
policy's ``update_model(model)`` method, inside the timed decision of the next step, so a planner's
belief updates (a rebuilt value function) count in its ``planning_cpu_seconds``.

A policy that declares ``oracle = True`` plans on the truth instead (``env.truth_model``, updated
whenever the threats that are on change): the reference for the price of information, labelled
``oracle:NAME`` in every table (``make_policy("oracle:NAME")`` builds one).

DECISION (docs/dynamic.md §4): a policy without ``update_model`` keeps the belief it was reset with
(an RL agent reads the observation, which is always the current belief's); no policy is ever
handed the truth unless it declares itself an oracle.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from uav_penetration_env.benchmark.policy_spec import OFFLINE, ORACLE
from uav_penetration_env.dynamic_env import episode_env  # noqa: F401  # re-exported: the harness's env choice
from uav_penetration_env.env import UAVPenetrationEnv
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.types import FloatArray


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
class _Wrapped:
    """A policy told more or less than the belief: the inner policy's determinism, record and config."""

    INFORMATION: ClassVar[str] = ""
    inner: Any

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
        """The inner policy's config (its ``config()``, else its repr) with ``information`` (a store key of its own)."""
        config = self.inner.config() if callable(getattr(self.inner, "config", None)) else {"policy": repr(self.inner)}
        return {**config, "information": self.INFORMATION}


@dataclass
class OraclePolicy(_Wrapped):
    """A policy given the truth: ``inner`` planned on ``env.truth_model`` (``oracle:NAME``, docs/dynamic.md §4).

    Raises:
        TypeError: ``inner`` without ``reset`` and ``act``.
    """

    INFORMATION: ClassVar[str] = ORACLE
    oracle: ClassVar[bool] = True  # read by is_oracle: the harness hands it the truth

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


@dataclass
class OfflinePolicy(_Wrapped):
    """The never-replanning floor: ``inner``'s plan on the prior map, flown open loop (``offline:NAME``).

    At its first step it flies ``inner`` on the model it was reset with (the belief at the start:
    the prior map), from the exact start state to the episode's end, in simulation, and records the
    actions; every step then applies the next recorded action, whatever the env reveals. The whole
    offline plan is computed inside the first decision, so its CPU time is that step's
    ``planning_cpu_seconds``.

    DECISION (docs/dynamic.md §4): after the simulated episode ends (goal, failure or K_max) the
    floor holds its course (zero controls); belief updates are ignored (it never replans).

    Raises:
        TypeError: ``inner`` without ``reset`` and ``act``.
    """

    INFORMATION: ClassVar[str] = OFFLINE
    model: PenetrationModel | None = field(default=None, repr=False)
    _plan: list[FloatArray] | None = field(default=None, repr=False)
    _next: int = field(default=0, repr=False)

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None = None) -> None:
        """Reset the inner policy on the prior map's model; the plan is made at the first step."""
        self.inner.reset(model, seed)
        self.model, self._plan, self._next = model, None, 0

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """The next action of the offline plan (made now, at the first step)."""
        if self.model is None:
            raise RuntimeError("OfflinePolicy.act() before reset(model, seed)")
        if self._plan is None:
            self._plan = self._simulate(observation, np.asarray(info["state"], dtype=np.float64), int(info["step"]))
        action = self._plan[self._next] if self._next < len(self._plan) else np.zeros(3)
        self._next += 1
        return action.copy()

    def _simulate(self, observation: np.ndarray, state: FloatArray, step: int) -> list[FloatArray]:
        """The actions ``inner`` takes flying ``self.model`` from ``state`` at ``step`` to the episode's end."""
        assert self.model is not None
        plan: list[FloatArray] = []
        for k in range(step, self.model.max_steps):
            action = np.asarray(self.inner.act(observation, {"state": state, "step": k}), dtype=np.float64)
            plan.append(action)
            result = self.model.step(state[None], action[None], k)
            if bool(result.terminated[0] or result.truncated[0]):
                break
            state = result.state[0]
            observation = self.model.observe(state[None], k + 1, result)[0]
        return plan


# Policy wrappers by information mode (policy_spec.INFORMATION_PREFIXES): make_policy builds them.
INFORMATION_WRAPPERS: dict[str, type[_Wrapped]] = {ORACLE: OraclePolicy, OFFLINE: OfflinePolicy}
