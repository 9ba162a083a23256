"""Leaderboard v3 as published: its tables agree with its committed rows (docs/publishing.md §5.5).

The tables in ``leaderboards/v3`` were written from the v3 store; its rows are the checkpoint chunks
in ``leaderboards/v3-checkpoint``. The fast test counts episodes and successes per policy from the
chunks' episode tables (integers, no platform float) and compares them with the installed CSVs;
the slow one rebuilds every table from the chunks, as a reader would, and compares the bytes.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.rows import checkpoint_stems, read_table

LEADERBOARDS = Path(__file__).resolve().parents[1] / "leaderboards"
PUBLISHED, CHECKPOINT = LEADERBOARDS / "v3", LEADERBOARDS / "v3-checkpoint"


def checkpoint_episodes() -> pd.DataFrame:
    columns = ("policy", "scenario", "seed", "outcome")
    return pd.concat([read_table(stem, "episodes", columns) for stem in checkpoint_stems(CHECKPOINT)])


@pytest.mark.parametrize("scenario", ["paper-2022-sec5", "paper-2022-sec5-w2"])
def test_the_installed_scenario_tables_count_the_committed_episodes(scenario):
    episodes = checkpoint_episodes()
    flown = episodes[episodes.scenario == scenario]
    table = pd.read_csv(PUBLISHED / f"{scenario}.csv", index_col="policy")
    counted = flown.groupby("policy").agg(
        episodes=("seed", "size"), successes=("outcome", lambda o: (o == "success").sum())
    )
    assert set(table.index) == set(counted.index)
    for policy, row in counted.iterrows():
        assert (int(table.loc[policy, "episodes"]), int(table.loc[policy, "successes"])) == (
            int(row.episodes),
            int(row.successes),
        ), policy


def test_the_checkpoint_names_every_chunk_it_holds():
    named = {stem.name for stem in checkpoint_stems(CHECKPOINT)}
    on_disk = {path.name.split("-episodes")[0] for path in CHECKPOINT.glob("chunk-*-episodes.parquet")}
    assert named == on_disk and len(named) >= 7


@pytest.mark.slow
def test_every_v3_table_rebuilds_from_the_committed_chunks(tmp_path):
    """``uav-bench leaderboard --rows leaderboards/v3-checkpoint`` gives every table, apart from its date line."""
    out = tmp_path / "rebuilt"
    argv = ["leaderboard", "--rows", str(CHECKPOINT), "--out", str(out), "--fixed-target-rule", "worse-final"]
    assert cli.main(argv) == 0
    rebuilt = sorted(p.name for p in out.iterdir() if p.suffix in (".md", ".csv"))
    published = sorted(p.name for p in PUBLISHED.iterdir() if p.suffix in (".md", ".csv"))
    assert rebuilt == published
    dated = ("- Date:", "Date:")  # the one line a rebuild may change (publish.date_free)
    for name in rebuilt:
        got, expected = ((folder / name).read_text().splitlines() for folder in (out, PUBLISHED))
        assert [x for x in got if not x.startswith(dated)] == [
            x for x in expected if not x.startswith(dated)
        ], name
