"""Choose the MPC terminal cost's default form on scenarios that are in no published table (model.md §7e.4).

Flies the seven MPC planners with each priced terminal form (``NAME-ctg-distance``,
``NAME-ctg-dubins``, ``NAME-ctg-value``), the lattice planner and the greedy floor on procedural
seeds 50000-50007 at difficulties 0.25, 0.5 and 0.75 (one store per difficulty, resumable: run
it again to continue), then prints, per form, the success rate, mean and median total cost, the
per-planner means, every failure with its closest approach to the goal, and the paired
differences between forms (one pair per scenario and planner).

Usage:
    python benchmarks/terminal_cost_selection.py --out results/ctg-selection [--summary-only]
"""

from __future__ import annotations

import argparse
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

PLANNERS = ("ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism", "cmaes")
FORMS = ("distance", "dubins", "value")
DIFFICULTIES = ("0.25", "0.5", "0.75")
SEEDS = "random:50000-50007"  # outside the suites (30000-30219), the held-out set (10000-10049) and the pool


def fly(out: Path, jobs: int) -> None:
    """Run (or resume) the selection sweep, one store per difficulty."""
    policies = [f"{p}-ctg-{f}" for f in FORMS for p in PLANNERS] + ["lattice", "greedy"]
    for difficulty in DIFFICULTIES:
        command = ["uav-bench", "run", "--policies", *policies, "--scenarios", SEEDS, "--difficulty", difficulty,
                   "--seeds", "1", "--store", str(out / f"select-d{difficulty}.sqlite"), "--no-report",
                   "--no-progress", "--jobs", str(jobs)]  # fmt: skip
        subprocess.run(command, check=True)


def episodes(out: Path) -> pd.DataFrame:
    """Every stored episode of the sweep with its difficulty, planner, form and closest approach [km]."""
    frames = []
    for difficulty in DIFFICULTIES:
        path = out / f"select-d{difficulty}.sqlite"
        if not path.exists():
            continue
        with sqlite3.connect(path) as connection:
            e = pd.read_sql("select episode_id, policy, scenario, outcome, total_cost, steps from episodes", connection)
            closest = pd.read_sql(
                "select episode_id, min(distance_to_goal) as closest_km from steps group by episode_id", connection
            )
        e = e.merge(closest, on="episode_id")
        e["difficulty"] = float(difficulty)
        frames.append(e)
    if not frames:
        raise SystemExit(f"terminal_cost_selection: no stores in {out}, run without --summary-only first")
    table = pd.concat(frames, ignore_index=True)
    form = table.policy.str.extract(r"-ctg-(\w+)$")[0]
    table["form"] = form.fillna(table.policy)
    table["planner"] = table.policy.str.replace(r"-ctg-\w+$", "", regex=True)
    return table


def summary(table: pd.DataFrame) -> None:
    pd.set_option("display.width", 160)
    by_form = table.groupby("form").agg(
        episodes=("outcome", "size"),
        success=("outcome", lambda s: float((s == "success").mean())),
        mean=("total_cost", "mean"),
        median=("total_cost", "median"),
    )
    print("per form (all planners, scenarios, difficulties):")
    print(by_form.round(3).to_string())
    print("\nmean total cost per planner and form:")
    print(table.pivot_table(index="planner", columns="form", values="total_cost", aggfunc="mean").round(2).to_string())
    failed = table[table.outcome != "success"]
    print(f"\nfailures ({len(failed)}):")
    if len(failed):
        print(failed[["difficulty", "scenario", "policy", "outcome", "total_cost", "steps", "closest_km"]].to_string(index=False))
    mpc = table[table.form.isin(FORMS)]
    paired = mpc.pivot_table(index=["difficulty", "scenario", "planner"], columns="form", values="total_cost").dropna()
    rng = np.random.default_rng(0)
    print(f"\npaired differences over {len(paired)} (scenario, planner) pairs, 95% bootstrap CI of the mean:")
    for a, b in (("value", "distance"), ("value", "dubins"), ("dubins", "distance")):
        d = (paired[a] - paired[b]).to_numpy()
        boots = rng.choice(d, size=(10_000, d.size)).mean(axis=1)
        low, high = np.percentile(boots, [2.5, 97.5])
        better = int((d < 0).sum())
        print(f"  {a} - {b}: mean {d.mean():+.3f} [{low:+.3f}, {high:+.3f}], median {np.median(d):+.3f}, "
              f"{a} cheaper in {better}/{d.size}")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("results/ctg-selection"), help="folder of the stores")
    parser.add_argument("--jobs", type=int, default=0, help="worker processes (0: all cores)")
    parser.add_argument("--summary-only", action="store_true", help="summarise the stores without flying")
    args = parser.parse_args(argv)
    if not args.summary_only:
        args.out.mkdir(parents=True, exist_ok=True)
        fly(args.out, args.jobs)
    summary(episodes(args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
