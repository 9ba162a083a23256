"""What to train: :class:`TrainConfig` (the user's settings) checked into a :class:`TrainingPlan`.

:func:`prepare_training` validates everything that can be checked before anything slow happens
(algorithm, hyper-parameters, env id, scenario, counts, the output folder), so ``train_agent``
and ``uav-bench train`` fail fast with a message naming the argument.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from baselines.artifacts import ModelFiles
from baselines.formulation import ACTIONS, FEATURES, SHAPINGS, Formulation, formulation_for
from baselines.hyperparameters import resolve_hyperparams
from baselines.resume import ResumeState, check_resumable, read_resume_state, resume_key
from baselines.warm_start import (
    CRITIC_WARMUP_STEPS,
    WarmStart,
    check_hyperparams,
    warm_start_for,
    warm_start_hyperparams,
)
from uav_penetration_env.benchmark.commands.common import path_argument
from uav_penetration_env.settings_fields import at_least, check_fields, one_of, setting
from uav_penetration_env.suggest import did_you_mean

DEFAULT_MODELS = Path("results/models")  # leaderboards/ holds only generated, published files
# DECISION: learning curves are measured on seeds 20000, 20001, ... for every training seed, so
# curves of different seeds are comparable; they stay clear of the held-out set (10000-10049,
# model.md §7c), which is kept for the final evaluation and must not steer training.
EVAL_SEED_START = 20_000
# The NAME in a default model path ALGO-NAME-sSEED.zip when no scenario is given.
DEFAULT_NAMES = {
    "UAVPenetration-v0": "paper",
    "UAVPenetrationPaper-v0": "paper-profile",
    "UAVPenetrationRandom-v0": "random",
    "UAVPenetrationDEM-v0": "dem",
}


@dataclass(frozen=True)
class TrainConfig:
    """Everything a training run is asked to do (``train_agent(**fields)``, ``uav-bench train``; api.md).

    Attributes:
        algo: ``ppo``, ``sac``, ``td3`` (tuned files) or ``a2c``, ``ddpg`` (SB3 defaults, with a warning).
        env_id: a registered id (``UAVPenetration-v0``, ``UAVPenetrationPaper-v0``,
            ``UAVPenetrationRandom-v0``, ``UAVPenetrationDEM-v0``).
        scenario: for the fixed ids, a catalogue name, Scenario, YAML path or mapping (``None``: the
            id's own).
        total_timesteps: environment steps to train for (SB3 finishes the rollout it is in).
        seed: seeds Python, numpy and torch, and (through a SeedSequence) the sub-envs' resets.
        n_envs: sub-envs stepped as one batch.
        out: the model's ``.zip`` path; sidecars go beside it (``None``:
            :func:`default_model_path`).
        hyperparams: overrides of the tuned hyper-parameters (a mapping or a YAML file, same keys).
        profile: ``benchmark`` or ``paper`` (``None``: the id's / scenario's).
        difficulty: the Random id's difficulty (default 0.5).
        env_kwargs: other keywords of the id (e.g. ``pool_size`` of the Random id).
        eval_freq: evaluate every this many environment steps, and at the end (0: never).
        eval_episodes: episodes per evaluation, seeds ``20000 ...`` (deterministic policy).
        eval_seeds: the evaluation episodes' reset seeds instead (``eval_episodes`` is then their
            number); :mod:`baselines.tune` evaluates on the tuning-validation seeds ``40000 ...``.
        on_evaluation: called with each evaluation row (a dict of :data:`~baselines.run.EVALUATION_COLUMNS`)
            as soon as it is written; an exception it raises (e.g. ``optuna.TrialPruned``) ends
            training and propagates (nothing more is saved).
        checkpoint_freq: save a checkpoint every this many environment steps, and at the end
            (0/None: never); each can be resumed from (docs/rl.md §2).
        resume: continue from the last checkpoint of the run writing ``out`` when there is one
            (its configuration must match: :func:`baselines.resume.check_resumable`); without
            one, train from scratch. ``False``: always from scratch (the old checkpoint is forgotten).
        progress_bar: show a progress bar (steps, ETA, last evaluation).
        verbose: SB3's verbosity.
        torch_threads: torch intra-op threads while training (``None``: leave torch's setting).
        device: torch device (``cpu``: small MLPs run fastest there).
        shaping: ``none`` or ``value``: potential-based shaping from the value function, in
            training only (:mod:`baselines.formulation`, docs/rl.md §6).
        action: ``physical`` (the env's box) or ``turn`` (a lattice turn flown by the candidate
            control; ``Discrete(5)`` for PPO and A2C, ``Box(1)`` otherwise).
        clearance_m: [m] the turn controller's terrain-following height (``action="turn"``).
        features: ``none`` or ``value``: the six value inputs after the observation.
        init_from: a distillation run folder whose ``turn`` network starts PPO's actor
            (:mod:`baselines.warm_start`, docs/rl.md §6.5; needs ``action="turn"`` and the
            network's features and clearance); ``None``: a fresh network.
        critic_warmup_steps: with ``init_from``, environment steps at the start in which only the
            critic learns (``None``: :data:`baselines.warm_start.CRITIC_WARMUP_STEPS`).
    """

    algo: str = setting("ppo", str, "ppo, sac, td3 (tuned), a2c, ddpg (SB3 defaults)")
    env_id: str = setting(
        "UAVPenetration-v0", str,
        "UAVPenetration-v0, UAVPenetrationPaper-v0, UAVPenetrationRandom-v0, UAVPenetrationDEM-v0",
    )  # fmt: skip
    scenario: Any = setting(
        None, object, "for the fixed ids: {scenario_help}, one scenario", default_text="the id's own"
    )
    total_timesteps: int = setting(200_000, int, "environment steps", flag="--timesteps", **at_least(1))
    seed: int = setting(0, int, "training seed", **at_least(0))
    n_envs: int = setting(8, int, "batched sub-envs", **at_least(1))
    out: str | Path | None = setting(
        None, object, "model .zip; sidecars go beside it", parse=path_argument,
        default_text=f"{DEFAULT_MODELS}/ALGO-SCENARIO-sSEED.zip",
    )  # fmt: skip
    hyperparams: Mapping[str, Any] | str | Path | None = setting(
        None, object, "YAML file overriding keys of baselines/hyperparams/ALGO.yaml", default_text=""
    )
    profile: str | None = setting(
        None, str, "physics profile", "one of benchmark, paper", allowed=("benchmark", "paper").__contains__,
        choices=("benchmark", "paper"), default_text="the id's",
    )  # fmt: skip
    difficulty: float | None = setting(
        None, float, "difficulty of the Random id or of a random:SEED scenario", "a number", default_text="0.5"
    )
    env_kwargs: Mapping[str, Any] | None = None
    eval_freq: int = setting(10_000, int, "evaluate every N environment steps (0: never)", **at_least(0))
    eval_episodes: int = setting(10, int, "episodes per evaluation", **at_least(1))
    eval_seeds: Sequence[int] | None = None
    on_evaluation: Callable[[dict[str, float]], None] | None = None
    checkpoint_freq: int | None = setting(
        50_000, int, "save a checkpoint every N environment steps (0: never)", optional=True, **at_least(0)
    )
    resume: bool = setting(
        False, bool, "continue from the last checkpoint of --out when there is one (same configuration; "
        "--timesteps may be larger); else train from scratch", "true or false", switch=True, default_text="",
    )  # fmt: skip
    progress_bar: bool = setting(
        False, bool, "no progress bar", "true or false", flag="--no-progress", switch=False, default_text=""
    )
    verbose: int = setting(0, int, "SB3 verbosity", "an integer")
    torch_threads: int | None = setting(1, int, "torch threads", optional=True, **at_least(1))
    device: str = "cpu"
    shaping: str = setting(
        "none", str, "value: add F = gamma*Phi(s') - Phi(s), Phi = -min(V, 50) of the value function, to the "
        "training reward only (the scored J is unchanged)", choices=SHAPINGS, **one_of(SHAPINGS),
    )  # fmt: skip
    action: str = setting(
        "physical", str, "turn: choose one of the lattice's five turns (PPO, A2C; a turn in [-1, 1] for SAC, "
        "TD3), flown by the lattice's candidate control; physical: (dv, dphi, dtheta)", choices=ACTIONS, **one_of(ACTIONS),
    )  # fmt: skip
    clearance_m: float = setting(
        40.0, float, "terrain-following height of the turn controller [m]", "a finite number of metres > 0",
        flag="--clearance", allowed=lambda metres: math.isfinite(metres) and metres > 0.0,
        default_text="40, lattice-c40's",
    )  # fmt: skip
    features: str = setting(
        "none", str, "value: append the six value inputs of the distilled planners to the observation",
        choices=FEATURES, **one_of(FEATURES),
    )  # fmt: skip
    init_from: str | Path | None = setting(
        None, object, "start PPO's actor from this distilled turn network (uav-bench distill --head turn; needs "
        "--action turn and the network's --features and --clearance) and fine-tune it (docs/rl.md §6.5)",
        metavar="RUN_FOLDER", default_text="",
    )  # fmt: skip
    critic_warmup_steps: int | None = setting(
        None, int, "with --init-from: environment steps at the start in which only the critic learns",
        flag="--critic-warmup", metavar="STEPS", default_text=str(CRITIC_WARMUP_STEPS), **at_least(0),
    )  # fmt: skip

    @classmethod
    def of(cls, **fields: Any) -> TrainConfig:
        """A config from keyword arguments.

        Raises:
            TypeError: an unknown field, with a did-you-mean and the known fields.
        """
        known = [f.name for f in dataclasses.fields(cls)]
        for name in fields:
            if name not in known:
                raise TypeError(
                    f"train_agent: unknown argument {name!r} — {did_you_mean(name, known)}known: {', '.join(known)}"
                )
        return cls(**fields)


@dataclass(frozen=True)
class TrainingPlan:
    """A validated training run: everything :func:`baselines.run.run_training` needs.

    Built by :func:`prepare_training` from a :class:`TrainConfig`: the hyper-parameters resolved,
    the scenario resolved into ``env_kwargs``, the files named, every count checked.
    """

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
    eval_seeds: tuple[int, ...]
    on_evaluation: Callable[[dict[str, float]], None] | None
    checkpoint_freq: int
    progress_bar: bool
    verbose: int
    torch_threads: int | None
    device: str
    resume_from: ResumeState | None = None
    formulation: Formulation = dataclasses.field(default_factory=Formulation)
    warm_start: WarmStart | None = None


def default_model_path(algo: str, env_id: str, scenario: Any, seed: int, tag: str = "") -> Path:
    """``results/models/ALGO-NAME[-TAG]-sSEED.zip``.

    NAME is the scenario's as the user gave it: a catalogue name or ``random:SEED`` as typed, a YAML
    path's stem, a Scenario's name, else the id's (:data:`DEFAULT_NAMES`). TAG names a training
    formulation other than today's (:attr:`baselines.formulation.Formulation.tag`, e.g.
    ``turn-value``), so its default file is not today's agent's.
    """
    if scenario is None:
        name = DEFAULT_NAMES.get(env_id, env_id)
    elif isinstance(scenario, (str, Path)):
        text = str(scenario)
        name = Path(text).stem if text.endswith((".yaml", ".yml")) else text
    else:
        found = getattr(scenario, "name", None) or (
            scenario.get("name") if isinstance(scenario, Mapping) else None
        )
        name = str(found or "custom")
    name = re.sub(r"[^A-Za-z0-9_.-]+", "-", name).strip("-")
    if tag:
        name = f"{name}-{tag}"
    return DEFAULT_MODELS / f"{algo.lower()}-{name}-s{seed}.zip"


def _eval_seeds(config: TrainConfig) -> tuple[int, ...]:
    """The evaluation seeds: ``config.eval_seeds``, else ``EVAL_SEED_START ...`` (``eval_episodes`` of them)."""
    if config.eval_seeds is None:
        return tuple(range(EVAL_SEED_START, EVAL_SEED_START + int(config.eval_episodes)))
    seeds = list(config.eval_seeds)
    if not seeds or any(isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s < 0 for s in seeds):
        raise ValueError(f"eval_seeds: got {config.eval_seeds!r}, expected a non-empty list of integers >= 0")
    return tuple(int(s) for s in seeds)


def vector_class(env_id: str) -> type | None:
    """The native vector env class of a UAV penetration id (``None`` for any other id)."""
    from gymnasium.envs.registration import load_env_creator, registry

    from uav_penetration_env.vector_env import UAVPenetrationVectorEnv

    entry = registry[env_id].vector_entry_point if env_id in registry else None
    creator = load_env_creator(entry) if isinstance(entry, str) else entry
    return creator if isinstance(creator, type) and issubclass(creator, UAVPenetrationVectorEnv) else None


def _native_class(env_id: str) -> type:
    """The native vector env class of ``env_id``; a ValueError with a did-you-mean for an unknown id."""
    import uav_penetration_env

    native_class = vector_class(env_id)
    if native_class is None:
        known = list(uav_penetration_env.ENV_IDS)
        raise ValueError(
            f"env_id: unknown id {env_id!r} — {did_you_mean(env_id, known)}known: {', '.join(known)}"
        )
    return native_class


def _env_kwargs(config: TrainConfig, native_class: type) -> dict[str, Any]:
    """The env's keywords: ``env_kwargs`` with the profile, and the difficulty (Random id) or the resolved scenario.

    Raises:
        ValueError: a scenario for the Random id, ``difficulty`` for a fixed id; ``ScenarioError``
            for a broken or unknown scenario.
    """
    from gymnasium.envs.registration import registry

    from uav_penetration_env.build import build_scenario
    from uav_penetration_env.env import resolve_scenario
    from uav_penetration_env.vector_env import UAVPenetrationRandomVectorEnv

    env_id, difficulty, profile = config.env_id, config.difficulty, config.profile
    kwargs = dict(config.env_kwargs or {})
    if profile is not None:
        kwargs["profile"] = profile
    spec_kwargs = dict(registry[env_id].kwargs)
    if issubclass(native_class, UAVPenetrationRandomVectorEnv):
        if config.scenario is not None:
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
        # Names resolve in the catalogue, as the env itself would resolve them.
        resolved = resolve_scenario(
            config.scenario,
            spec_kwargs.get("default_scenario", "paper"),
            profile,
            spec_kwargs.get("id_profile"),
        )
        build_scenario(resolved)  # terrain-dependent validation now, and the disk cache warmed
        # The resolved scenario carries its profile; passing both keeps the id's profile from
        # overriding an explicit one when the env resolves it again.
        kwargs.update(scenario=resolved, profile=resolved.profile)
    return kwargs


def _tag(config: TrainConfig) -> str:
    """The default file name's tag of ``config``'s formulation (checked later by :func:`_formulation`)."""
    try:
        tag = formulation_for(
            config.algo, config.shaping, config.action, config.clearance_m, config.features
        ).tag
    except ValueError:
        return ""
    return f"{tag}-warm" if config.init_from is not None else tag


def _model_files(config: TrainConfig) -> ModelFiles:
    """The run's files (``out``, else :func:`default_model_path`), their folder created.

    Raises:
        ValueError: the folder cannot be created (named as ``out``).
    """
    out = (
        config.out
        if config.out is not None
        else default_model_path(config.algo, config.env_id, config.scenario, config.seed, _tag(config))
    )
    files = ModelFiles.of(out)
    try:
        files.model.parent.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ValueError(f"out: cannot create folder {files.model.parent} ({error.strerror})") from None
    return files


def _with_resume(plan: TrainingPlan, config: TrainConfig) -> TrainingPlan:
    """``plan`` with the checkpoint to continue from, when ``config.resume`` and one matches.

    Raises:
        ValueError: the checkpoint is of another configuration or has more steps than ``total_timesteps``.
    """
    if not config.resume:
        return plan
    state = read_resume_state(plan.files)
    if state is not None:
        check_resumable(state, resume_key(plan), plan.total_timesteps)
    return dataclasses.replace(plan, resume_from=state)


def prepare_training(config: TrainConfig) -> TrainingPlan:
    """Validate every input of a training run before anything slow happens.

    Raises:
        ValueError: an unknown algorithm, env id or hyper-parameter, a scenario for the Random id,
            ``difficulty`` for a fixed id, a non-positive count; ``ScenarioError`` (a ValueError)
            for a broken or unknown scenario; with ``resume``, a checkpoint of another
            configuration or with more steps than ``total_timesteps``.
        FileNotFoundError: a hyper-parameter file that does not exist.
    """
    check_fields(config)  # each declared field against its domain, named by the field
    params, source = resolve_hyperparams(config.algo, config.hyperparams)
    native_class = _native_class(config.env_id)
    formulation = _formulation(config, native_class, params)
    warm = _warm_start(config, formulation)
    if warm is not None:
        params, source = resolve_hyperparams(
            config.algo, config.hyperparams, ("warm start (docs/rl.md §6.5)", warm_start_hyperparams(warm))
        )
        check_hyperparams(params, warm)
    kwargs = _env_kwargs(config, native_class)
    seed = int(config.seed)
    files = _model_files(config)
    torch_threads = config.torch_threads
    eval_seeds = _eval_seeds(config)
    plan = TrainingPlan(
        algo=str(config.algo).lower(),
        env_id=config.env_id,
        env_kwargs=kwargs,
        total_timesteps=int(config.total_timesteps),
        seed=seed,
        n_envs=int(config.n_envs),
        files=files,
        hyperparams=params,
        hyperparams_source=source,
        eval_freq=int(config.eval_freq),
        eval_episodes=len(eval_seeds),
        eval_seeds=eval_seeds,
        on_evaluation=config.on_evaluation,
        checkpoint_freq=int(config.checkpoint_freq or 0),
        progress_bar=bool(config.progress_bar),
        verbose=int(config.verbose),
        torch_threads=None if torch_threads is None else int(torch_threads),
        device=config.device,
        formulation=formulation,
        warm_start=warm,
    )
    return _with_resume(plan, config)


def _warm_start(config: TrainConfig, formulation: Formulation) -> WarmStart | None:
    """The checked warm start of ``config.init_from`` (``None`` without one).

    Raises:
        ValueError: ``critic_warmup_steps`` without ``init_from``, or what
            :func:`baselines.warm_start.warm_start_for` refuses.
        FileNotFoundError: no distilled network there.
    """
    if config.init_from is None:
        if config.critic_warmup_steps is not None:
            raise ValueError("critic_warmup_steps: given without init_from, expected a warm-started run")
        return None
    steps = CRITIC_WARMUP_STEPS if config.critic_warmup_steps is None else config.critic_warmup_steps
    return warm_start_for(config.init_from, config.algo, formulation, steps)


def _formulation(config: TrainConfig, native_class: type, params: Mapping[str, Any]) -> Formulation:
    """The run's checked :class:`~baselines.formulation.Formulation` (docs/rl.md §6).

    DECISION (docs/rl.md §6, one scenario): shaping, the turn action and the value inputs read the
    scenario's value function at the exact state, so they train on the fixed-scenario ids; the
    Random id, whose sub-envs fly a changing pool, is refused with them.

    Raises:
        ValueError: an unknown value; a formulation other than today's on the Random id; shaping
            with a discount outside (0, 1]; the turn action with generalised state-dependent
            exploration (``use_sde``, continuous boxes only).
    """
    from uav_penetration_env.vector_env import UAVPenetrationRandomVectorEnv

    formulation = formulation_for(
        config.algo, config.shaping, config.action, config.clearance_m, config.features
    )
    if formulation.is_default:
        return formulation
    if issubclass(native_class, UAVPenetrationRandomVectorEnv):
        raise ValueError(
            f"env_id: {config.env_id} flies a pool of procedural scenarios; shaping, the turn action and "
            "the value inputs need one scenario (use UAVPenetration-v0 with scenario=)"
        )
    gamma = float(params.get("gamma", 0.99))
    if formulation.shaping == "value" and not 0.0 < gamma <= 1.0:
        raise ValueError(f"gamma: got {gamma!r}, expected a discount in (0, 1] for value shaping")
    if formulation.action == "turn" and formulation.turn_space == "discrete" and params.get("use_sde"):
        raise ValueError("use_sde: got true, expected false with action='turn' (a Discrete action space)")
    return formulation
