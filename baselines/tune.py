"""Tuning the SB3 baselines with Optuna: ``uav-bench tune`` (docs/rl.md §1; issue 15).

A study samples hyper-parameters (search spaces after rl-baselines3-zoo's ``hyperparams_opt.py``
samplers, adapted below), trains each trial for a fixed number of environment steps with
:func:`baselines.train_agent`, reports its periodic evaluations to a median pruner and scores it
by its last evaluation. The study lives in an SQLite storage, so it resumes after an interruption;
after every finished trial the best hyper-parameters are written as a YAML file that ``uav-bench
train --hyperparams`` loads, with a provenance block, and the trials as CSV and Markdown.

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
import contextlib
import csv
import datetime as dt
import gc
import io
import json
import math
import sys
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from uav_penetration_env.atomic import write_text_atomic
from uav_penetration_env.suggest import did_you_mean

TUNED_ALGORITHMS = ("ppo", "sac", "td3")
REGIMES = ("paper", "random")
# Tuning-validation seeds of the Random regime (HELPERS.md): 40000-40049, difficulty 0.5.
VALIDATION_SEED_START = 40_000
VALIDATION_SEEDS = 50
RANDOM_DIFFICULTY = 0.5
DEFAULT_OUT = Path("results/rl/tune")
# DECISION (docs/rl.md §1.3): steps per trial, from benchmarks/bench_rl.py (CPU seconds, one torch
# thread, 8 sub-envs): PPO trains at ~1300 steps per CPU-second with the untuned set (64x64, 10
# epochs), ~400 at the space's slowest corner (256x256, 20 epochs, batch 64) and ~2900 at its
# fastest, so a 200 k-step trial takes ~2.5 CPU-minutes at typical sizes (1-8 at the corners):
# well past the ~60 k steps PPO needs to reach the goal. SAC and TD3 spend their time in gradient
# steps, so their trials are 50 k steps (see the measured figures in docs/rl.md §1.3).
DEFAULT_TIMESTEPS = {"ppo": 150_000, "sac": 50_000, "td3": 50_000}
DEFAULT_TRIALS = {"ppo": 30, "sac": 15, "td3": 15}
STATES_COUNTED = ("COMPLETE", "PRUNED")


# --- search spaces -------------------------------------------------------------------------------


def sample_ppo(trial: Any) -> dict[str, Any]:
    """PPO's search space, after rl-baselines3-zoo's ``sample_ppo_params``.

    Returns overrides of ``baselines/hyperparams/ppo.yaml`` in its format (``policy_kwargs`` with the
    activation by name). DECISION (docs/rl.md §1.2): the zoo's space with three adaptations. ``n_steps``
    is per sub-env here (8 by default), so its choices stop at 1024 (8192 transitions per update) and
    start at 64; ``batch_size`` 64-512. ``log_std_init`` (the initial exploration std, -3..0) is sampled,
    because the untuned set's hand-picked -1 was the one setting that changed whether PPO learned at all
    (hyperparams/ppo.yaml's provenance). ``norm_reward`` is sampled (value scale is one of issue 15's
    suspects for the high corridor); observations are always normalised.
    """
    one_minus_gamma = trial.suggest_float("one_minus_gamma", 1e-4, 0.03, log=True)
    one_minus_gae_lambda = trial.suggest_float("one_minus_gae_lambda", 1e-4, 0.1, log=True)
    net = trial.suggest_categorical("net_arch", ["tiny", "small", "medium"])
    width = {"tiny": [64], "small": [64, 64], "medium": [256, 256]}[net]
    return {
        "n_steps": trial.suggest_categorical("n_steps", [64, 128, 256, 512, 1024]),
        "batch_size": trial.suggest_categorical("batch_size", [64, 128, 256, 512]),
        "gamma": 1.0 - one_minus_gamma,
        "gae_lambda": 1.0 - one_minus_gae_lambda,
        "learning_rate": trial.suggest_float("learning_rate", 1e-5, 2e-3, log=True),
        "ent_coef": trial.suggest_float("ent_coef", 1e-8, 0.1, log=True),
        "clip_range": trial.suggest_categorical("clip_range", [0.1, 0.2, 0.3, 0.4]),
        "n_epochs": trial.suggest_categorical("n_epochs", [1, 5, 10, 20]),
        "max_grad_norm": trial.suggest_float("max_grad_norm", 0.3, 2.0),
        "normalize": {"norm_reward": trial.suggest_categorical("norm_reward", [False, True])},
        "policy_kwargs": {
            "net_arch": {"pi": width, "vf": list(width)},
            "activation_fn": trial.suggest_categorical("activation_fn", ["tanh", "relu"]),
            "log_std_init": trial.suggest_float("log_std_init", -3.0, 0.0),
        },
    }


def _off_policy_common(trial: Any) -> dict[str, Any]:
    """The keys SAC and TD3 share, after the zoo's ``sample_sac_params`` / ``sample_td3_params``.

    DECISION (docs/rl.md §1.2): the zoo's gamma, learning-rate, batch, tau and network choices;
    three changes. ``train_freq`` counts vector steps of 8 transitions here, so its choices are
    1-16, and the update ratio is sampled on its own as ``updates_per_step`` (gradient steps per
    vector step: 1, 2, 4, i.e. 1/8 to 1/2 update per transition; the zoo ties gradient_steps to
    train_freq with one env, a ratio of 1). A ratio of 1 is left out: SAC then trains at ~50 steps
    per CPU-second (benchmarks/bench_rl.py), so a 50 k-step trial would take ~16 CPU-minutes and
    the ~20-minute final runs would see only ~60 k steps; a study at a fixed step budget would
    favour it for its sample efficiency, which the CPU-budgeted runs cannot afford.
    ``learning_starts`` is 1000-10000 (a trial is 50 k steps; the zoo's 20000 would spend 40 % of
    it acting at random). ``buffer_size`` is not tuned (300 000, the untuned set's): a trial never
    fills it, so a study cannot tell the choices apart.
    """
    gamma = trial.suggest_categorical("gamma", [0.95, 0.98, 0.99, 0.995, 0.999])
    train_freq = trial.suggest_categorical("train_freq", [1, 2, 4, 8, 16])
    updates = trial.suggest_categorical("updates_per_step", [1, 2, 4])
    net = trial.suggest_categorical("net_arch", ["small", "medium", "big"])
    return {
        "gamma": gamma,
        "learning_rate": trial.suggest_float("learning_rate", 1e-5, 3e-3, log=True),
        "batch_size": trial.suggest_categorical("batch_size", [64, 128, 256, 512]),
        "learning_starts": trial.suggest_categorical("learning_starts", [1000, 5000, 10000]),
        "tau": trial.suggest_categorical("tau", [0.001, 0.005, 0.01, 0.02, 0.05]),
        "train_freq": train_freq,
        "gradient_steps": train_freq * updates,
        "policy_kwargs": {"net_arch": {"small": [64, 64], "medium": [256, 256], "big": [400, 300]}[net]},
    }


def sample_sac(trial: Any) -> dict[str, Any]:
    """SAC's search space (:func:`_off_policy_common`; entropy coefficient ``auto``, as in the zoo)."""
    return {**_off_policy_common(trial), "ent_coef": "auto"}


def sample_td3(trial: Any) -> dict[str, Any]:
    """TD3's search space (:func:`_off_policy_common` plus the zoo's action noise: type and std).

    DECISION (docs/rl.md §1.2): the zoo samples the noise std in [0, 1]; here 0.05-0.5 (log), as a std of
    1 in the [-1, 1] box saturates most actions, and no noise at all is not offered (TD3 then explores
    only through its initial random steps).
    """
    return {
        **_off_policy_common(trial),
        "noise_type": trial.suggest_categorical("noise_type", ["normal", "ornstein-uhlenbeck"]),
        "noise_std": trial.suggest_float("noise_std", 0.05, 0.5, log=True),
    }


SAMPLERS: dict[str, Callable[[Any], dict[str, Any]]] = {
    "ppo": sample_ppo,
    "sac": sample_sac,
    "td3": sample_td3,
}


# --- configuration -------------------------------------------------------------------------------


@dataclass(frozen=True)
class TuneConfig:
    """One tuning study (``uav-bench tune``; docs/rl.md §1).

    Attributes:
        algo: ``ppo``, ``sac`` or ``td3``.
        regime: ``paper`` (the paper scenario) or ``random`` (Random id at difficulty 0.5).
        trials: finished trials wanted (COMPLETE + PRUNED); a resumed study runs only the rest.
        timesteps: environment steps per trial (``None``: :data:`DEFAULT_TIMESTEPS`).
        eval_every: evaluate (and report to the pruner) every this many steps (``None``: a fifth of
            ``timesteps``).
        eval_episodes: deterministic episodes per evaluation (``None``: 1 for ``paper``, whose
            start is fixed, 50 for ``random``, the whole validation set 40000-40049).
        storage: an ``sqlite:///PATH`` URL (``None``: ``sqlite:///OUT/study.sqlite``).
        study_name: the study's name in the storage (``None``: ``ALGO-REGIME``).
        n_envs: sub-envs per trial.
        seed: the training seed of every trial, and the sampler's seed.
        out: the folder for the best YAML, the summaries and the trials' models (``None``:
            ``results/rl/tune/ALGO-REGIME``).
        fixed: hyper-parameters set after sampling (e.g. tiny rollouts in tests); recorded.
        startup_trials: trials sampled at random before TPE models the results (``None``:
            ``min(10, max(1, trials // 3))``, the zoo's 10 for 30 trials).
        pruner_startup_trials: finished trials before the median pruner acts.
        pruner_warmup_steps: steps of a trial before it can be pruned (``None``: a third of
            ``timesteps``, as the zoo's a third of the evaluations).
        torch_threads: torch threads per trial.
        progress: print one line per finished trial.
    """

    algo: str = "ppo"
    regime: str = "paper"
    trials: int | None = None
    timesteps: int | None = None
    eval_every: int | None = None
    eval_episodes: int | None = None
    storage: str | None = None
    study_name: str | None = None
    n_envs: int = 8
    seed: int = 0
    out: str | Path | None = None
    fixed: Mapping[str, Any] | None = None
    startup_trials: int | None = None
    pruner_startup_trials: int = 5
    pruner_warmup_steps: int | None = None
    torch_threads: int | None = 1
    progress: bool = True


@dataclass(frozen=True)
class StudyFiles:
    """Where a study writes: storage, lock, best YAML, trials CSV and Markdown, trial models."""

    out: Path
    storage: str
    database: Path
    lock: Path
    best_yaml: Path
    trials_csv: Path
    summary_md: Path
    trial_models: Path


@dataclass(frozen=True)
class TunePlan:
    """A validated :class:`TuneConfig`: every default filled in."""

    algo: str
    regime: str
    trials: int
    timesteps: int
    eval_every: int
    eval_seeds: tuple[int, ...]
    study_name: str
    n_envs: int
    seed: int
    files: StudyFiles
    fixed: dict[str, Any]
    startup_trials: int
    pruner_startup_trials: int
    pruner_warmup_steps: int
    torch_threads: int | None
    progress: bool
    env: dict[str, Any] = field(default_factory=dict)

    def settings(self) -> dict[str, Any]:
        """What must not change when a study resumes (stored as the study's user attributes)."""
        return {
            "algo": self.algo,
            "regime": self.regime,
            "timesteps": self.timesteps,
            "eval_every": self.eval_every,
            "eval_seeds": list(self.eval_seeds),
            "n_envs": self.n_envs,
            "seed": self.seed,
            "fixed": self.fixed,
            "env": {k: v for k, v in self.env.items()},
        }


def _positive(name: str, value: Any, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise ValueError(f"{name}: got {value!r}, expected an integer >= {minimum}")
    return value


def sqlite_path(url: str) -> Path:
    """The database file of an ``sqlite:///PATH`` URL.

    Raises:
        ValueError: any other URL (a resumable study needs a local file, and its lock beside it).
    """
    prefix = "sqlite:///"
    if not isinstance(url, str) or not url.startswith(prefix) or len(url) == len(prefix):
        raise ValueError(f"storage: got {url!r}, expected sqlite:///PATH (a local SQLite file)")
    return Path(url[len(prefix) :])


def prepare_tuning(config: TuneConfig) -> TunePlan:
    """Validate a tuning configuration and fill in its defaults.

    Raises:
        ValueError: an unknown algorithm or regime (with a did-you-mean), a non-positive count,
            more evaluation episodes than validation seeds, a storage that is not SQLite, or a
            ``fixed`` hyper-parameter the algorithm does not take.
    """
    from baselines.hyperparameters import resolve_hyperparams

    algo = str(config.algo).lower()
    if algo not in TUNED_ALGORITHMS:
        raise ValueError(
            f"algo: got {config.algo!r} — {did_you_mean(algo, TUNED_ALGORITHMS)}expected one of "
            f"{', '.join(TUNED_ALGORITHMS)}"
        )
    if config.regime not in REGIMES:
        raise ValueError(
            f"regime: got {config.regime!r} — {did_you_mean(str(config.regime), REGIMES)}expected one of "
            f"{', '.join(REGIMES)}"
        )
    trials = _positive("trials", DEFAULT_TRIALS[algo] if config.trials is None else config.trials)
    timesteps = _positive(
        "timesteps", DEFAULT_TIMESTEPS[algo] if config.timesteps is None else config.timesteps
    )
    eval_every = _positive(
        "eval_every", max(1, timesteps // 5) if config.eval_every is None else config.eval_every
    )
    default_episodes = 1 if config.regime == "paper" else VALIDATION_SEEDS
    episodes = _positive(
        "eval_episodes", default_episodes if config.eval_episodes is None else config.eval_episodes
    )
    if episodes > VALIDATION_SEEDS:
        raise ValueError(
            f"eval_episodes: got {episodes}, expected at most {VALIDATION_SEEDS} "
            f"(the validation seeds {VALIDATION_SEED_START}-{VALIDATION_SEED_START + VALIDATION_SEEDS - 1})"
        )
    fixed = dict(config.fixed or {})
    resolve_hyperparams(algo, fixed)  # unknown keys fail now, with a did-you-mean
    study_name = config.study_name or f"{algo}-{config.regime}"
    out = Path(config.out) if config.out is not None else DEFAULT_OUT / study_name
    storage = config.storage or f"sqlite:///{out / 'study.sqlite'}"
    database = sqlite_path(storage)
    files = StudyFiles(
        out=out,
        storage=storage,
        database=database,
        lock=database.with_name(database.name + ".lock"),
        best_yaml=out / f"{study_name}.yaml",
        trials_csv=out / f"{study_name}.trials.csv",
        summary_md=out / f"{study_name}.summary.md",
        trial_models=out / "trials",
    )
    if config.regime == "paper":
        env = {"env_id": "UAVPenetration-v0", "scenario": None}
    else:
        env = {"env_id": "UAVPenetrationRandom-v0", "difficulty": RANDOM_DIFFICULTY}
    startup = config.startup_trials
    return TunePlan(
        algo=algo,
        regime=config.regime,
        trials=trials,
        timesteps=timesteps,
        eval_every=eval_every,
        eval_seeds=tuple(range(VALIDATION_SEED_START, VALIDATION_SEED_START + episodes)),
        study_name=study_name,
        n_envs=_positive("n_envs", config.n_envs),
        seed=_positive("seed", config.seed, 0),
        files=files,
        fixed=fixed,
        startup_trials=min(10, max(1, trials // 3))
        if startup is None
        else _positive("startup_trials", startup),
        pruner_startup_trials=_positive("pruner_startup_trials", config.pruner_startup_trials, 0),
        pruner_warmup_steps=(
            timesteps // 3
            if config.pruner_warmup_steps is None
            else _positive("pruner_warmup_steps", config.pruner_warmup_steps, 0)
        ),
        torch_threads=config.torch_threads,
        progress=bool(config.progress),
        env=env,
    )


# --- the study -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class TuneResult:
    """A study's state after :func:`run_study`: counts, the best trial, the files written."""

    study_name: str
    files: StudyFiles
    complete: int
    pruned: int
    failed: int
    best_trial: int | None
    best_value: float | None
    best_hyperparams: dict[str, Any] | None


class StudyBusy(RuntimeError):
    """Another process holds the study's lock."""


@contextlib.contextmanager
def study_lock(path: Path) -> Iterator[None]:
    """An exclusive lock on ``path`` for as long as the block runs (one process per study).

    Raises:
        StudyBusy: another process holds it.
    """
    import fcntl

    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise StudyBusy(
                f"storage: {path.with_suffix('')} is in use by another `uav-bench tune` (lock {path})"
            ) from None
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _json_safe(value: Any) -> Any:
    return json.loads(json.dumps(value, default=str))


def _counts(study: Any) -> dict[str, int]:
    from optuna.trial import TrialState

    states = [t.state for t in study.get_trials(deepcopy=False)]
    return {
        "COMPLETE": states.count(TrialState.COMPLETE),
        "PRUNED": states.count(TrialState.PRUNED),
        "FAIL": states.count(TrialState.FAIL),
    }


def _recover(study: Any, progress: bool) -> None:
    """Fail the trials a killed run left RUNNING and queue once more every interrupted trial's parameters.

    DECISION (docs/rl.md §1.4): a trial cut by Ctrl-C or a kill is not a result (its training did not
    finish), so it is marked FAIL (not counted) and its sampled parameters are queued to run first, so the
    resumed study tries the point the sampler chose instead of losing it. Under :func:`study_lock` no
    other process runs the study, so a RUNNING trial found at start is stale.
    """
    from optuna.trial import TrialState

    trials = study.get_trials(deepcopy=False)
    for trial in trials:
        if trial.state == TrialState.RUNNING:
            study._storage.set_trial_state_values(trial._trial_id, state=TrialState.FAIL)
            if progress:
                print(f"trial {trial.number}: left running by an interrupted run, marked FAIL")
    retried = {t.user_attrs.get("retry_of") for t in trials}
    for trial in study.get_trials(deepcopy=False, states=(TrialState.FAIL,)):
        if trial.number not in retried and trial.params and not trial.user_attrs.get("error"):
            study.enqueue_trial(trial.params, user_attrs={"retry_of": trial.number}, skip_if_exists=False)
            if progress:
                print(f"trial {trial.number}: interrupted; its parameters are queued again")


def _objective(plan: TunePlan) -> Callable[[Any], float]:
    """Train one trial with sampled hyper-parameters; report evaluations; return the last one's cost.

    DECISION (docs/rl.md §1.1): the objective is the mean cost, total J plus the failure penalty
    (the negative return, the benchmark's reward), of the deterministic policy at the end of the
    trial. For an agent that reaches the goal it is its total J; J alone would score a crash at
    the first step (a few J(k)) better than any crossing. Every trial trains with the same seed,
    so trials differ by their hyper-parameters only.
    """
    import optuna

    from baselines.hyperparameters import resolve_hyperparams
    from baselines.train import train_agent

    def objective(trial: Any) -> float:
        sampled = SAMPLERS[plan.algo](trial)
        overrides = _merge(sampled, plan.fixed)
        params, _ = resolve_hyperparams(plan.algo, overrides)
        params.pop("provenance", None)
        trial.set_user_attr("hyperparams", _json_safe(params))

        def report(row: Mapping[str, Any]) -> None:
            steps = int(row["timesteps"])
            trial.report(float(row["mean_cost"]), steps)
            # The final evaluation is the trial's result, never a reason to prune it.
            if steps < plan.timesteps and trial.should_prune():
                trial.set_user_attr("pruned_at", steps)
                raise optuna.TrialPruned(f"cost {row['mean_cost']:.3f} at {steps} steps")

        model = plan.files.trial_models / f"trial-{trial.number:04d}.zip"
        started, cpu = time.perf_counter(), time.process_time()
        try:
            result = train_agent(
                plan.algo,
                **plan.env,
                total_timesteps=plan.timesteps,
                seed=plan.seed,
                n_envs=plan.n_envs,
                out=model,
                hyperparams=overrides,
                eval_freq=plan.eval_every,
                eval_seeds=plan.eval_seeds,
                on_evaluation=report,
                checkpoint_freq=0,
                torch_threads=plan.torch_threads,
            )
        except KeyboardInterrupt:
            trial.set_user_attr("interrupted", True)
            raise
        except (ValueError, RuntimeError, AssertionError) as error:
            # A diverged run (NaN actions or losses) is a bad point of the space, not a broken study:
            # it is pruned, as the zoo does, with the error kept for the summary.
            trial.set_user_attr("error", f"{type(error).__name__}: {error}"[:500])
            raise optuna.TrialPruned(str(error)) from error
        finally:
            trial.set_user_attr("train_seconds", round(time.perf_counter() - started, 3))
            # CPU seconds of this process: the trial's cost on one free core, whatever else ran.
            trial.set_user_attr("train_cpu_seconds", round(time.process_time() - cpu, 3))
        last = result.evaluations[-1]
        trial.set_user_attr("model", str(model))
        trial.set_user_attr("timesteps_done", int(result.sidecar["timesteps_done"]))
        for key in ("mean_J", "mean_penalty", "success_rate", "mean_length"):
            trial.set_user_attr(key, float(last[key]))
        return float(last["mean_cost"])

    return objective


def _merge(sampled: Mapping[str, Any], fixed: Mapping[str, Any]) -> dict[str, Any]:
    merged = dict(sampled)
    for key, value in fixed.items():
        if (
            key in ("policy_kwargs", "normalize")
            and isinstance(merged.get(key), dict)
            and isinstance(value, dict)
        ):
            merged[key] = {**merged[key], **value}
        else:
            merged[key] = value
    return merged


def open_study(plan: TunePlan) -> Any:
    """Create or load the study (TPE sampler, median pruner), checking a loaded one's settings.

    DECISION (docs/rl.md §1.4): the sampler's seed is ``seed + number of trials already in the study``: a
    seeded sampler restarted with the same seed would propose the same first random points again.

    Raises:
        ValueError: a stored study with other settings (algorithm, regime, budget, ...).
    """
    import warnings

    import optuna

    plan.files.database.parent.mkdir(parents=True, exist_ok=True)
    # Optuna's own lines (a trial's failure with a traceback on Ctrl-C) only repeat what the
    # command prints per trial; its errors still show.
    optuna.logging.set_verbosity(optuna.logging.ERROR)
    pruner = optuna.pruners.MedianPruner(
        n_startup_trials=plan.pruner_startup_trials, n_warmup_steps=plan.pruner_warmup_steps
    )
    study = optuna.create_study(
        study_name=plan.study_name,
        storage=plan.files.storage,
        direction="minimize",
        pruner=pruner,
        load_if_exists=True,
    )
    settings = _json_safe(plan.settings())
    stored = study.user_attrs.get("settings")
    if stored is None:
        study.set_user_attr("settings", settings)
    else:
        changed = [k for k in settings if stored.get(k) != settings[k]]
        if changed:
            key = changed[0]
            raise ValueError(
                f"{key}: study {plan.study_name!r} in {plan.files.storage} was created with "
                f"{key}={stored.get(key)!r}, got {settings[key]!r} (use another --study-name or --storage)"
            )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        study.sampler = optuna.samplers.TPESampler(
            seed=plan.seed + len(study.get_trials(deepcopy=False)),
            n_startup_trials=plan.startup_trials,
            multivariate=True,
        )
    return study


def run_study(config: TuneConfig | TunePlan) -> TuneResult:
    """Run (or resume) a study until ``trials`` trials are COMPLETE or PRUNED; write its files.

    After every finished trial, and at the end, :func:`write_study_files` rewrites the best
    YAML and the summaries (atomically).

    Raises:
        ValueError: invalid configuration (:func:`prepare_tuning`) or a stored study with other settings.
        StudyBusy: another process runs the same study.
        KeyboardInterrupt: after the interrupted trial is marked FAIL and the files are written.
    """
    plan = config if isinstance(config, TunePlan) else prepare_tuning(config)
    with study_lock(plan.files.lock):
        study = open_study(plan)
        _recover(study, plan.progress)
        objective = _objective(plan)

        def finished(study: Any, trial: Any) -> None:
            write_study_files(study, plan)
            if plan.progress:
                counts = _counts(study)
                value = "-" if trial.value is None else f"{trial.value:.4f}"
                duration = trial.duration.total_seconds() if trial.duration else float("nan")
                print(
                    f"trial {trial.number}: {trial.state.name} cost {value} in {duration:.0f} s "
                    f"({counts['COMPLETE']} complete, {counts['PRUNED']} pruned of {plan.trials})",
                    flush=True,
                )

        try:
            while sum(_counts(study)[s] for s in STATES_COUNTED) < plan.trials:
                study.optimize(objective, n_trials=1, callbacks=[finished], catch=())
                # A trial's model, envs and replay buffer form reference cycles; numpy arrays do not
                # count toward Python's collection thresholds, so without this the buffers of past
                # trials piled up (17 GB after 27 PPO trials on the Random id: the OOM killer).
                gc.collect()
        finally:
            write_study_files(study, plan)
        return _result(study, plan)


def _best(study: Any) -> Any:
    """The COMPLETE trial with the lowest value that recorded its hyper-parameters (``None``: none yet)."""
    from optuna.trial import TrialState

    done = [
        t
        for t in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))
        if t.value is not None and "hyperparams" in t.user_attrs and math.isfinite(t.value)
    ]
    return min(done, key=lambda t: (t.value, t.number)) if done else None


def _result(study: Any, plan: TunePlan) -> TuneResult:
    counts = _counts(study)
    best = _best(study)
    return TuneResult(
        study_name=plan.study_name,
        files=plan.files,
        complete=counts["COMPLETE"],
        pruned=counts["PRUNED"],
        failed=counts["FAIL"],
        best_trial=None if best is None else best.number,
        best_value=None if best is None else float(best.value),
        best_hyperparams=None if best is None else dict(best.user_attrs["hyperparams"]),
    )


# --- outputs -------------------------------------------------------------------------------------


def best_yaml_text(study: Any, plan: TunePlan) -> str | None:
    """The best trial's hyper-parameters as a ``baselines/hyperparams`` file (``None``: none complete yet)."""
    from uav_penetration_env.benchmark.provenance import library_versions

    best = _best(study)
    if best is None:
        return None
    counts = _counts(study)
    versions = library_versions()
    versions["optuna"] = _version("optuna")
    where = (
        "the paper scenario (UAVPenetration-v0)"
        if plan.regime == "paper"
        else (f"UAVPenetrationRandom-v0 at difficulty {RANDOM_DIFFICULTY} (its pool, seeds >= 2**32)")
    )
    seeds = plan.eval_seeds
    provenance = {
        "source": (
            f"uav-bench tune (baselines/tune.py): Optuna TPE sampler (seed {plan.seed}) and median pruner, "
            f"search space after rl-baselines3-zoo's hyperparams_opt.py; keys not tuned come from "
            f"baselines/hyperparams/{plan.algo}.yaml"
        ),
        "study": plan.study_name,
        "storage": plan.files.storage,
        "regime": plan.regime,
        "trained_on": where,
        "objective": (
            f"mean cost (total J + failure penalty) of the deterministic policy at the end of the trial, "
            f"on {len(seeds)} episode(s) with seeds {seeds[0]}-{seeds[-1]}"
            + (
                f" at difficulty {RANDOM_DIFFICULTY}"
                if plan.regime == "random"
                else " (the fixed paper start)"
            )
            + "; minimised"
        ),
        "trials_complete": counts["COMPLETE"],
        "trials_pruned": counts["PRUNED"],
        "trials_failed": counts["FAIL"],
        "budget_steps_per_trial": plan.timesteps,
        "eval_every": plan.eval_every,
        "n_envs": plan.n_envs,
        "training_seed": plan.seed,
        "best_trial": best.number,
        "best_value": float(best.value),
        "best_mean_J": best.user_attrs.get("mean_J"),
        "best_success_rate": best.user_attrs.get("success_rate"),
        # The programme sizes the long off-policy runs from this (baselines/programme.py).
        "best_trial_cpu_seconds": best.user_attrs.get("train_cpu_seconds"),
        "fixed": plan.fixed or None,
        "date": dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat(),
        "versions": versions,
    }
    body = {"provenance": provenance, **best.user_attrs["hyperparams"]}
    header = (
        f"# {plan.algo.upper()} hyper-parameters tuned by `uav-bench tune` (study {plan.study_name}).\n"
        f"# Load with: uav-bench train --algo {plan.algo} --hyperparams THIS_FILE (keys as in "
        f"baselines/hyperparams/{plan.algo}.yaml).\n"
    )
    return header + yaml.safe_dump(_json_safe(body), sort_keys=False, width=100)


def _version(name: str) -> str:
    from importlib import metadata

    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "not installed"


def trial_rows(study: Any) -> list[dict[str, Any]]:
    """One row per trial: number, state, value, duration, last reported step, sampled parameters, notes."""
    rows = []
    names = sorted({name for t in study.get_trials(deepcopy=False) for name in t.params})
    for t in study.get_trials(deepcopy=False):
        steps = max(t.intermediate_values) if t.intermediate_values else None
        row = {
            "number": t.number,
            "state": t.state.name,
            "value": t.value,
            "duration_s": round(t.duration.total_seconds(), 1) if t.duration else None,
            "cpu_s": t.user_attrs.get("train_cpu_seconds"),
            "last_step": steps,
            "mean_J": t.user_attrs.get("mean_J"),
            "success_rate": t.user_attrs.get("success_rate"),
        }
        row.update({f"param_{name}": t.params.get(name) for name in names})
        notes = []
        if "retry_of" in t.user_attrs:
            notes.append(f"retry of {t.user_attrs['retry_of']}")
        if t.user_attrs.get("interrupted"):
            notes.append("interrupted")
        if "error" in t.user_attrs:
            notes.append(t.user_attrs["error"])
        row["notes"] = "; ".join(notes)
        rows.append(row)
    return rows


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value).replace("|", "/")


def write_study_files(study: Any, plan: TunePlan) -> None:
    """Rewrite the best YAML (once a trial is complete), the trials CSV and the summary, atomically."""
    text = best_yaml_text(study, plan)
    if text is not None:
        write_text_atomic(plan.files.best_yaml, text)
    rows = trial_rows(study)
    columns = list(rows[0]) if rows else ["number", "state", "value", "duration_s"]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, columns, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    write_text_atomic(plan.files.trials_csv, buffer.getvalue())
    counts = _counts(study)
    best = _best(study)
    lines = [
        f"# Tuning study {plan.study_name}",
        "",
        f"- algorithm {plan.algo}, regime {plan.regime}, {plan.timesteps} steps per trial, "
        f"{plan.n_envs} envs, training seed {plan.seed}, evaluation every {plan.eval_every} steps on "
        f"{len(plan.eval_seeds)} episode(s) (seeds {plan.eval_seeds[0]}-{plan.eval_seeds[-1]})",
        f"- storage `{plan.files.storage}`; {counts['COMPLETE']} complete, {counts['PRUNED']} pruned, "
        f"{counts['FAIL']} failed/interrupted of {plan.trials} wanted",
        *(
            [f"- fixed after sampling (these override the param_ columns): `{json.dumps(plan.fixed)}`"]
            if plan.fixed
            else []
        ),
        "- best: "
        + (
            f"trial {best.number}, cost {best.value:.4f} -> `{plan.files.best_yaml.name}`"
            if best
            else "none yet"
        ),
        "",
    ]
    if rows:
        lines.append("| " + " | ".join(columns) + " |")
        lines.append("|" + "---|" * len(columns))
        lines.extend("| " + " | ".join(_cell(row[c]) for c in columns) + " |" for row in rows)
    write_text_atomic(plan.files.summary_md, "\n".join(lines) + "\n")


# --- the command ---------------------------------------------------------------------------------


def _per_algo(values: dict[str, int]) -> str:
    """``ppo 30, sac 15, td3 15``: a per-algorithm default as help text."""
    return ", ".join(f"{algo} {value:,}" for algo, value in values.items())


def add_tune_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench tune`` (defaults: :class:`TuneConfig`'s)."""
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
    parser.add_argument("--out", help=f"output folder (default: {DEFAULT_OUT}/ALGO-REGIME)")
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
