"""Training speed of the SB3 baselines, to size tuning trials and long runs (docs/rl.md §1.3).

Trains PPO, SAC and TD3 on the paper scenario (one torch thread, 8 envs, no evaluation) with
the untuned sets and with the slowest and fastest corners of the tuning search spaces, and prints
environment steps per second and the seconds a tuning trial of ``baselines.tune.DEFAULT_TIMESTEPS``
would take at that speed.

    python benchmarks/bench_rl.py            # ~5 min on one free core
    python benchmarks/bench_rl.py --quick    # a smoke run (seconds)
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

# name -> (algorithm, overrides of baselines/hyperparams/ALGO.yaml, steps measured)
CASES = {
    "ppo untuned (64x64, 10 epochs, batch 128)": ("ppo", {}, 40_000),
    "ppo slow corner (256x256, 20 epochs, batch 64)": (
        "ppo",
        {
            "n_epochs": 20,
            "batch_size": 64,
            "policy_kwargs": {"net_arch": {"pi": [256, 256], "vf": [256, 256]}},
        },
        16_000,
    ),
    "ppo fast corner (64, 5 epochs, batch 512)": (
        "ppo",
        {"n_epochs": 5, "batch_size": 512, "policy_kwargs": {"net_arch": {"pi": [64], "vf": [64]}}},
        40_000,
    ),
    "sac untuned (256x256, 2 updates / 8 transitions)": ("sac", {"learning_starts": 1000}, 8_000),
    "sac 1 update / transition (256x256)": (
        "sac",
        {"learning_starts": 1000, "train_freq": 1, "gradient_steps": 8},
        4_000,
    ),
    "td3 untuned (256x256, 1 update / vector step)": (
        "td3",
        {"learning_starts": 1000, "gradient_steps": 1},
        8_000,
    ),
}


def main(argv: list[str] | None = None) -> dict[str, float]:
    """Run the cases; print steps/s and the implied seconds per tuning trial; return steps/s by case."""
    from baselines import train_agent
    from baselines.tune import DEFAULT_TIMESTEPS

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="a few hundred steps per case")
    args = parser.parse_args(argv)
    speeds = {}
    with tempfile.TemporaryDirectory() as folder:
        for name, (algo, overrides, steps) in CASES.items():
            if args.quick:
                steps = 256
                overrides = {**overrides, **({"learning_starts": 64} if algo != "ppo" else {"n_steps": 32})}
            started = time.perf_counter()
            train_agent(
                algo, total_timesteps=steps, n_envs=8, seed=0, out=Path(folder) / f"{algo}.zip",
                hyperparams=overrides, eval_freq=0, checkpoint_freq=0, torch_threads=1,
            )  # fmt: skip
            seconds = time.perf_counter() - started
            speeds[name] = steps / seconds
            trial = DEFAULT_TIMESTEPS[algo] / speeds[name]
            print(
                f"{name:52s} {speeds[name]:8.0f} steps/s  -> a {DEFAULT_TIMESTEPS[algo]}-step trial: "
                f"{trial / 60:5.1f} min",
                flush=True,
            )
    return speeds


if __name__ == "__main__":
    main()
