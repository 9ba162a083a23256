"""What a result column is: its sources, its leaderboard display and the :class:`Column` type.

A :class:`Column` names a value of one table (the store's ``steps``, ``episodes`` and
``window_runs``, the leaderboard, the RL table) and says how it is obtained: a step column has a
source (:class:`Info`: the env's ``info``, known at reset too; :class:`Action`: the action taken;
:class:`Planner`: the policy's ``last_record``), an episode column may have a ``summary`` of the
episode's step rows (:class:`EpisodeSteps`). A column shown on the leaderboard carries a
:class:`Board`: its header, legend line, section, aggregate and print style. The built-in columns
are declared in :mod:`.registry`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from uav_penetration_env.types import FloatArray

SECTIONS = ("outcomes", "means", "comparison", "training")
AGGREGATES = ("mean", "mean_recorded", "statistic")
STYLES = ("number", "count")


# --- where a step value comes from ---------------------------------------------------------------------


@dataclass(frozen=True)
class Info:
    """A value of the env's ``info`` (an element of it when ``index`` is set); known at reset too."""

    key: str
    index: int | None = None
    kind: Callable[[Any], Any] = float

    def step(self, info: Mapping[str, Any], action: FloatArray, record: Mapping[str, Any]) -> Any:
        """The value after a transition."""
        value = info[self.key] if self.index is None else info[self.key][self.index]
        return self.kind(value)

    def start(self, info: Mapping[str, Any]) -> Any:
        """The value at the start state (the reset info)."""
        return self.step(info, np.zeros(3), {})


@dataclass(frozen=True)
class Action:
    """Component ``index`` of the action taken; none at the start state."""

    index: int

    def step(self, info: Mapping[str, Any], action: FloatArray, record: Mapping[str, Any]) -> Any:
        """The value after a transition."""
        return float(action[self.index])

    def start(self, info: Mapping[str, Any]) -> Any:
        """No action led to the start state."""
        return None


@dataclass(frozen=True)
class Planner:
    """An entry of the policy's ``last_record`` (``default`` when absent); none at the start state."""

    key: str
    kind: Callable[[Any], Any] | None = None
    default: Any = None

    def step(self, info: Mapping[str, Any], action: FloatArray, record: Mapping[str, Any]) -> Any:
        """The value after a transition."""
        value = record.get(self.key, self.default)
        return value if self.kind is None else self.kind(value)

    def start(self, info: Mapping[str, Any]) -> Any:
        """No planning led to the start state."""
        return None


Source = Info | Action | Planner


# --- the input of an episode column's summary ----------------------------------------------------------


@dataclass(frozen=True)
class EpisodeSteps:
    """One finished episode's step rows, for the ``summary`` of episode columns.

    Attributes:
        rows: the rows of the transitions k = 1..K (the step-0 row is not among them).
        states: (K + 1, 6) the exact states from the start state on.
        final_info: the env's ``info`` after the last transition.
        truncated: whether the episode ended by reaching K_max.
    """

    rows: Sequence[Mapping[str, Any]]
    states: FloatArray
    final_info: Mapping[str, Any]
    truncated: bool

    def column(self, name: str) -> FloatArray:
        """(K,) the values of one step column, float64."""
        return np.array([row[name] for row in self.rows], dtype=np.float64)

    def sum(self, name: str) -> float:
        """Σ_k of one step column."""
        return float(self.column(name).sum())

    def mean(self, name: str) -> float:
        """Mean over the K transitions of one step column."""
        return float(self.column(name).mean())

    @property
    def count(self) -> int:
        """K, the number of transitions."""
        return len(self.rows)



# --- the column declaration ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Board:
    """How the leaderboard shows a column.

    Attributes:
        header: the Markdown header (``{reference}`` is replaced by the reference policy).
        legend: the line of the leaderboard's "Columns" section; consecutive columns with the same
            legend share one bullet; ``None`` leaves the column unexplained there. ``{resamples}``
            is replaced by the number of bootstrap resamples.
        name: the column's name in the legend (default: ``header``).
        section: one of :data:`SECTIONS`.
        aggregate: ``mean`` (over the policy's finished episodes), ``mean_recorded`` (over those
            that recorded a value) or ``statistic`` (computed by the leaderboard's statistics).
        out: the leaderboard CSV's column name (default: the column's name).
        digits: significant digits printed.
        style: ``number`` (:func:`~uav_penetration_env.benchmark.leaderboard.format_number`) or ``count`` (an integer with
            thousands separators).
        optional: shown only when some policy has a value.
        csv: the leaderboard CSV columns a statistic writes (default: its ``out`` alone).
        recorded_only: left out of the Markdown, its legend and the CSV when no policy has a value.
            DECISION (api.md §4.8): for columns declared after stores existed (the trace summaries),
            so the leaderboard of an older store stays the one it was.
    """

    header: str
    legend: str | None
    name: str | None = None
    section: str = "means"
    aggregate: str = "mean"
    out: str | None = None
    digits: int = 4
    style: str = "number"
    optional: bool = False
    csv: tuple[str, ...] = ()
    recorded_only: bool = False

    def __post_init__(self) -> None:
        for attribute, allowed in (("section", SECTIONS), ("aggregate", AGGREGATES), ("style", STYLES)):
            value = getattr(self, attribute)
            if value not in allowed:
                raise ValueError(f"Board.{attribute}: got {value!r}, expected one of {', '.join(allowed)}")


@dataclass(frozen=True)
class Column:
    """One result column.

    Attributes:
        name: the column's name (SQL column, DataFrame column, CSV column).
        table: ``episodes``, ``steps``, ``window_runs``, ``leaderboard`` (a leaderboard-only
            statistic) or ``rl_groups`` (the RL table).
        sql: its SQLite type and constraints (``None`` for leaderboard statistics). A column added
            after stores exist must allow NULL or carry a DEFAULT (SQLite's ADD COLUMN rule).
        definition: one line saying what the value is (the glossary).
        summary: episodes: how the episode's value is computed from its step rows; ``None`` when
            the harness sets it.
        source: steps: where the value of a step row comes from.
        board: how the leaderboard aggregates and prints it; ``None`` when it is not shown.
    """

    name: str
    table: str
    sql: str | None
    definition: str
    summary: Callable[[EpisodeSteps], Any] | None = field(default=None, compare=False)
    source: Source | None = None
    board: Board | None = None

    @property
    def out(self) -> str:
        """The leaderboard CSV's column name."""
        if self.board is None or self.board.out is None:
            return self.name
        return self.board.out

    @property
    def csv(self) -> tuple[str, ...]:
        """The leaderboard CSV columns this column writes."""
        if self.board is None:
            return ()
        return self.board.csv or (self.out,)

    @property
    def numeric(self) -> bool:
        """Whether the stored value is a number (INTEGER or REAL)."""
        return self.sql is not None and self.sql.split()[0] in ("INTEGER", "REAL")
