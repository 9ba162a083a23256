"""``uav-bench train``: train an SB3 agent from the command line (api.md).

A plug-in command (:data:`baselines.plugin.TRAIN_COMMAND`, entry-point group
``uav_penetration.commands``): ``uav-bench`` builds the ``train`` sub-parser with
:func:`add_train_arguments` and hands the parsed flags to :func:`train_command`. Every input is
checked before training starts; problems exit with status 2 (``CLIError``), Ctrl-C saves the
partly trained model and exits with 130.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from baselines.plan import DEFAULT_MODELS, TrainConfig, default_model_path, vector_class
from uav_penetration_env.benchmark.commands.common import CLIError, path_argument, resolve_scenarios
from uav_penetration_env.catalogue import SCENARIO_HELP

DEFAULTS = TrainConfig()  # every default of the flags below is TrainConfig's


def _add_task_arguments(parser: argparse.ArgumentParser) -> None:
    """What to train: the algorithm, the env id, the scenario, its profile and difficulty."""
    parser.add_argument(
        "--algo",
        default=DEFAULTS.algo,
        help=f"ppo, sac, td3 (tuned), a2c, ddpg (SB3 defaults); default: {DEFAULTS.algo}",
    )
    parser.add_argument(
        "--env-id",
        dest="env_id",
        default=DEFAULTS.env_id,
        help="UAVPenetration-v0 (default), UAVPenetrationPaper-v0, UAVPenetrationRandom-v0, UAVPenetrationDEM-v0",
    )
    parser.add_argument(
        "--scenario",
        help=f"for the fixed ids: {SCENARIO_HELP}, one scenario (default: the id's own)",
    )
    parser.add_argument(
        "--profile", choices=["benchmark", "paper"], help="physics profile (default: the id's)"
    )
    parser.add_argument(
        "--difficulty",
        type=float,
        help="difficulty of the Random id or of a random:SEED scenario (default: 0.5)",
    )


def _add_budget_arguments(parser: argparse.ArgumentParser) -> None:
    """How much and where: steps, seed, sub-envs, the model file, hyper-parameter overrides."""
    parser.add_argument(
        "--timesteps",
        type=int,
        default=DEFAULTS.total_timesteps,
        help=f"environment steps (default: {DEFAULTS.total_timesteps})",
    )
    parser.add_argument(
        "--seed", type=int, default=DEFAULTS.seed, help=f"training seed (default: {DEFAULTS.seed})"
    )
    parser.add_argument(
        "--n-envs",
        dest="n_envs",
        type=int,
        default=DEFAULTS.n_envs,
        help=f"batched sub-envs (default: {DEFAULTS.n_envs})",
    )
    parser.add_argument(
        "--out",
        type=path_argument,
        help=f"model .zip (default: {DEFAULT_MODELS}/ALGO-SCENARIO-sSEED.zip); sidecars go beside it",
    )
    parser.add_argument("--hyperparams", help="YAML file overriding keys of baselines/hyperparams/ALGO.yaml")


def _add_checkpoint_arguments(parser: argparse.ArgumentParser) -> None:
    """Evaluation during training, checkpoints and resuming from them."""
    parser.add_argument(
        "--eval-freq",
        dest="eval_freq",
        type=int,
        default=DEFAULTS.eval_freq,
        help=f"evaluate every N environment steps (0: never; default: {DEFAULTS.eval_freq})",
    )
    parser.add_argument(
        "--eval-episodes",
        dest="eval_episodes",
        type=int,
        default=DEFAULTS.eval_episodes,
        help=f"episodes per evaluation (default: {DEFAULTS.eval_episodes})",
    )
    parser.add_argument(
        "--checkpoint-freq",
        dest="checkpoint_freq",
        type=int,
        default=DEFAULTS.checkpoint_freq,
        help=f"save a checkpoint every N environment steps (0: never; default: {DEFAULTS.checkpoint_freq})",
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="continue from the last checkpoint of --out when there is one (same configuration; "
        "--timesteps may be larger); else train from scratch",
    )


def _add_formulation_arguments(parser: argparse.ArgumentParser) -> None:
    """What the learner learns from and acts in (docs/rl.md §6); the defaults are today's."""
    parser.add_argument(
        "--shaping",
        choices=["none", "value"],
        default=DEFAULTS.shaping,
        help="value: add F = gamma*Phi(s') - Phi(s), Phi = -min(V, 50) of the value function, to the "
        "training reward only (the scored J is unchanged); default: none",
    )
    parser.add_argument(
        "--action",
        choices=["physical", "turn"],
        default=DEFAULTS.action,
        help="turn: choose one of the lattice's five turns (PPO, A2C; a turn in [-1, 1] for SAC, TD3), "
        "flown by the lattice's candidate control; default: physical (dv, dphi, dtheta)",
    )
    parser.add_argument(
        "--clearance",
        dest="clearance_m",
        type=float,
        default=DEFAULTS.clearance_m,
        help=f"terrain-following height of the turn controller [m] (default: {DEFAULTS.clearance_m:g}, lattice-c40's)",
    )
    parser.add_argument(
        "--features",
        choices=["none", "value"],
        default=DEFAULTS.features,
        help="value: append the six value inputs of the distilled planners to the observation; default: none",
    )
    parser.add_argument(
        "--init-from",
        metavar="RUN_FOLDER",
        default=None,
        help="start PPO's actor from this distilled turn network (uav-bench distill --head turn; needs "
        "--action turn and the network's --features and --clearance) and fine-tune it (docs/rl.md §6.5)",
    )
    parser.add_argument(
        "--critic-warmup",
        dest="critic_warmup_steps",
        metavar="STEPS",
        type=int,
        default=None,
        help="with --init-from: environment steps at the start in which only the critic learns (default: 20480)",
    )


def _add_runtime_arguments(parser: argparse.ArgumentParser) -> None:
    """How the run behaves: torch threads, SB3 verbosity, the progress bar."""
    parser.add_argument(
        "--torch-threads",
        dest="torch_threads",
        type=int,
        default=DEFAULTS.torch_threads,
        help=f"torch threads (default: {DEFAULTS.torch_threads})",
    )
    parser.add_argument(
        "--verbose", type=int, default=DEFAULTS.verbose, help=f"SB3 verbosity (default: {DEFAULTS.verbose})"
    )
    parser.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")


def add_train_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench train`` (defaults: :class:`~baselines.plan.TrainConfig`'s)."""
    # In this order: it is the order of the flags in ``uav-bench train --help``.
    _add_task_arguments(parser)
    _add_budget_arguments(parser)
    _add_checkpoint_arguments(parser)
    _add_formulation_arguments(parser)
    _add_runtime_arguments(parser)


def _scenario(args: argparse.Namespace) -> Any:
    if args.scenario is None:
        return None
    difficulty = 0.5 if args.difficulty is None else args.difficulty
    scenarios = resolve_scenarios([args.scenario], args.profile, None, difficulty, flag="--scenario")
    if len(scenarios) != 1:
        raise CLIError(
            f"--scenario: got {args.scenario!r} ({len(scenarios)} scenarios), expected one scenario"
        )
    return scenarios[0]


def _is_random(env_id: str) -> bool:
    from uav_penetration_env.vector_env import UAVPenetrationRandomVectorEnv

    cls = vector_class(env_id)
    return cls is not None and issubclass(cls, UAVPenetrationRandomVectorEnv)


def _train_config(args: argparse.Namespace) -> TrainConfig:
    """The :class:`TrainConfig` of ``uav-bench train``'s flags (the default model path from the scenario as typed).

    Raises:
        CLIError: ``--difficulty`` where it does not apply, or a scenario that does not resolve.
    """
    from baselines.formulation import formulation_for

    scenario = _scenario(args)
    difficulty = args.difficulty
    if args.scenario is not None and args.scenario.startswith("random:"):
        difficulty = None  # it shaped the procedural scenario; the fixed id takes none
    elif difficulty is not None and not _is_random(args.env_id):
        raise CLIError(
            f"--difficulty: applies to --env-id UAVPenetrationRandom-v0 or a --scenario random:SEED, "
            f"not to {args.scenario or args.env_id}"
        )
    # The default file is named after the scenario as typed (``paper``), not the resolved name.
    tag = ""
    try:
        tag = formulation_for(args.algo, args.shaping, args.action, args.clearance_m, args.features).tag
    except ValueError:
        pass  # prepare_training names the bad flag
    if args.init_from is not None:
        tag = f"{tag}-warm"
    out = Path(args.out) if args.out else default_model_path(args.algo, args.env_id, args.scenario, args.seed, tag)
    return TrainConfig(
        algo=args.algo, env_id=args.env_id, scenario=scenario, total_timesteps=args.timesteps, seed=args.seed,
        n_envs=args.n_envs, out=out, hyperparams=args.hyperparams, profile=args.profile, difficulty=difficulty,
        eval_freq=args.eval_freq, eval_episodes=args.eval_episodes, checkpoint_freq=args.checkpoint_freq,
        progress_bar=args.progress, verbose=args.verbose, torch_threads=args.torch_threads, resume=args.resume,
        shaping=args.shaping, action=args.action, clearance_m=args.clearance_m, features=args.features,
        init_from=args.init_from, critic_warmup_steps=args.critic_warmup_steps,
    )  # fmt: skip


def _print_trained(result: Any) -> None:
    """Where the model, its sidecar and its evaluations went, and the last evaluation."""
    files = result.files
    print(f"model: {files.model}")
    print(f"sidecar: {files.sidecar}")
    if result.sidecar["vecnormalize"]:
        print(f"observation statistics: {files.vecnormalize}")
    if result.evaluations:
        last = result.evaluations[-1]
        print(f"evaluations: {files.evaluations}")
        print(
            f"final evaluation ({last['episodes']} episodes, {last['timesteps']} steps): return "
            f"{last['mean_return']:.3f} ± {last['std_return']:.3f}, success {last['success_rate']:.0%}"
        )
    print(
        f"trained in {result.sidecar['wall_seconds']:.1f} s; evaluate with: uav-bench run --policies sb3:{files.model}"
    )


def train_command(args: argparse.Namespace) -> int:
    """Run ``uav-bench train``: validate, train with a progress bar, print where everything went.

    Returns:
        0 on success, 130 when interrupted (the partly trained model is saved; ``--resume``
        continues from the last checkpoint).

    Raises:
        CLIError: invalid input (printed by ``uav-bench`` with exit status 2).
    """
    from baselines.plan import prepare_training
    from baselines.run import run_training

    config = _train_config(args)
    try:
        plan = prepare_training(config)
    except (ValueError, FileNotFoundError) as error:
        raise CLIError(str(error)) from None
    where = f"scenario {args.scenario}" if args.scenario else args.env_id
    print(
        f"uav-bench train: {plan.algo} on {where} ({plan.env_kwargs.get('profile') or 'id'} profile), "
        f"{plan.total_timesteps} steps, seed {plan.seed}, {plan.n_envs} envs -> {plan.files.model}"
    )
    state = plan.resume_from
    if state is not None and state.finished and state.timesteps >= plan.total_timesteps:
        print(f"already trained ({state.timesteps} steps); nothing to do")
    elif state is not None:
        print(f"resuming from the checkpoint at {state.timesteps} steps ({state.model})")
    elif args.resume:
        print(f"no checkpoint to resume in {plan.files.checkpoints}; training from scratch")
    try:
        result = run_training(plan)
    except KeyboardInterrupt:
        print(
            f"\ninterrupted: the partly trained model is saved in {plan.files.model} (sidecar says interrupted); "
            "rerun with --resume to continue from the last checkpoint",
            file=sys.stderr,
        )
        return 130
    _print_trained(result)
    return 0
