"""What ``baselines`` adds to the harness, registered as entry points in ``pyproject.toml``.

- ``uav_penetration.policies``: ``sb3`` -> :data:`SB3_POLICY_KIND`, policies
  ``sb3[model=PATH.zip]`` (published ``sb3:PATH.zip``; a model without a sidecar, e.g.
  rl-baselines3-zoo's, takes ``vecnormalize=STATS.pkl``, docs/rl.md §5) and the hybrids
  ``PLANNER+sb3[model=PATH.zip]`` (an MPC planner warm-started by the agent, :mod:`baselines.hybrid`);
  ``distill`` -> :data:`DISTILL_POLICY_KIND`, policies ``distill[run=RUN_FOLDER,guard=GUARD]`` (a
  planner imitated by an MLP, :mod:`baselines.distill`), the guard ``none``, ``safe`` (a safety
  layer on its pitch) or ``shield`` (a verified fallback to the greedy floor); published
  ``distill:DIR``, ``distill-safe:DIR``, ``distill-shield:DIR`` (:mod:`baselines.policy_params`);
- ``uav_penetration.commands``: ``train`` -> :data:`TRAIN_COMMAND` (``uav-bench train``), ``tune``
  -> :data:`TUNE_COMMAND` (``uav-bench tune``, Optuna studies), ``distill`` -> :data:`DISTILL_COMMAND`
  (``uav-bench distill``) and ``plot.models`` -> :data:`LEARNING_CURVES` (``uav-bench plot --models DIR``).

The harness never imports ``baselines`` by name; it finds these objects through the entry
points and checks :data:`RL_EXTRA` before it uses the first two, so without the ``rl`` extra
``uav-bench --help`` still works and ``sb3:...`` or ``train`` is refused with one line saying what
to install. Learning curves read CSV and JSON files only and need no extra.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

from baselines.install import RL_INSTALL
from baselines.policy_params import (
    GUARD_PREFIXES,
    DistillParams,
    SB3Params,
    distill_label,
    read_sb3_argument,
    sb3_label,
)
from uav_penetration_env.benchmark.commands.common import Command, CommandExtension
from uav_penetration_env.benchmark.plugins import Needs, PolicyKind, argument_as


def later(module: str, name: str) -> Callable[..., Any]:
    """``module.name``, imported when first called: listing the commands imports neither the env nor torch."""

    def call(*args: Any, **kwargs: Any) -> Any:
        return getattr(importlib.import_module(module), name)(*args, **kwargs)

    call.__name__ = call.__qualname__ = name
    call.__doc__ = f"``{module}.{name}``, imported on first call."
    return call


add_train_arguments, train_command = (
    later("baselines.cli", "add_train_arguments"),
    later("baselines.cli", "train_command"),
)
add_curve_arguments, curves_command = (
    later("baselines.curves", "add_curve_arguments"),
    later("baselines.curves", "curves_command"),
)
add_tune_arguments, tune_command = (
    later("baselines.tune", "add_tune_arguments"),
    later("baselines.tune", "tune_command"),
)
load_hybrid = later("baselines.hybrid", "load_hybrid")
load_sb3_policy = later("baselines.policy", "load_sb3_policy")
add_distill_arguments = later("baselines.distill.cli", "add_distill_arguments")
distill_command = later("baselines.distill.cli", "distill_command")
load_guarded_distill_policy = later("baselines.distill.policy", "load_guarded_distill_policy")

RL_EXTRA = Needs(
    modules=("stable_baselines3", "torch"),
    install=f"the rl extra: {RL_INSTALL}",
)


SB3_POLICY_KIND = PolicyKind(
    name="sb3",
    params=SB3Params,
    load=load_sb3_policy,
    usage="sb3[model=PATH.zip,vecnormalize=STATS.pkl] (sb3:PATH.zip[?vecnormalize=STATS.pkl])",
    label=sb3_label,
    needs=RL_EXTRA,
    hybrid=load_hybrid,
    prefixes={"sb3": read_sb3_argument},
)
# A distilled network flies with NumPy alone (docs/rl.md §4): loading it needs no extra. The three
# published prefixes are its guards: the safety layer (§4.7) and the verified fallback (§4.8).
DISTILL_POLICY_KIND = PolicyKind(
    name="distill",
    params=DistillParams,
    load=load_guarded_distill_policy,
    usage="distill[run=RUN_FOLDER,guard=none|safe|shield] (distill:DIR, distill-safe:DIR, distill-shield:DIR)",
    label=distill_label,
    prefixes={prefix: argument_as("run", guard=guard) for guard, prefix in GUARD_PREFIXES.items()},
)
TRAIN_COMMAND = Command(
    name="train",
    help="train a Stable-Baselines3 agent (extra rl)",
    add_arguments=add_train_arguments,
    run=train_command,
    needs=RL_EXTRA,
)
# Tuning needs Optuna as well (in the rl extra).
TUNE_EXTRA = Needs(modules=("stable_baselines3", "torch", "optuna"), install=RL_EXTRA.install)
TUNE_COMMAND = Command(
    name="tune",
    help="tune an SB3 agent's hyper-parameters with Optuna (extra rl)",
    add_arguments=add_tune_arguments,
    run=tune_command,
    needs=TUNE_EXTRA,
)
DISTILL_COMMAND = Command(
    name="distill",
    help="imitate a planner with behaviour cloning + DAgger into a small MLP (extra rl)",
    add_arguments=add_distill_arguments,
    run=distill_command,
    needs=RL_EXTRA,
)
LEARNING_CURVES = CommandExtension(
    command="plot",
    add_arguments=add_curve_arguments,
    selected=lambda args: args.models is not None,
    run=curves_command,
)
