"""Why MPC episodes fail: how close each failed episode came to the goal, and where it ended.

On the leaderboard v2 sweep most failed MPC episodes are not crashes on the way: the UAV passes the
goal several kilometres off, flies on and ends at the map edge (docs/optimizers.md §5.6). This
script prints, from a results store, per scenario group (one scenario, or a frozen suite's
difficulty level) and policy: the episodes, the failures by outcome, the median closest approach
to the goal of the failed episodes (and of the successful ones), and how many failures ended
within 5 km of the map's edge.

Usage: ``python benchmarks/goal_misses.py STORE [--policies NAME ...]``.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from anywhere: the package of this checkout
    sys.path.insert(0, str(ROOT))

from uav_penetration_env.benchmark.families import MPC_FAMILIES, policy_family  # noqa: E402
from uav_penetration_env.benchmark.rows import store_tables  # noqa: E402
from uav_penetration_env.benchmark.store import ResultsStore  # noqa: E402

EDGE_KM = 5.0  # "at the edge": the track ends within this distance of the map boundary


def scenario_group(name: str) -> str:
    """``random-30006`` -> ``uavpen-v1 d0.25`` and the like; other scenarios keep their name."""
    if name.startswith("random-"):
        seed = int(name.split("-")[1])
        for first, label in ((30000, "uavpen-v1 d0.25"), (30100, "uavpen-v1 d0.50"), (30200, "uavpen-v1 d0.75"),
                             (10000, "uavpen-heldout-v1")):  # fmt: skip
            if first <= seed < first + 100:
                return label
    return name


def approaches(store: str | Path, policies: Sequence[str] | None = None) -> pd.DataFrame:
    """One row per finished MPC episode: outcome, closest approach to the goal [km], distance of its end to the map edge [km].

    Raises:
        FileNotFoundError: no store at ``store``.
    """
    tables = store_tables(store)
    episodes = tables.episodes
    episodes = episodes[(episodes["error"].fillna("") == "") & episodes["policy"].map(
        lambda p: policy_family(str(p)) in MPC_FAMILIES)]  # fmt: skip
    if policies:
        episodes = episodes[episodes["policy"].isin(policies)]
    with ResultsStore(store, create=False) as s:
        steps = s.steps(episodes["episode_id"].astype(int).tolist())
        scenarios = s.scenarios()
    closest = steps.groupby("episode_id")["distance_to_goal"].min()
    last = steps.sort_values("step").groupby("episode_id")[["x_km", "y_km"]].last()
    bounds = {}
    for scenario_hash, (_, text) in scenarios.items():
        data = yaml.safe_load(text) if text else {}
        area = (data or {}).get("map", {})
        if "x_km" in area and "y_km" in area:
            bounds[scenario_hash] = (*area["x_km"], *area["y_km"])
    rows = []
    for r in episodes.itertuples():
        box = bounds.get(str(r.scenario_hash))
        end = last.loc[r.episode_id] if r.episode_id in last.index else None
        edge = (
            float(min(end.x_km - box[0], box[1] - end.x_km, end.y_km - box[2], box[3] - end.y_km))
            if box is not None and end is not None
            else np.nan
        )
        rows.append({"group": scenario_group(str(r.scenario)), "policy": r.policy, "outcome": r.outcome,
                     "closest_km": float(closest.get(r.episode_id, np.nan)), "edge_km": edge})  # fmt: skip
    return pd.DataFrame(rows)


def summary(frame: pd.DataFrame) -> pd.DataFrame:
    """Per (group, policy): episodes, failures by outcome, median closest approach of failures and successes, failures ending at the edge."""
    out = []
    for (group, policy), rows in frame.groupby(["group", "policy"], sort=True):
        failed = rows[rows["outcome"] != "success"]
        out.append({
            "group": group, "policy": policy, "episodes": len(rows), "failed": len(failed),
            "collided": int((failed["outcome"] == "collided").sum()),
            "out_of_area": int((failed["outcome"] == "out_of_area").sum()),
            "truncated": int((failed["outcome"] == "truncated").sum()),
            "closest_km_failed": float(failed["closest_km"].median()) if len(failed) else np.nan,
            "closest_km_success": float(rows.loc[rows["outcome"] == "success", "closest_km"].median())
            if (rows["outcome"] == "success").any() else np.nan,
            "failed_at_edge": int((failed["edge_km"] < EDGE_KM).sum()),
        })  # fmt: skip
    return pd.DataFrame(out)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python benchmarks/goal_misses.py", description=__doc__.splitlines()[0])
    parser.add_argument("store", help="results store (SQLite)")
    parser.add_argument("--policies", nargs="+", default=None, help="only these policies")
    args = parser.parse_args(argv)
    if not Path(args.store).is_file():
        parser.error(f"store {args.store}: not found; expected an SQLite file from `uav-bench run`")
    table = summary(approaches(args.store, args.policies))
    failing = table[table["failed"] > 0]
    with pd.option_context("display.width", 160, "display.max_rows", 500):
        print(f"{int(table['failed'].sum())} failed of {int(table['episodes'].sum())} MPC episodes; "
              f"{int(table['failed_at_edge'].sum())} failures ended within {EDGE_KM:g} km of the map edge")  # fmt: skip
        print(failing.round(2).to_string(index=False) if len(failing) else "no failed MPC episode")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
