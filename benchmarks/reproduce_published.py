"""Compare a re-run sweep with the published episode rows (do seeded runs reproduce?).

The current publication, leaderboard v3 (leaderboards/README.md, docs/publishing.md §5), commits its
episodes as the Parquet chunks of ``leaderboards/v3-checkpoint/`` (its ``manifest.json`` names them);
that folder is the default. ``--published`` also takes leaderboard v2's rows
(``leaderboards/rows/leaderboard``, a row-table stem, docs/publishing.md §3), any checkpoint folder
or export stem, and version 1's episode CSVs (``results-*-episodes.csv``, the numpy model).
The compiled model is deterministic, so on the machine that recorded them the episodes reproduce bit
for bit; elsewhere a last-digit difference of the floating-point library can flip a comparison
inside an optimiser and the trajectories part. This script matches each episode of a results store
with the published row of the same policy, scenario and seed, and prints, per policy, how many
reproduce exactly (total J bit for bit, the same steps and outcome) and the relative total-J
difference of the others, then one line per episode that differs.

Re-run part of the published paper-scenario sweep (one command line; v3 flies the current MPC
defaults, the lattice value function as terminal cost):

    nice -n 10 uav-bench run --policies hpso lpso ps2o mcpso ccpso-ism pso cem de cmaes greedy
        --scenarios paper --seeds 5 --max-evals 10000 --store /tmp/repro.sqlite --no-report
    python benchmarks/reproduce_published.py /tmp/repro.sqlite

Episodes still missing from the store (a sweep in progress) are counted as missing, not as failures.

Usage: ``python benchmarks/reproduce_published.py STORE [--published CHECKPOINT_FOLDER | ROWS_STEM | CSV]``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import pandas as pd

from uav_penetration_env.benchmark.rows import RowsError, read_chunks
from uav_penetration_env.benchmark.store import ResultsStore

ROOT = Path(__file__).resolve().parents[1]
PUBLISHED = ROOT / "leaderboards" / "v3-checkpoint"  # the current publication's rows (leaderboards/README.md)
KEY = ["policy", "scenario", "seed"]
# Same steps and outcome, total J within rounding: the trajectory is the published one to the last
# digits (the compiled model's 1e-15 differences summed over an episode), not a different path.
RTOL_ROUNDING = 1e-12


def compare(store_episodes: pd.DataFrame, published: pd.DataFrame) -> pd.DataFrame:
    """One row per re-run episode with its published counterpart and the differences.

    Args:
        store_episodes: the store's episodes (columns policy, scenario, seed, outcome, total_J, steps).
        published: the published episode rows (the same columns).

    Returns:
        Columns ``policy, scenario, seed``, the re-run and published ``total_J``, ``steps`` and
        ``outcome``, ``relative_dJ`` ((re-run - published) / |published|), ``exact`` (total J bit for
        bit, same steps and outcome) and ``published_found``.
    """
    columns = [*KEY, "outcome", "total_J", "steps"]
    rerun = (
        store_episodes[store_episodes["error"].fillna("") == ""][columns]
        if "error" in store_episodes
        else (store_episodes[columns])
    )
    merged = rerun.merge(
        published[columns], on=KEY, how="left", suffixes=("", "_published"), indicator="found"
    )
    merged["published_found"] = merged.pop("found") == "both"
    merged["relative_dJ"] = (merged["total_J"] - merged["total_J_published"]) / merged[
        "total_J_published"
    ].abs()
    merged["exact"] = (
        merged["published_found"]
        & (merged["total_J"] == merged["total_J_published"])
        & (merged["steps"] == merged["steps_published"])
        & (merged["outcome"] == merged["outcome_published"])
    )
    return merged.sort_values(KEY).reset_index(drop=True)


def summary(compared: pd.DataFrame, published: pd.DataFrame) -> pd.DataFrame:
    """Per policy: episodes re-run, exact reproductions, and the relative total-J differences of the others.

    Columns: episodes re-run, published rows (all seeds), exact reproductions, reproductions to
    rounding (:data:`RTOL_ROUNDING`), same outcome, episodes not exact and their |dJ| / J.
    """
    rows = []
    for policy, group in compared.groupby("policy", sort=True):
        found = group[group["published_found"]]
        differing = found[~found["exact"]]
        scenarios = set(group["scenario"])
        expected = published[(published["policy"] == policy) & published["scenario"].isin(scenarios)]
        rows.append(
            {
                "policy": policy,
                "rerun": len(group),
                "published": len(expected),
                "exact": int(found["exact"].sum()),
                "within_1e-12": int(
                    (
                        (found["relative_dJ"].abs() <= RTOL_ROUNDING)
                        & (found["steps"] == found["steps_published"])
                        & (found["outcome"] == found["outcome_published"])
                    ).sum()
                ),
                "same_outcome": int((found["outcome"] == found["outcome_published"]).sum()),
                "differing": len(differing),
                "median_|dJ|/J": float(differing["relative_dJ"].abs().median())
                if len(differing)
                else math.nan,
                "max_|dJ|/J": float(differing["relative_dJ"].abs().max()) if len(differing) else math.nan,
                "mean_dJ/J": float(differing["relative_dJ"].mean()) if len(differing) else math.nan,
            }
        )
    return pd.DataFrame(rows)


def read_published(source: str | Path) -> pd.DataFrame:
    """The published episodes: an episode CSV, a checkpoint folder's chunks, or a row export (its stem).

    Raises:
        SystemExit: one line naming ``--published`` when neither can be read.
    """
    if str(source).endswith(".csv"):
        if not Path(source).is_file():
            raise SystemExit(f"--published {source}: no such file; expected an episode CSV")
        return pd.read_csv(source)
    try:
        return read_chunks([source]).episodes  # a checkpoint folder stands for its chunks
    except RowsError as error:
        raise SystemExit(f"--published {source}: {error}") from None


def main(argv: list[str] | None = None) -> pd.DataFrame:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("store", help="results store (sqlite) of the re-run")
    parser.add_argument(
        "--published",
        default=str(PUBLISHED),
        help="published episode rows: a checkpoint folder (default: leaderboard v3's), a row-table stem "
        "(uav-bench export; v2: leaderboards/rows/leaderboard) or an episode CSV",
    )
    args = parser.parse_args(argv)
    if not Path(args.store).is_file():
        parser.error(f"store: got {args.store!r}, expected an existing results store (sqlite file)")
    published = read_published(args.published)
    with ResultsStore(args.store, create=False) as store:
        episodes = store.episodes()
    compared = compare(episodes, published)
    table = summary(compared, published)
    pd.set_option("display.width", 160)
    print(f"== re-run {args.store} against {args.published} ==")
    print(table.to_string(index=False, float_format=lambda value: f"{value:.3g}"))
    found = compared[compared["published_found"]]
    print(
        f"\ntotal: {len(compared)} episodes re-run, {int(found['exact'].sum())} reproduce exactly, "
        f"{int((found['outcome'] == found['outcome_published']).sum())} with the same outcome, "
        f"{int((~compared['published_found']).sum())} without a published row"
    )
    differing = found[~found["exact"]]
    if len(differing):
        print("\nepisodes that differ:")
        shown = differing[
            [
                *KEY,
                "total_J",
                "total_J_published",
                "relative_dJ",
                "steps",
                "steps_published",
                "outcome",
                "outcome_published",
            ]
        ]
        print(shown.to_string(index=False))
    return compared


if __name__ == "__main__":
    sys.exit(0 if main() is not None else 1)
