"""Train Stable-Baselines3 agents on the UAV penetration envs (api.md, ``baselines``; issue 6).

``train_agent("ppo", env_id="UAVPenetration-v0", ...)`` trains on the native batched vector env
(:class:`baselines.vec_env.UAVPenetrationSB3VecEnv`, actions in [-1, 1]), with hyper-parameters
from ``baselines/hyperparams/<algo>.yaml``, and writes:

- ``<out>`` (``.zip``): the SB3 model;
- ``<stem>.vecnormalize.pkl``: observation statistics (when the hyper-parameters normalise);
- ``<stem>.json``: the sidecar (algorithm, env id and kwargs, profile, scenario hash, spaces,
  hyper-parameters with provenance, timesteps, seed, n_envs, wall time, versions, commit);
- ``<stem>.evaluations.csv``: the learning curve, a deterministic evaluation on fixed seeds every
  ``eval_freq`` environment steps;
- ``<stem>.checkpoints/``: a model (with its sidecars) every ``checkpoint_freq`` steps.

Reproducibility: ``set_random_seed(seed)`` seeds Python, numpy and torch; the training sub-envs'
reset seeds come from ``SeedSequence(seed)`` (STYLE §5); torch runs on one thread unless told
otherwise (thread-count-dependent reductions would break bit-for-bit repeats, and one thread is
also the fastest for these small MLPs on 2-core machines). Evaluations never touch the training
env or any generator the training uses, so the same seed gives the same curve whatever
``eval_freq`` is.
"""

from __future__ import annotations

import csv
import datetime as dt
import difflib
import inspect
import json
import os
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from baselines.artifacts import SIDECAR_FORMAT, ModelFiles, sha256_file

# Continuous-action SB3 algorithms (DQN needs a discrete action space, so it is not offered).
KNOWN_ALGORITHMS = {"a2c": "A2C", "ddpg": "DDPG", "ppo": "PPO", "sac": "SAC", "td3": "TD3"}
HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams"
# Keys of a hyper-parameter file that are not keywords of the algorithm's constructor.
SPECIAL_KEYS = ("provenance", "policy", "normalize", "policy_kwargs", "noise_type", "noise_std")
# Keywords train_agent sets itself; a hyper-parameter file must not.
RESERVED_KEYS = ("env", "seed", "verbose", "device", "_init_setup_model", "tensorboard_log")
VECNORMALIZE_KEYS = ("norm_obs", "norm_reward", "clip_obs", "clip_reward", "gamma", "epsilon")
ACTIVATIONS = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU", "gelu": "GELU"}
NOISE_TYPES = ("normal", "ornstein-uhlenbeck")
# DECISION: learning curves are measured on seeds 20000, 20001, ... for every training seed, so
# curves of different seeds are comparable; they stay clear of the held-out set (10000-10049,
# model.md §7c), which is kept for the final evaluation and must not steer training.
EVAL_SEED_START = 20_000
EVALUATION_COLUMNS = (
    "timesteps",
    "episodes",
    "mean_return",
    "std_return",
    "mean_cost",
    "mean_J",
    "mean_penalty",
    "success_rate",
    "mean_length",
    "wall_seconds",
)
DEFAULT_NAMES = {
    "UAVPenetration-v0": "paper",
    "UAVPenetrationPaper-v0": "paper-profile",
    "UAVPenetrationRandom-v0": "random",
    "UAVPenetrationDEM-v0": "dem",
}


# --- algorithms and hyper-parameters -----------------------------------------------------------------


def _did_you_mean(name: str, known: Sequence[str]) -> str:
    close = difflib.get_close_matches(name, list(known), n=3, cutoff=0.5)
    return f" — did you mean {', '.join(repr(c) for c in close)}?" if close else ""


def algorithm_class(name: str) -> type:
    """The SB3 class of an algorithm name (``ppo``, ``sac``, ``td3``, ``a2c``, ``ddpg``; any case).

    Raises:
        ValueError: an unknown name, with a did-you-mean and the known names.
    """
    key = str(name).lower()
    if key not in KNOWN_ALGORITHMS:
        raise ValueError(
            f"unknown algorithm {name!r}{_did_you_mean(key, KNOWN_ALGORITHMS)} known: {', '.join(KNOWN_ALGORITHMS)}"
        )
    try:
        import stable_baselines3
    except ImportError as error:  # pragma: no cover - depends on the installed extras
        raise ImportError(f"training needs the RL extra: pip install -e '.[rl]' ({error})") from error
    return getattr(stable_baselines3, KNOWN_ALGORITHMS[key])


def _read_yaml(path: Path, what: str) -> dict[str, Any]:
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except OSError as error:
        raise FileNotFoundError(f"{what}: cannot read {path} ({error.strerror})") from None
    except yaml.YAMLError as error:
        raise ValueError(f"{what}: {path} is not valid YAML ({error})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{what}: {path} must hold a mapping of hyper-parameter names to values")
    return data


def resolve_hyperparams(
    algo: str, overrides: Mapping[str, Any] | str | Path | None = None
) -> tuple[dict[str, Any], str]:
    """The tuned hyper-parameters of ``algo`` with ``overrides`` merged in, validated.

    Without a tuned file (e.g. ``a2c``) SB3's defaults are used, with a warning. ``overrides`` (a
    mapping or a YAML file with the same keys) replaces keys; ``policy_kwargs`` and ``normalize``
    mappings are merged key by key.

    Returns:
        The hyper-parameters and where they came from.

    Raises:
        ValueError: an unknown algorithm or key (with a did-you-mean), or a reserved key.
    """
    cls = algorithm_class(algo)
    key = str(algo).lower()
    path = HYPERPARAMS_DIR / f"{key}.yaml"
    if path.is_file():
        params = _read_yaml(path, "hyperparams")
        source = f"baselines/hyperparams/{key}.yaml"
    else:
        warnings.warn(
            f"no tuned hyper-parameters for {key!r} (baselines/hyperparams/{key}.yaml); using SB3's defaults",
            UserWarning,
            stacklevel=2,
        )
        params = {"provenance": f"SB3 {cls.__name__} defaults (no tuned file)", "policy": "MlpPolicy"}
        source = f"stable_baselines3.{cls.__name__} defaults"
    if overrides is not None:
        if isinstance(overrides, (str, Path)):
            source += f" + {overrides}"
            overrides = _read_yaml(Path(overrides), "hyperparams")
        else:
            source += " + overrides"
        for name, value in dict(overrides).items():
            current = params.get(name)
            if (
                name in ("policy_kwargs", "normalize")
                and isinstance(current, dict)
                and isinstance(value, dict)
            ):
                params[name] = {**current, **value}
            else:
                params[name] = value
    _validate_hyperparams(params, cls)
    return params, source


def _validate_hyperparams(params: Mapping[str, Any], cls: type) -> None:
    accepted = [p for p in inspect.signature(cls.__init__).parameters if p not in ("self", "policy")]
    for name in params:
        if name in RESERVED_KEYS:
            raise ValueError(
                f"hyperparams: {name!r} is set by train_agent (seed=, verbose=, device=), not here"
            )
        if name not in SPECIAL_KEYS and name not in accepted:
            allowed = sorted([*SPECIAL_KEYS, *(a for a in accepted if a not in RESERVED_KEYS)])
            raise ValueError(
                f"hyperparams: unknown key {name!r} for {cls.__name__}{_did_you_mean(name, allowed)} "
                f"allowed: {', '.join(allowed)}"
            )
    normalize = params.get("normalize", False)
    if not isinstance(normalize, (bool, dict)):
        raise ValueError(
            f"hyperparams: normalize: got {normalize!r}, expected false or a mapping of VecNormalize keywords"
        )
    for name in normalize if isinstance(normalize, dict) else ():
        if name not in VECNORMALIZE_KEYS:
            raise ValueError(
                f"hyperparams: normalize.{name}: unknown VecNormalize keyword{_did_you_mean(name, VECNORMALIZE_KEYS)} "
                f"allowed: {', '.join(VECNORMALIZE_KEYS)}"
            )
    noise = params.get("noise_type")
    if noise is not None:
        if "action_noise" not in accepted:
            raise ValueError(f"hyperparams: noise_type: {cls.__name__} takes no action noise")
        if noise not in NOISE_TYPES:
            raise ValueError(
                f"hyperparams: noise_type: got {noise!r}, expected one of {', '.join(NOISE_TYPES)}"
            )
    activation = (params.get("policy_kwargs") or {}).get("activation_fn")
    if activation is not None and activation not in ACTIVATIONS:
        raise ValueError(
            f"hyperparams: policy_kwargs.activation_fn: got {activation!r}, expected one of {', '.join(ACTIVATIONS)}"
        )


def normalize_kwargs(params: Mapping[str, Any]) -> dict[str, Any] | None:
    """VecNormalize keywords of the hyper-parameters (``None``: no normalisation)."""
    normalize = params.get("normalize", False)
    if normalize is False:
        return None
    kwargs = {"norm_obs": True, "norm_reward": False}
    if isinstance(normalize, dict):
        kwargs.update(normalize)
    if kwargs["norm_reward"] and "gamma" not in kwargs and "gamma" in params:
        kwargs["gamma"] = params["gamma"]  # the return statistics must use the agent's discount
    return kwargs


def algorithm_kwargs(params: Mapping[str, Any], action_dim: int) -> dict[str, Any]:
    """The constructor keywords of the SB3 algorithm: names resolved to torch classes and noise objects."""
    import torch

    kwargs = {k: v for k, v in params.items() if k not in SPECIAL_KEYS}
    if isinstance(kwargs.get("train_freq"), list):
        kwargs["train_freq"] = tuple(kwargs["train_freq"])  # YAML has no tuples; SB3 wants (n, unit)
    policy_kwargs = dict(params.get("policy_kwargs") or {})
    if "activation_fn" in policy_kwargs:
        policy_kwargs["activation_fn"] = getattr(torch.nn, ACTIVATIONS[policy_kwargs["activation_fn"]])
    if policy_kwargs:
        kwargs["policy_kwargs"] = policy_kwargs
    if params.get("noise_type") is not None:
        from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise

        noise = NormalActionNoise if params["noise_type"] == "normal" else OrnsteinUhlenbeckActionNoise
        sigma = float(params.get("noise_std", 0.1)) * np.ones(action_dim)
        kwargs["action_noise"] = noise(mean=np.zeros(action_dim), sigma=sigma)
    return kwargs


# --- the training plan --------------------------------------------------------------------------------


@dataclass(frozen=True)
class TrainingPlan:
    """A validated training run: everything :func:`run_training` needs (built by :func:`prepare_training`)."""

    algo: str
    env_id: str
    env_kwargs: dict[str, Any]
    total_timesteps: int
    seed: int
    n_envs: int
    files: ModelFiles
    hyperparams: dict[str, Any]
    hyperparams_source: str
    eval_freq: int
    eval_episodes: int
    checkpoint_freq: int
    progress_bar: bool
    verbose: int
    torch_threads: int | None
    device: str


@dataclass(frozen=True)
class TrainResult:
    """What a training run wrote, and the trained SB3 model."""

    files: ModelFiles
    sidecar: dict[str, Any]
    evaluations: list[dict[str, float]]
    model: Any = field(repr=False, default=None)


def _check_positive(name: str, value: Any, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name}: got {value!r}, expected an integer >= {minimum}")
    return int(value)


def vector_class(env_id: str) -> type | None:
    """The native vector env class of a UAV penetration id (``None`` for any other id)."""
    from gymnasium.envs.registration import load_env_creator, registry

    from uav_penetration_env.vector_env import UAVPenetrationVectorEnv

    entry = registry[env_id].vector_entry_point if env_id in registry else None
    creator = load_env_creator(entry) if isinstance(entry, str) else entry
    return creator if isinstance(creator, type) and issubclass(creator, UAVPenetrationVectorEnv) else None


def prepare_training(
    algo: str,
    env_id: str = "UAVPenetration-v0",
    scenario: Any = None,
    total_timesteps: int = 200_000,
    seed: int = 0,
    n_envs: int = 8,
    out: str | Path = "leaderboards/models/ppo-paper-s0.zip",
    *,
    hyperparams: Mapping[str, Any] | str | Path | None = None,
    profile: str | None = None,
    difficulty: float | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    eval_freq: int = 10_000,
    eval_episodes: int = 10,
    checkpoint_freq: int | None = 50_000,
    progress_bar: bool = False,
    verbose: int = 0,
    torch_threads: int | None = 1,
    device: str = "cpu",
) -> TrainingPlan:
    """Validate every input of :func:`train_agent` before anything slow happens (see there for the args).

    Raises:
        ValueError: an unknown algorithm, env id or hyper-parameter, a scenario for the Random id,
            ``difficulty`` for a fixed id, a non-positive count; ``ScenarioError`` (a ValueError)
            for a broken scenario.
        FileNotFoundError: a hyper-parameter file that does not exist.
    """
    from gymnasium.envs.registration import registry

    import uav_penetration_env
    from uav_penetration_env.build import build_scenario
    from uav_penetration_env.env import resolve_scenario
    from uav_penetration_env.vector_env import UAVPenetrationRandomVectorEnv

    params, source = resolve_hyperparams(algo, hyperparams)
    native_class = vector_class(env_id)
    if native_class is None:
        known = list(uav_penetration_env.ENV_IDS)
        raise ValueError(
            f"env_id: unknown id {env_id!r}{_did_you_mean(env_id, known)} known: {', '.join(known)}"
        )
    kwargs = dict(env_kwargs or {})
    if profile is not None:
        kwargs["profile"] = profile
    spec_kwargs = dict(registry[env_id].kwargs)
    if issubclass(native_class, UAVPenetrationRandomVectorEnv):
        if scenario is not None:
            raise ValueError(
                f"scenario: {env_id} draws procedural scenarios (set difficulty= instead); "
                "to train on one scenario use UAVPenetration-v0 with scenario="
            )
        kwargs["difficulty"] = 0.5 if difficulty is None else float(difficulty)
    else:
        if difficulty is not None:
            raise ValueError(
                f"difficulty: only UAVPenetrationRandom-v0 takes a difficulty, not {env_id} "
                "(for one procedural scenario pass scenario=random_scenario(rng, difficulty))"
            )
        resolved = resolve_scenario(
            scenario, spec_kwargs.get("default_scenario", "paper"), profile, spec_kwargs.get("id_profile")
        )
        build_scenario(resolved)  # terrain-dependent validation now, and the disk cache warmed
        # The resolved scenario carries its profile; passing both keeps the id's profile from
        # overriding an explicit one when the env resolves it again.
        kwargs.update(scenario=resolved, profile=resolved.profile)
    files = ModelFiles.of(out)
    try:
        files.model.parent.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ValueError(f"out: cannot create folder {files.model.parent} ({error.strerror})") from None
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed: got {seed!r}, expected an integer >= 0")
    return TrainingPlan(
        algo=str(algo).lower(),
        env_id=env_id,
        env_kwargs=kwargs,
        total_timesteps=_check_positive("total_timesteps", total_timesteps),
        seed=int(seed),
        n_envs=_check_positive("n_envs", n_envs),
        files=files,
        hyperparams=params,
        hyperparams_source=source,
        eval_freq=_check_positive("eval_freq", eval_freq, 0),
        eval_episodes=_check_positive("eval_episodes", eval_episodes),
        checkpoint_freq=_check_positive("checkpoint_freq", checkpoint_freq or 0, 0),
        progress_bar=bool(progress_bar),
        verbose=int(verbose),
        torch_threads=None if torch_threads is None else _check_positive("torch_threads", torch_threads),
        device=device,
    )


def train_agent(
    algo: str,
    env_id: str = "UAVPenetration-v0",
    scenario: Any = None,
    total_timesteps: int = 200_000,
    seed: int = 0,
    n_envs: int = 8,
    out: str | Path = "leaderboards/models/ppo-paper-s0.zip",
    *,
    hyperparams: Mapping[str, Any] | str | Path | None = None,
    profile: str | None = None,
    difficulty: float | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    eval_freq: int = 10_000,
    eval_episodes: int = 10,
    checkpoint_freq: int | None = 50_000,
    progress_bar: bool = False,
    verbose: int = 0,
    torch_threads: int | None = 1,
    device: str = "cpu",
) -> TrainResult:
    """Train an SB3 agent on a UAV penetration env and save it with its sidecars (api.md).

    Args:
        algo: ``ppo``, ``sac``, ``td3`` (tuned files) or ``a2c``, ``ddpg`` (SB3 defaults, with a warning).
        env_id: a registered id (``UAVPenetration-v0``, ``UAVPenetrationPaper-v0``,
            ``UAVPenetrationRandom-v0``, ``UAVPenetrationDEM-v0``).
        scenario: for the fixed ids, a Scenario, YAML path or mapping (``None``: the id's own).
        total_timesteps: environment steps to train for (SB3 finishes the rollout it is in).
        seed: seeds Python, numpy and torch, and (through a SeedSequence) the sub-envs' resets.
        n_envs: sub-envs stepped as one batch.
        out: the model's ``.zip`` path; sidecars go beside it.
        hyperparams: overrides of the tuned hyper-parameters (a mapping or a YAML file, same keys).
        profile: ``benchmark`` or ``paper`` (``None``: the id's / scenario's).
        difficulty: the Random id's difficulty (default 0.5).
        env_kwargs: other keywords of the id (e.g. ``pool_size`` of the Random id).
        eval_freq: evaluate every this many environment steps, and at the end (0: never).
        eval_episodes: episodes per evaluation, seeds ``20000 ...`` (deterministic policy).
        checkpoint_freq: save a checkpoint every this many environment steps (0/None: never).
        progress_bar: show a tqdm bar (steps, ETA, last evaluation).
        verbose: SB3's verbosity.
        torch_threads: torch intra-op threads while training (``None``: leave torch's setting).
        device: torch device (``cpu``: small MLPs run fastest there).

    Returns:
        The written files, the sidecar, the evaluation rows and the trained model.

    Raises:
        ValueError: invalid input (see :func:`prepare_training`), before any training.
        KeyboardInterrupt: after saving the partly trained model (sidecar ``interrupted: true``).
    """
    plan = prepare_training(
        algo, env_id, scenario, total_timesteps, seed, n_envs, out,
        hyperparams=hyperparams, profile=profile, difficulty=difficulty, env_kwargs=env_kwargs,
        eval_freq=eval_freq, eval_episodes=eval_episodes, checkpoint_freq=checkpoint_freq,
        progress_bar=progress_bar, verbose=verbose, torch_threads=torch_threads, device=device,
    )  # fmt: skip
    return run_training(plan)


# --- running it -------------------------------------------------------------------------------------


def train_env_seeds(seed: int, n_envs: int) -> list[int]:
    """Reset seeds of the training sub-envs: one child of ``SeedSequence(seed)`` each (STYLE §5)."""
    children = np.random.SeedSequence(seed).spawn(n_envs)
    return [int(child.generate_state(1, dtype=np.uint32)[0]) for child in children]


def evaluate_agent(model: Any, env: Any, seeds: Sequence[int], normalizer: Any = None) -> dict[str, float]:
    """One deterministic episode per sub-env of ``env`` (one seed each); summary statistics.

    Args:
        model: anything with SB3's ``predict(obs, deterministic=True)``.
        env: a :class:`~baselines.vec_env.UAVPenetrationSB3VecEnv` with ``len(seeds)`` sub-envs.
        seeds: the reset seed of each sub-env.
        normalizer: a ``VecNormalize`` whose statistics normalise the observations (not updated).

    Returns:
        ``episodes``, ``mean_return``, ``std_return``, ``mean_cost`` (= -mean_return, J + penalty),
        ``mean_J`` (sum of J(k), the harness's ``total_J``), ``mean_penalty``, ``success_rate``,
        ``mean_length``.
    """
    env.seed(list(seeds))
    obs = env.reset()
    n = env.num_envs
    total_j, penalty, length = np.zeros(n), np.zeros(n), np.zeros(n, dtype=np.int64)
    success = np.zeros(n, dtype=bool)
    active = np.ones(n, dtype=bool)
    while active.any():
        inputs = normalizer.normalize_obs(obs) if normalizer is not None else obs
        actions, _ = model.predict(inputs, deterministic=True)
        obs, _, dones, infos = env.step(actions)
        for i in np.flatnonzero(active):
            # Costs from the float64 infos: the float32 rewards SB3 sees would round the sums.
            total_j[i] += infos[i]["J"]
            penalty[i] += infos[i]["penalty"]
            length[i] += 1
            if dones[i]:
                success[i] = bool(infos[i]["reached_goal"])
        active &= ~dones
    returns = -(total_j + penalty)
    return {
        "episodes": int(n),
        "mean_return": float(returns.mean()),
        "std_return": float(returns.std()),
        "mean_cost": float(-returns.mean()),
        "mean_J": float(total_j.mean()),
        "mean_penalty": float(penalty.mean()),
        "success_rate": float(success.mean()),
        "mean_length": float(length.mean()),
    }


def _json_scenario(value: Any) -> Any:
    from uav_penetration_env.scenario import Scenario

    return value.to_dict() if isinstance(value, Scenario) else value


def describe_env(plan: TrainingPlan, venv: Any, seeds: Sequence[int]) -> dict[str, Any]:
    """The env part of the sidecar: JSON-able env kwargs, profile, scenario (hash or description), spaces."""
    described = venv.vector_env.describe_scenarios()
    env_kwargs = {k: _json_scenario(v) for k, v in plan.env_kwargs.items()}
    profile = described["profile"]
    if described["kind"] == "fixed":
        scenario = {"name": described["name"], "hash": described["hash"]}
    else:
        scenario = {
            "description": (
                f"{plan.env_id}: procedural scenarios (model.md §7c) at difficulty {described['difficulty']}; "
                f"each sub-env's first episode flies the scenario of its reset seed {list(seeds)}, later "
                f"episodes a pool of {described['pool_size']} scenarios from pool_seed {described['pool_seed']}"
            ),
            "difficulty": described["difficulty"],
            "pool_size": described["pool_size"],
            "pool_seed": described["pool_seed"],
        }
    physical = venv.physical_action_space
    return {
        "env_id": plan.env_id,
        "env_kwargs": env_kwargs,
        "profile": profile,
        "scenario": scenario,
        "observation_space": {
            "shape": list(venv.observation_space.shape),
            "low": float(np.min(venv.observation_space.low)),
            "high": float(np.max(venv.observation_space.high)),
            "dtype": str(venv.observation_space.dtype),
        },
        "action_space": {
            "shape": list(physical.shape),
            "low": physical.low.astype(float).tolist(),
            "high": physical.high.astype(float).tolist(),
            "units": ["m/s", "rad", "rad"],
            "policy_low": -1.0,
            "policy_high": 1.0,
        },
    }


def _write_json_atomic(path: Path, data: Mapping[str, Any]) -> None:
    # The sidecar is written last and atomically: its presence means the model beside it is whole.
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2, sort_keys=False, default=str) + "\n")
    os.replace(tmp, path)


class _Run:
    """The mutable state of one training run: envs, model, callbacks' shared bookkeeping."""

    def __init__(self, plan: TrainingPlan) -> None:
        from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

        from baselines.vec_env import UAVPenetrationSB3VecEnv

        self.plan = plan
        self.seeds = train_env_seeds(plan.seed, plan.n_envs)
        self.venv = UAVPenetrationSB3VecEnv(plan.env_id, plan.n_envs, **plan.env_kwargs)
        env: Any = VecMonitor(self.venv)  # episode returns/lengths for SB3's logger
        self.norm_kwargs = normalize_kwargs(plan.hyperparams)
        if self.norm_kwargs is not None:
            env = VecNormalize(env, **self.norm_kwargs)
        self.env = env
        self.eval_seeds = list(range(EVAL_SEED_START, EVAL_SEED_START + plan.eval_episodes))
        self.eval_env = (
            UAVPenetrationSB3VecEnv(plan.env_id, plan.eval_episodes, **plan.env_kwargs)
            if plan.eval_freq
            else None
        )
        self.evaluations: list[dict[str, float]] = []
        self.eval_seconds = 0.0
        self.started = time.perf_counter()
        self.model: Any = None
        self.env_description: dict[str, Any] | None = None

    def normalizer(self) -> Any:
        return self.model.get_vec_normalize_env()

    def evaluate(self) -> dict[str, float]:
        tick = time.perf_counter()
        row = {"timesteps": int(self.model.num_timesteps)}
        row.update(evaluate_agent(self.model, self.eval_env, self.eval_seeds, self.normalizer()))
        self.eval_seconds += time.perf_counter() - tick
        row["wall_seconds"] = time.perf_counter() - self.started
        self.evaluations.append(row)
        with self.plan.files.evaluations.open("a", newline="") as handle:
            csv.DictWriter(handle, EVALUATION_COLUMNS).writerow(row)
        return row

    def save(self, files: ModelFiles, wall_seconds: float, interrupted: bool = False) -> dict[str, Any]:
        """Write model, observation statistics and sidecar to ``files``; return the sidecar."""
        from uav_penetration_env.benchmark.provenance import git_commit, library_versions

        plan = self.plan
        files.model.parent.mkdir(parents=True, exist_ok=True)
        self.model.save(files.model)
        normalizer = self.normalizer()
        if normalizer is not None:
            normalizer.save(files.vecnormalize)
        if self.env_description is None:
            self.env_description = describe_env(plan, self.venv, self.seeds)
        sidecar = {
            "format": SIDECAR_FORMAT,
            "algorithm": plan.algo,
            "sb3_class": f"stable_baselines3.{type(self.model).__name__}",
            **self.env_description,
            "hyperparameters": plan.hyperparams,
            "hyperparameters_source": plan.hyperparams_source,
            "vecnormalize": files.vecnormalize.name if normalizer is not None else None,
            "model_sha256": sha256_file(files.model),
            "total_timesteps": plan.total_timesteps,
            "timesteps_done": int(self.model.num_timesteps),
            "seed": plan.seed,
            "n_envs": plan.n_envs,
            "train_env_seeds": self.seeds,
            "eval_seeds": self.eval_seeds if plan.eval_freq else [],
            "wall_seconds": wall_seconds,
            "eval_seconds": self.eval_seconds,
            "torch_threads": plan.torch_threads,
            "device": plan.device,
            "final_evaluation": self.evaluations[-1] if self.evaluations else None,
            "interrupted": interrupted,
            "versions": library_versions(),
            "commit": git_commit(),
            "created": dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat(),
        }
        _write_json_atomic(files.sidecar, sidecar)
        return sidecar


def _callbacks(run: _Run) -> list[Any]:
    """Periodic evaluation, checkpoints and the progress bar, as SB3 callbacks."""
    from stable_baselines3.common.callbacks import BaseCallback

    plan = run.plan

    class ProgressBar(BaseCallback):
        """A tqdm bar over environment steps (SB3's own bar needs rich, not a dependency here)."""

        def _on_training_start(self) -> None:
            from tqdm.auto import tqdm

            self.bar = tqdm(
                total=plan.total_timesteps, unit="step", desc=f"train {plan.algo}", smoothing=0.05
            )

        def _on_step(self) -> bool:
            self.bar.update(min(self.training_env.num_envs, plan.total_timesteps - self.bar.n))
            if run.evaluations:
                last = run.evaluations[-1]
                self.bar.set_postfix(
                    eval_return=f"{last['mean_return']:.2f}",
                    success=f"{last['success_rate']:.0%}",
                    refresh=False,
                )
            return True

        def _on_training_end(self) -> None:
            self.bar.close()

    class Periodic(BaseCallback):
        """Evaluate and checkpoint every ``eval_freq`` / ``checkpoint_freq`` environment steps.

        Both happen at the start of a rollout, i.e. right after the update that used every step
        counted so far (mid-rollout, PPO's policy would still be the one before its last update).
        """

        def _on_training_start(self) -> None:
            self.next_eval = plan.eval_freq
            self.next_checkpoint = plan.checkpoint_freq

        def _on_step(self) -> bool:
            return True

        def _on_rollout_start(self) -> None:
            steps = self.model.num_timesteps
            if plan.eval_freq and steps >= self.next_eval:
                run.evaluate()
                self.next_eval = (steps // plan.eval_freq + 1) * plan.eval_freq
            if plan.checkpoint_freq and steps >= self.next_checkpoint:
                stem = f"{plan.files.model.stem}-{steps}steps"
                run.save(
                    ModelFiles.of(plan.files.checkpoints / f"{stem}.zip"), time.perf_counter() - run.started
                )
                self.next_checkpoint = (steps // plan.checkpoint_freq + 1) * plan.checkpoint_freq

    callbacks: list[Any] = [Periodic()]
    if plan.progress_bar:
        callbacks.append(ProgressBar())
    return callbacks


def run_training(plan: TrainingPlan) -> TrainResult:
    """Train as ``plan`` says and write the model with its sidecars (see :func:`train_agent`)."""
    import torch
    from stable_baselines3.common.callbacks import CallbackList
    from stable_baselines3.common.utils import set_random_seed

    previous_threads = torch.get_num_threads()
    if plan.torch_threads is not None:
        torch.set_num_threads(plan.torch_threads)
    run: _Run | None = None
    try:
        set_random_seed(plan.seed)
        run = _Run(plan)
        cls = algorithm_class(plan.algo)
        kwargs = algorithm_kwargs(plan.hyperparams, int(np.prod(run.venv.action_space.shape)))
        run.model = cls(
            plan.hyperparams.get("policy", "MlpPolicy"),
            run.env,
            seed=plan.seed,
            verbose=plan.verbose,
            device=plan.device,
            **kwargs,
        )
        # The constructor seeded sub-env i with seed + i; the SeedSequence children replace that.
        run.env.seed(run.seeds)
        if plan.eval_freq:
            with plan.files.evaluations.open("w", newline="") as handle:
                csv.DictWriter(handle, EVALUATION_COLUMNS).writeheader()
        callback = CallbackList(_callbacks(run))
        run.started = time.perf_counter()
        try:
            run.model.learn(plan.total_timesteps, callback=callback, progress_bar=False)
        except KeyboardInterrupt:
            run.save(plan.files, time.perf_counter() - run.started, interrupted=True)
            raise
        if plan.eval_freq and (
            not run.evaluations or run.evaluations[-1]["timesteps"] != run.model.num_timesteps
        ):
            run.evaluate()
        wall = time.perf_counter() - run.started
        sidecar = run.save(plan.files, wall)
        return TrainResult(
            files=plan.files, sidecar=sidecar, evaluations=list(run.evaluations), model=run.model
        )
    finally:
        if run is not None:
            run.env.close()
            if run.eval_env is not None:
                run.eval_env.close()
        torch.set_num_threads(previous_threads)
