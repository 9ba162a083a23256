"""The objective of a trial: train with the sampled hyper-parameters and score the trained policy (docs/rl.md §1.1).

:func:`make_objective` gives the function Optuna calls per trial: it samples the trial's set
(:mod:`baselines.tuning.space`), trains it with :func:`baselines.train_agent`, reports each
periodic evaluation to the pruner and returns the mean cost of the last one.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any

from baselines.tuning.config import TunePlan, json_safe
from baselines.tuning.space import SAMPLERS


def make_objective(plan: TunePlan) -> Callable[[Any], float]:
    """The function Optuna calls per trial: train a sampled set, report its evaluations, return the last cost.

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
        overrides = merge_fixed(sampled, plan.fixed)
        params, _ = resolve_hyperparams(plan.algo, overrides)
        params.pop("provenance", None)
        trial.set_user_attr("hyperparams", json_safe(params))

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


def merge_fixed(sampled: Mapping[str, Any], fixed: Mapping[str, Any]) -> dict[str, Any]:
    """The sampled set with the ``fixed`` hyper-parameters on top (``policy_kwargs`` and ``normalize`` merged key by key)."""
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
