"""Where do the agents fly? Altitude above the terrain and radar exposure per policy (docs/rl.md §3.2).

PPO trained 200 k steps learned to reach the goal and then stayed in a high corridor (median about
1 240 m above the terrain against greedy's 108 m), where terrain masking gives no signal. This
prints, for each policy's episode of a stored scenario, the quantities that say whether an agent
still flies that corridor: total J, median and quartiles of the altitude above ground, the share of
steps detected, the mean detection probability and the three cost terms, from the results store's
per-step rows (so any store the harness wrote can be read, e.g. the published one).

```bash
uav-bench run --scenarios paper --policies greedy ihpso sb3:leaderboards/rl/models/ppo-paper-zoo-s0.zip \
    --seeds 1 --store results/corridor.sqlite --no-report
python benchmarks/rl_corridor.py results/corridor.sqlite [--scenario paper-2022-sec5] [--seed 0]
```
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd


def corridor_table(store_path: str | Path, scenario: str = "paper-2022-sec5", seed: int = 0) -> pd.DataFrame:
    """One row per policy: its episode's cost and where it flew (altitudes in m above ground).

    Raises:
        FileNotFoundError: no store at ``store_path``.
        ValueError: no finished episode of ``scenario`` with ``seed`` in the store.
    """
    from uav_penetration_env.benchmark.store import ResultsStore

    if not Path(store_path).is_file():
        raise FileNotFoundError(f"{store_path}: no results store there")
    with ResultsStore(store_path, create=False) as store:
        episodes = store.episodes()
        chosen = episodes[
            (episodes["scenario"] == scenario)
            & (episodes["seed"] == seed)
            & (episodes["error"].fillna("") == "")
        ]
        if chosen.empty:
            known = ", ".join(sorted(set(episodes["scenario"])))
            raise ValueError(
                f"--scenario {scenario} --seed {seed}: no finished episode; stored scenarios: {known}"
            )
        steps = store.steps(chosen["episode_id"].astype(int).tolist())
    rows = []
    for episode in chosen.itertuples():
        flown = steps[steps["episode_id"] == episode.episode_id]
        agl = flown["altitude_agl"].to_numpy(dtype=np.float64)
        rows.append(
            {
                "policy": episode.policy,
                "total J": episode.total_cost,
                "steps": int(episode.steps),
                "AGL median [m]": float(np.median(agl)),
                "AGL q25 [m]": float(np.quantile(agl, 0.25)),
                "AGL q75 [m]": float(np.quantile(agl, 0.75)),
                "detected steps": f"{int(flown['detected'].sum())}/{len(flown)}",
                "mean P(detect)": float(flown["detection_prob"].mean()),
                "terrain Σ": float(flown["terrain_threat_n"].sum()),
                "radar Σ": float(flown["radar_threat_n"].sum()),
                "third Σ": float(flown["third_term_n"].sum()),
            }
        )
    return pd.DataFrame(rows).sort_values("total J", kind="mergesort").reset_index(drop=True)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python benchmarks/rl_corridor.py", description=__doc__.splitlines()[0]
    )
    parser.add_argument("store", help="a results store with the policies' episodes and their steps")
    parser.add_argument(
        "--scenario", default="paper-2022-sec5", help="stored scenario name (default: the paper's)"
    )
    parser.add_argument("--seed", type=int, default=0, help="episode seed (default 0)")
    args = parser.parse_args(argv)
    try:
        table = corridor_table(args.store, args.scenario, args.seed)
    except (FileNotFoundError, ValueError) as error:
        parser.error(str(error))
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
