"""Harness speed, measured in one run on the paper scenario (the speed targets as ratios).

Prints, for each planner as an MPC policy (horizon 5, ``--max-evals`` per step), on one thread:
* planning seconds per MPC step with the numpy model (the test oracle tests/numpy_model.py) and
  with the compiled model, and the speed-up (target: >= 5x for ihpso, pso, cem at 10 000
  evaluations);
* the share of the compiled step spent inside ``model.rollout_cost`` (the rest is optimiser +
  harness overhead), and for DE its own overhead per iteration;
* DE's own time per iteration on a free objective, split into scipy's solver parts (why it
  cannot be cut further: docs/optimizers.md §3b);
and the speed-up of ``n_jobs=2`` over ``n_jobs=1`` on a sweep of 8 episodes (target: >= 1.7x on
2 cores), both timed end to end (worker start-up included).

With ``--main-job``, also the wall time of ``uav-bench run`` with no flags (45 episodes, all cores,
a fresh store, the compile cache as it is).

Usage: ``python benchmarks/bench_harness.py [--quick] [--steps 8] [--max-evals 10000] [--main-job]``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba

from uav_penetration_env import paper_scenario
from uav_penetration_env.benchmark.clock import timed
from uav_penetration_env.benchmark.evaluate import evaluate
from uav_penetration_env.benchmark.policies import make_policy
from uav_penetration_env.env import UAVPenetrationEnv

ROOT = Path(__file__).resolve().parents[1]
sys.path.append(str(ROOT / "tests"))  # appended: tests/optimizers must not shadow optimizers
from numpy_model import NumpyPenetrationModel  # noqa: E402  (the oracle lives under tests/)

SWARM = ("ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism", "pso")
REFERENCES = ("cem", "de", "cmaes")


def planning_profile(
    name: str, steps: int, max_evals: int, numpy_model: bool = False
) -> tuple[float, float, float, float]:
    """Per-MPC-step figures of one planner over ``steps`` steps.

    Returns:
        (planning seconds, share inside rollout_cost, evaluations, optimiser + harness seconds per
        optimiser iteration).
    """
    env = UAVPenetrationEnv(paper_scenario())
    if numpy_model:
        for key, model in env._models.items():  # the env's model cache: swap in the numpy model
            env._models[key] = NumpyPenetrationModel(model.built)
    policy = make_policy(name, max_evals=max_evals)
    observation, info = env.reset(seed=0)
    policy.reset(env.model, 0)
    planning = inside = evaluations = iterations = 0.0
    for _ in range(steps):
        action, clock = timed(policy.act, observation, info)  # the harness's clock (api.md §4.12)
        record = policy.last_record
        planning += clock.wall
        inside += record["objective_seconds"]
        evaluations += record["nfev"]
        iterations += max(1, len(record["history"]) - 1)
        observation, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            observation, info = env.reset(seed=0)
    return planning / steps, inside / planning, evaluations / steps, (planning - inside) / iterations


# scipy's DifferentialEvolutionSolver methods timed by de_overhead_breakdown (inclusive seconds).
DE_PARTS = (
    ("_select_samples", "3-of-N picks: one Generator.shuffle per member"),
    ("_mutate_many", "mutation + crossover (incl. the picks)"),
    ("_accept_trial", "selection: one Python call per member"),
    ("_calculate_population_energies", "objective call + bookkeeping"),
    ("converged", "convergence test (std of the energies)"),
)


def de_overhead_breakdown(max_evals: int, dim: int = 15) -> tuple[float, int, dict[str, float]]:
    """Where DE's own time goes: scipy's solver parts per iteration, on a free objective.

    Runs the project's DE (scipy's ``differential_evolution``, population 100) on ``sum(x^2)``
    (about 10 us per batch) so that nearly all of the time is DE's own, then again with each
    method of :data:`DE_PARTS` wrapped in a timer (the wrappers add about 0.2 us per call).

    Returns:
        (CPU seconds per iteration unwrapped, iterations, {method: seconds per iteration, inclusive}).
    """
    import numpy as np
    from scipy.optimize import Bounds
    from scipy.optimize._differentialevolution import DifferentialEvolutionSolver

    from optimizers import get_optimizer

    optimizer = get_optimizer("de")
    bounds = Bounds(-np.ones(dim), np.ones(dim))

    def run():
        return optimizer.minimize(
            lambda x: (x * x).sum(axis=1), bounds, rng=np.random.default_rng(0), max_evals=max_evals
        )

    run()
    best = np.inf
    for _ in range(3):
        start = time.process_time()
        result = run()
        best = min(best, time.process_time() - start)
    spent = dict.fromkeys((name for name, _ in DE_PARTS), 0.0)
    originals = {name: getattr(DifferentialEvolutionSolver, name) for name in spent}

    def timed(name, method):
        def wrapper(*args, **kwargs):
            start = time.process_time()
            try:
                return method(*args, **kwargs)
            finally:
                spent[name] += time.process_time() - start

        return wrapper

    try:
        for name, method in originals.items():
            setattr(DifferentialEvolutionSolver, name, timed(name, method))
        run()
    finally:
        for name, method in originals.items():
            setattr(DifferentialEvolutionSolver, name, method)
    iterations = max(1, result.nit)
    return best / iterations, iterations, {name: seconds / iterations for name, seconds in spent.items()}


def main_job_seconds() -> float:
    """Wall seconds of ``uav-bench run`` with no flags, into a fresh store and output folder."""
    with tempfile.TemporaryDirectory() as folder:
        command = [
            sys.executable,
            "-c",
            "import sys; from uav_penetration_env.benchmark.cli import main; sys.exit(main(sys.argv[1:]))",
            "run",
            "--store",
            os.path.join(folder, "results.sqlite"),
            "--out",
            os.path.join(folder, "out"),
        ]
        start = time.perf_counter()
        subprocess.run(command, env=dict(os.environ, PYTHONPATH=str(ROOT)), check=True, capture_output=True)
        return time.perf_counter() - start


def sweep_seconds(n_jobs: int, max_evals: int, episodes: int = 8, max_steps: int | None = None) -> float:
    """Wall seconds of an ``evaluate`` sweep of ``episodes`` pso episodes (fresh store, start-up included)."""
    scenario = paper_scenario()
    if max_steps is not None:
        scenario = scenario.updated({"time": {"max_steps": max_steps}})
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        evaluate(
            {"pso": make_policy("pso", max_evals=max_evals)},
            [scenario],
            range(episodes),
            n_jobs=n_jobs,
            store=os.path.join(folder, "sweep.sqlite"),
            progress=False,
        )
        return time.perf_counter() - start


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="tiny budgets (a smoke run, not a measurement)")
    parser.add_argument("--steps", type=int, default=8, help="MPC steps timed per planner")
    parser.add_argument("--max-evals", type=int, default=10_000, help="evaluations per planning step")
    parser.add_argument("--main-job", action="store_true", help="also time `uav-bench run` with no flags")
    parser.add_argument(
        "--sweep-max-evals", type=int, default=5_000, help="evaluations per step in the 8-episode sweep"
    )
    args = parser.parse_args(argv)
    steps = 2 if args.quick else args.steps
    max_evals = 300 if args.quick else args.max_evals
    results: dict[str, float] = {}

    print(
        f"== planning per MPC step (paper scenario, H = 5, {max_evals} evaluations, {steps} steps, 1 thread) =="
    )
    print(
        f"{'planner':<12}{'numpy s':>9}{'compiled s':>12}{'speed-up':>10}"
        f"{'in rollout_cost':>17}{'overhead/iter':>15}{'evals/step':>12}"
    )
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    planning_profile("pso", 1, 300)  # load (or compile) the kernels before anything is timed
    try:
        for name in (*SWARM, *REFERENCES):
            slow, _, _, _ = planning_profile(name, steps, max_evals, numpy_model=True)
            per_step, share, evals, per_iteration = planning_profile(name, steps, max_evals)
            results[f"{name}_share"] = share
            results[f"{name}_speedup"] = slow / per_step
            results[f"{name}_overhead_per_iteration_s"] = per_iteration
            flag = "" if name in REFERENCES or share >= 0.75 else "  <-- overhead above 25 %"
            print(
                f"{name:<12}{slow:>9.4f}{per_step:>12.4f}{slow / per_step:>9.1f}x{share:>16.1%}"
                f"{per_iteration * 1e3:>12.3f} ms{evals:>12.0f}{flag}"
            )
    finally:
        numba.set_num_threads(threads)

    per_iteration, iterations, parts = de_overhead_breakdown(max_evals)
    results["de_own_per_iteration_s"] = per_iteration
    print(
        f"\n== DE's own time per iteration (scipy differential_evolution, population 100, free objective, "
        f"{iterations} iterations) ==\ntotal {per_iteration * 1e3:7.3f} ms per iteration (CPU)"
    )
    for name, meaning in DE_PARTS:
        results[f"de_{name.strip('_')}_per_iteration_s"] = parts[name]
        print(f"  {name:<32}{parts[name] * 1e3:7.3f} ms  {parts[name] / per_iteration:6.1%}  {meaning}")

    sweep_evals = 300 if args.quick else args.sweep_max_evals
    print(
        f"\n== 8-episode sweep (pso, {sweep_evals} evaluations per step), wall time incl. worker start-up =="
    )
    max_steps = 3 if args.quick else None
    one = sweep_seconds(1, sweep_evals, max_steps=max_steps)
    two = sweep_seconds(2, sweep_evals, max_steps=max_steps)
    results["speedup"] = one / two
    print(
        f"n_jobs=1 {one:7.1f} s   n_jobs=2 {two:7.1f} s   speed-up {one / two:4.2f}x  (cores: {os.cpu_count()})"
    )
    if args.main_job:
        seconds = main_job_seconds()
        results["main_job_s"] = seconds
        print(
            f"\n== main job: `uav-bench run` (no flags, {os.cpu_count()} cores) ==\nwall time {seconds:7.1f} s"
        )
    return results


if __name__ == "__main__":
    main()
