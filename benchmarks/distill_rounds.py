"""Each round's network of a distillation run alone on one scenario; one round's episode step by step.

    python benchmarks/distill_rounds.py results/distill/lattice-s0 paper            # every round
    python benchmarks/distill_rounds.py results/distill/lattice-s0 paper 8          # and round 8 in full
    python benchmarks/distill_rounds.py results/distill/lattice-s0 random:10001 3   # a held-out member

Each printed step shows the exact state, and the normalised action of the network next to the one
the run's expert (its ``config.json``; ``lattice`` for a Python-object expert) would take from that state (docs/rl.md §4.6 reads the crashes from this).
The episode seed is the harness's seed 0 (`episode_seeds(0, scenario.hash)`), as `uav-bench run`.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from baselines.distill import load_distill_policy
from baselines.distill.episodes import normalisers
from uav_penetration_env.benchmark.policies import make_policy
from uav_penetration_env.benchmark.seeding import episode_seeds
from uav_penetration_env.catalogue import resolve_scenarios
from uav_penetration_env.env import UAVPenetrationEnv


def _line(info, learner, expert) -> str:
    s = info["state"]
    return (
        f"k={info['step']:3d} x={s[0] / 1000:6.1f} y={s[1] / 1000:6.1f} z={s[2]:6.0f} agl={info['altitude_agl']:6.0f} "
        f"v={s[3]:5.2f} psi={np.degrees(s[4]):7.1f} th={np.degrees(s[5]):6.1f} dist={info['distance_to_goal']:6.1f} "
        f"learner={np.round(learner, 2)} expert={np.round(expert, 2)}"
    )


def fly(env, scenario, policy, verbose: bool, expert_spec: str = "lattice") -> tuple[float, float, int, str]:
    env_seed, policy_seed = episode_seeds(0, scenario.hash)
    observation, info = env.reset(seed=env_seed)
    policy.reset(env.model, policy_seed)
    expert = make_policy(expert_spec)
    expert.reset(env.model, None)
    to_unit, _ = normalisers(env.model)
    total_j, steps, done = 0.0, 0, False
    while not done:
        action = policy.act(observation, info)
        if verbose:
            print(_line(info, to_unit(action), to_unit(expert.act(observation, info))))
        observation, _, terminated, truncated, info = env.step(action)
        total_j += info["J"]
        steps += 1
        done = terminated or truncated
    outcome = next((f for f in ("reached_goal", "collided", "out_of_area") if info[f]), "truncated")
    return total_j, info["penalty"], steps, outcome


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="the run folder (OUT of uav-bench distill)")
    parser.add_argument("scenario", help="a scenario spec (paper, random:SEED, ...)")
    parser.add_argument("detail", type=int, nargs="?", default=-1, help="a round to print step by step")
    args = parser.parse_args()
    # The expert the run imitated (its config.json), so each step compares with the labeller's action.
    config = args.run / "config.json"
    expert = json.loads(config.read_text()).get("expert", "lattice") if config.is_file() else "lattice"
    expert = expert if isinstance(expert, str) else "lattice"
    scenario = resolve_scenarios(args.scenario)[0]
    env = UAVPenetrationEnv(scenario)
    k = 0
    while (args.run / "nets" / f"round-{k}.npz").is_file():
        policy = load_distill_policy(args.run / "nets" / f"round-{k}.npz")
        total_j, penalty, steps, outcome = fly(env, scenario, policy, k == args.detail, expert)
        print(f"round {k}: total J {total_j + penalty:.2f} (J {total_j:.2f} + penalty {penalty:.0f}), {steps} steps, {outcome}")
        k += 1


if __name__ == "__main__":
    main()
