"""Tune the SB3 baselines with Optuna: the ``uav-bench tune`` command (docs/rl.md §1).

A study samples hyper-parameters (search spaces after rl-baselines3-zoo's ``hyperparams_opt.py``
samplers, adapted below), trains each trial for a fixed number of environment steps with
:func:`baselines.train_agent`, reports its periodic evaluations to a median pruner and scores it
by its last evaluation. The study lives in an SQLite storage, so it resumes after an interruption;
after every finished trial the best hyper-parameters are written as a YAML file that ``uav-bench
train --hyperparams`` loads, with a provenance block, and the trials as CSV and Markdown.

This module is the command (its flags and :func:`tune_command`); the work is done in
:mod:`baselines.tuning`, split by job, whose public names are importable from here too.

```python
from baselines.tune import TuneConfig, run_study
result = run_study(TuneConfig(algo="ppo", regime="paper", trials=30, timesteps=150_000))
print(result.best_value, result.files.best_yaml)
```

Regimes (seeds: HELPERS.md's project-wide ranges):

- ``paper``: trains and evaluates on the paper scenario (``UAVPenetration-v0``, its only
  scenario, as in the paper). Its start is fixed, so a deterministic policy flies the very same
  episode for every evaluation seed: one episode per evaluation measures it exactly.
- ``random``: trains on ``UAVPenetrationRandom-v0`` at difficulty 0.5 (the id's own pool, seeds
  >= 2**32) and evaluates on the tuning-validation scenarios, seeds 40000-40049 at difficulty 0.5,
  disjoint from the held-out set (10000-10049), the suite (30000-30219) and the learning-curve
  seeds (20000+).
"""

from __future__ import annotations

import argparse
import sys

from baselines.tuning.config import (
    DEFAULT_OUT,
    DEFAULT_TIMESTEPS,
    DEFAULT_TRIALS,
    RANDOM_DIFFICULTY,
    REGIMES,
    TUNED_ALGORITHMS,
    VALIDATION_SEED_START,
    VALIDATION_SEEDS,
    StudyFiles,
    TuneConfig,
    TunePlan,
    prepare_tuning,
    sqlite_path,
)
from baselines.tuning.objective import make_objective
from baselines.tuning.outputs import best_yaml_text, write_study_files
from baselines.tuning.space import SAMPLERS, sample_ppo, sample_sac, sample_td3
from baselines.tuning.study import StudyBusy, TuneResult, open_study, run_study, study_lock
from baselines.tuning.trials import STATES_COUNTED, trial_rows

__all__ = [
    "DEFAULT_OUT",
    "DEFAULT_TIMESTEPS",
    "DEFAULT_TRIALS",
    "RANDOM_DIFFICULTY",
    "REGIMES",
    "SAMPLERS",
    "STATES_COUNTED",
    "TUNED_ALGORITHMS",
    "VALIDATION_SEEDS",
    "VALIDATION_SEED_START",
    "StudyBusy",
    "StudyFiles",
    "TuneConfig",
    "TunePlan",
    "TuneResult",
    "add_tune_arguments",
    "best_yaml_text",
    "make_objective",
    "open_study",
    "prepare_tuning",
    "run_study",
    "sample_ppo",
    "sample_sac",
    "sample_td3",
    "sqlite_path",
    "study_lock",
    "trial_rows",
    "tune_command",
    "write_study_files",
]


def _per_algo(values: dict[str, int]) -> str:
    """``ppo 30, sac 15, td3 15``: a per-algorithm default as help text."""
    return ", ".join(f"{algo} {value:,}" for algo, value in values.items())


def add_tune_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench tune`` (defaults: :class:`TuneConfig`'s)."""
    from uav_penetration_env.benchmark.commands.common import path_argument

    parser.add_argument("--algo", default="ppo", help="ppo, sac or td3 (default: ppo)")
    parser.add_argument("--regime", default="paper", help="paper or random (default: paper)")
    parser.add_argument(
        "--trials", type=int, help=f"COMPLETE + PRUNED trials wanted (default: {_per_algo(DEFAULT_TRIALS)})"
    )
    parser.add_argument(
        "--timesteps", type=int, help=f"environment steps per trial (default: {_per_algo(DEFAULT_TIMESTEPS)})"
    )
    parser.add_argument(
        "--eval-every", dest="eval_every", type=int, help="evaluate every N steps (default: timesteps / 5)"
    )
    parser.add_argument(
        "--eval-episodes",
        dest="eval_episodes",
        type=int,
        help="episodes per evaluation (default: 1 for paper, 50 for random)",
    )
    parser.add_argument("--storage", help="sqlite:///PATH (default: sqlite:///OUT/study.sqlite)")
    parser.add_argument("--study-name", dest="study_name", help="default: ALGO-REGIME")
    parser.add_argument(
        "--n-envs", dest="n_envs", type=int, default=8, help="sub-envs per trial (default: 8)"
    )
    parser.add_argument("--seed", type=int, default=0, help="training and sampler seed (default: 0)")
    parser.add_argument(
        "--out", type=path_argument, help=f"output folder (default: {DEFAULT_OUT}/ALGO-REGIME)"
    )
    parser.add_argument(
        "--torch-threads", dest="torch_threads", type=int, default=1, help="torch threads (default: 1)"
    )


def tune_command(args: argparse.Namespace) -> int:
    """Run ``uav-bench tune``.

    Returns:
        0 when the study has its trials, 130 when interrupted (the storage stays consistent; run
        the same command again to continue).

    Raises:
        CLIError: invalid input or a study in use by another process (exit status 2).
    """
    from uav_penetration_env.benchmark.commands.common import CLIError

    config = TuneConfig(
        algo=args.algo, regime=args.regime, trials=args.trials, timesteps=args.timesteps,
        eval_every=args.eval_every, eval_episodes=args.eval_episodes, storage=args.storage,
        study_name=args.study_name, n_envs=args.n_envs, seed=args.seed, out=args.out,
        torch_threads=args.torch_threads,
    )  # fmt: skip
    try:
        plan = prepare_tuning(config)
    except ValueError as error:
        name, _, rest = str(error).partition(":")
        raise CLIError(f"--{name.replace('_', '-')}:{rest}") from None
    print(
        f"uav-bench tune: {plan.algo} on the {plan.regime} regime, study {plan.study_name} in "
        f"{plan.files.storage}: {plan.trials} trials x {plan.timesteps} steps, evaluation every "
        f"{plan.eval_every} steps on {len(plan.eval_seeds)} episode(s)",
        flush=True,
    )
    try:
        result = run_study(plan)
    except KeyboardInterrupt:
        print(
            f"\ninterrupted: the study in {plan.files.storage} is consistent (the cut trial is marked FAIL "
            "and will be run again); rerun the same command to continue",
            file=sys.stderr,
        )
        return 130
    except (ValueError, StudyBusy) as error:
        raise CLIError(str(error)) from None
    print(f"{result.complete} complete, {result.pruned} pruned, {result.failed} failed/interrupted")
    if result.best_trial is not None:
        print(f"best: trial {result.best_trial}, cost {result.best_value:.4f}")
        print(f"hyper-parameters: {plan.files.best_yaml}")
    print(f"trials: {plan.files.trials_csv} and {plan.files.summary_md}")
    return 0
