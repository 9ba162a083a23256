"""The results store: one SQLite file that survives interruption (api.md, harness).

Tables: ``schema_version``; ``runs`` (provenance of each ``evaluate`` call); ``policies`` and
``scenarios`` (configurations by hash, so a store is self-describing); ``episodes`` (one row per
episode, unique by ``(policy_hash, scenario_hash, seed)``); ``steps`` (one row per step).

Only the parent process writes, one transaction per finished episode (its row and all its steps
together), in WAL mode: an interrupted sweep leaves every finished episode and nothing partial,
and a rerun skips what is done and retries ``error`` rows.
"""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

SCHEMA_VERSION = 1

EPISODE_COLUMNS: dict[str, str] = {
    "policy": "TEXT NOT NULL",
    "policy_hash": "TEXT NOT NULL",
    "scenario": "TEXT NOT NULL",
    "scenario_hash": "TEXT NOT NULL",
    "seed": "INTEGER NOT NULL",
    "outcome": "TEXT",  # success | collided | out_of_area | truncated | error
    "total_J": "REAL",  # sum of J(k) over the episode (without the failure penalty)
    "total_penalty": "REAL",
    "total_cost": "REAL",  # total_J + total_penalty = -return
    "mean_J": "REAL",  # total_J / steps: mean J per track point
    "terrain_total": "REAL",
    "radar_total": "REAL",
    "third_total": "REAL",
    "fuel_kg": "REAL",
    "p_detected": "REAL",  # 1 - prod_k (1 - detection_prob_k)
    "detected_steps": "INTEGER",
    "max_detection_prob": "REAL",
    "path_length_km": "REAL",
    "steps": "INTEGER",
    "nfev": "INTEGER",  # objective evaluations over the episode
    "nfev_per_step": "REAL",
    "planning_seconds": "REAL",  # mean per step
    "objective_seconds": "REAL",  # mean per step spent inside rollout_cost
    "episode_seconds": "REAL",
    "weights": "TEXT",
    "profile": "TEXT",
    "horizon": "INTEGER",
    "max_evals": "INTEGER",
    "train_timesteps": "INTEGER",
    "train_seconds": "REAL",
    "error": "TEXT NOT NULL DEFAULT ''",
    "run_id": "INTEGER",
    "finished": "TEXT",
}

STEP_COLUMNS: dict[str, str] = {
    "step": "INTEGER NOT NULL",
    "x_km": "REAL",
    "y_km": "REAL",
    "z_m": "REAL",
    "altitude_agl": "REAL",
    "distance_to_goal": "REAL",
    "speed": "REAL",
    "heading": "REAL",
    "pitch": "REAL",
    "J": "REAL",
    "penalty": "REAL",
    "terrain_threat": "REAL",
    "radar_threat": "REAL",
    "third_term": "REAL",
    "terrain_threat_n": "REAL",
    "radar_threat_n": "REAL",
    "third_term_n": "REAL",
    "fuel_kg": "REAL",
    "detection_prob": "REAL",
    "detected": "INTEGER",
    "action_dv": "REAL",
    "action_dphi": "REAL",
    "action_dtheta": "REAL",
    "nfev": "INTEGER",
    "planning_seconds": "REAL",
    "objective_seconds": "REAL",
    "plan_cost": "REAL",
    "history": "TEXT",  # JSON list: the optimiser's best-so-far after each iteration
    "history_nfev": "TEXT",  # JSON list: evaluations spent at each history entry
}


class StoreError(RuntimeError):
    """The results store cannot be opened, created or written."""


def _json(value: Any) -> str:
    return json.dumps(
        value, sort_keys=True, default=lambda o: o.tolist() if isinstance(o, np.ndarray) else str(o)
    )


class ResultsStore:
    """An SQLite results file. Opening creates it (and its folder) if needed.

    Args:
        path: the SQLite file.

    Raises:
        StoreError: the path is not writable, or the file has another schema version.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._connection = sqlite3.connect(self.path, timeout=60.0)
            self._connection.execute("PRAGMA journal_mode=WAL")
            self._connection.execute("PRAGMA synchronous=NORMAL")
            self._connection.execute("PRAGMA foreign_keys=ON")
            self._create()
        except (OSError, sqlite3.Error) as error:
            raise StoreError(
                f"results store {self.path}: cannot open or create it ({error}); expected a writable file path"
            ) from error

    def _create(self) -> None:
        connection = self._connection
        with connection:
            connection.execute("CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL)")
            row = connection.execute("SELECT version FROM schema_version").fetchone()
            if row is None:
                connection.execute("INSERT INTO schema_version VALUES (?)", (SCHEMA_VERSION,))
            elif row[0] != SCHEMA_VERSION:
                raise StoreError(
                    f"results store {self.path}: schema version {row[0]}, expected {SCHEMA_VERSION}"
                )
            connection.execute(
                "CREATE TABLE IF NOT EXISTS runs (run_id INTEGER PRIMARY KEY AUTOINCREMENT, started TEXT, "
                "provenance TEXT, settings TEXT)"
            )
            connection.execute(
                "CREATE TABLE IF NOT EXISTS policies (policy_hash TEXT PRIMARY KEY, policy TEXT, config TEXT)"
            )
            connection.execute(
                "CREATE TABLE IF NOT EXISTS scenarios (scenario_hash TEXT PRIMARY KEY, scenario TEXT, yaml TEXT)"
            )
            columns = ", ".join(f"{name} {kind}" for name, kind in EPISODE_COLUMNS.items())
            connection.execute(
                f"CREATE TABLE IF NOT EXISTS episodes (episode_id INTEGER PRIMARY KEY AUTOINCREMENT, {columns}, "
                "UNIQUE (policy_hash, scenario_hash, seed))"
            )
            columns = ", ".join(f"{name} {kind}" for name, kind in STEP_COLUMNS.items())
            connection.execute(
                "CREATE TABLE IF NOT EXISTS steps (episode_id INTEGER NOT NULL REFERENCES episodes(episode_id) "
                f"ON DELETE CASCADE, {columns}, PRIMARY KEY (episode_id, step))"
            )

    # --- writing ---------------------------------------------------------------------------------------

    def start_run(self, provenance: Mapping[str, Any], settings: Mapping[str, Any]) -> int:
        """Record a sweep's provenance; returns its ``run_id``."""
        with self._connection:
            cursor = self._connection.execute(
                "INSERT INTO runs (started, provenance, settings) VALUES (?, ?, ?)",
                (provenance.get("date", ""), _json(dict(provenance)), _json(dict(settings))),
            )
        return int(cursor.lastrowid)

    def register(
        self, policies: Mapping[str, tuple[str, Mapping[str, Any]]], scenarios: Mapping[str, tuple[str, str]]
    ) -> None:
        """Store configurations: ``policies[hash] = (name, config)``, ``scenarios[hash] = (name, yaml)``."""
        with self._connection:
            self._connection.executemany(
                "INSERT OR REPLACE INTO policies VALUES (?, ?, ?)",
                [(h, n, _json(dict(c))) for h, (n, c) in policies.items()],
            )
            self._connection.executemany(
                "INSERT OR REPLACE INTO scenarios VALUES (?, ?, ?)",
                [(h, n, y) for h, (n, y) in scenarios.items()],
            )

    def write_episode(self, episode: Mapping[str, Any], steps: Sequence[Mapping[str, Any]]) -> int:
        """Write one finished episode and its steps in one transaction (replacing an ``error`` row).

        Returns:
            The new ``episode_id``.
        """
        row = {name: _sql_value(episode.get(name)) for name in EPISODE_COLUMNS}
        row["error"] = row["error"] or ""
        key = (row["policy_hash"], row["scenario_hash"], row["seed"])
        with self._connection:
            self._connection.execute(
                "DELETE FROM episodes WHERE policy_hash = ? AND scenario_hash = ? AND seed = ?", key
            )
            names = ", ".join(row)
            marks = ", ".join("?" for _ in row)
            cursor = self._connection.execute(
                f"INSERT INTO episodes ({names}) VALUES ({marks})", tuple(row.values())
            )
            episode_id = int(cursor.lastrowid)
            if steps:
                step_names = list(STEP_COLUMNS)
                self._connection.executemany(
                    f"INSERT INTO steps (episode_id, {', '.join(step_names)}) VALUES (?, {', '.join('?' for _ in step_names)})",
                    [(episode_id, *(_sql_value(s.get(name)) for name in step_names)) for s in steps],
                )
        return episode_id

    # --- reading ---------------------------------------------------------------------------------------

    def done_keys(self) -> set[tuple[str, str, int]]:
        """Keys of episodes that finished without error (these are skipped on rerun)."""
        rows = self._connection.execute(
            "SELECT policy_hash, scenario_hash, seed FROM episodes WHERE error = ''"
        ).fetchall()
        return {(p, s, int(seed)) for p, s, seed in rows}

    def episodes(self, include_errors: bool = True) -> pd.DataFrame:
        """All episode rows as a DataFrame (in write order)."""
        query = (
            "SELECT * FROM episodes"
            + ("" if include_errors else " WHERE error = ''")
            + " ORDER BY episode_id"
        )
        return pd.read_sql_query(query, self._connection)

    def steps(self, episode_ids: Iterable[int] | None = None) -> pd.DataFrame:
        """Step rows (optionally of some episodes), ordered by episode and step."""
        if episode_ids is None:
            return pd.read_sql_query("SELECT * FROM steps ORDER BY episode_id, step", self._connection)
        ids = [int(i) for i in episode_ids]
        if not ids:
            return pd.read_sql_query("SELECT * FROM steps WHERE 0", self._connection)
        marks = ", ".join("?" for _ in ids)
        return pd.read_sql_query(
            f"SELECT * FROM steps WHERE episode_id IN ({marks}) ORDER BY episode_id, step",
            self._connection,
            params=ids,
        )

    def runs(self) -> pd.DataFrame:
        """Run provenance rows (``provenance`` and ``settings`` are JSON text)."""
        return pd.read_sql_query("SELECT * FROM runs ORDER BY run_id", self._connection)

    def scenarios(self) -> dict[str, tuple[str, str]]:
        """Stored scenarios: ``hash -> (name, yaml text)``."""
        return {
            h: (n, y)
            for h, n, y in self._connection.execute("SELECT scenario_hash, scenario, yaml FROM scenarios")
        }

    def policies(self) -> dict[str, tuple[str, dict[str, Any]]]:
        """Stored policy configurations: ``hash -> (name, config)``."""
        return {
            h: (n, json.loads(c))
            for h, n, c in self._connection.execute("SELECT policy_hash, policy, config FROM policies")
        }

    def close(self) -> None:
        """Close the connection."""
        self._connection.close()

    def __enter__(self) -> ResultsStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _sql_value(value: Any) -> Any:
    if value is None or isinstance(value, (str, int, float)):
        return value
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    return _json(value)
