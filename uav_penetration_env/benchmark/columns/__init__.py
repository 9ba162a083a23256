"""The result columns, each declared once: the store schema, episode summaries, leaderboard and glossary.

Every column of the results store, the leaderboard and the RL table is one :class:`Column`
declared once; the store's schema, the step and episode rows, the leaderboard's layout and legend
and docs/columns.md are all derived from those declarations. The package is split by job; every
public name is importable from here:

* :mod:`.definition`: what a column is (:class:`Column`, its step sources :class:`Info`,
  :class:`Action`, :class:`Planner`, its leaderboard display :class:`Board`, the
  :class:`EpisodeSteps` an episode summary reads);
* :mod:`.registry`: the built-in columns (:data:`STEP`, :data:`EPISODE`, :data:`STATISTICS`,
  :data:`WINDOW_RUN`, :data:`RL_GROUP`); adding a column is one line there;
* :mod:`.values`: the rows the store keeps (:func:`step_row`, :func:`start_row`,
  :func:`summarise`) and their SQL types (:func:`sql_types`, :func:`numeric_columns`);
* :mod:`.layout`: the leaderboard's columns in table order and its legend (:func:`legend_lines`);
* :mod:`.glossary`: the column glossary and docs/columns.md (:func:`glossary_page`).
"""

from __future__ import annotations

from uav_penetration_env.benchmark.columns.definition import (
    AGGREGATES,
    SECTIONS,
    STYLES,
    Action,
    Board,
    Column,
    EpisodeSteps,
    Info,
    Planner,
    Source,
)
from uav_penetration_env.benchmark.columns.glossary import (
    GLOSSARY_PAGE_HEADER,
    glossary_markdown,
    glossary_page,
)
from uav_penetration_env.benchmark.columns.layout import aggregated_columns, leaderboard_columns, legend_lines
from uav_penetration_env.benchmark.columns.registry import (
    EPISODE,
    MEASURED,
    RL_GROUP,
    STATISTICS,
    STEP,
    WINDOW_RUN,
)
from uav_penetration_env.benchmark.columns.values import (
    numeric_columns,
    sql_types,
    start_row,
    step_row,
    summarise,
)

__all__ = [
    "AGGREGATES",
    "EPISODE",
    "GLOSSARY_PAGE_HEADER",
    "MEASURED",
    "RL_GROUP",
    "SECTIONS",
    "STATISTICS",
    "STEP",
    "STYLES",
    "WINDOW_RUN",
    "Action",
    "Board",
    "Column",
    "EpisodeSteps",
    "Info",
    "Planner",
    "Source",
    "aggregated_columns",
    "glossary_markdown",
    "glossary_page",
    "leaderboard_columns",
    "legend_lines",
    "numeric_columns",
    "sql_types",
    "start_row",
    "step_row",
    "summarise",
]
