"""What the network's outputs mean: the whole action (``action`` head) or the lattice's turn (``turn`` head).

The ``action`` head regresses the normalised action (dv, dphi, dtheta) and flies it as it is
(docs/rl.md §4.2). The ``turn`` head classifies the expert's action into the lattice planner's
candidate turns (``LatticeGuidance.turns``, fractions of dphi_max) and flies the chosen turn as the
lattice flies each of its candidates: toward v_max, with the terrain-following pitch at the
lattice's clearance along the new heading (:func:`turn_action`, the lattice's own candidate
control). The network then chooses one of five discrete moves; speed and altitude follow the
closed-form rule that the greedy floor and the lattice share (docs/rl.md §4.8).

A ``turn`` network is recognised by its ``turns`` array (saved with the weights, so the weights'
hash covers it).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Mapping

import numpy as np

from baselines.distill.episodes import normalisers
from baselines.distill.features import features_of, learner_input, value_prior
from baselines.distill.network import forward, outputs
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.types import FloatArray
from uav_penetration_env.value_function import LATTICE_GUIDANCE, LatticeGuidance, candidate_control

TURNS = tuple(float(t) for t in LATTICE_GUIDANCE.turns)

# A learner as the DAgger loop flies it: (model, observation, exact state) -> the physical action.
Learner = Callable[[PenetrationModel, np.ndarray, FloatArray], FloatArray]


def head_of(arrays: Mapping[str, np.ndarray]) -> str:
    """``turn-value`` for a network with a value prior, ``turn`` with its ``turns`` array, else ``action``."""
    if "prior_log_weight" in arrays:
        return "turn-value"
    return "turn" if "turns" in arrays else "action"


def turn_logits(arrays: Mapping[str, np.ndarray], inputs: np.ndarray) -> np.ndarray:
    """(n, 5) a turn network's scores for (n, input) inputs: its outputs, plus the value prior for ``turn-value``.

    DECISION (docs/rl.md §4.9): the ``turn-value`` head is a residual on the ``value-greedy``
    rule: logits = MLP(x) + exp(w) * (-value input of each turn), w learned with the network, so
    the fit starts from the rule's choice and learns where the expert departs from it.
    """
    logits = outputs(arrays, inputs)
    if "prior_log_weight" in arrays:
        logits = logits + math.exp(float(arrays["prior_log_weight"])) * value_prior(features_of(arrays), inputs)
    return logits


def turn_clearance(arrays: Mapping[str, np.ndarray]) -> float:
    """The terrain-following clearance [m] a ``turn`` network flies: its expert's (a ``clearance_m`` array), else the lattice's."""
    return float(arrays["clearance_m"]) if "clearance_m" in arrays else LATTICE_GUIDANCE.clearance_m


def expert_clearance(expert: object) -> float:
    """The terrain-following clearance [m] of a lattice expert (``lattice-cN``), the lattice's own otherwise."""
    guidance = getattr(expert, "guidance", None)
    return float(getattr(guidance, "clearance_m", LATTICE_GUIDANCE.clearance_m))


def turn_classes(unit_actions: np.ndarray, turns: tuple[float, ...] = TURNS) -> np.ndarray:
    """(n,) the index of the turn in ``turns`` nearest to each normalised label's dphi.

    The action box is symmetric, so a normalised dphi is the turn as a fraction of dphi_max, the
    unit of ``turns``; the lattice's own labels sit on the turns exactly.
    """
    dphi = np.asarray(unit_actions, dtype=np.float64)[:, 1]
    return np.argmin(np.abs(dphi[:, None] - np.asarray(turns)[None, :]), axis=1).astype(np.int64)


def turn_action(
    model: PenetrationModel, state: FloatArray, turn: float, clearance_m: float = LATTICE_GUIDANCE.clearance_m
) -> FloatArray:
    """The lattice's candidate control for ``turn`` (a fraction of dphi_max) from ``state``.

    Accelerate toward v_max, turn by ``turn`` x dphi_max, pitch toward ``clearance_m`` (the
    expert lattice's clearance; default the lattice's own) above the highest terrain under the
    next steps along the new heading: the control the lattice planner prices for each of its turns
    (:func:`uav_penetration_env.value_function.candidate_control`).
    """
    guidance = LATTICE_GUIDANCE if clearance_m == LATTICE_GUIDANCE.clearance_m else _guidance(clearance_m)
    return candidate_control(model, np.asarray(state, dtype=np.float64), float(turn), guidance)


@functools.lru_cache(maxsize=16)
def _guidance(clearance_m: float) -> LatticeGuidance:
    return dataclasses.replace(LATTICE_GUIDANCE, clearance_m=clearance_m)


def network_action(
    arrays: Mapping[str, np.ndarray],
    model: PenetrationModel,
    observation: np.ndarray,
    state: FloatArray,
    from_unit: Callable[[np.ndarray], np.ndarray],
) -> FloatArray:
    """The physical action a network flies from one observation and its exact state, by its head.

    DECISION (docs/rl.md §4.8): a ``turn`` network flies the lattice's candidate control for its
    arg-max turn, so it chooses among the five moves its expert chooses among, and its speed and
    pitch are the closed-form rule greedy and the lattice share: the regression head's failures
    (§4.6) were shrunken pitch corrections and turns dithering between the five values, and
    neither exists here.
    """
    row = learner_input(features_of(arrays), model, observation, state).reshape(1, -1)
    if head_of(arrays) != "action":
        logits = turn_logits(arrays, row)[0]
        turn = float(arrays["turns"][int(np.argmax(logits))])
        return turn_action(model, np.asarray(state, dtype=np.float64), turn, turn_clearance(arrays))
    return from_unit(forward(arrays, row)[0])


def learner_of(arrays: Mapping[str, np.ndarray]) -> Learner:
    """A network as the DAgger loop's learner: its physical action from (model, observation, state)."""

    def learner(model: PenetrationModel, observation: np.ndarray, state: FloatArray) -> FloatArray:
        return network_action(arrays, model, observation, state, normalisers(model)[1])

    return learner
