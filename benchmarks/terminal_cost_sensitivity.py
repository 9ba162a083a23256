"""The terminal-cost sensitivity of the paper-scenario conclusions (model.md §7e, issue: cost-to-go).

Flies the seven MPC planners under each priced terminal form (``NAME-ctg-value``,
``NAME-ctg-distance``, ``NAME-ctg-dubins``), the lattice planner and the greedy floor on the paper
scenario for 20 paired seeds (one resumable store), then prints per form and planner the success
rate, mean and IQM total cost, and IHPSO against HPSO paired by seed (mean difference with a
seeded 95 % bootstrap CI, Wilcoxon signed-rank p), so a reader sees which conclusions hold under
every form.

Usage:
    python benchmarks/terminal_cost_sensitivity.py --store results/ctg-sensitivity/paper.sqlite [--summary-only]
"""

from __future__ import annotations

import argparse
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

PLANNERS = ("ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism", "cmaes")
FORMS = ("value", "distance", "dubins")


def fly(store: Path, seeds: int, jobs: int) -> None:
    policies = [f"{p}-ctg-{f}" for f in FORMS for p in PLANNERS] + ["lattice", "greedy"]
    command = ["uav-bench", "run", "--policies", *policies, "--scenarios", "paper", "--seeds", str(seeds),
               "--store", str(store), "--no-report", "--no-progress", "--jobs", str(jobs)]  # fmt: skip
    subprocess.run(command, check=True)


def iqm(values: np.ndarray) -> float:
    """Interquartile mean: the mean of the middle 50 % (rliable's aggregate)."""
    return float(stats.trim_mean(values, 0.25))


def summary(store: Path) -> None:
    with sqlite3.connect(store) as connection:
        e = pd.read_sql("select policy, seed, outcome, total_cost from episodes", connection)
    e["form"] = e.policy.str.extract(r"-ctg-(\w+)$")[0].fillna("-")
    e["planner"] = e.policy.str.replace(r"-ctg-\w+$", "", regex=True)
    table = e.groupby(["form", "planner"]).agg(
        seeds=("seed", "nunique"),
        success=("outcome", lambda s: float((s == "success").mean())),
        mean=("total_cost", "mean"),
        iqm=("total_cost", lambda s: iqm(s.to_numpy())),
    )
    pd.set_option("display.width", 160)
    print(table.round(3).to_string())
    rng = np.random.default_rng(0)
    print("\nIHPSO - HPSO, paired by seed:")
    for form in FORMS:
        both = e[e.form == form].pivot_table(index="seed", columns="planner", values="total_cost")
        if not {"ihpso", "hpso"} <= set(both.columns):
            continue
        d = (both["ihpso"] - both["hpso"]).dropna().to_numpy()
        if d.size < 2:
            continue
        boots = rng.choice(d, size=(10_000, d.size)).mean(axis=1)
        low, high = np.percentile(boots, [2.5, 97.5])
        p = stats.wilcoxon(d).pvalue if np.any(d != 0) else 1.0
        print(f"  {form:8s} n={d.size:2d}: mean {d.mean():+.3f} [{low:+.3f}, {high:+.3f}], "
              f"median {np.median(d):+.3f}, IHPSO cheaper on {int((d < 0).sum())}, Wilcoxon p={p:.3g}")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--store", type=Path, default=Path("results/ctg-sensitivity/paper.sqlite"))
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--jobs", type=int, default=0, help="worker processes (0: all cores)")
    parser.add_argument("--summary-only", action="store_true", help="summarise the store without flying")
    args = parser.parse_args(argv)
    if not args.summary_only:
        args.store.parent.mkdir(parents=True, exist_ok=True)
        fly(args.store, args.seeds, args.jobs)
    summary(args.store)
    return 0


if __name__ == "__main__":
    sys.exit(main())
