"""Harness speed, measured in one run on the paper scenario (issue 5's targets).

Prints, for each planner as an MPC policy (horizon 5, ``--max-evals`` per step):
* planning seconds per MPC step;
* the share of it spent inside ``model.rollout_cost`` (the rest is optimiser + harness overhead;
  target: overhead < 25 % for every swarm planner);
and the speed-up of ``n_jobs=2`` over ``n_jobs=1`` on a sweep of 8 episodes (target: >= 1.7x on
2 cores), both timed end to end (worker start-up included).

Usage: ``python benchmarks/bench_harness.py [--quick] [--steps 8] [--max-evals 10000]``.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

from uav_penetration_env import paper_scenario
from uav_penetration_env.benchmark.evaluate import evaluate
from uav_penetration_env.benchmark.policies import make_policy
from uav_penetration_env.env import UAVPenetrationEnv

SWARM = ("ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism", "pso")
REFERENCES = ("cem", "de", "cmaes")


def planning_profile(name: str, steps: int, max_evals: int) -> tuple[float, float, float]:
    """(planning seconds per step, share inside rollout_cost, evaluations per step) over ``steps`` MPC steps."""
    env = UAVPenetrationEnv(paper_scenario())
    policy = make_policy(name, max_evals=max_evals)
    observation, info = env.reset(seed=0)
    policy.reset(env.model, 0)
    planning = inside = evaluations = 0.0
    for _ in range(steps):
        action = policy.act(observation, info)
        record = policy.last_record
        planning += record["planning_seconds"]
        inside += record["objective_seconds"]
        evaluations += record["nfev"]
        observation, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            observation, info = env.reset(seed=0)
    return planning / steps, inside / planning, evaluations / steps


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
    parser.add_argument(
        "--sweep-max-evals", type=int, default=5_000, help="evaluations per step in the 8-episode sweep"
    )
    args = parser.parse_args(argv)
    steps = 2 if args.quick else args.steps
    max_evals = 300 if args.quick else args.max_evals
    results: dict[str, float] = {}

    print(f"== planning per MPC step (paper scenario, H = 5, {max_evals} evaluations, {steps} steps) ==")
    print(f"{'planner':<12}{'s/step':>9}{'in rollout_cost':>17}{'overhead':>10}{'evals/step':>12}")
    for name in (*SWARM, *REFERENCES):
        per_step, share, evals = planning_profile(name, steps, max_evals)
        results[f"{name}_share"] = share
        flag = "" if name in REFERENCES or share >= 0.75 else "  <-- overhead above 25 %"
        print(f"{name:<12}{per_step:>9.3f}{share:>16.1%}{1 - share:>10.1%}{evals:>12.0f}{flag}")

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
    return results


if __name__ == "__main__":
    main()
