"""Train Stable-Baselines3 agents on the UAV penetration envs (api.md, ``baselines``).

``train_agent("ppo", env_id="UAVPenetration-v0", ...)`` (the fields of
:class:`~baselines.plan.TrainConfig`) trains on the native batched vector env
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

The work is split by idea: :mod:`baselines.hyperparameters` (tuned files, overrides, validation),
:mod:`baselines.plan` (:class:`~baselines.plan.TrainConfig` checked into a
:class:`~baselines.plan.TrainingPlan`) and :mod:`baselines.run` (training, evaluation, sidecar).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from baselines.hyperparameters import KNOWN_ALGORITHMS
from baselines.plan import TrainConfig, prepare_training
from baselines.run import TrainResult, run_training

__all__ = ["KNOWN_ALGORITHMS", "TrainConfig", "TrainResult", "train_agent"]


def train_agent(algo: str | TrainConfig = "ppo", /, **fields: Any) -> TrainResult:
    """Train an SB3 agent on a UAV penetration env and save it with its sidecars (api.md).

    Args:
        algo: the algorithm name, or a whole :class:`~baselines.plan.TrainConfig`.
        **fields: the other fields of :class:`~baselines.plan.TrainConfig` (``env_id``, ``scenario``,
            ``total_timesteps``, ``seed``, ``n_envs``, ``out``, ``hyperparams``, ...), or changes to
            the given config.

    Returns:
        The written files, the sidecar, the evaluation rows and the trained model.

    Raises:
        TypeError: an unknown field (with a did-you-mean).
        ValueError: invalid input (see :func:`~baselines.plan.prepare_training`), before any training.
        KeyboardInterrupt: after saving the partly trained model (sidecar ``interrupted: true``).
    """
    if isinstance(algo, TrainConfig):
        given = {f.name: getattr(algo, f.name) for f in dataclasses.fields(algo)}
        config = TrainConfig.of(**{**given, **fields})
    else:
        config = TrainConfig.of(algo=algo, **fields)
    return run_training(prepare_training(config))
