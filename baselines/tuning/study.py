"""Running a study: open or resume it in its SQLite storage, one process at a time, until it has its trials.

:func:`run_study` holds :func:`study_lock`, opens the study (:func:`open_study`, which refuses a
stored study with other settings), repairs what an interrupted run left (docs/rl.md §1.4), and runs
trials until enough are COMPLETE or PRUNED, rewriting the study's files after each one.
"""

from __future__ import annotations

import contextlib
import gc
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from baselines.tuning.config import StudyFiles, TuneConfig, TunePlan, json_safe, prepare_tuning
from baselines.tuning.objective import make_objective
from baselines.tuning.outputs import write_study_files
from baselines.tuning.trials import STATES_COUNTED, best_complete_trial, recover_interrupted, trial_counts


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
    settings = json_safe(plan.settings())
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
        recover_interrupted(study, plan.progress)
        objective = make_objective(plan)

        def finished(study: Any, trial: Any) -> None:
            write_study_files(study, plan)
            if plan.progress:
                counts = trial_counts(study)
                value = "-" if trial.value is None else f"{trial.value:.4f}"
                duration = trial.duration.total_seconds() if trial.duration else float("nan")
                print(
                    f"trial {trial.number}: {trial.state.name} cost {value} in {duration:.0f} s "
                    f"({counts['COMPLETE']} complete, {counts['PRUNED']} pruned of {plan.trials})",
                    flush=True,
                )

        try:
            while sum(trial_counts(study)[s] for s in STATES_COUNTED) < plan.trials:
                study.optimize(objective, n_trials=1, callbacks=[finished], catch=())
                # A trial's model, envs and replay buffer form reference cycles; numpy arrays do not
                # count toward Python's collection thresholds, so without this the buffers of past
                # trials piled up (17 GB after 27 PPO trials on the Random id: the OOM killer).
                gc.collect()
        finally:
            write_study_files(study, plan)
        return _result(study, plan)


def _result(study: Any, plan: TunePlan) -> TuneResult:
    counts = trial_counts(study)
    best = best_complete_trial(study)
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
