"""A distilled network as a harness Policy: ``distill:PATH`` (PATH: a run folder or its ``policy.npz``).

The network is plain arrays (:mod:`baselines.distill.network`), flown with NumPy: loading needs
neither torch nor a pickle, and the policy pickles small into the evaluator's workers. The sidecar
(``policy.json`` beside the weights) records the SHA-256 of the weights; :func:`load_distill_policy`
refuses weights that do not match it, and the results store keys the policy by that hash.

``distill-safe:PATH`` flies the same network behind a safety layer (:class:`SafeDistillPolicy`):
it may raise the network's pitch change to the greedy floor's terrain-following one, and
nothing else.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from baselines.distill.features import check_features, features_of, input_size, prepare
from baselines.distill.files import load_npz, sha256_file
from baselines.distill.heads import head_of, network_action, turn_clearance
from baselines.distill.network import layer_count
from baselines.distill.weights_check import check_weights
from baselines.policy_params import DistillParams, weights_path
from uav_penetration_env.benchmark.policies import GreedyPolicy
from uav_penetration_env.kinematics import HEADING, SPEED
from uav_penetration_env.model import OBSERVATION_SIZE, PenetrationModel
from uav_penetration_env.types import FloatArray
from uav_penetration_env.value_function import terrain_following_dtheta

GREEDY_CLEARANCE_M = float(GreedyPolicy.clearance_m)  # the greedy floor's own clearance [m]


class DistillPolicy:
    """The deterministic action of a distilled MLP, mapped from [-1, 1] to the env's action box.

    Args:
        weights: the ``.npz`` file.
        arrays: its arrays (checked against the sidecar's hash).
        sidecar: the parsed sidecar.
    """

    deterministic = True

    def __init__(self, weights: Path, arrays: dict[str, np.ndarray], sidecar: dict[str, Any]) -> None:
        self.weights = weights
        self.arrays = arrays
        self.sidecar = sidecar
        self._from_unit: Any = None
        self._model: PenetrationModel | None = None

    def __repr__(self) -> str:
        return f"DistillPolicy({str(self.weights)!r}, expert={self.sidecar['expert']!r})"

    def config(self) -> dict[str, Any]:
        """What determines behaviour (the store key): the weights' hash and the network's form.

        Hashes, not paths, and nothing measured (training seconds), so the key is the same in
        every process and for a moved file.
        """
        key = {
            "kind": "distill",
            "weights_sha256": self.sidecar["weights_sha256"],
            "hidden": list(self.sidecar["hidden"]),
            "activation": self.sidecar["activation"],
            "deterministic": True,
        }
        # The action head's key is the one of the networks made before heads existed.
        if head_of(self.arrays) != "action":
            key["head"] = head_of(self.arrays)
        if features_of(self.arrays):
            key["features"] = list(features_of(self.arrays))
        return key

    @property
    def metadata(self) -> dict[str, Any]:
        """The training budget copied into every episode row: the run's expert labels and CPU seconds."""
        return {
            "train_timesteps": int(self.sidecar["expert_labels"]),
            "train_seconds": float(self.sidecar["train_cpu_seconds"]),
        }

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None = None) -> None:
        """Bind the env's action box; refuse a physics profile the network was not trained under."""
        del seed
        from baselines.distill.episodes import normalisers

        profile = model.scenario.profile
        if profile not in self.sidecar["profiles"]:
            raise ValueError(
                f"distill policy {self.weights} was trained under the profile(s) {self.sidecar['profiles']}, "
                f"not {profile!r} (scenario {model.scenario.name!r})"
            )
        _, self._from_unit = normalisers(model)
        self._model = model
        prepare(features_of(self.arrays), model)

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """The network's action for ``observation``, in physical units [dv, dphi, dtheta].

        A ``turn`` network's chosen turn is flown as the lattice's candidate control from the
        exact state in ``info`` (:func:`baselines.distill.heads.turn_action`).
        """
        if self._from_unit is None or self._model is None:
            raise RuntimeError("DistillPolicy.act() before reset(model, seed)")
        return network_action(self.arrays, self._model, observation, info["state"], self._from_unit)


def safe_action(
    model: PenetrationModel, state: FloatArray, action: FloatArray, clearance_m: float, lookahead_steps: float
) -> tuple[FloatArray, bool]:
    """``action`` with its pitch change raised to the terrain-following minimum where it falls short.

    The minimum is the greedy floor's pitch change (:func:`terrain_following_dtheta`) toward
    ``clearance_m`` above the highest terrain under the next ``lookahead_steps`` steps along the
    heading and at the speed ``action`` itself chooses, so the layer answers the network's own
    course. A smaller pitch change would end the step below that altitude; a larger one is the
    network's to keep, and dv and dphi are never touched. Returns the action and whether the
    pitch change was raised.
    """
    limits = model.limits
    dv, dphi, dtheta = (float(a) for a in action)
    heading = float(state[HEADING]) + dphi
    speed = float(np.clip(state[SPEED] + dv, limits.speed_min, limits.speed_max))
    floor = terrain_following_dtheta(model, state, heading, speed, clearance_m, lookahead_steps)
    if dtheta >= floor:
        return np.asarray(action, dtype=np.float64), False
    return np.array([dv, dphi, floor]), True


class SafeDistillPolicy(DistillPolicy):
    """A distilled network behind a safety layer that limits its pitch toward the terrain.

    DECISION (docs/rl.md §4.7): the layer may override the network's pitch change only, and only
    upward, to the greedy floor's terrain-following pitch change at the lattice's clearance
    (100 m, two steps ahead, along the network's own new heading): the failures of the unguarded
    networks are pitch-ups they under-do near rising terrain (§4.6), and a floor on one channel
    keeps every other choice the network's. ``last_record["safety_override"]`` is 1 on a step
    the layer changed, 0 otherwise, so the episodes count its overrides.

    Args:
        clearance_m: the height above the terrain ahead the layer keeps.
        lookahead_steps: how many steps ahead the terrain counts.
    """

    def __init__(
        self,
        weights: Path,
        arrays: dict[str, np.ndarray],
        sidecar: dict[str, Any],
        clearance_m: float = 100.0,
        lookahead_steps: float = 2.0,
    ) -> None:
        super().__init__(weights, arrays, sidecar)
        self.clearance_m = clearance_m
        self.lookahead_steps = lookahead_steps
        self.model: PenetrationModel | None = None
        self.last_record: dict[str, Any] = {}

    def __repr__(self) -> str:
        return f"SafeDistillPolicy({str(self.weights)!r}, expert={self.sidecar['expert']!r})"

    def config(self) -> dict[str, Any]:
        """The unguarded network's key plus the layer's settings, so the two are stored apart."""
        safety = {"clearance_m": float(self.clearance_m), "lookahead_steps": float(self.lookahead_steps)}
        return {**super().config(), "safety": safety}

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None = None) -> None:
        """As the unguarded policy's; the layer keeps the model for the terrain."""
        super().reset(model, seed)
        self.model = model
        self.last_record = {}

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """The network's action, its pitch change raised where it would descend below the clearance."""
        proposed = super().act(observation, info)
        assert self.model is not None  # bound with _from_unit by reset()
        state = np.asarray(info["state"], dtype=np.float64)
        action, overridden = safe_action(self.model, state, proposed, self.clearance_m, self.lookahead_steps)
        self.last_record = {"safety_override": int(overridden)}
        return action


class ShieldedDistillPolicy(DistillPolicy):
    """A distilled network behind a verified fallback to the greedy floor (:mod:`baselines.distill.shield`).

    DECISION (docs/rl.md §4.8): before each step the network's own policy is flown forward
    ``horizon`` = 5 steps with the model; if it collides or leaves the area, the greedy floor
    flies the step, and it flies every step once the episode is past twice the steps of a
    straight flight to the goal. The failures of the turn networks off their training scenarios
    are flights out of the area and circling until the step limit (§4.8), which the greedy floor,
    turning toward the goal, does not do; one checked candidate and one fixed fallback is a
    verification, not a search; after such an override the greedy floor keeps the controls
    for ``hold`` = 5 steps, and it flies every step within ``homing`` = 4 steps of flight of the
    goal, where a network that passes beside the goal flies on toward the edge (§4.8).
    ``last_record["shield"]`` is 0 on a step the network flew, 1 on one overridden for a
    failure ahead, 2 for the step budget, 3 during a hold, 4 near the goal.

    Args:
        shield: the horizon and the step budget.
    """

    def __init__(self, weights: Path, arrays: dict[str, np.ndarray], sidecar: dict[str, Any], shield: Any = None) -> None:
        from baselines.distill.shield import Shield

        super().__init__(weights, arrays, sidecar)
        self.shield = shield if shield is not None else Shield()
        self.last_record: dict[str, Any] = {}
        self._budget: float | None = None
        self._held_until = -1

    def __repr__(self) -> str:
        return f"ShieldedDistillPolicy({str(self.weights)!r}, expert={self.sidecar['expert']!r})"

    def config(self) -> dict[str, Any]:
        """The unguarded network's key plus the shield's settings, so the two are stored apart."""
        shield = {
            "horizon": int(self.shield.horizon),
            "budget": float(self.shield.budget),
            "hold": int(self.shield.hold),
            "homing": float(self.shield.homing),
            "fallback": "greedy",
        }
        if self._fallback_clearance() != GREEDY_CLEARANCE_M:  # keyed only where it differs (older keys unchanged)
            shield["homing_clearance_m"] = self._fallback_clearance()
            shield["homing_checked"] = True  # the low homing rule's own rollout, falling back to 100 m
        return {**super().config(), "shield": shield}

    def _fallback_clearance(self) -> float:
        """The greedy homing's clearance: a turn network's own flight clearance, else the floor's 100 m.

        DECISION (docs/rl.md §4.9): a network that flies its expert's lower clearance
        (``lattice-cN``) homes on the goal with the greedy floor's rule at that same clearance, so
        the last steps are not flown at the floor's height; a failure ahead, the hold after it and
        the spent budget fall back to the floor itself at 100 m, no less safe than the floor (at
        40 m, a failure ahead at the start of held-out members 10001 and 10032, steep rising
        terrain, was flown into by the fallback too); the low homing step is checked by its own
        5-step rollout and handed to the floor at 100 m when that fails (at 40 m the homing
        collided on the DEM member `dem-topobathy`'s rough terrain at step 22).
        """
        if head_of(self.arrays) != "action" and "clearance_m" in self.arrays:
            return turn_clearance(self.arrays)
        return GREEDY_CLEARANCE_M

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None = None) -> None:
        """As the unguarded policy's; the step budget is set from the first state flown."""
        super().reset(model, seed)
        self.last_record = {}
        self._budget = None
        self._held_until = -1

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """The network's action, or the greedy floor's where the network's rollout fails or the budget is spent."""
        from baselines.distill.shield import FAILS_AHEAD, shielded_action, straight_steps

        if self._from_unit is None or self._model is None:
            raise RuntimeError("ShieldedDistillPolicy.act() before reset(model, seed)")
        step = int(info["step"])
        if self._budget is None:
            self._budget = step + self.shield.budget * straight_steps(self._model, info["state"])
        action, why = shielded_action(
            self.arrays, self._model, self._from_unit, observation, info["state"], step, self.shield, self._budget,
            self._held_until, self._fallback_clearance(),
        )  # fmt: skip
        if why == FAILS_AHEAD:
            self._held_until = step + 1 + self.shield.hold
        self.last_record = {"shield": why}
        return action


def load_distill_policy(path: str | Path) -> DistillPolicy:
    """The harness Policy of a distilled network (``distill[run=PATH]``, published ``distill:PATH``).

    Raises:
        FileNotFoundError: no weights or no sidecar (naming the path).
        ValueError: weights whose SHA-256 is not the sidecar's, a corrupt sidecar, a member whose
            header declares a dtype or size the sidecar's network cannot have
            (:func:`~.weights_check.check_weights`), or a network for another observation size.
    """
    weights = weights_path(path)
    sidecar_path = weights.with_suffix(".json")
    for needed in (weights, sidecar_path):
        if not needed.is_file():
            raise FileNotFoundError(f"{needed}: no such file (a distill policy is OUT/policy.npz with OUT/policy.json)")
    try:
        sidecar = json.loads(sidecar_path.read_text())
        expected = sidecar["weights_sha256"]
    except (ValueError, KeyError, TypeError) as error:
        raise ValueError(f"{sidecar_path}: not a distill sidecar ({error})") from None
    found = sha256_file(weights)
    if found != expected:
        raise ValueError(
            f"{weights}: SHA-256 {found[:12]}… is not the {expected[:12]}… its sidecar {sidecar_path} records "
            "(the weights were changed or replaced)"
        )
    try:  # the headers against the sidecar first: no array is read before its size is known to be sane
        check_weights(weights, sidecar, OBSERVATION_SIZE)
    except ValueError as error:
        text = str(error)
        raise ValueError(text if text.startswith(str(weights)) else f"{sidecar_path}: {text}") from None
    arrays = load_npz(weights)
    first = arrays["W0"].shape[1] if layer_count(arrays) else None
    features = features_of(arrays)
    try:
        check_features(features)
    except ValueError as error:
        raise ValueError(f"{weights}: {error}") from None
    if first != input_size(features) or sidecar.get("observation_size") != OBSERVATION_SIZE:
        raise ValueError(
            f"{weights}: a network for inputs of size {first}, this env's observations ({OBSERVATION_SIZE}) "
            f"with the features {list(features)} are {input_size(features)}"
        )
    return DistillPolicy(weights, arrays, sidecar)


def load_guarded_distill_policy(params: DistillParams) -> DistillPolicy:
    """The policy ``distill[run=DIR,guard=GUARD]``: the network of ``run`` alone or behind its guard.

    ``guard`` ``none``: :class:`DistillPolicy`; ``safe``: :class:`SafeDistillPolicy` (the safety
    layer on its pitch, docs/rl.md §4.7); ``shield``: :class:`ShieldedDistillPolicy` (the
    verified fallback to the greedy floor, §4.8). Published as ``distill:DIR``,
    ``distill-safe:DIR``, ``distill-shield:DIR``.

    Raises:
        FileNotFoundError, ValueError: as :func:`load_distill_policy`.
    """
    plain = load_distill_policy(params.run)
    if params.guard == "safe":
        return SafeDistillPolicy(plain.weights, plain.arrays, plain.sidecar)
    if params.guard == "shield":
        return ShieldedDistillPolicy(plain.weights, plain.arrays, plain.sidecar)
    return plain
