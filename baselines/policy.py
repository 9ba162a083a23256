"""A trained SB3 agent as a harness Policy (``reset(model, seed)``, ``act(observation, info)``; api.md).

``load_policy("leaderboards/rl/models/ppo-paper-zoo-s0.zip")`` reads the model's sidecar and hashes its
files; a model trained outside the project has no sidecar, and what its ``.zip`` records is read
instead, with its observation statistics from ``?vecnormalize=PATH`` or where the project and
rl-baselines3-zoo save them (:mod:`baselines.foreign`, docs/rl.md §5.2). Either way nothing heavy
is loaded: the evaluator pickles policies into worker processes, so the SB3
model (and torch) are loaded lazily in the process that acts, once per process and model file.
Loading runs pickle-based code from the model and statistics files (SB3's and VecNormalize's
formats): load only models you trust.
"""

from __future__ import annotations

import dataclasses
import io
import pickle
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium.wrappers.utils import rescale_box

from baselines.artifacts import (
    ModelFiles,
    UnverifiedArtifactWarning,
    read_sidecar,
    sha256_file,
    verify_artifacts,
)
from baselines.foreign import (
    ModelHeader,
    check_spaces,
    check_trusted,
    find_statistics,
    read_model_header,
    zoo_env_id,
)
from baselines.formulation import Formulation, learner_observation, turn_control
from baselines.install import RL_INSTALL
from baselines.policy_params import STATISTICS_OPTION, SB3Params
from baselines.policy_params import sb3_label as sb3_label  # re-exported: an agent's name in tables
from uav_penetration_env.env import action_space, observation_space
from uav_penetration_env.model import OBSERVATION_SIZE, PenetrationModel
from uav_penetration_env.types import FloatArray

# Per-process cache of loaded models: (model sha256, statistics sha256) -> (SB3 model, VecNormalize).
# Loky workers are reused across episodes, so each worker loads a model once.
_LOADED: dict[tuple[str, str | None], tuple[Any, Any]] = {}
# Placeholders for lr schedules when loading for inference only: avoids unpickling training-time
# closures, which can fail across Python/SB3 versions (rl-baselines3-zoo's enjoy.py does the same).
_INFERENCE_OBJECTS = {"learning_rate": 0.0, "lr_schedule": lambda _: 0.0, "clip_range": lambda _: 0.0}


class SB3Policy:
    """A Stable-Baselines3 model acting deterministically in physical units.

    Built by :func:`load_policy`. Pickles to its paths, hashes and sidecar only; the model is
    loaded on first use in each process (with torch on one thread there).

    Args:
        files: the model's files (``files.vecnormalize``: its observation statistics, wherever they are).
        sidecar: its parsed ``.json`` sidecar; ``None`` for a model trained outside the project.
        model_sha256: SHA-256 of the ``.zip`` bytes.
        vecnormalize_sha256: SHA-256 of the ``.vecnormalize.pkl`` bytes (``None``: not normalised).
        sidecar_sha256: SHA-256 of the ``.json`` bytes (``None`` without a sidecar).
        header: what the ``.zip`` records (:func:`baselines.foreign.read_model_header`); required
            without a sidecar, where it gives the algorithm and timesteps.
    """

    def __init__(
        self,
        files: ModelFiles,
        sidecar: dict[str, Any] | None,
        model_sha256: str,
        vecnormalize_sha256: str | None,
        sidecar_sha256: str | None,
        header: ModelHeader | None = None,
    ) -> None:
        if sidecar is not None:
            algorithm, timesteps = str(sidecar["algorithm"]), int(sidecar["timesteps_done"])
        elif header is not None:
            algorithm, timesteps = header.algorithm, header.num_timesteps
        else:
            raise ValueError("SB3Policy: a model without a sidecar needs its header (read_model_header)")
        self.files = files
        self.sidecar = sidecar
        self.model_sha256 = model_sha256
        self.vecnormalize_sha256 = vecnormalize_sha256
        self.sidecar_sha256 = sidecar_sha256
        self.header = header
        self.algorithm = algorithm
        self.train_timesteps = timesteps
        self.formulation = Formulation.from_json(sidecar.get("formulation") if sidecar is not None else None)
        self._agent: Any = None
        self._normalizer: Any = None
        self._to_physical: Any = None
        self._model: PenetrationModel | None = None

    def __repr__(self) -> str:
        return f"SB3Policy({str(self.files.model)!r}, algorithm={self.algorithm!r})"

    def __getstate__(self) -> dict[str, Any]:
        # Torch modules stay out of the pickle: workers load the model themselves (and cache it).
        state = self.__dict__.copy()
        state.update(_agent=None, _normalizer=None, _to_physical=None, _model=None)
        return state

    # --- what the harness reads ---------------------------------------------------------------------

    def config(self) -> dict[str, Any]:
        """Everything that determines behaviour (the store key): file hashes, not paths.

        A retrained model has new bytes, hence a new key; a moved or renamed file keeps its key.
        A model without a sidecar has ``sidecar_sha256`` ``None``; its key is the hashes of the
        ``.zip`` and of the statistics it was given.
        """
        config = {
            "kind": "sb3",
            "algorithm": self.algorithm,
            "deterministic": True,
            "model_sha256": self.model_sha256,
            "vecnormalize_sha256": self.vecnormalize_sha256,
            "sidecar_sha256": self.sidecar_sha256,
        }
        if not self.formulation.is_default:
            # Also in the sidecar's hash; named here so a results table can say how the agent acts.
            config["formulation"] = self.formulation.to_json()
        return config

    @property
    def metadata(self) -> dict[str, Any]:
        """Training budget copied into every episode row (``train_timesteps``, ``train_seconds``).

        Without a sidecar only ``train_timesteps`` is known (the ``.zip``'s ``num_timesteps``).
        """
        if self.sidecar is None:
            return {"train_timesteps": self.train_timesteps}
        return {
            "train_timesteps": self.train_timesteps,
            "train_seconds": float(self.sidecar["wall_seconds"]),
        }

    # --- the Policy protocol ------------------------------------------------------------------------

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None = None) -> None:
        """Check the model fits the env of ``model`` and prepare to act (the policy is deterministic).

        A different scenario is allowed (that is the generalisation experiment); a different
        observation shape, action box or profile is not.

        Raises:
            ValueError: naming what differs between the sidecar and the env.
        """
        del seed
        self.check_compatible(model)
        box = action_space(model.limits)
        ones = np.ones(box.shape, dtype=box.dtype)
        # The map RescaleAction(env, -1, 1) and the training adapter apply: bit-identical actions.
        _, _, self._to_physical = rescale_box(box, -ones, ones)
        self._model = model
        self._load()
        if self.formulation.features != "none":
            from baselines.distill.features import prepare

            # The value function is built here, once per scenario, not inside the first act(),
            # whose time the harness records as decision time (planning_seconds).
            prepare((self.formulation.features,), model)

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """The deterministic action for ``observation``, in physical units [dv, dphi, dtheta].

        A model trained with a formulation (docs/rl.md §6) reads the value inputs of
        ``info["state"]`` after the observation, and its turn action is flown as the same candidate
        control as in training (:func:`baselines.formulation.turn_control`).
        """
        if self._to_physical is None or self._model is None:
            raise RuntimeError("SB3Policy.act() before reset(model, seed)")
        agent, normalizer = self._load()
        formulation = self.formulation
        state = info.get("state") if not formulation.is_default else None
        if state is None and (formulation.features != "none" or formulation.action == "turn"):
            raise ValueError("info: got no 'state', expected the exact state for this model's formulation")
        inputs = (
            learner_observation(formulation, self._model, observation, state)
            if state is not None
            else observation
        )
        obs = np.asarray(inputs, dtype=np.float32).reshape(1, -1)
        if normalizer is not None:
            obs = normalizer.normalize_obs(obs)
        action, _ = agent.predict(obs, deterministic=True)
        if formulation.action == "turn":
            return turn_control(self._model, state, formulation, action)
        clipped = np.clip(np.asarray(action, dtype=np.float32).reshape(-1), -1.0, 1.0)
        return np.asarray(self._to_physical(clipped), dtype=np.float64)

    # --- checks and loading -------------------------------------------------------------------------

    def check_compatible(self, model: PenetrationModel) -> None:
        """Raise ``ValueError`` naming every difference between the sidecar and ``model``'s env.

        Without a sidecar only the spaces were checked (by :func:`load_policy`); nothing here
        depends on the env then.
        """
        sidecar, path = self.sidecar, self.files.sidecar
        if sidecar is None:
            return
        problems = []
        shape = tuple(sidecar["observation_space"]["shape"])
        if shape != (self.formulation.observation_size,):
            problems.append(
                f"observation shape {shape} (the env's is ({OBSERVATION_SIZE},), "
                f"{self.formulation.observation_size} with the formulation's inputs)"
            )
        box = action_space(model.limits)
        trained = sidecar["action_space"]
        if tuple(trained["shape"]) != box.shape or not (
            np.allclose(trained["low"], box.low, rtol=1e-6, atol=0.0)
            and np.allclose(trained["high"], box.high, rtol=1e-6, atol=0.0)
        ):
            problems.append(
                f"action bounds high={trained['high']} (the env's are high={box.high.astype(float).tolist()} "
                "[dv m/s, dphi rad, dtheta rad])"
            )
        profile = model.scenario.profile
        if sidecar["profile"] != profile:
            problems.append(
                f"profile {sidecar['profile']!r} (the env's scenario {model.scenario.name!r} uses {profile!r})"
            )
        if problems:
            raise ValueError(
                f"sb3 model {self.files.model} does not fit this env: its sidecar {path} says "
                + "; ".join(problems)
            )

    def _load(self) -> tuple[Any, Any]:
        """The SB3 model and observation normaliser, loaded once per process and verified by hash."""
        if self._agent is not None:
            return self._agent, self._normalizer
        key = (self.model_sha256, self.vecnormalize_sha256)
        if key not in _LOADED:
            _LOADED[key] = self._load_files()
        self._agent, self._normalizer = _LOADED[key]
        return self._agent, self._normalizer

    def _load_files(self) -> tuple[Any, Any]:
        try:
            import torch

            from baselines.hyperparameters import algorithm_class
        except ImportError as error:  # pragma: no cover - depends on the installed extras
            raise ImportError(f"sb3 policies need the RL extra: {RL_INSTALL} ({error})") from error
        # One intra-op thread: evaluation workers run one per core, and a 64x64 MLP gains nothing
        # from more.
        torch.set_num_threads(1)
        data = _read_verified(self.files.model, self.model_sha256)
        agent = algorithm_class(self.algorithm).load(
            io.BytesIO(data), device="cpu", custom_objects=_INFERENCE_OBJECTS
        )
        normalizer = None
        if self.vecnormalize_sha256 is not None:
            normalizer = pickle.loads(_read_verified(self.files.vecnormalize, self.vecnormalize_sha256))
        return agent, normalizer


def _read_verified(path: Path, sha256: str) -> bytes:
    import hashlib

    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: the file disappeared after load_policy()") from None
    if hashlib.sha256(data).hexdigest() != sha256:
        raise ValueError(
            f"{path} changed after load_policy() (its hash is part of the results-store key); load it again"
        )
    return data


class NoSidecarWarning(UnverifiedArtifactWarning):
    """A model without a ``.json`` sidecar is scored: the checks the sidecar allows could not run."""


def load_sb3_policy(params: SB3Params) -> SB3Policy:
    """The policy ``sb3[model=...,vecnormalize=...]`` (:func:`load_policy` with its parameters)."""
    return load_policy(params.model, vecnormalize=params.vecnormalize)


def load_policy(path: str | Path, vecnormalize: str | None = None) -> SB3Policy:
    """A harness Policy for the model saved at ``path`` (``.zip``; the suffix may be omitted).

    ``vecnormalize``: for a model without a sidecar, its observation statistics, ``STATS.pkl`` or
    ``none`` (raw observations); the policy ``sb3[model=PATH.zip,vecnormalize=STATS.pkl]``,
    published ``sb3:PATH.zip?vecnormalize=STATS.pkl``.

    DECISION (docs/rl.md §5.2, models without a sidecar): a ``.zip`` with no ``.json`` beside it
    (saved by SB3 itself or by rl-baselines3-zoo) is scored, with a :class:`NoSidecarWarning`,
    rather than refused: the algorithm, the spaces and the timesteps come from the ``.zip``, the
    observation statistics from the option or the project's and the zoo's file names
    (:func:`baselines.foreign.find_statistics`), and the spaces must be the env's observation box
    and ``Box(-1, 1, (3,))`` (refused in one line otherwise). What only a sidecar records cannot be
    checked: the physics profile, the physical action bounds, the training scenarios and
    hyper-parameters, and the hashes of the files as they were at training. The store key is the
    SHA-256 of the ``.zip`` and of the statistics, so it is as stable as a sidecar model's.

    Raises:
        FileNotFoundError: no model file; a sidecar that says the model uses observation
            statistics that are not there; without a sidecar, no statistics found (each naming
            the path).
        ValueError: a corrupt sidecar; a model file, observation statistics or hyper-parameters
            whose SHA-256 differs from the one the sidecar records (naming the file); a sidecar
            for another observation shape; ``vecnormalize`` given to a model with a sidecar; a
            ``.zip`` without a sidecar that is not an SB3 model of a known algorithm, or whose
            spaces are not the env's.

    Warns:
        UnverifiedArtifactWarning: a sidecar written before it recorded every file's hash
            (why: :func:`baselines.artifacts.verify_artifacts`, api.md §5).
        NoSidecarWarning: a model without a sidecar (one line naming what could not be checked).

    The ``.zip`` and ``.vecnormalize.pkl`` are pickles: load models from trusted sources only.
    """
    statistics_option = vecnormalize
    files = ModelFiles.of(str(path))
    if not files.model.is_file():
        raise FileNotFoundError(f"{files.model}: no such SB3 model file")
    if not files.sidecar.exists():
        return _load_without_sidecar(files, statistics_option)
    if statistics_option is not None:
        raise ValueError(
            f"{files.model}: {STATISTICS_OPTION}= is for models without a sidecar; {files.sidecar} names "
            "this model's observation statistics"
        )
    sidecar = read_sidecar(files.sidecar)
    model_sha256, vecnormalize_sha256 = verify_artifacts(files, sidecar)
    shape = tuple(sidecar["observation_space"].get("shape", ()))
    formulation = Formulation.from_json(sidecar.get("formulation"))
    expected = formulation.observation_size
    if shape != (expected,):
        inputs = "" if formulation.is_default else " with the sidecar's formulation's inputs"
        raise ValueError(
            f"{files.sidecar}: the model was trained on observations of shape {shape}, "
            f"this env's are ({expected},){inputs}"
        )
    return SB3Policy(files, sidecar, model_sha256, vecnormalize_sha256, sha256_file(files.sidecar))


def _load_without_sidecar(files: ModelFiles, statistics_option: str | None) -> SB3Policy:
    """A model trained outside the project: header, spaces and statistics (:func:`load_policy`)."""
    header = read_model_header(files.model)  # JSON only: nothing unpickled yet
    check_spaces(files.model, header, observation_space())
    statistics = find_statistics(files, statistics_option)
    check_trusted(files.model)  # SB3's load unpickles the .zip (and the statistics): only with the user's opt-in
    env_id = zoo_env_id(files)
    if statistics is not None:
        files = dataclasses.replace(files, vecnormalize=statistics)
    trained_on = f"an rl_zoo3 run on {env_id}" if env_id is not None else "an unknown env"
    seen = f"observation statistics {statistics}" if statistics is not None else "raw observations"
    if statistics_option is None and env_id is not None and files.model.stem != env_id:
        # rl_zoo3 rewrites ENV/vecnormalize.pkl at the end of training (docs/rl.md §5.3).
        seen += f" (the zoo's statistics at the end of training, those of {env_id}.zip)"
    warnings.warn(
        f"{files.model}: no sidecar {files.sidecar.name}; scored as a {header.algorithm} model from "
        f"{trained_on} with {seen}; unchecked: its physics profile, physical action bounds, training "
        "scenarios and hyper-parameters",
        NoSidecarWarning,
        stacklevel=3,
    )
    return SB3Policy(
        files,
        None,
        sha256_file(files.model),
        sha256_file(statistics) if statistics is not None else None,
        None,
        header=header,
    )
