"""``uav-bench train``: train an SB3 agent from the command line (api.md; issue 6).

A plug-in command (:data:`baselines.plugin.TRAIN_COMMAND`, entry-point group
``uav_penetration.commands``): ``uav-bench`` builds the ``train`` sub-parser with
:func:`add_train_arguments` and hands the parsed flags to :func:`train_command`. Every input is
checked before training starts; problems exit with status 2 (``CLIError``), Ctrl-C saves the
partly trained model and exits with 130.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import Any

from uav_penetration_env.benchmark.commands.common import CLIError, resolve_scenarios
from uav_penetration_env.catalogue import SCENARIO_HELP

DEFAULT_MODELS = Path("leaderboards/models")


def add_train_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench train``."""
    parser.add_argument(
        "--algo", default="ppo", help="ppo, sac, td3 (tuned), a2c, ddpg (SB3 defaults); default: ppo"
    )
    parser.add_argument(
        "--env-id",
        dest="env_id",
        default="UAVPenetration-v0",
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
    parser.add_argument("--timesteps", type=int, default=200_000, help="environment steps (default: 200000)")
    parser.add_argument("--seed", type=int, default=0, help="training seed (default: 0)")
    parser.add_argument("--n-envs", dest="n_envs", type=int, default=8, help="batched sub-envs (default: 8)")
    parser.add_argument(
        "--out",
        help=f"model .zip (default: {DEFAULT_MODELS}/ALGO-SCENARIO-sSEED.zip); sidecars go beside it",
    )
    parser.add_argument("--hyperparams", help="YAML file overriding keys of baselines/hyperparams/ALGO.yaml")
    parser.add_argument(
        "--eval-freq",
        dest="eval_freq",
        type=int,
        default=10_000,
        help="evaluate every N environment steps (0: never; default: 10000)",
    )
    parser.add_argument(
        "--eval-episodes",
        dest="eval_episodes",
        type=int,
        default=10,
        help="episodes per evaluation (default: 10)",
    )
    parser.add_argument(
        "--checkpoint-freq",
        dest="checkpoint_freq",
        type=int,
        default=50_000,
        help="save a checkpoint every N environment steps (0: never; default: 50000)",
    )
    parser.add_argument(
        "--torch-threads", dest="torch_threads", type=int, default=1, help="torch threads (default: 1)"
    )
    parser.add_argument("--verbose", type=int, default=0, help="SB3 verbosity (default: 0)")
    parser.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")


def default_out(algo: str, env_id: str, scenario: str | None, seed: int) -> Path:
    """``leaderboards/models/ALGO-NAME-sSEED.zip``; NAME from the scenario flag or the id."""
    from baselines.train import DEFAULT_NAMES

    if scenario is None:
        name = DEFAULT_NAMES.get(env_id, env_id)
    else:
        name = Path(scenario).stem if scenario.endswith((".yaml", ".yml")) else scenario
    name = re.sub(r"[^A-Za-z0-9_.-]+", "-", name).strip("-")
    return DEFAULT_MODELS / f"{algo.lower()}-{name}-s{seed}.zip"


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
    from baselines.train import vector_class
    from uav_penetration_env.vector_env import UAVPenetrationRandomVectorEnv

    cls = vector_class(env_id)
    return cls is not None and issubclass(cls, UAVPenetrationRandomVectorEnv)


def train_command(args: argparse.Namespace) -> int:
    """Run ``uav-bench train``: validate, train with a progress bar, print where everything went.

    Returns:
        0 on success, 130 when interrupted (the partly trained model is saved).

    Raises:
        CLIError: invalid input (printed by ``uav-bench`` with exit status 2).
    """
    from baselines.train import prepare_training, run_training

    scenario = _scenario(args)
    difficulty = args.difficulty
    if args.scenario is not None and args.scenario.startswith("random:"):
        difficulty = None  # it shaped the procedural scenario; the fixed id takes none
    elif difficulty is not None and not _is_random(args.env_id):
        raise CLIError(
            f"--difficulty: applies to --env-id UAVPenetrationRandom-v0 or a --scenario random:SEED, "
            f"not to {args.scenario or args.env_id}"
        )
    out = Path(args.out) if args.out else default_out(args.algo, args.env_id, args.scenario, args.seed)
    try:
        plan = prepare_training(
            args.algo, args.env_id, scenario, args.timesteps, args.seed, args.n_envs, out,
            hyperparams=args.hyperparams, profile=args.profile, difficulty=difficulty,
            eval_freq=args.eval_freq, eval_episodes=args.eval_episodes,
            checkpoint_freq=args.checkpoint_freq, progress_bar=args.progress, verbose=args.verbose,
            torch_threads=args.torch_threads,
        )  # fmt: skip
    except (ValueError, FileNotFoundError) as error:
        raise CLIError(str(error)) from None
    where = f"scenario {args.scenario}" if args.scenario else args.env_id
    print(
        f"uav-bench train: {plan.algo} on {where} ({plan.env_kwargs.get('profile') or 'id'} profile), "
        f"{plan.total_timesteps} steps, seed {plan.seed}, {plan.n_envs} envs -> {plan.files.model}"
    )
    try:
        result = run_training(plan)
    except KeyboardInterrupt:
        print(
            f"\ninterrupted: the partly trained model is saved in {plan.files.model} (sidecar says interrupted)",
            file=sys.stderr,
        )
        return 130
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
    return 0
