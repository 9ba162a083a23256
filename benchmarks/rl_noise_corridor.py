"""Which altitude pays for a policy that explores like PPO? The greedy floor flown with action noise.

    python benchmarks/rl_noise_corridor.py                                  # the table of docs/rl.md §3.2
    python benchmarks/rl_noise_corridor.py --stds 0.37 --clearances 100 1000 --episodes 5

The greedy floor's rule (`greedy_action`: turn toward the goal, v_max, pitch toward a clearance
above the highest terrain of the next two steps) is flown at several clearances; to each action,
normalised to [-1, 1] by the env's action box, independent Gaussian noise of standard deviation
``std`` is added per channel and the result clipped to the box, as a PPO policy's Gaussian samples
are in the normalised box SB3 trains in (log_std_init = -1: std e^-1 = 0.37). For each (std,
clearance): the share of episodes that crash (terrain, area edge or ceiling), the mean total cost
(total J plus the failure penalty: minus the return a training run estimates), and the noiseless
episode's cost. Episodes draw the noise from ``SeedSequence([seed, std index, clearance index,
episode])``; the env's reset seed is fixed (the paper scenario's start is fixed anyway).
"""

from __future__ import annotations

import argparse

import numpy as np

from uav_penetration_env.benchmark.policies import greedy_action
from uav_penetration_env.catalogue import resolve_scenarios
from uav_penetration_env.env import UAVPenetrationEnv


def noisy_episode(env: UAVPenetrationEnv, clearance_m: float, std: float, rng: np.random.Generator | None) -> tuple[float, bool]:
    """One episode of the greedy rule at ``clearance_m`` with normalised action noise ``std``; (total cost, crashed)."""
    high = np.asarray(env.model.limits.action_high, dtype=np.float64)
    _, info = env.reset(seed=0)
    total, done, truncated = 0.0, False, False
    while not done:
        action = greedy_action(env.model, np.asarray(info["state"], dtype=np.float64), clearance_m=clearance_m)
        if rng is not None and std > 0:
            action = np.clip(action / high + rng.normal(0.0, std, action.shape), -1.0, 1.0) * high
        _, reward, terminated, truncated, info = env.step(action)
        total -= float(reward)
        done = terminated or truncated
    crashed = bool(info.get("collided") or info.get("out_of_area") or info.get("above_ceiling"))
    return total, crashed


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="paper", help="a scenario spec (default: paper)")
    parser.add_argument("--stds", type=float, nargs="+", default=[0.37, 0.15], help="noise std in the normalised box")
    parser.add_argument("--clearances", type=float, nargs="+", default=[100, 200, 400, 700, 1000, 1500],
                        help="greedy clearances [m]")  # fmt: skip
    parser.add_argument("--episodes", type=int, default=20, help="noisy episodes per (std, clearance)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    env = UAVPenetrationEnv(resolve_scenarios(args.scenario)[0])
    print(f"{args.scenario}: the greedy rule with normalised action noise, {args.episodes} episodes each")
    print("std   clearance [m]   noiseless cost   crash rate   mean cost (incl. penalty)   mean cost of the others")
    for i, std in enumerate(args.stds):
        for j, clearance in enumerate(args.clearances):
            clean, _ = noisy_episode(env, clearance, 0.0, None)
            results = [
                noisy_episode(env, clearance, std, np.random.default_rng(np.random.SeedSequence([args.seed, i, j, k])))
                for k in range(args.episodes)
            ]
            costs = np.array([cost for cost, _ in results])
            crashed = np.array([crash for _, crash in results])
            others = f"{costs[~crashed].mean():8.2f}" if (~crashed).any() else "       -"
            print(f"{std:4.2f}   {clearance:13.0f}   {clean:14.2f}   {crashed.mean():10.0%}   {costs.mean():25.2f}   {others}")


if __name__ == "__main__":
    main()
