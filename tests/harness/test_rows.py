"""Leaderboards recomputed from exported rows, with no store (api.md §4.7).

The published tables must be recomputable from committed rows alone: ``export`` then
``leaderboard --rows`` gives the same files as ``leaderboard --store``, byte for byte apart from
the lines that name the date and the command.
"""

from __future__ import annotations

import pytest

from tests.conftest import tiny_scenario
from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.commands.common import OUT_SOURCE_FILE
from uav_penetration_env.benchmark.rows import RowsError, read_rows

VOLATILE = ("- Date: ",)  # the date line (with the command) is the only line that may differ


def run_cli(*argv):
    return cli.main([str(a) for a in argv])


def stable_lines(path):
    return [line for line in path.read_text().splitlines() if not line.startswith(VOLATILE)]


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rows")
    scenario = str(tiny_scenario(time={"max_steps": 12}).to_yaml(folder / "tiny.yaml"))
    store = folder / "r.sqlite"
    assert run_cli("run", "--policies", "greedy", "pso", "--scenarios", scenario, "--seeds", "2",
                   "--max-evals", "200", "--horizon", "3", "--store", store, "--jobs", "1",
                   "--no-report", "--no-progress") == 0  # fmt: skip
    assert run_cli("windows", "--store", store, "--from-policy", "greedy", "--scenario", "tiny", "--steps", "2",
                   "--optimizers", "ihpso", "hpso", "--seeds", "2", "--max-evals", "200", "--horizon", "3") == 0  # fmt: skip
    for fmt in ("parquet", "csv"):
        assert run_cli("export", "--format", fmt, "--store", store, "--out", folder / fmt / "published") == 0
    return folder, store


def test_rows_reproduce_the_store_leaderboards_in_both_formats(exported):
    folder, store = exported
    assert run_cli("leaderboard", "--store", store, "--out", folder / "from-store") == 0
    for fmt in ("parquet", "csv"):
        out = folder / f"from-{fmt}"
        assert run_cli("leaderboard", "--rows", folder / fmt / "published", "--out", out) == 0
        # every file alike but the folder's record of its source (the store, or the rows: api.md §4.7)
        reference = sorted(p.name for p in (folder / "from-store").iterdir() if p.name != OUT_SOURCE_FILE)
        assert sorted(p.name for p in out.iterdir() if p.name != OUT_SOURCE_FILE) == reference
        assert (out / OUT_SOURCE_FILE).read_text().strip() == str((folder / fmt / "published").resolve())
        assert any(name.endswith("-fixed-target.md") for name in reference)  # window rows travel too
        for name in reference:
            expected, got = folder / "from-store" / name, out / name
            if name.endswith(".csv"):
                assert got.read_bytes() == expected.read_bytes(), f"{fmt}: {name}"
            else:
                assert stable_lines(got) == stable_lines(expected), f"{fmt}: {name}"


def test_parquet_row_tables_are_zstd_compressed(exported):
    import pyarrow.parquet as pq

    folder, _ = exported
    tables = sorted((folder / "parquet").glob("published-*.parquet"))
    assert tables
    for path in tables:
        metadata = pq.ParquetFile(path).metadata
        codecs = {metadata.row_group(0).column(i).compression for i in range(metadata.num_columns)}
        assert codecs == {"ZSTD"}, path.name


def test_the_same_rows_give_the_same_bytes_apart_from_the_date(exported):
    folder, _ = exported
    out = folder / "again"
    rebuild = ("leaderboard", "--rows", folder / "parquet" / "published", "--out", out)
    assert run_cli(*rebuild) == 0
    first = {path.name: path.read_text().splitlines() for path in out.iterdir()}
    assert run_cli(*rebuild) == 0
    for name, lines in first.items():
        again = (out / name).read_text().splitlines()
        assert [line for line in again if not line.startswith("- Date: ")] == [
            line for line in lines if not line.startswith("- Date: ")
        ], name


def test_csv_rows_keep_the_store_types(exported):
    folder, _ = exported
    from uav_penetration_env.benchmark.rows import store_tables

    parquet, csv = read_rows(folder / "parquet" / "published"), read_rows(folder / "csv" / "published")
    stored = store_tables(exported[1])
    for name in ("episodes", "runs", "window_runs"):
        a, b, c = getattr(stored, name), getattr(parquet, name), getattr(csv, name)
        assert list(a.columns) == list(b.columns) == list(c.columns)
        for column in a.columns:
            assert a[column].dtype.kind == c[column].dtype.kind or a[column].isna().all(), (name, column)
        assert (a["total_cost"] == c["total_cost"]).all() if name == "episodes" else True


def test_missing_rows_and_two_sources_are_refused_in_one_line(exported, tmp_path, capsys):
    folder, store = exported
    with pytest.raises(RowsError, match="no episodes table; expected"):
        read_rows(tmp_path / "nothing")
    assert run_cli("leaderboard", "--rows", tmp_path / "nothing", "--out", tmp_path / "o") == 2
    assert "--rows" in capsys.readouterr().err
    assert run_cli("leaderboard", "--rows", folder / "csv" / "published", "--store", store,
                   "--out", tmp_path / "o") == 2  # fmt: skip
    assert "not both" in capsys.readouterr().err
    mixed = tmp_path / "mixed"
    for fmt in ("parquet", "csv"):
        assert run_cli("export", "--format", fmt, "--store", store, "--out", mixed / "x") == 0
    with pytest.raises(RowsError, match=r"both x-episodes\.parquet and x-episodes\.csv exist"):
        read_rows(mixed / "x")


def split_export(folder, store, target):
    """The store's export in two chunks by run (the `run` command's run, then the `windows` run), with a manifest."""
    import json

    from uav_penetration_env.benchmark.rows import EXPORT_TABLES, read_table, row_path, write_table

    frames = {table: read_table(folder / "parquet" / "published", table) for table in EXPORT_TABLES}
    runs = sorted(frames["runs"].run_id)
    assert len(runs) == 2  # the fixture's run and windows commands
    names = []
    for index, run_id in enumerate(runs, start=1):
        episodes = frames["episodes"][frames["episodes"].run_id == run_id]
        chunk = {
            "runs": frames["runs"][frames["runs"].run_id == run_id],
            "episodes": episodes,
            "window_runs": frames["window_runs"][frames["window_runs"].run_id == run_id],
            "steps": frames["steps"][frames["steps"].episode_id.isin(set(episodes.episode_id))],
            "scenarios": frames["scenarios"],
            "policies": frames["policies"],
        }
        name = f"chunk-{index:03d}"
        for table, frame in chunk.items():
            write_table(frame, row_path(target / name, table, "parquet"), "parquet")
        names.append(name)
    (target / "manifest.json").write_text(json.dumps({"seeds": [], "chunks": [{"name": n} for n in names]}))
    return [target / n for n in names]


def test_a_checkpoint_folder_and_its_chunks_rebuild_the_store_tables(exported, tmp_path):
    """Pieces of one store's export (docs/publishing.md §5.2) read as one give the store's tables."""
    folder, store = exported
    stems = split_export(folder, store, tmp_path / "checkpoint")
    reference = folder / "from-store-chunks"
    assert run_cli("leaderboard", "--store", store, "--out", reference) == 0
    names = sorted(p.name for p in reference.iterdir() if p.name != OUT_SOURCE_FILE)
    for source, out in (([tmp_path / "checkpoint"], tmp_path / "a"), (stems, tmp_path / "b")):
        assert run_cli("leaderboard", "--rows", *source, "--out", out) == 0
        assert sorted(p.name for p in out.iterdir() if p.name != OUT_SOURCE_FILE) == names
        for name in names:
            if name.endswith(".csv"):
                assert (out / name).read_bytes() == (reference / name).read_bytes(), name
            else:
                assert stable_lines(out / name) == stable_lines(reference / name), name
    # the pieces are recorded as their folder
    assert (tmp_path / "b" / OUT_SOURCE_FILE).read_text().strip() == str((tmp_path / "checkpoint").resolve())


def test_chunks_of_two_stores_and_bad_manifests_are_refused_in_one_line(exported, tmp_path, capsys):
    import json

    from uav_penetration_env.benchmark.rows import checkpoint_stems, read_chunks

    folder, _store = exported
    published = folder / "parquet" / "published"
    with pytest.raises(RowsError, match="episodes episode_id 1 is in two of"):
        read_chunks([published, published])  # the same ids twice: not pieces of one store
    assert run_cli("leaderboard", "--rows", published, published, "--out", tmp_path / "o") == 2
    assert "disjoint ids" in capsys.readouterr().err
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "manifest.json").write_text("{not json")
    with pytest.raises(RowsError, match="not a checkpoint manifest"):
        checkpoint_stems(bad)
    (bad / "manifest.json").write_text(json.dumps({"seeds": ["other/store"], "chunks": [{"name": "chunk-001"}]}))
    with pytest.raises(RowsError, match="seed rows of another store"):
        checkpoint_stems(bad)
    (bad / "manifest.json").write_text(json.dumps({"seeds": [], "chunks": []}))
    with pytest.raises(RowsError, match="names no chunk"):
        checkpoint_stems(bad)
    assert checkpoint_stems(published) == [published]  # a plain stem stands for itself


def test_chunks_keep_a_numeric_column_numeric_where_one_piece_has_it_all_null(tmp_path):
    """A column NULL throughout one piece (no RL episode there) reads as object; joined, it is float again."""
    import pandas as pd

    from uav_penetration_env.benchmark.rows import read_chunks, row_path, write_table

    pieces = {"a": (1, [None, None]), "b": (2, [1000.0, None])}
    for name, (run_id, timesteps) in pieces.items():
        episodes = pd.DataFrame({"episode_id": [2 * run_id - 1, 2 * run_id], "run_id": [run_id] * 2,
                                 "scenario_hash": ["h", "h"], "train_timesteps": timesteps})  # fmt: skip
        write_table(episodes, row_path(tmp_path / name, "episodes", "parquet"), "parquet")
        write_table(pd.DataFrame({"run_id": [run_id]}), row_path(tmp_path / name, "runs", "parquet"), "parquet")
    assert pd.read_parquet(row_path(tmp_path / "a", "episodes", "parquet")).train_timesteps.dtype == object
    joined = read_chunks([tmp_path / "a", tmp_path / "b"]).episodes
    assert joined.train_timesteps.dtype == "float64" and list(joined.episode_id) == [1, 2, 3, 4]
    assert joined.train_timesteps.isna().tolist() == [True, True, False, True]
