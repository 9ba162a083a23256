"""``UAVPenetrationDynamic-v0``: threats that appear, move, or were never on the map (docs/dynamic.md).

The env holds two models of the same terrain: the **truth** (the radars on at this step, at their
true sites), on which it flies the UAV and scores J, and the **belief** (the radars the planner
knows of, at the sites it believes), which it hands to planners as ``env.model`` and from which it
builds the observation. A planner that plans on ``env.model`` therefore never reads a threat it has
not been told of; one that declares itself an oracle reads ``env.truth_model`` instead and is
labelled so in every table (docs/dynamic.md §4).

A scenario without threat dynamics flies exactly as in :class:`~uav_penetration_env.env.UAVPenetrationEnv`
(truth and belief are then the scenario's own model), bit for bit.

Version history:
    v0: first release.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from uav_penetration_env.env import ScenarioLike, UAVPenetrationEnv
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.scenario import Radar, Scenario
from uav_penetration_env.threats import ThreatState, draw_threats

MODEL_CACHE_LIMIT = 64  # models of radar sets kept per env (a mobile radar makes one per step)


class UAVPenetrationDynamicEnv(UAVPenetrationEnv):
    """The UAV penetration env with threat dynamics and a partially known world (docs/dynamic.md).

    Observation: as ``UAVPenetration-v0``'s, computed on the belief: the nearest **known** radars.

    Action: as ``UAVPenetration-v0``'s.

    Reward: ``-(J(k) + penalty)`` scored on the truth: every radar that is on, known or not.

    Episode end: as ``UAVPenetration-v0``'s.

    Info: ``UAVPenetration-v0``'s keys, scored on the truth (``radar_threat_per_radar`` has one
    entry per scenario radar, in file order, 0 for a radar that is off), plus ``revealed`` (names
    of the radars this step revealed), ``known_threats`` (names of the radars in the belief) and
    ``belief_version`` (a counter that grows whenever the belief changes: a reveal, or a tracked
    radar that moved). Planners read ``state`` and ``step`` from it, and the belief from
    ``env.model``.

    Args:
        scenario: a YAML path, a mapping, a :class:`~uav_penetration_env.scenario.Scenario`, or
            ``None`` for the id's default (``paper-dynamic``).
        profile, render_mode, default_scenario, id_profile, threads: as :class:`UAVPenetrationEnv`.

    Attributes:
        model: the belief model (what planners plan on).
        truth_model: the truth model of the current step (what the env scores on).
        threats: the episode's :class:`~uav_penetration_env.threats.ThreatState` (None for a
            static scenario).
    """

    def __init__(
        self,
        scenario: ScenarioLike = None,
        profile: str | None = None,
        render_mode: str | None = None,
        *,
        default_scenario: str = "paper-dynamic",
        id_profile: str | None = None,
        threads: int | None = None,
    ) -> None:
        self._radar_models: dict[tuple[Radar, ...], PenetrationModel] = {}
        self.threats: ThreatState | None = None
        self.belief_version = 0
        self.truth_indices_before: tuple[int, ...] = ()  # the radars that scored the last transition
        super().__init__(
            scenario, profile, render_mode, default_scenario=default_scenario, id_profile=id_profile, threads=threads
        )
        self.truth_model: PenetrationModel | None = self.model

    @property
    def _dynamic(self) -> bool:
        return self.threats is not None

    def _model_of(self, radars: tuple[Radar, ...]) -> PenetrationModel:
        """The model of this scenario with exactly ``radars`` (static copies), built once per set."""
        if radars not in self._radar_models:
            if len(self._radar_models) >= MODEL_CACHE_LIMIT:
                self._radar_models.pop(next(iter(self._radar_models)))
            assert self.scenario is not None
            static = replace(self.scenario, radars=radars, sensing=None)
            self._radar_models[radars] = PenetrationModel(self._built.get(static), threads=self._threads)
        return self._radar_models[radars]

    def _bind_models(self) -> None:
        """Point ``truth_model`` and ``model`` at the current step's truth and belief."""
        assert self.threats is not None
        self.truth_model = self._model_of(self.threats.truth_radars())
        belief = self._model_of(self.threats.belief_radars())
        if belief is not self.model:
            self.belief_version += 1
        self.model = belief

    def _full_info(self, info: dict[str, Any], revealed: tuple[str, ...]) -> dict[str, Any]:
        """``info`` with the per-radar threat in scenario order and the belief keys."""
        if self.threats is None:
            assert self.scenario is not None
            known = tuple(r.name for r in self.scenario.radars)
        else:
            per_radar = np.zeros(len(self.threats.scenario.radars))
            per_radar[list(self.truth_indices_before)] = info["radar_threat_per_radar"]
            info["radar_threat_per_radar"] = per_radar
            known = tuple(self.threats.scenario.radars[i].name for i in self.threats.belief_indices())
        info["revealed"] = revealed
        info["known_threats"] = known
        info["belief_version"] = self.belief_version
        return info

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode: the start state, then the episode's threat draws, from the env generator.

        A dynamic scenario draws its threats after the start state (:func:`draw_threats`), so a
        static scenario's generator use, and its episodes, are those of ``UAVPenetration-v0``.
        """
        observation, info = super().reset(seed=seed, options=options)
        assert self.scenario is not None
        self.belief_version = 0
        if not self.scenario.is_dynamic:
            self.threats = None
            self.truth_model = self.model
            return observation, self._full_info(info, ())
        self._radar_models = {}
        self.threats = ThreatState(self.scenario, draw_threats(self.scenario, self.np_random))
        self.model = None
        self._bind_models()
        self.belief_version = 0
        return self._describe_dynamic(())

    def _describe_dynamic(self, revealed: tuple[str, ...]) -> tuple[np.ndarray, dict[str, Any]]:
        """Observation on the belief, info on the truth, for the current state."""
        assert self.threats is not None
        self.truth_indices_before = self.threats.truth_indices()
        observation, _ = self._describe_state(self.model)
        _, info = self._describe_state(self.truth_model)
        return observation, self._full_info(info, revealed)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Fly one planning period on the truth, then update what is on and what is known."""
        if not self._dynamic:
            observation, reward, terminated, truncated, info = super().step(action)
            return observation, reward, terminated, truncated, self._full_info(info, ())
        if self._done or self.model is None:
            raise RuntimeError("step() called without a running episode: call reset() first")
        assert self.threats is not None and self.truth_model is not None
        truth = self.truth_model
        self.truth_indices_before = self.threats.truth_indices()
        observation, reward, terminated, truncated, info = self._step_compiled(action, truth)
        _, per_radar, visible, _ = truth.state_threats(self.state[None])
        revealed = self.threats.advance(
            (float(self.state[0]) / 1000.0, float(self.state[1]) / 1000.0), visible[0], per_radar[0]
        )
        self._bind_models()
        if self.model is not truth:
            observation = self.model._env_reset_one(self.state, self.step_index + 1).observation
        self.step_index += 1
        self._done = terminated or truncated
        self._track.append(self.state.copy())
        if self.render_mode == "human":
            self.render()
        return observation, reward, terminated, truncated, self._full_info(info, revealed)

    def set_state(self, state: Any, step_index: int = 0) -> tuple[np.ndarray, dict[str, Any]]:
        """As :meth:`UAVPenetrationEnv.set_state` for a static scenario.

        Raises:
            RuntimeError: on a dynamic scenario, whose threats depend on the flown history.
        """
        if self._dynamic:
            raise RuntimeError(
                "set_state: a dynamic scenario's threats depend on the flown history (reveals, triggers); "
                "expected a static scenario, or reset() and step()"
            )
        return super().set_state(state, step_index)


def episode_env(scenario: Scenario) -> UAVPenetrationEnv:
    """The env a scenario's episode flies: the dynamic env for a dynamic scenario, else the static one.

    The one choice the harness, the suite freeze and the fingerprint replay share.
    """
    return UAVPenetrationDynamicEnv(scenario) if scenario.is_dynamic else UAVPenetrationEnv(scenario)
