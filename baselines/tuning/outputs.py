"""What a study writes: the best set as a ``baselines/hyperparams`` YAML with its provenance, and the trials as CSV and Markdown.

Every file is rewritten atomically after each finished trial, so a study stopped at any time leaves
whole files behind, and ``uav-bench train --hyperparams`` can load the best YAML at any point.
"""

from __future__ import annotations

import csv
import datetime as dt
import io
import json
from typing import Any

import yaml

from baselines.tuning.config import RANDOM_DIFFICULTY, TunePlan, json_safe
from baselines.tuning.trials import best_complete_trial, trial_counts, trial_rows
from uav_penetration_env.atomic import write_text_atomic


def best_yaml_text(study: Any, plan: TunePlan) -> str | None:
    """The best trial's hyper-parameters as a ``baselines/hyperparams`` file (``None``: none complete yet)."""
    from uav_penetration_env.benchmark.provenance import library_versions

    best = best_complete_trial(study)
    if best is None:
        return None
    counts = trial_counts(study)
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
    return header + yaml.safe_dump(json_safe(body), sort_keys=False, width=100)


def _version(name: str) -> str:
    from importlib import metadata

    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "not installed"


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
    counts = trial_counts(study)
    best = best_complete_trial(study)
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
