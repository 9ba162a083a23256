"""The column table: every declared column reaches the store, the summary, the leaderboard, the glossary."""

from __future__ import annotations

import pytest

from uav_penetration_env.benchmark import columns
from uav_penetration_env.benchmark.store import EPISODE_COLUMNS, STEP_COLUMNS


def test_names_are_unique_per_table():
    for table in (columns.EPISODE, columns.STEP, columns.STATISTICS, columns.RL_GROUP):
        names = [column.name for column in table]
        assert len(names) == len(set(names))
    outs = [name for column in columns.leaderboard_columns() for name in column.csv]
    assert len(outs) == len(set(outs))


def test_the_store_schema_is_the_declared_columns():
    assert list(EPISODE_COLUMNS) == [column.name for column in columns.EPISODE]
    assert list(STEP_COLUMNS) == [column.name for column in columns.STEP]
    assert all(column.source is not None for column in columns.STEP)
    assert all(column.board is None or column.board.aggregate != "statistic" for column in columns.EPISODE)


def test_glossary_lists_every_column():
    text = columns.glossary_markdown()
    sections = [part.splitlines() for part in text.split("### ")[1:]]
    assert [lines[0].split(" (")[0] for lines in sections] == [
        "Episode columns",
        "Step columns",
        "Leaderboard columns",
        "Window-run columns",
        "RL-group columns",
    ]
    for lines, table in zip(
        [*sections[:2], sections[3]], (columns.EPISODE, columns.STEP, columns.WINDOW_RUN), strict=True
    ):
        rows = [line for line in lines if line.startswith("| `")]
        assert [row.split("`")[1] for row in rows] == [column.name for column in table]
    rows = [line for line in sections[2] if line.startswith("| ")][2:]
    headers = [column.board.header.format(reference="reference") for column in columns.leaderboard_columns()]
    assert [row[2:].split(" | ")[0] for row in rows] == headers
    rl_rows = [line for line in sections[4] if line.startswith("| ")][2:]
    csv = [[name.strip("`") for name in row.split(" | ")[1].split(", ")] for row in rl_rows]
    assert csv == [list(column.csv) for column in columns.RL_GROUP]


def test_legend_merges_consecutive_columns_that_share_a_definition():
    legend = columns.legend_lines("1,000")
    assert any(line.startswith("- **terrain Σ, radar Σ, third Σ**: mean raw") for line in legend)
    assert any(line.startswith("- **train steps, train [s]**: RL agents only") for line in legend)
    assert any("(1,000 resamples, seeded)" in line for line in legend)


def test_start_row_has_no_action_and_zero_transition_costs():
    info = {
        "step": 0, "position": [1.0, 2.0, 300.0], "altitude_agl": 90.0, "distance_to_goal": 30.0,
        "state": [1000.0, 2000.0, 300.0, 9.0, 0.5, 0.0], "J": 0.0, "penalty": 0.0, "terrain_threat": 0.2,
        "radar_threat": 0.1, "third_term": 0.0, "terrain_threat_n": 0.0, "radar_threat_n": 0.0,
        "third_term_n": 0.0, "fuel_kg": 0.0, "detection_prob": 0.7, "detected": True,
    }  # fmt: skip
    row = columns.start_row(info)
    assert list(row) == list(STEP_COLUMNS)
    assert row["step"] == 0 and row["detected"] is True and row["speed"] == 9.0 and row["y_km"] == 2.0
    assert row["action_dv"] is None and row["nfev"] is None and row["history"] is None


def test_a_board_rejects_unknown_settings():
    with pytest.raises(ValueError, match=r"Board\.section: got 'middle'"):
        columns.Board("x", "y", section="middle")
