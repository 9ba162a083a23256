"""What each training formulation changed, over its training seeds (docs/rl.md §6.4).

Reads a results store in which the formulation agents (``sb3:.../ALGO-REGIME-NAME-sS.zip``, the
programme's experiment names) and the reference planners were flown on the paper scenario and on
validation maps, and prints per formulation NAME: the paper scenario's total J of each seed, their
mean with a 95 % percentile-bootstrap interval over the seeds, and on the validation maps the success
share, the mean total J over all seeds' episodes (failures at their penalised cost) and the maps on
which the mean over seeds is cheaper than greedy's. The reference planners (one deterministic run
each) are printed beside them.

```bash
uav-bench run --policies greedy lattice-c40 value-greedy-c40 distill:leaderboards/distill/c40-value-s1 \
    sb3:leaderboards/rl/models/ppo-paper-turn-s0.zip ... \
    --scenarios paper random:50500-50509 --seeds 1 --store results/formulations.sqlite --no-report
python benchmarks/rl_formulations.py results/formulations.sqlite
```
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

PAPER = "paper-2022-sec5"
# The store labels an agent sb3:STEM (a path and .zip are accepted too).
AGENT = re.compile(r"^sb3:(?:.*/)?(?P<algo>[a-z0-9]+)-(?P<regime>paper|random)-(?P<name>.+)-s(?P<seed>\d+)(?:\.zip)?$")
REFERENCES = ("greedy", "lattice-c40", "value-greedy-c40")


def seed_interval(values: np.ndarray, *, seed: int = 0, resamples: int = 10_000) -> tuple[float, float]:
    """95 % percentile-bootstrap interval of the mean of ``values`` (one per training seed)."""
    values = np.asarray(values, dtype=float)
    if len(values) < 2:
        return float("nan"), float("nan")
    rng = np.random.default_rng(seed)
    means = rng.choice(values, size=(resamples, len(values)), replace=True).mean(axis=1)
    low, high = np.percentile(means, [2.5, 97.5])
    return float(low), float(high)


def formulation_table(episodes: pd.DataFrame) -> pd.DataFrame:
    """One row per formulation (agents grouped by NAME) and per reference planner.

    Args:
        episodes: the store's episode rows (``policy``, ``scenario``, ``outcome``, ``total_cost``).

    Raises:
        ValueError: no episode on the paper scenario.
    """
    frame = episodes[episodes["error"].fillna("") == ""].copy()
    if not (frame["scenario"] == PAPER).any():
        raise ValueError(f"episodes: none on {PAPER}; fly the agents there first")
    parsed = frame["policy"].str.extract(AGENT)
    frame["group"] = np.where(parsed["name"].notna(), parsed["algo"] + "-" + parsed["name"], frame["policy"])
    frame["training_seed"] = pd.to_numeric(parsed["seed"])
    validation = frame[frame["scenario"] != PAPER]
    greedy = validation[validation["policy"] == "greedy"].groupby("scenario")["total_cost"].mean()
    rows = []
    for group, rows_of in frame.groupby("group", sort=False):
        paper = rows_of[rows_of["scenario"] == PAPER].groupby("training_seed", dropna=False)["total_cost"].mean()
        val = rows_of[rows_of["scenario"] != PAPER]
        per_map = val.groupby("scenario")["total_cost"].mean()
        shared = per_map.index.intersection(greedy.index)
        low, high = seed_interval(paper.to_numpy())
        rows.append(
            {
                "formulation": group,
                "seeds": int(rows_of["training_seed"].nunique()) if rows_of["training_seed"].notna().any() else 0,
                "paper J per seed": " / ".join(f"{v:.2f}" for v in paper.to_numpy()),
                "paper J mean": float(paper.mean()),
                "paper CI low": low,
                "paper CI high": high,
                "maps": int(per_map.size),
                "validation success": float((val["outcome"] == "success").mean()) if len(val) else float("nan"),
                "validation mean J": float(val["total_cost"].mean()) if len(val) else float("nan"),
                "maps cheaper than greedy": int((per_map[shared] < greedy[shared]).sum()),
            }
        )
    table = pd.DataFrame(rows)
    is_reference = table["formulation"].isin(REFERENCES) | table["formulation"].str.startswith("distill")
    return pd.concat([table[~is_reference], table[is_reference]], ignore_index=True)


def markdown(table: pd.DataFrame) -> str:
    """The table as Markdown, numbers rounded for reading."""
    lines = ["| formulation | seeds | paper J per seed | paper J mean [95% CI over seeds] | validation maps | success | mean J | maps cheaper than greedy |",
             "|---|---:|---|---:|---:|---:|---:|---:|"]  # fmt: skip
    for r in table.itertuples(index=False):
        interval = f" [{r[4]:.2f}, {r[5]:.2f}]" if np.isfinite(r[4]) else ""
        lines.append(
            f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:.2f}{interval} | {r[6]} | {r[7]:.0%} | {r[8]:.2f} | {r[9]}/{r[6]} |"
        )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("store", help="a results store with the agents and references flown")
    args = parser.parse_args(argv)
    from uav_penetration_env.benchmark.store import ResultsStore

    if not Path(args.store).is_file():
        print(f"store: {args.store}: no results store there", file=sys.stderr)
        return 2
    with ResultsStore(args.store, create=False) as store:
        episodes = store.episodes()
    try:
        table = formulation_table(episodes)
    except ValueError as error:
        print(str(error), file=sys.stderr)
        return 2
    print(markdown(table))
    return 0


if __name__ == "__main__":
    sys.exit(main())
