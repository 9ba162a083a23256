"""Best-known records: the offline planner, record files, replay, the CLI and the gap columns."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_scenario

from optimizers.sep_cma_restarts import SepCMARestarts
from uav_penetration_env.benchmark.bestknown import record as record_module
from uav_penetration_env.benchmark.bestknown.checkpoint import checkpoint_path
from uav_penetration_env.benchmark.bestknown.compute import (
    _record_from,
    compute_record,
    greedy_track,
    stored_tracks,
    update_from_store,
)
from uav_penetration_env.benchmark.bestknown.planner import (
    EpisodeObjective,
    SearchSettings,
    Start,
    search,
)
from uav_penetration_env.benchmark.bestknown.record import (
    RECORDS_DIR,
    REPLAY_TOLERANCE,
    BestKnownRecord,
    RecordError,
    best_known_total,
    load_record,
    read_record,
    records,
    relative_difference,
    replay_controls,
    replay_record,
    write_record,
)
from uav_penetration_env.benchmark.cli import main
from uav_penetration_env.benchmark.evaluate import evaluate
from uav_penetration_env.benchmark.leaderboard import leaderboard_table, markdown_rows, suite_group
from uav_penetration_env.benchmark.policies import GreedyPolicy, RandomPolicy
from uav_penetration_env.model import PenetrationModel

# A tiny scenario with a short episode keeps every search here under a second or two.
SCENARIO = tiny_scenario(name="tiny-best-known", time={"max_steps": 20})
TINY_SEARCH = {
    "seconds": None,
    "optimizer": SepCMARestarts(population=6, stall_generations=3),
    "checkpoint_seconds": 1e9,
}


@pytest.fixture(scope="module")
def objective() -> EpisodeObjective:
    model = PenetrationModel(SCENARIO)
    return EpisodeObjective(model, model.initial_state(None))


@pytest.fixture(scope="module")
def greedy() -> tuple[np.ndarray, float]:
    return greedy_track(SCENARIO)


@pytest.fixture(scope="module")
def store(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("store") / "store.sqlite"
    evaluate(
        {"greedy": GreedyPolicy(), "random": RandomPolicy()}, [SCENARIO], range(3), store=path, progress=False
    )
    return path


def made_record(controls: np.ndarray, total: float = 1.0, **changes) -> BestKnownRecord:
    fields = {
        "scenario_name": SCENARIO.name,
        "scenario_hash": SCENARIO.hash,
        "scenario": SCENARIO.to_dict(),
        "total_cost": total,
        "outcome": "success",
        "steps": len(controls),
        "controls": tuple(tuple(float(v) for v in row) for row in controls),
        "found_by": {"method": "test"},
        "found_at": "2026-11-29T00:00:00+00:00",
    }
    return BestKnownRecord(**(fields | changes))


# --- records --------------------------------------------------------------------------------------------


def test_record_round_trip_keeps_every_float_exactly(tmp_path):
    rng = np.random.default_rng(7)
    # Values with long expansions (thirds, tiny and huge magnitudes): repr round-trips each exactly.
    controls = np.column_stack([rng.uniform(-2, 2, 9), rng.normal(0, 1e-9, 9), np.full(9, 1 / 3)])
    record = made_record(controls, total=float(np.pi * 1e3), unseeded_total=0.1 + 0.2)
    path = write_record(record, tmp_path)
    assert path.name == f"{SCENARIO.hash}.json"
    again = read_record(path)
    assert again == record
    assert again.control_array.tobytes() == controls.tobytes()
    assert load_record(SCENARIO.hash, tmp_path) == record
    assert best_known_total(SCENARIO.hash, tmp_path) == float(np.pi * 1e3)
    assert load_record("0" * 16, tmp_path) is None and best_known_total("0" * 16, tmp_path) is None
    assert again.load_scenario().hash == SCENARIO.hash


def test_bad_record_files_are_one_line_errors(tmp_path):
    record = made_record(np.zeros((2, 3)))
    data = json.loads(record.to_json())
    (tmp_path / f"{SCENARIO.hash}.json").write_text(json.dumps(data | {"colour": 1}))
    with pytest.raises(RecordError, match="colour: unknown field"):
        load_record(SCENARIO.hash, tmp_path)
    (tmp_path / f"{SCENARIO.hash}.json").write_text(json.dumps(data | {"format": "other/9"}))
    with pytest.raises(RecordError, match="format: got 'other/9', expected 'uav-penetration-best-known/1'"):
        load_record(SCENARIO.hash, tmp_path)
    (tmp_path / "0123456789abcdef.json").write_text(record.to_json())
    with pytest.raises(RecordError, match="expected the file name 0123456789abcdef"):
        read_record(tmp_path / "0123456789abcdef.json")
    with pytest.raises(RecordError, match="controls: got 2 rows, expected steps = 3"):
        made_record(np.zeros((2, 3)), steps=3)


# --- the objective is the evaluator's total cost -------------------------------------------------------


def test_batched_cost_equals_the_env_replay(objective, greedy):
    controls, greedy_total = greedy
    rng = np.random.default_rng(3)
    sequences = [
        controls,  # reaches the goal
        controls + rng.normal(0, 0.05, controls.shape) * objective.high,  # a perturbed track
        np.tile([0.0, 0.0, -1.0], (objective.steps, 1)) * objective.high,  # dives into the terrain
        np.tile([0.0, 1.0, 0.0], (objective.steps, 1)) * objective.high,  # circles until K_max
    ]
    outcomes = set()
    for sequence in sequences:
        x = objective.normalise(sequence)
        batched = float(objective(x[None])[0])
        replay = replay_controls(SCENARIO, objective.controls(x))
        outcomes.add(replay.outcome)
        # The kernel adds J + penalty step by step, the evaluator ΣJ + Σpenalty: equal up to rounding.
        assert relative_difference(batched, replay.total_cost) <= REPLAY_TOLERANCE
    assert {"success", "collided", "truncated"} <= outcomes
    assert (
        relative_difference(float(objective(objective.normalise(controls)[None])[0]), greedy_total) <= 1e-12
    )


# --- the search ----------------------------------------------------------------------------------------


def test_search_improves_on_greedy_and_is_seeded(objective, greedy):
    starts = [Start("greedy", objective.normalise(greedy[0]))]
    settings = SearchSettings(max_evals=400, seed=1, **TINY_SEARCH)
    first = search(objective, starts, settings, scenario_hash=SCENARIO.hash)
    again = search(objective, starts, settings, scenario_hash=SCENARIO.hash)
    other = search(
        objective, starts, SearchSettings(max_evals=400, seed=2, **TINY_SEARCH), scenario_hash=SCENARIO.hash
    )
    assert first.total < greedy[1] and first.evals <= 400
    assert first.total == again.total and first.controls.tobytes() == again.controls.tobytes()
    assert other.controls.tobytes() != first.controls.tobytes()
    assert {r["label"].split("(")[0] for r in first.runs} >= {"start:greedy", "incumbent", "random", "refine"}
    assert (
        relative_difference(replay_controls(SCENARIO, first.controls).total_cost, first.total)
        <= REPLAY_TOLERANCE
    )


def killed_after(generations: int):
    """A progress callback that interrupts the search after ``generations`` generations, as Ctrl-C would."""
    calls = iter(range(1, generations + 1))

    def progress(state, share) -> None:
        if next(calls, None) is None:
            raise KeyboardInterrupt(f"killed after {generations} generations")

    return progress


def test_an_interrupted_search_continues_to_the_uninterrupted_result(objective, greedy, tmp_path):
    starts = [Start("greedy", objective.normalise(greedy[0]))]
    settings = SearchSettings(max_evals=300, seed=4, **TINY_SEARCH)
    whole = search(objective, starts, settings, scenario_hash=SCENARIO.hash)
    path = checkpoint_path(tmp_path, SCENARIO.hash, "unseeded")
    # A checkpoint after every generation; each kill loses the generation it interrupts.
    every = SearchSettings(max_evals=300, seed=4, **(TINY_SEARCH | {"checkpoint_seconds": 0.0}))
    for generations in (7, 11):  # two interruptions, each after a checkpoint
        with pytest.raises(KeyboardInterrupt):
            search(
                objective,
                starts,
                every,
                scenario_hash=SCENARIO.hash,
                checkpoint=path,
                progress=killed_after(generations),
            )
    resumed = search(objective, starts, settings, scenario_hash=SCENARIO.hash, checkpoint=path)
    assert resumed.total == whole.total and resumed.evals == whole.evals
    assert resumed.controls.tobytes() == whole.controls.tobytes()
    assert [r["label"] for r in resumed.runs] == [r["label"] for r in whole.runs]
    with pytest.raises(ValueError, match=r"--work .*holds a search with settings"):
        search(
            objective,
            starts,
            SearchSettings(max_evals=300, seed=5, **TINY_SEARCH),
            scenario_hash=SCENARIO.hash,
            checkpoint=path,
        )
    path.write_bytes(b"not a pickle")
    with pytest.raises(ValueError, match=r"--work .*not a best-known search checkpoint"):
        search(objective, starts, settings, scenario_hash=SCENARIO.hash, checkpoint=path)


def test_settings_errors_name_the_field():
    with pytest.raises(ValueError, match="budget: got neither seconds nor max_evals"):
        SearchSettings(seconds=None)
    with pytest.raises(ValueError, match="optimizer: got 'sep-cma', expected a SepCMARestarts"):
        SearchSettings(optimizer="sep-cma")


# --- compute, update, verify -----------------------------------------------------------------------------


def test_compute_keeps_the_unseeded_result_and_never_writes_a_worse_record(tmp_path, store, greedy):
    settings = SearchSettings(max_evals=200, **TINY_SEARCH)
    outcome = compute_record(SCENARIO, settings, store=store, folder=tmp_path)
    record = outcome.record
    assert outcome.replaced and record.total_cost < greedy[1]
    assert record.unseeded_total is not None and record.total_cost <= record.unseeded_total
    assert record.found_by["method"] == "offline-search" and record.budget["evaluations"] > 0
    assert set(record.versions) >= {"uav-penetration", "python", "numpy", "numba", "cmaes"}
    assert relative_difference(replay_record(record).total_cost, record.total_cost) == 0.0
    before = (tmp_path / f"{SCENARIO.hash}.json").read_bytes()
    # A search with a smaller budget cannot beat the record: the file stays as it was.
    again = compute_record(
        SCENARIO, SearchSettings(max_evals=30, **TINY_SEARCH), track_seeds=False, folder=tmp_path
    )
    assert not again.replaced and (tmp_path / f"{SCENARIO.hash}.json").read_bytes() == before
    assert "kept the record" in again.message(SCENARIO.name)


def test_update_replaces_only_with_a_cheaper_stored_episode_and_says_by_how_much(tmp_path, store):
    tracks = stored_tracks(store, SCENARIO.hash, count=None)
    cheapest, costliest = tracks[0], tracks[-1]
    assert cheapest.total_cost < costliest.total_cost
    # A record of the costliest stored episode: the cheapest one beats it.
    worse = _record_from(
        SCENARIO, costliest.controls, costliest.total_cost, costliest.found_by(), {}, None, None
    )
    write_record(worse, tmp_path)
    outcome = update_from_store(SCENARIO, store, folder=tmp_path)
    gain = costliest.total_cost - cheapest.total_cost
    assert outcome.replaced and outcome.record.total_cost == cheapest.total_cost
    assert outcome.message(SCENARIO.name) == (
        f"{SCENARIO.name}: record improved from {costliest.total_cost:.10g} to {cheapest.total_cost:.10g} "
        f"(-{gain:.6g}, -{100 * gain / costliest.total_cost:.4g} %; stored episode: {cheapest.policy}, "
        f"seed {cheapest.seed}, run {cheapest.run_id})"
    )
    assert (
        outcome.record.found_by["policy"] == cheapest.policy
        and outcome.record.history[0]["total_cost"] == costliest.total_cost
    )
    # Again: nothing cheaper in the store, the record stays byte for byte.
    before = (tmp_path / f"{SCENARIO.hash}.json").read_bytes()
    again = update_from_store(SCENARIO, store, folder=tmp_path)
    assert not again.replaced and (tmp_path / f"{SCENARIO.hash}.json").read_bytes() == before


def test_cli_verify_catches_a_tampered_record(tmp_path, store, capsys):
    folder = tmp_path / "records"
    assert main(["best-known", "update", "--store", str(store), "--records", str(folder)]) == 0
    assert "new record J*" in capsys.readouterr().out
    assert main(["best-known", "verify", "--records", str(folder)]) == 0
    assert f"{SCENARIO.name} ({SCENARIO.hash}): ok" in capsys.readouterr().out
    path = folder / f"{SCENARIO.hash}.json"
    record = read_record(path)
    write_record(record_module.updated(record, total_cost=record.total_cost * (1 + 1e-10)), folder)
    assert main(["best-known", "verify", "--records", str(folder)]) == 1
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 1 and "total_cost: replay gives" in lines[0] and "> 1e-12" in lines[0]
    controls = [list(row) for row in record.controls]
    controls[0] = [0.0, -0.2, 0.0]  # greedy turns toward the goal at the first step; this turns away
    write_record(record_module.updated(record, controls=tuple(map(tuple, controls))), folder)
    assert main(["best-known", "verify", "--records", str(folder)]) == 1


def test_cli_errors_are_one_line(tmp_path, capsys):
    assert main(["best-known", "compute", "--scenarios", "papr", "--records", str(tmp_path)]) == 2
    assert "--scenarios: unknown scenario 'papr'" in capsys.readouterr().err
    assert main(["best-known", "compute", "--records", str(tmp_path)]) == 2
    assert "--scenarios: missing" in capsys.readouterr().err
    assert main(["best-known", "update", "--records", str(tmp_path)]) == 2
    assert "--store: missing" in capsys.readouterr().err
    jittered = tiny_scenario(start={"jitter": {"xy_km": 1.0}})
    with pytest.raises(ValueError, match=r"start\.jitter"):
        compute_record(jittered, SearchSettings(max_evals=10), folder=tmp_path)


# --- every committed record replays ----------------------------------------------------------------------


def check_replays(committed) -> None:
    for record in committed:
        replay = replay_record(record)
        assert replay.steps == record.steps, record.scenario_name
        assert relative_difference(replay.total_cost, record.total_cost) <= REPLAY_TOLERANCE, (
            record.scenario_name
        )


@pytest.mark.slow
def test_every_committed_record_replays_to_its_total():
    committed = records()
    assert len(committed) == len(list(RECORDS_DIR.glob("*.json")))
    check_replays(committed)


def test_a_record_of_each_kind_of_scenario_replays_to_its_total():
    """The fast twin of the test above: the paper scenarios, the DEM one and one procedural member.

    Each kind builds its terrain another way (the paper's mountains, a raster, a generated field);
    the slow test replays all of them.
    """
    committed = records()
    names = {record.scenario_name for record in committed}
    wanted = [n for n in ("paper-2022-sec5", "dem-topobathy") if n in names]
    wanted.append(min(n for n in names if n.startswith("random-")))
    check_replays([record for record in committed if record.scenario_name in wanted])
    assert len(wanted) == 3


# --- gap columns -------------------------------------------------------------------------------------------


def toy_episodes() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "policy": ["a", "b"] * 6,
            "policy_hash": ["ha", "hb"] * 6,
            "scenario": ["s1"] * 4 + ["s2"] * 4 + ["s3"] * 4,
            "scenario_hash": ["h1"] * 4 + ["h2"] * 4 + ["h3"] * 4,
            "seed": [0, 0, 1, 1] * 3,
            "outcome": ["success"] * 12,
            "error": [""] * 12,
            "total_cost": [1.0, 1.005, 1.5, 1.08, 2.0, 2.0, 4.0, 2.2, 9.0, 9.0, 9.0, 9.0],
        }
    )


def test_gap_columns_on_a_hand_computed_suite():
    # J*: h1 -> 1, h2 -> 2, h3 has no record (its episodes do not count).
    lookup = {"h1": 1.0, "h2": 2.0}.get
    group = suite_group(toy_episodes(), "toy")
    table = leaderboard_table(group.episodes, reference="a", n_resamples=200, best_known=lookup).set_index(
        "policy"
    )
    # a: gaps 0, 0.5, 0, 1 ; b: gaps 0.005, 0.08, 0, 0.1 (each against its own scenario's J*).
    assert table.loc["a", "gap_mean"] == pytest.approx(0.375)
    assert table.loc["a", "gap_iqm"] == pytest.approx(0.25)  # mean of the middle two: 0, 0.5
    assert table.loc["b", "gap_mean"] == pytest.approx(0.185 / 4)
    assert table.loc["b", "gap_iqm"] == pytest.approx((0.005 + 0.08) / 2)
    assert table.loc["a", ["within_1pct", "within_5pct", "within_10pct"]].tolist() == [0.5, 0.5, 0.5]
    assert table.loc["b", ["within_1pct", "within_5pct", "within_10pct"]].tolist() == [0.5, 0.5, 1.0]
    assert table.loc["a", "gap_mean_ci_low"] <= 0.375 <= table.loc["a", "gap_mean_ci_high"]
    header, rows, _ = markdown_rows(table.reset_index(), "a")
    cells = dict(zip(header, rows[list(table.index).index("b")], strict=True))
    assert cells["≤10% of J*"] == "100%" and cells["gap to J* mean [95% CI]"].startswith("4.625%")


def test_gap_columns_are_left_out_without_a_record_and_blank_for_a_policy_without_one():
    one = toy_episodes()[lambda f: f["scenario_hash"] == "h3"]
    table = leaderboard_table(one, reference="a", n_resamples=200, best_known=lambda h: None)
    assert not {"gap_mean", "within_1pct"} & set(table.columns)
    assert "≤1% of J*" not in markdown_rows(table, "a")[0]
    frame = toy_episodes()
    frame.loc[frame["scenario_hash"] != "h3", "policy"] = "a"  # b flew only h3, which has no record
    frame.loc[frame["scenario_hash"] != "h3", "policy_hash"] = "ha"
    group = suite_group(frame, "toy")
    table = leaderboard_table(group.episodes, reference="a", n_resamples=200, best_known={"h1": 1.0}.get)
    row = table.set_index("policy")
    assert np.isnan(row.loc["b", "gap_mean"]) and row.loc["a", "gap_mean"] >= 0
    header, rows, _ = markdown_rows(table, "a")
    b_cells = dict(zip(header, rows[table["policy"].tolist().index("b")], strict=True))
    assert b_cells["gap to J* mean [95% CI]"] == "" and b_cells["≤5% of J*"] == ""


def test_track_figures_draw_the_best_known_track(tmp_path, store, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    from uav_penetration_env.benchmark.figures.common import FigureInput, policy_styles
    from uav_penetration_env.benchmark.figures.tracks import plot_tracks_3d, plot_tracks_top, scenario_model
    from uav_penetration_env.benchmark.leaderboard import scenario_groups
    from uav_penetration_env.benchmark.store import ResultsStore

    with ResultsStore(store, create=False) as results:
        group = scenario_groups(results.episodes())[0]
        rows = results.steps(group.episodes["episode_id"].astype(int).tolist(), include_start=True)
        yaml_text = results.scenarios()[group.scenario_hash][1]
    styles = policy_styles(group.episodes["label"].unique())
    inp = FigureInput(
        group, rows[rows["step"] > 0], rows[rows["step"] == 0], scenario_model(yaml_text), styles
    )

    def labels(figure) -> list[str]:
        return [line.get_label() for ax in figure.axes for line in ax.get_lines()]

    assert not any(label.startswith("best known") for label in labels(plot_tracks_top(inp)))
    monkeypatch.setattr(record_module, "RECORDS_DIR", tmp_path)
    record_module._cached.cache_clear()
    record = update_from_store(SCENARIO, store, folder=tmp_path).record
    expected = f"best known (J* = {record.total_cost:.4g})"
    top, three_d = plot_tracks_top(inp), plot_tracks_3d(inp)
    assert labels(top).count(expected) == 1 and labels(three_d).count(expected) == 1
    line = next(line for line in top.axes[0].get_lines() if line.get_label() == expected)
    replay = replay_record(record)
    np.testing.assert_allclose(line.get_xdata(), replay.positions[:, 0] / 1000.0)
    assert len(line.get_xdata()) == record.steps + 1
    record_module._cached.cache_clear()


def test_cli_verify_refuses_a_records_folder_that_does_not_exist(tmp_path, capsys):
    missing = tmp_path / "no-such-records"
    assert main(["best-known", "verify", "--records", str(missing)]) == 2
    assert f"--records {missing}: not found" in capsys.readouterr().err
    assert not missing.exists()  # a typo must not look like an empty, clean verification
