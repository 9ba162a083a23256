"""What a tuning study is: its settings, checked and completed into a plan (docs/rl.md §1).

:class:`TuneConfig` is what a user gives (``uav-bench tune`` flags); :func:`prepare_tuning`
refuses bad values in one line naming the field and fills in every default, giving the
:class:`TunePlan` the study runs, with the files it writes (:class:`StudyFiles`). Regimes and their
seeds follow HELPERS.md's project-wide ranges (see :mod:`baselines.tune`).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

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


def json_safe(value: Any) -> Any:
    """``value`` as JSON gives it back (tuples as lists, anything else JSON lacks as its string): what a study stores."""
    return json.loads(json.dumps(value, default=str))


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


def study_files(out: Path, study_name: str, storage: str) -> StudyFiles:
    """Where the study ``study_name`` writes, in ``out`` and the SQLite ``storage``.

    Raises:
        ValueError: a storage that is not ``sqlite:///PATH`` (:func:`sqlite_path`).
    """
    database = sqlite_path(storage)
    return StudyFiles(
        out=out,
        storage=storage,
        database=database,
        lock=database.with_name(database.name + ".lock"),
        best_yaml=out / f"{study_name}.yaml",
        trials_csv=out / f"{study_name}.trials.csv",
        summary_md=out / f"{study_name}.summary.md",
        trial_models=out / "trials",
    )


def regime_env(regime: str) -> dict[str, Any]:
    """The environment a regime trains on, as :func:`baselines.train_agent` arguments."""
    if regime == "paper":
        return {"env_id": "UAVPenetration-v0", "scenario": None}
    return {"env_id": "UAVPenetrationRandom-v0", "difficulty": RANDOM_DIFFICULTY}


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
    files = study_files(out, study_name, config.storage or f"sqlite:///{out / 'study.sqlite'}")
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
        env=regime_env(config.regime),
    )
