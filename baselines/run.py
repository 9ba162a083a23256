"""Running a training plan: the envs, the SB3 model, periodic evaluation and checkpoints, the sidecar.

:func:`run_training` trains as a :class:`~baselines.plan.TrainingPlan` says on the native batched
vector env (:class:`baselines.vec_env.UAVPenetrationSB3VecEnv`), evaluates the deterministic
policy on fixed seeds every ``eval_freq`` steps (:func:`evaluate_agent`), saves checkpoints, and
writes the model with its sidecars (:mod:`baselines.artifacts`). Torch and SB3 are imported inside
the functions that use them.
"""

from __future__ import annotations

import csv
import dataclasses
import datetime as dt
import json
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from baselines.artifacts import SIDECAR_FORMAT, ModelFiles, artifact_hashes
from baselines.hyperparameters import algorithm_class, algorithm_kwargs, normalize_kwargs
from baselines.plan import TrainingPlan
from baselines.resume import ResumeState
from uav_penetration_env.atomic import atomic_open, atomic_path, write_text_atomic

EVALUATION_COLUMNS = (
    "timesteps",
    "episodes",
    "mean_return",
    "std_return",
    "mean_cost",
    "mean_J",
    "mean_penalty",
    "success_rate",
    "mean_length",
    "wall_seconds",
)


@dataclass(frozen=True)
class TrainResult:
    """What a training run wrote, and the trained SB3 model."""

    files: ModelFiles
    sidecar: dict[str, Any]
    evaluations: list[dict[str, float]]
    model: Any = field(repr=False, default=None)


def train_env_seeds(seed: int | Sequence[int], n_envs: int, pool: bool = False) -> list[int]:
    """Reset seeds of the training sub-envs: one child of ``SeedSequence(seed)`` each (STYLE §5).

    Args:
        seed: the training seed (or a sequence of integers, e.g. ``[seed, timesteps]`` on resume).
        n_envs: sub-envs.
        pool: the Random id: the seeds are moved by ``POOL_SEED_OFFSET`` (2**32).

    DECISION: a Random-id sub-env's first episode flies the scenario of its reset seed (model.md
    §7c); a 32-bit child seed could, however rarely, be a held-out (10000-10049), suite
    (30000-30219) or tuning-validation (40000-40049) seed, so for the Random id the reset seeds
    lie at or above 2**32, where the id's own training pool lives (``env.POOL_SEED_OFFSET``).
    """
    from uav_penetration_env.env import POOL_SEED_OFFSET

    children = np.random.SeedSequence(seed).spawn(n_envs)
    offset = POOL_SEED_OFFSET if pool else 0
    return [offset + int(child.generate_state(1, dtype=np.uint32)[0]) for child in children]


def evaluate_agent(model: Any, env: Any, seeds: Sequence[int], normalizer: Any = None) -> dict[str, float]:
    """One deterministic episode per sub-env of ``env`` (one seed each); summary statistics.

    Args:
        model: anything with SB3's ``predict(obs, deterministic=True)``.
        env: a :class:`~baselines.vec_env.UAVPenetrationSB3VecEnv` with ``len(seeds)`` sub-envs.
        seeds: the reset seed of each sub-env.
        normalizer: a ``VecNormalize`` whose statistics normalise the observations (not updated).

    Returns:
        ``episodes``, ``mean_return``, ``std_return``, ``mean_cost`` (= -mean_return, J + penalty),
        ``mean_J`` (sum of J(k), the harness's ``total_J``), ``mean_penalty``, ``success_rate``,
        ``mean_length``.
    """
    env.seed(list(seeds))
    obs = env.reset()
    n = env.num_envs
    total_j, penalty, length = np.zeros(n), np.zeros(n), np.zeros(n, dtype=np.int64)
    success = np.zeros(n, dtype=bool)
    active = np.ones(n, dtype=bool)
    while active.any():
        inputs = normalizer.normalize_obs(obs) if normalizer is not None else obs
        actions, _ = model.predict(inputs, deterministic=True)
        obs, _, dones, infos = env.step(actions)
        for i in np.flatnonzero(active):
            # Costs from the float64 infos: the float32 rewards SB3 sees would round the sums.
            total_j[i] += infos[i]["J"]
            penalty[i] += infos[i]["penalty"]
            length[i] += 1
            if dones[i]:
                success[i] = bool(infos[i]["reached_goal"])
        active &= ~dones
    returns = -(total_j + penalty)
    return {
        "episodes": int(n),
        "mean_return": float(returns.mean()),
        "std_return": float(returns.std()),
        "mean_cost": float(-returns.mean()),
        "mean_J": float(total_j.mean()),
        "mean_penalty": float(penalty.mean()),
        "success_rate": float(success.mean()),
        "mean_length": float(length.mean()),
    }


def _json_scenario(value: Any) -> Any:
    from uav_penetration_env.scenario import Scenario

    return value.to_dict() if isinstance(value, Scenario) else value


def describe_env(plan: TrainingPlan, venv: Any, seeds: Sequence[int]) -> dict[str, Any]:
    """The env part of the sidecar: JSON-able env kwargs, profile, scenario (hash or description), spaces."""
    described = venv.vector_env.describe_scenarios()
    env_kwargs = {k: _json_scenario(v) for k, v in plan.env_kwargs.items()}
    profile = described["profile"]
    if described["kind"] == "fixed":
        scenario = {"name": described["name"], "hash": described["hash"]}
    else:
        scenario = {
            "description": (
                f"{plan.env_id}: procedural scenarios (model.md §7c) at difficulty {described['difficulty']}; "
                f"each sub-env's first episode flies the scenario of its reset seed {list(seeds)}, later "
                f"episodes a pool of {described['pool_size']} scenarios from pool_seed {described['pool_seed']}"
            ),
            "difficulty": described["difficulty"],
            "pool_size": described["pool_size"],
            "pool_seed": described["pool_seed"],
        }
    physical = venv.physical_action_space
    formulation = plan.formulation
    learner = {}
    if not formulation.is_default:
        # Only a new formulation is recorded, so the sidecars of today's agents keep their bytes.
        learner = {"formulation": formulation.to_json()}
        if formulation.shaping == "value":
            learner["formulation"]["gamma"] = float(plan.hyperparams.get("gamma", 0.99))
    if plan.warm_start is not None:
        learner["warm_start"] = plan.warm_start.to_json()
    return {
        **learner,
        "env_id": plan.env_id,
        "env_kwargs": env_kwargs,
        "profile": profile,
        "scenario": scenario,
        "observation_space": {
            "shape": [formulation.observation_size],
            "low": float(np.min(venv.observation_space.low)),
            "high": float(np.max(venv.observation_space.high)),
            "dtype": str(venv.observation_space.dtype),
        },
        "action_space": {
            "shape": list(physical.shape),
            "low": physical.low.astype(float).tolist(),
            "high": physical.high.astype(float).tolist(),
            "units": ["m/s", "rad", "rad"],
            "policy_low": -1.0,
            "policy_high": 1.0,
        },
    }


def _write_json_atomic(path: Path, data: Mapping[str, Any]) -> None:
    # The sidecar is written last and atomically: its presence means the model beside it is whole.
    write_text_atomic(path, json.dumps(data, indent=2, sort_keys=False, default=str) + "\n")


def _write_evaluations(path: Path, rows: Sequence[Mapping[str, Any]]) -> None:
    """The learning curve so far, rewritten whole (atomically) after each evaluation."""
    with atomic_open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, EVALUATION_COLUMNS)
        writer.writeheader()
        writer.writerows(rows)


class _Run:
    """The mutable state of one training run: envs, model, callbacks' shared bookkeeping."""

    def __init__(self, plan: TrainingPlan) -> None:
        from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

        from baselines.plan import vector_class
        from baselines.vec_env import UAVPenetrationSB3VecEnv, make_formulation_vec_env
        from uav_penetration_env.vector_env import UAVPenetrationRandomVectorEnv

        self.plan = plan
        self.random_id = issubclass(vector_class(plan.env_id) or object, UAVPenetrationRandomVectorEnv)
        self.seeds = train_env_seeds(plan.seed, plan.n_envs, pool=self.random_id)
        env_kwargs = dict(plan.env_kwargs)
        if self.random_id:
            # The pool the id would draw anyway (the first reset's seed), named so a resumed run keeps it.
            env_kwargs.setdefault("pool_seed", self.seeds[0])
        self.venv = UAVPenetrationSB3VecEnv(plan.env_id, plan.n_envs, **env_kwargs)
        # The formulation's wrapper (docs/rl.md §6); today's formulation is the adapter itself.
        self.learner_env = make_formulation_vec_env(
            self.venv, plan.formulation, plan.hyperparams.get("gamma", 0.99)
        )
        env: Any = VecMonitor(self.learner_env)  # episode returns/lengths for SB3's logger
        self.norm_kwargs = normalize_kwargs(plan.hyperparams)
        state = plan.resume_from
        if self.norm_kwargs is not None and state is not None:
            # The checkpoint's running statistics, still updated as training continues.
            env = VecNormalize.load(str(state.files.vecnormalize), env)
            env.training = True
        elif self.norm_kwargs is not None:
            env = VecNormalize(env, **self.norm_kwargs)
        self.env = env
        self.segments = [*state.segments, state.timesteps] if state is not None else [0]
        self.eval_seeds = list(plan.eval_seeds)
        # Evaluation flies the learner's actions and inputs, never the shaping (it reads info["J"]).
        evaluated = dataclasses.replace(plan.formulation, shaping="none")
        self.eval_env = (
            make_formulation_vec_env(
                UAVPenetrationSB3VecEnv(plan.env_id, plan.eval_episodes, **plan.env_kwargs), evaluated, None
            )
            if plan.eval_freq
            else None
        )
        self.evaluations: list[dict[str, float]] = list(state.evaluations) if state is not None else []
        self.eval_seconds = state.eval_seconds if state is not None else 0.0
        self.started = time.perf_counter()
        self.model: Any = None
        self.env_description: dict[str, Any] | None = None

    def normalizer(self) -> Any:
        return self.model.get_vec_normalize_env()

    def evaluate(self) -> dict[str, float]:
        tick = time.perf_counter()
        row = {"timesteps": int(self.model.num_timesteps)}
        row.update(evaluate_agent(self.model, self.eval_env, self.eval_seeds, self.normalizer()))
        self.eval_seconds += time.perf_counter() - tick
        row["wall_seconds"] = time.perf_counter() - self.started
        self.evaluations.append(row)
        _write_evaluations(self.plan.files.evaluations, self.evaluations)
        if self.plan.on_evaluation is not None:
            self.plan.on_evaluation(dict(row))
        return row

    def save(self, files: ModelFiles, wall_seconds: float, interrupted: bool = False) -> dict[str, Any]:
        """Write model, observation statistics and sidecar to ``files``; return the sidecar."""
        from uav_penetration_env.benchmark.provenance import git_commit, library_versions

        plan = self.plan
        files.model.parent.mkdir(parents=True, exist_ok=True)
        # Each file whole or not at all; the sidecar, last, records their hashes.
        with atomic_open(files.model, "wb") as stream:
            self.model.save(stream)
        normalizer = self.normalizer()
        if normalizer is not None:
            with atomic_path(files.vecnormalize) as temporary:
                normalizer.save(temporary)
        if self.env_description is None:
            self.env_description = describe_env(plan, self.venv, self.seeds)
        sidecar = {
            "format": SIDECAR_FORMAT,
            "algorithm": plan.algo,
            "sb3_class": f"stable_baselines3.{type(self.model).__name__}",
            **self.env_description,
            "hyperparameters": plan.hyperparams,
            "hyperparameters_source": plan.hyperparams_source,
            "vecnormalize": files.vecnormalize.name if normalizer is not None else None,
            **artifact_hashes(files, plan.hyperparams, normalizer is not None),
            "total_timesteps": plan.total_timesteps,
            "timesteps_done": int(self.model.num_timesteps),
            "seed": plan.seed,
            "n_envs": plan.n_envs,
            "train_env_seeds": self.seeds,
            "eval_seeds": self.eval_seeds if plan.eval_freq else [],
            "wall_seconds": wall_seconds,
            "eval_seconds": self.eval_seconds,
            "torch_threads": plan.torch_threads,
            "device": plan.device,
            "final_evaluation": self.evaluations[-1] if self.evaluations else None,
            "interrupted": interrupted,
            "resumed_at_timesteps": self.segments[1:],
            "versions": library_versions(),
            "commit": git_commit(),
            "created": dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat(),
        }
        _write_json_atomic(files.sidecar, sidecar)
        return sidecar

    def checkpoint(self, finished: bool = False) -> None:
        """Save a checkpoint a run can resume from (docs/rl.md §2): model, statistics, replay buffer, state."""
        from baselines.resume import resume_key, save_replay_buffer, write_resume_state

        plan, steps = self.plan, int(self.model.num_timesteps)
        stem = f"{plan.files.model.stem}-{steps}steps"
        files = ModelFiles.of(plan.files.checkpoints / f"{stem}.zip")
        wall = time.perf_counter() - self.started
        self.save(files, wall)
        replay = None
        if getattr(self.model, "replay_buffer", None) is not None:
            replay = plan.files.checkpoints / f"{stem}.replay.npz"
            save_replay_buffer(self.model, replay)
        write_resume_state(
            plan.files, files, replay, timesteps=steps, evaluations=self.evaluations, wall_seconds=wall,
            eval_seconds=self.eval_seconds, finished=finished, key=resume_key(plan), segments=self.segments,
        )  # fmt: skip


def _finished_result(plan: TrainingPlan) -> TrainResult | None:
    """The saved result of a run that already trained ``plan.total_timesteps`` steps (``None``: not whole)."""
    from baselines.artifacts import read_sidecar

    files = plan.files
    try:
        sidecar = read_sidecar(files.sidecar)
    except (FileNotFoundError, ValueError):
        return None
    if (
        sidecar.get("interrupted")
        or int(sidecar["timesteps_done"]) < plan.total_timesteps
        or not files.model.is_file()
    ):
        return None
    rows: list[dict[str, float]] = []
    if files.evaluations.is_file():
        with files.evaluations.open(newline="") as handle:
            rows = [
                {k: int(float(v)) if k in ("timesteps", "episodes") else float(v) for k, v in row.items()}
                for row in csv.DictReader(handle)
            ]
    return TrainResult(files=files, sidecar=sidecar, evaluations=rows, model=None)


def _callbacks(run: _Run) -> list[Any]:
    """Periodic evaluation, checkpoints and the progress bar, as SB3 callbacks (:mod:`baselines.callbacks`)."""
    from baselines.callbacks import CriticWarmup, Periodic, ProgressBar, StartEvaluation

    callbacks: list[Any] = [Periodic(run)]
    if run.plan.warm_start is not None:
        callbacks = [StartEvaluation(run), CriticWarmup(run), *callbacks]
    if run.plan.progress_bar:
        callbacks.append(ProgressBar(run))
    return callbacks


def _stdout_logger(verbose: int) -> Any:
    """SB3's logger writing to stdout only (when ``verbose``), with no log folder.

    Left to itself, ``learn()`` configures a logger whose folder defaults to a new, empty
    ``/tmp/SB3-<date>`` directory per call, so a tuning study would leave hundreds of them.
    """
    import sys

    from stable_baselines3.common.logger import HumanOutputFormat, Logger

    return Logger(folder=None, output_formats=[HumanOutputFormat(sys.stdout)] if verbose else [])


def _already_finished(plan: TrainingPlan) -> TrainResult | None:
    """The saved result when ``plan.resume_from`` already trained ``total_timesteps`` steps, else ``None``."""
    state = plan.resume_from
    if state is not None and state.finished and state.timesteps >= plan.total_timesteps:
        return _finished_result(plan)
    return None


def _build_model(run: _Run, cls: type) -> list[int]:
    """Construct a fresh model on ``run.env``; return the sub-envs' reset seeds (the run's own)."""
    plan = run.plan
    kwargs = algorithm_kwargs(plan.hyperparams, int(np.prod(run.learner_env.action_space.shape)))
    run.model = cls(
        plan.hyperparams.get("policy", "MlpPolicy"),
        run.env,
        seed=plan.seed,
        verbose=plan.verbose,
        device=plan.device,
        **kwargs,
    )
    if plan.warm_start is not None:
        from baselines.warm_start import load_into

        load_into(run.model, plan.warm_start.arrays())  # the actor starts as the distilled network
    return run.seeds


def _resumed_seed(plan: TrainingPlan, state: ResumeState) -> int:
    """The seed a resumed run reseeds torch and numpy with, from ``SeedSequence([seed, steps])``."""
    return int(np.random.SeedSequence([plan.seed, state.timesteps]).generate_state(1)[0])


def _load_model(run: _Run, cls: type, state: ResumeState, resumed_seed: int) -> list[int]:
    """Load the checkpoint's model (and replay buffer) onto ``run.env``; return the sub-envs' reset seeds.

    The reset seeds are drawn from ``SeedSequence([seed, steps])``, so the resumed run does not
    replay the first episodes of the run it continues.
    """
    from baselines.resume import load_replay_buffer

    plan = run.plan
    run.model = cls.load(state.model, env=run.env, device=plan.device, verbose=plan.verbose)
    run.model.set_random_seed(resumed_seed)
    if state.replay_buffer is not None:
        load_replay_buffer(run.model, state.replay_buffer)
    return train_env_seeds([plan.seed, state.timesteps], plan.n_envs, pool=run.random_id)


def _learn(run: _Run) -> None:
    """Train up to ``total_timesteps``; on Ctrl-C save the partly trained model (interrupted), re-raise."""
    from stable_baselines3.common.callbacks import CallbackList

    plan, state = run.plan, run.plan.resume_from
    callbacks = _callbacks(run)
    callback = CallbackList(callbacks)
    run.started = time.perf_counter() - (state.wall_seconds if state is not None else 0.0)
    done_steps = state.timesteps if state is not None else 0
    try:
        run.model.learn(
            plan.total_timesteps - done_steps,
            callback=callback,
            progress_bar=False,
            reset_num_timesteps=state is None,
        )
    except KeyboardInterrupt:
        for each in callbacks:
            if hasattr(each, "close"):
                each.close()
        run.save(plan.files, time.perf_counter() - run.started, interrupted=True)
        raise


def _finish(run: _Run) -> TrainResult:
    """The final evaluation and checkpoint (when due), then the model with its sidecars; the result."""
    plan = run.plan
    if plan.eval_freq and (
        not run.evaluations or run.evaluations[-1]["timesteps"] != run.model.num_timesteps
    ):
        run.evaluate()
    if plan.checkpoint_freq:
        run.checkpoint(finished=True)  # a later run may extend this one (--resume, more steps)
    wall = time.perf_counter() - run.started
    sidecar = run.save(plan.files, wall)
    return TrainResult(files=plan.files, sidecar=sidecar, evaluations=list(run.evaluations), model=run.model)


def _close(run: _Run | None) -> None:
    """Close the training and evaluation envs of ``run`` (nothing when it was never built)."""
    if run is not None:
        run.env.close()
        if run.eval_env is not None:
            run.eval_env.close()


def run_training(plan: TrainingPlan) -> TrainResult:
    """Train as ``plan`` says and write the model with its sidecars (see :func:`train_agent`).

    With ``plan.resume_from`` (``train_agent(resume=True)``) training continues from that
    checkpoint with SB3's ``reset_num_timesteps=False``, so the step counter, the learning-rate
    schedule and the learning curve run on to ``total_timesteps``; a run whose checkpoint already
    finished them returns its saved result without training.

    DECISION (docs/rl.md §2): a resumed run restores the model with its optimisers, the observation
    statistics, the replay buffer (SAC, TD3), the step counter and the learning curve, but not the
    sub-envs' mid-episode states or the random generators' states: it resets the sub-envs with
    seeds drawn from ``SeedSequence([seed, steps])`` (so it does not replay the first episodes)
    and reseeds torch and numpy from the same. An interrupted-and-resumed run is therefore a valid
    continuation, not a bit-identical replay of an uninterrupted one; its curve rows up to the
    checkpoint are the uninterrupted run's exactly.
    """
    import torch
    from stable_baselines3.common.utils import set_random_seed

    from baselines.resume import discard_resume_state

    done = _already_finished(plan)
    if done is not None:
        return done
    previous_threads = torch.get_num_threads()
    if plan.torch_threads is not None:
        torch.set_num_threads(plan.torch_threads)
    state = plan.resume_from
    run: _Run | None = None  # set as soon as the envs exist, so ``finally`` closes them on any error
    try:
        cls = algorithm_class(plan.algo)
        if state is None:
            discard_resume_state(plan.files)  # a fresh run: an older run's checkpoint must not be resumed
            set_random_seed(plan.seed)
            run = _Run(plan)
            reset_seeds = _build_model(run, cls)
        else:
            resumed_seed = _resumed_seed(plan, state)
            set_random_seed(resumed_seed)
            run = _Run(plan)
            reset_seeds = _load_model(run, cls, state, resumed_seed)
        run.model.set_logger(_stdout_logger(plan.verbose))
        # The constructor seeded sub-env i with seed + i; the SeedSequence children replace that.
        run.env.seed(reset_seeds)
        if plan.eval_freq:
            _write_evaluations(plan.files.evaluations, run.evaluations)
        _learn(run)
        return _finish(run)
    finally:
        _close(run)
        torch.set_num_threads(previous_threads)
