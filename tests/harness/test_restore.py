"""A results store rebuilt from exported rows (``uav-bench import``, api.md §4.9).

The oracle is the store the rows came from: the rebuilt one must read the same in every table,
step-0 rows included (an export leaves them out; the import recomputes them from the scenario), and
a ``run`` on it must find every episode already done.
"""

from __future__ import annotations

import pandas as pd
import pytest

from tests.conftest import tiny_scenario
from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.restore import RestoreError, restore_store
from uav_penetration_env.benchmark.rows import JSON_TEXT_COLUMNS, row_path
from uav_penetration_env.benchmark.store import ResultsStore, StoreError


def run_cli(*argv):
    return cli.main([str(a) for a in argv])


def everything(path):
    """Every table of a store, as frames and dicts, in a form two stores can be compared in."""
    with ResultsStore(path, create=False) as store:
        return {
            "episodes": store.episodes(),
            "runs": store.runs(),
            "window_runs": store.window_runs(),
            "steps": store.steps(include_start=True),
            "scenarios": store.scenarios(),
            "policies": store.policies(),
        }


def text_as_read_from_csv(frame):
    """NULL plain text as empty text: what CSV cannot keep apart (api.md §4.9); JSON columns stay exact."""
    frame = frame.copy()
    for column in frame.columns:
        if column in JSON_TEXT_COLUMNS:
            continue
        if pd.api.types.is_string_dtype(frame[column]) or frame[column].dtype == object:
            frame[column] = frame[column].astype(object).where(frame[column].notna(), "")
    return frame


def assert_same_store(a, b, *, csv=False):
    first, second = everything(a), everything(b)
    for table in ("episodes", "runs", "window_runs", "steps"):
        x, y = first[table], second[table]
        if csv:
            x, y = text_as_read_from_csv(x), text_as_read_from_csv(y)
        pd.testing.assert_frame_equal(x, y, check_dtype=False, obj=table)
    assert first["scenarios"] == second["scenarios"]
    assert first["policies"] == second["policies"]


@pytest.fixture(scope="module")
def original(tmp_path_factory):
    folder = tmp_path_factory.mktemp("restore")
    scenario = str(tiny_scenario(time={"max_steps": 10}).to_yaml(folder / "tiny.yaml"))
    store = folder / "original.sqlite"
    flags = ("--scenarios", scenario, "--seeds", "2", "--max-evals", "150", "--horizon", "3",
             "--jobs", "1", "--no-report", "--no-progress")  # fmt: skip
    assert run_cli("run", "--policies", "greedy", "pso", "--store", store, *flags) == 0
    assert run_cli("windows", "--store", store, "--from-policy", "greedy", "--scenario", "tiny", "--steps", "2",
                   "--optimizers", "hpso", "--seeds", "1", "--max-evals", "150", "--horizon", "3") == 0  # fmt: skip
    for fmt in ("parquet", "csv"):
        assert run_cli("export", "--format", fmt, "--store", store, "--out", folder / fmt / "rows") == 0
    return folder, store, flags


@pytest.mark.parametrize("fmt", ["parquet", "csv"])
def test_an_imported_store_reads_as_the_exported_one(original, fmt):
    folder, store, _ = original
    target = folder / f"imported-{fmt}.sqlite"
    assert run_cli("import", "--rows", folder / fmt / "rows", "--store", target) == 0
    assert_same_store(store, target, csv=fmt == "csv")
    with ResultsStore(target, create=False) as rebuilt:
        assert (rebuilt.steps(include_start=True)["step"] == 0).sum() == len(rebuilt.episodes())


def test_a_run_on_the_imported_store_adds_only_what_is_new(original):
    folder, _, flags = original
    target = folder / "extended.sqlite"
    restore_store(folder / "parquet" / "rows", target)
    before = everything(target)["episodes"]
    assert run_cli("run", "--policies", "greedy", "random", "--store", target, *flags) == 0
    after = everything(target)["episodes"]
    # greedy's episodes were imported: only the random policy's two seeds fly
    assert len(after) == len(before) + 2
    assert set(after.loc[len(before) :, "policy"]) == {"random"}
    assert after["episode_id"].iloc[len(before) :].min() > before["episode_id"].max()  # ids carry on
    kept = after.iloc[: len(before)]
    pd.testing.assert_frame_equal(kept, before)


def test_rows_without_a_scenarios_table_rebuild_catalogue_scenarios_by_hash(tmp_path):
    store = tmp_path / "s.sqlite"
    assert run_cli("run", "--policies", "greedy", "--scenarios", "random:7", "--seeds", "1", "--store", store,
                   "--jobs", "1", "--no-report", "--no-progress") == 0  # fmt: skip
    assert run_cli("export", "--format", "parquet", "--store", store, "--out", tmp_path / "rows") == 0
    row_path(tmp_path / "rows", "scenarios", "parquet").unlink()  # as leaderboard v2's first exports
    row_path(tmp_path / "rows", "policies", "parquet").unlink()
    (tmp_path / "rows-manifest.json").unlink()  # exports before the manifest had none
    restored = restore_store(tmp_path / "rows", tmp_path / "back.sqlite")
    assert restored.rebuilt_scenarios == ("random-7",)
    original, back = everything(store), everything(tmp_path / "back.sqlite")
    assert back["scenarios"] == original["scenarios"]  # the same YAML, hence the same start rows
    pd.testing.assert_frame_equal(original["steps"], back["steps"], check_dtype=False)
    assert back["policies"] == {}


def test_a_scenario_nothing_rebuilds_is_named_in_one_line(original, tmp_path):
    folder, _, _ = original
    for table in ("episodes", "runs", "window_runs", "steps"):
        source = row_path(folder / "parquet" / "rows", table, "parquet")
        row_path(tmp_path / "rows", table, "parquet").write_bytes(source.read_bytes())
    with pytest.raises(
        RestoreError, match=r"^scenario 'tiny' \(hash [0-9a-f]+\) is not in the rows' scenarios table"
    ):
        restore_store(tmp_path / "rows", tmp_path / "x.sqlite")
    assert not (tmp_path / "x.sqlite").exists()  # nothing half-written


def test_an_existing_target_and_missing_rows_are_refused(original, tmp_path, capsys):
    folder, store, _ = original
    size = store.stat().st_size
    assert run_cli("import", "--rows", folder / "parquet" / "rows", "--store", store) == 2
    err = capsys.readouterr().err
    assert "exists; expected a new file path" in err and len(err.strip().splitlines()) == 1
    assert store.stat().st_size == size
    assert run_cli("import", "--rows", tmp_path / "none", "--store", tmp_path / "n.sqlite") == 2
    assert "no episodes table" in capsys.readouterr().err
    assert not (tmp_path / "n.sqlite").exists()


def test_loading_rows_into_a_store_that_holds_results_is_refused(original):
    _, store, _ = original
    with ResultsStore(store) as results, pytest.raises(StoreError, match="expected an empty store"):
        results.load_exported({"episodes": everything(store)["episodes"]})


def test_the_csv_import_keeps_null_json_text_null_for_its_readers(original):
    folder, _, _ = original
    target = folder / "from-csv.sqlite"
    restore_store(folder / "csv" / "rows", target)
    steps = everything(target)["steps"]
    greedy = steps["episode_id"].isin(
        everything(target)["episodes"].query("policy == 'greedy'")["episode_id"]
    )
    assert steps.loc[greedy, "history"].isna().all()  # the floor plans nothing: NULL, not ""
    assert run_cli("plot", "--store", target, "--out", folder / "csv-plots") == 0  # parses the histories


def copy_rows(folder, tmp_path, tables=("episodes", "runs", "window_runs", "steps", "scenarios", "policies")):
    for table in tables:
        source = row_path(folder / "parquet" / "rows", table, "parquet")
        row_path(tmp_path / "rows", table, "parquet").write_bytes(source.read_bytes())


def test_rows_a_store_refuses_leave_nothing_behind(original, tmp_path):
    folder, _, _ = original
    copy_rows(folder, tmp_path)
    steps = pd.read_parquet(row_path(tmp_path / "rows", "steps", "parquet"))
    steps.assign(episode_id=steps["episode_id"] + 1000).to_parquet(
        row_path(tmp_path / "rows", "steps", "parquet")
    )
    with pytest.raises(
        RestoreError, match=r"^--rows .*: the steps table has rows a store refuses \(FOREIGN KEY"
    ):
        restore_store(tmp_path / "rows", tmp_path / "out" / "x.sqlite")
    episodes = pd.read_parquet(row_path(folder / "parquet" / "rows", "episodes", "parquet"))
    episodes.assign(bogus=1).to_parquet(row_path(tmp_path / "rows", "episodes", "parquet"))
    with pytest.raises(
        RestoreError, match=r"the episodes table has column 'bogus', which this version does not store"
    ):
        restore_store(tmp_path / "rows", tmp_path / "out" / "x.sqlite")
    assert list((tmp_path / "out").iterdir()) == []  # no store, no temporary, no journal


def test_a_leftover_journal_of_the_target_is_refused(original, tmp_path):
    folder, _, _ = original
    (tmp_path / "x.sqlite-wal").write_bytes(b"stale")  # SQLite would replay it onto the new file
    with pytest.raises(RestoreError, match=r"has a leftover SQLite journal x\.sqlite-wal"):
        restore_store(folder / "parquet" / "rows", tmp_path / "x.sqlite")
