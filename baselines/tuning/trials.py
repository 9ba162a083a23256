"""Reading a study's trials: the counts, the best one, a table of them, and repairing interrupted ones.

Optuna is imported inside each function, so importing this module (as the CLI does to list its
commands) does not need the extra.
"""

from __future__ import annotations

import math
from typing import Any

STATES_COUNTED = ("COMPLETE", "PRUNED")


def trial_counts(study: Any) -> dict[str, int]:
    """How many of the study's trials are COMPLETE, PRUNED and FAIL."""
    from optuna.trial import TrialState

    states = [t.state for t in study.get_trials(deepcopy=False)]
    return {
        "COMPLETE": states.count(TrialState.COMPLETE),
        "PRUNED": states.count(TrialState.PRUNED),
        "FAIL": states.count(TrialState.FAIL),
    }


def best_complete_trial(study: Any) -> Any:
    """The COMPLETE trial with the lowest value that recorded its hyper-parameters (``None``: none yet)."""
    from optuna.trial import TrialState

    done = [
        t
        for t in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))
        if t.value is not None and "hyperparams" in t.user_attrs and math.isfinite(t.value)
    ]
    return min(done, key=lambda t: (t.value, t.number)) if done else None


def recover_interrupted(study: Any, progress: bool) -> None:
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
