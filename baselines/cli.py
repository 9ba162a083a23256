"""``uav-bench train``: train an SB3 agent from the command line (api.md).

A plug-in command (:data:`baselines.plugin.TRAIN_COMMAND`, entry-point group
``uav_penetration.commands``): ``uav-bench`` builds the ``train`` sub-parser with
:func:`add_train_arguments`, whose flags are generated from :class:`~baselines.plan.TrainConfig`'s
declared fields (:mod:`uav_penetration_env.settings_fields`), and hands the parsed flags to
:func:`train_command`. Every input is
checked before training starts; problems exit with status 2 (``CLIError``), Ctrl-C saves the
partly trained model and exits with 130.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import Any

from baselines.plan import TrainConfig, default_model_path, vector_class
from uav_penetration_env.benchmark.commands.common import CLIError, resolve_scenarios
from uav_penetration_env.catalogue import SCENARIO_HELP
from uav_penetration_env.settings_fields import SettingError, add_flags, given_values, parse_values

# DECISION (docs/rl.md §2): the command line shows a progress bar unless --no-progress, while
# train_agent() from Python shows none unless asked; every other default is TrainConfig's.
CLI_DEFAULTS = TrainConfig(progress_bar=True)


def add_train_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench train``: one per declared :class:`~baselines.plan.TrainConfig` field."""
    add_flags(parser, TrainConfig, fill={"scenario_help": SCENARIO_HELP})


def _scenario(config: TrainConfig) -> Any:
    """The one scenario of ``--scenario`` as typed (None: the id's own)."""
    if config.scenario is None:
        return None
    difficulty = 0.5 if config.difficulty is None else config.difficulty
    scenarios = resolve_scenarios([config.scenario], config.profile, None, difficulty, flag="--scenario")
    if len(scenarios) != 1:
        raise CLIError(
            f"--scenario: got {config.scenario!r} ({len(scenarios)} scenarios), expected one scenario"
        )
    return scenarios[0]


def _is_random(env_id: str) -> bool:
    from uav_penetration_env.vector_env import UAVPenetrationRandomVectorEnv

    cls = vector_class(env_id)
    return cls is not None and issubclass(cls, UAVPenetrationRandomVectorEnv)


def _train_config(args: argparse.Namespace) -> TrainConfig:
    """The :class:`TrainConfig` of ``uav-bench train``'s flags (the default model path from the scenario as typed).

    Raises:
        CLIError: a flag outside its domain (named by the field, as ``train_agent`` names it),
            ``--difficulty`` where it does not apply, or a scenario that does not resolve.
    """
    from baselines.formulation import formulation_for

    try:
        typed = parse_values(TrainConfig, given_values(args, TrainConfig), CLI_DEFAULTS, label="field")
    except SettingError as error:
        raise CLIError(str(error)) from None
    scenario = _scenario(typed)
    difficulty = typed.difficulty
    if typed.scenario is not None and typed.scenario.startswith("random:"):
        difficulty = None  # it shaped the procedural scenario; the fixed id takes none
    elif difficulty is not None and not _is_random(typed.env_id):
        raise CLIError(
            f"--difficulty: applies to --env-id UAVPenetrationRandom-v0 or a --scenario random:SEED, "
            f"not to {typed.scenario or typed.env_id}"
        )
    # The default file is named after the scenario as typed (``paper``), not the resolved name.
    tag = ""
    try:
        tag = formulation_for(typed.algo, typed.shaping, typed.action, typed.clearance_m, typed.features).tag
    except ValueError:
        pass  # prepare_training names the bad flag
    if typed.init_from is not None:
        tag = f"{tag}-warm"
    out = (
        Path(typed.out)
        if typed.out
        else default_model_path(typed.algo, typed.env_id, typed.scenario, typed.seed, tag)
    )
    return dataclasses.replace(typed, scenario=scenario, difficulty=difficulty, out=out)


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
    where = f"scenario {args.scenario}" if args.scenario else plan.env_id
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
