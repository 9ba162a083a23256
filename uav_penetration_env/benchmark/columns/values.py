"""The store's rows derived from the column tables: step rows, episode summaries and SQL types.

:func:`step_row` and :func:`start_row` (the step-0 row of the start state) read each step
column's source; :func:`summarise` computes the episode columns that have a ``summary``;
:func:`sql_types` and :func:`numeric_columns` give the store its schema and its numeric columns.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from uav_penetration_env.benchmark.columns.definition import Column, EpisodeSteps
from uav_penetration_env.benchmark.columns.registry import EPISODE, STEP
from uav_penetration_env.types import FloatArray


def sql_types(columns: Sequence[Column]) -> dict[str, str]:
    """``name -> SQLite type`` of stored columns, in declaration order (the store schema)."""
    return {column.name: column.sql for column in columns if column.sql is not None}


def numeric_columns(columns: Sequence[Column] = EPISODE) -> tuple[str, ...]:
    """Names of the INTEGER and REAL columns (coerced to float when a store returns them)."""
    return tuple(column.name for column in columns if column.numeric)



def step_row(info: Mapping[str, Any], action: FloatArray, record: Mapping[str, Any]) -> dict[str, Any]:
    """The step row of one transition, from the env's info after it, the action and the planner's record."""
    return {column.name: column.source.step(info, action, record) for column in STEP}


def start_row(info: Mapping[str, Any]) -> dict[str, Any]:
    """The step-0 row of an episode's start state, from the env's reset info.

    DECISION (api.md §4.4, model.md §7a): the state's own quantities (position, altitude, threats,
    detection) describe the start state; a transition's (J, penalty, third term, normalised terms,
    fuel) are the reset info's 0; the action and planner columns are NULL, since no action led
    there. Episode sums never include this row (:func:`summarise` gets the transitions alone).
    """
    return {column.name: column.source.start(info) for column in STEP}


def summarise(steps: EpisodeSteps) -> dict[str, Any]:
    """The episode columns that summarise step rows (every column with a ``summary``)."""
    return {column.name: column.summary(steps) for column in EPISODE if column.summary is not None}
