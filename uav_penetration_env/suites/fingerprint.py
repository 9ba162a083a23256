"""Fingerprints of a built member, and the guard that refuses a member that no longer reproduces.

A member's fingerprint (docs/suite.md §2) is frozen when its suite is written
(``uav-bench suite freeze``, :func:`uav_penetration_env.benchmark.suite_freeze.freeze_suite`):

* ``scenario_hash``: :attr:`Scenario.hash` of the built scenario (every field, and the content of
  every file it reads);
* ``terrain_hash`` and ``floors_hash``: SHA-256 (16 hex digits) of the BUILT terrain height grid
  and of the radars' visibility floors (:class:`~uav_penetration_env.build.BuiltScenario`), each
  value rounded to :data:`QUANTUM_M` first;
* ``replay_total_j``: the total cost ΣJ(k) + Σ penalty of one fixed control sequence,
  ``replay_actions`` (stored in the member), replayed open loop through the env
  (:func:`replay_total_j`), compared to a relative tolerance of :data:`TOTAL_J_RTOL`; the replay
  must also end (goal, failure or K_max) exactly at the sequence's last control.

:func:`check_fingerprint` raises :class:`SuiteMismatchError` when any field differs, so a silent
change to the model, the terrain synthesis or the generator cannot pass unnoticed.

The check only replays: which planner produced the controls (the harness's greedy floor, when the
suite was frozen: :mod:`uav_penetration_env.benchmark.suite_freeze`) is no part of it, so
improving that planner changes no member's check, and the env core imports nothing from the
harness (``tests/test_imports.py``).
"""

from __future__ import annotations

import hashlib
import json
import math
from typing import Any

import numpy as np

from uav_penetration_env.scenario import Scenario
from uav_penetration_env.suites.schema import (
    ACTIONS_ENCODING,
    FINGERPRINT_SCHEME,
    Controls,
    Fingerprint,
    SuiteError,
    SuiteMember,
    as_controls,
)
from uav_penetration_env.types import FloatArray

# DECISION (docs/suite.md §2): heights and floors are rounded to 1 cm before hashing. A last-digit
# difference between machines moves a value by about 1e-12 m (10 ulp at 1 km); it changes the
# hash only if it carries a value across a rounding boundary, with probability about
# 2 x 1e-12 / 0.01 per value, i.e. about 1e-4 for a member's 6e5 values. A real change moves
# thousands of values by centimetres to metres and changes the hash with certainty; even a
# uniform 1 mm shift of one array moves a tenth of its values across a boundary.
QUANTUM_M = 0.01
# DECISION (docs/suite.md §2): the replayed total J is compared, not hashed: a relative tolerance
# of 1e-9 absorbs the last-digit differences of 150 summed steps (about 1e-14 relative) and still
# catches any change of the cost, the radar model or the kinematics, which moves it by far more.
TOTAL_J_RTOL = 1e-9
REPLAY_SEED = 0  # the env seed of the replay episode (the members have no start jitter)
FINGERPRINT_FIELDS = {
    "scenario_hash": "scenario hash",
    "terrain_hash": "terrain hash",
    "floors_hash": "floors hash",
    "replay_total_j": "replayed total J",
    "replay_steps": "replay episode length",
}


class SuiteMismatchError(SuiteError):
    """A member built now differs from its frozen fingerprint.

    Attributes:
        suite: the suite's name.
        member: the member's name.
        field: the fingerprint field (``scenario_hash``, ``terrain_hash``, ``floors_hash``,
            ``replay_steps``, ``replay_total_j``).
        got: the value computed now.
        frozen: the value in the suite file.
    """

    def __init__(self, suite: str, member: str, field: str, got: Any, frozen: Any) -> None:
        self.suite, self.member, self.field, self.got, self.frozen = suite, member, field, got, frozen
        relation = "!=" if field != "replay_total_j" else f"!= (rtol {TOTAL_J_RTOL:g})"
        super().__init__(
            f"suite {suite} member {member}: {FINGERPRINT_FIELDS[field]} {got!r} {relation} frozen {frozen!r}"
            " — the model, the terrain synthesis or the generator changed; freeze a new suite version "
            "(uav-bench suite freeze, docs/suite.md)"
        )


def array_hash(values: FloatArray, quantum: float = QUANTUM_M) -> str:
    """16 hex digits of SHA-256 over an array's shape and its values rounded to ``quantum``.

    Args:
        values: any float array (heights, floors) [m].
        quantum: the rounding step [m] (:data:`QUANTUM_M`).

    Raises:
        ValueError: a NaN or infinite value.
    """
    array = np.asarray(values, dtype=np.float64)
    if not np.all(np.isfinite(array)):
        raise ValueError(
            f"values: got {int(np.sum(~np.isfinite(array)))} non-finite values, expected finite heights"
        )
    steps = np.rint(array / quantum).astype("<i8")  # integers: no -0.0, no representation ambiguity
    digest = hashlib.sha256(json.dumps({"shape": list(array.shape), "quantum": quantum}).encode())
    digest.update(np.ascontiguousarray(steps).tobytes())
    return digest.hexdigest()[:16]


def replay_episode(scenario: Scenario, actions: Controls) -> tuple[float, int, bool]:
    """Fly ``actions`` open loop through the env from ``reset(seed=REPLAY_SEED)``.

    The env is stepped with each control in turn until the episode ends or the controls run out;
    the sum is taken as the harness takes it (numpy sums of the step columns), so a stored episode
    that flew these controls has this total.

    Args:
        scenario: the member's scenario.
        actions: (n, 3) controls [dv (m/s), dphi (rad), dtheta (rad)].

    Returns:
        The total cost ΣJ(k) + Σ penalty (= −return) of the steps flown, the number of steps
        flown, and whether the episode ended (goal, failure or K_max) at the last of them.
    """
    from uav_penetration_env.dynamic_env import episode_env

    env = episode_env(scenario)  # a dynamic member replays in the dynamic env (threats drawn from the reset seed)
    env.reset(seed=REPLAY_SEED)
    costs, penalties = [], []
    done = False
    for action in actions:
        _, _, terminated, truncated, info = env.step(np.array(action, dtype=np.float64))
        costs.append(info["J"])
        penalties.append(info["penalty"])
        done = terminated or truncated
        if done:
            break
    total = float(np.array(costs, dtype=np.float64).sum() + np.array(penalties, dtype=np.float64).sum())
    return total, len(costs), done


def replay_total_j(scenario: Scenario, actions: Controls) -> float:
    """Total cost ΣJ(k) + Σ penalty (= −return) of ``actions`` replayed open loop (:func:`replay_episode`).

    DECISION (docs/suite.md §2): a member stores the controls of its replay episode, and the check
    replays them open loop, rather than flying a planner again: the fingerprint then depends on the
    model alone, never on the planner that chose the controls (improving the harness's greedy
    floor changes no suite's check), and the env core needs nothing from the harness. The
    controls are the greedy floor's episode at freeze time rather than a pseudo-random sequence,
    because a random sequence crashes into the terrain within a few steps and never meets most
    radars, while the greedy one flies to the goal past them, so the replay exercises kinematics,
    terrain, every radar, the cost and the normalisation along a whole route.
    """
    return replay_episode(scenario, actions)[0]


def fingerprint(scenario: Scenario, actions: FloatArray | Controls) -> Fingerprint:
    """The fingerprint of a scenario as built now (terrain and floors from the build cache).

    Args:
        scenario: the member's scenario.
        actions: (n, 3) the controls of its replay episode, which must end the episode (goal,
            failure or K_max) at the last of them.

    Raises:
        ValueError: ``actions`` not (n, 3) finite controls, or not ending the episode at the last
            control.
    """
    from uav_penetration_env.build import build_scenario

    controls = as_controls(actions)
    total, steps, ended = replay_episode(scenario, controls)
    if not (ended and steps == len(controls)):
        where = f"ends after {steps}" if ended else f"has not ended after {steps}"
        raise ValueError(
            f"replay_actions: got {len(controls)} controls whose episode {where}, "
            "expected an episode that ends at the last control"
        )
    built = build_scenario(scenario)
    return Fingerprint(
        scenario_hash=scenario.hash,
        terrain_hash=array_hash(built.terrain),
        floors_hash=array_hash(built.floors),
        replay_total_j=total,
        replay_actions=controls,
    )


def check_fingerprint(suite: str, member: SuiteMember, scenario: Scenario, *, replay: bool = True) -> None:
    """Compare ``scenario`` (the member built now) with the member's frozen fingerprint.

    The fields are checked in the order scenario hash, terrain hash, floors hash, replay episode
    length, replayed total J; the first difference raises. The scenario hash is checked before
    anything is built.

    Args:
        suite: the suite's name (for the message).
        member: the member with its frozen fingerprint.
        scenario: the member's scenario built now.
        replay: also replay the stored controls (about 0.05 s per member).

    Raises:
        SuiteMismatchError: naming the suite, the member, the field and both values.
    """
    from uav_penetration_env.build import build_scenario

    frozen = member.fingerprint
    if scenario.hash != frozen.scenario_hash:
        raise SuiteMismatchError(suite, member.name, "scenario_hash", scenario.hash, frozen.scenario_hash)
    built = build_scenario(scenario)
    for key, values in (("terrain_hash", built.terrain), ("floors_hash", built.floors)):
        got = array_hash(values)
        if got != getattr(frozen, key):
            raise SuiteMismatchError(suite, member.name, key, got, getattr(frozen, key))
    if replay:
        actions = frozen.replay_actions
        total, steps, ended = replay_episode(scenario, actions)
        if not (ended and steps == len(actions)):
            flown: int | str = steps if ended else f"more than {steps}"
            raise SuiteMismatchError(suite, member.name, "replay_steps", flown, len(actions))
        if not math.isclose(total, frozen.replay_total_j, rel_tol=TOTAL_J_RTOL, abs_tol=0.0):
            raise SuiteMismatchError(suite, member.name, "replay_total_j", total, frozen.replay_total_j)


def fingerprint_rules(replay: str) -> dict[str, Any]:
    """The ``fingerprint`` block of a suite file: how the fields were computed and compared.

    Args:
        replay: who chose the replay controls, and from which reset (``the greedy floor
            (GreedyPolicy, default settings) from env.reset(seed=0)``).
    """
    return {
        "scheme": FINGERPRINT_SCHEME,
        "quantum_m": QUANTUM_M,
        "replay": replay,
        "replay_actions": ACTIONS_ENCODING,
        "replay_total_j_rtol": TOTAL_J_RTOL,
    }
