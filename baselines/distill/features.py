"""Inputs a distilled network reads beside the env's observation (``--features``; docs/rl.md §4.9).

The env's 67-value observation (docs/envs/UAVPenetration-v0.md) describes the UAV's surroundings
out to 6 km and the four nearest radars. The lattice planner it imitates also reads the scenario's
cost-to-go field V(x, y, psi) (docs/model.md §7e.2), built once per map by value iteration, and that
field is what a network trained on 21 or 201 maps could not infer from the local view: off its
training maps it chose turns at the greedy floor's level (docs/rl.md §4.8).

A feature set appends values computed from the exact state and the model (the same
``(model, observation, state)`` every learner is flown with), after the observation, in the order
of the names given. A network saved with features carries their names in a ``features`` array,
so its weights' hash covers them and a policy flies the inputs it was fitted on.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from uav_penetration_env.model import OBSERVATION_SIZE, PenetrationModel
from uav_penetration_env.types import FloatArray
from uav_penetration_env.value_function import LATTICE_GUIDANCE, value_ahead, value_function

VALUE_TURNS = tuple(float(t) for t in LATTICE_GUIDANCE.turns)
VALUE_CAP = 50.0  # [J] V at the pose is capped here (V of a pose off the lattice is the crash price, ~100)
VALUE_SPREAD = 5.0  # [J] each one-step difference is clipped to +- this


def value_features(model: PenetrationModel, state: FloatArray) -> FloatArray:
    """(1 + len(VALUE_TURNS),) the cost-to-go field around the pose of ``state`` (docs/rl.md §4.9).

    ``[min(V(p, psi), 50) / 10, clip(V(p_i, psi_i) - V(p, psi), -5, 5) for each turn i]`` with
    ``psi_i = psi + turn_i * dphi_max`` and ``p_i`` the point one step of v_max * dt ahead along
    ``psi_i``: where the field says each of the lattice's five turns leads, in J, relative to here.

    DECISION (docs/rl.md §4.9): read V at five points a fixed distance ahead, not at the ends of
    flown moves: the feature is a look at the map's field, like the terrain patch is a look at the
    DEM, and no move is simulated or priced (the lattice planner flies and prices 25 two-step
    sequences with the model; the network weighs these five numbers with the rest of its inputs).
    Units are J, the field's own, with the pose's V capped and the differences clipped so that a
    pose beside a crash-priced node does not dominate the input scaling.
    """
    here, ahead = value_ahead(model, value_function(model), np.asarray(state, dtype=np.float64), VALUE_TURNS)
    return np.concatenate(([min(here, VALUE_CAP) / 10.0], np.clip(ahead - here, -VALUE_SPREAD, VALUE_SPREAD)))


# name -> (function of (model, state), width)
FEATURE_SETS = {"value": (value_features, 1 + len(VALUE_TURNS))}


def check_features(names: Sequence[str]) -> None:
    """Raise ``ValueError`` (naming ``--features``) for an unknown or repeated feature set."""
    for name in names:
        if name not in FEATURE_SETS:
            raise ValueError(f"--features: got {name!r}, expected feature sets among {', '.join(FEATURE_SETS)}")
    if len(set(names)) != len(names):
        raise ValueError(f"--features: got {list(names)!r}, expected each feature set once")


def input_size(names: Sequence[str]) -> int:
    """The network's input width: the observation's plus each feature set's."""
    return OBSERVATION_SIZE + sum(FEATURE_SETS[name][1] for name in names)


def features_of(arrays: Mapping[str, np.ndarray]) -> tuple[str, ...]:
    """The feature sets a saved network reads (its ``features`` array; none for older networks)."""
    return tuple(str(name) for name in arrays["features"]) if "features" in arrays else ()


def learner_input(names: Sequence[str], model: PenetrationModel, observation: np.ndarray, state: FloatArray) -> np.ndarray:
    """(input_size(names),) the observation followed by each feature set's values, as float32 like the env's."""
    observation = np.asarray(observation, dtype=np.float32).reshape(-1)
    if not names:
        return observation
    parts = [observation, *(FEATURE_SETS[name][0](model, state) for name in names)]
    return np.concatenate(parts).astype(np.float32)


def value_prior(names: Sequence[str], inputs: np.ndarray) -> np.ndarray:
    """(n, 5) minus each turn's value input (J one step ahead, relative to here) of (n, input_size) inputs.

    The ``turn-value`` head's prior: the turn toward the lowest V ahead has the highest score,
    the ``value-greedy`` rule's choice (docs/rl.md §4.9).

    Raises:
        ValueError: ``names`` without the ``value`` feature set.
    """
    if "value" not in names:
        raise ValueError(f"features: got {list(names)!r}, expected 'value' among them for the value prior")
    start = OBSERVATION_SIZE + sum(FEATURE_SETS[name][1] for name in names[: list(names).index("value")])
    inputs = np.asarray(inputs, dtype=np.float64).reshape(-1, input_size(names))
    return -inputs[:, start + 1 : start + 1 + len(VALUE_TURNS)]


def prepare(names: Sequence[str], model: PenetrationModel) -> None:
    """Build (or load) what the feature sets read for ``model``, so the first decision is not slowed by it."""
    if "value" in names:
        value_function(model)
