"""Best-known records: one JSON file per scenario hash with the cheapest control sequence known.

A :class:`BestKnownRecord` holds the scenario (its name, hash and full content), the control
sequence (K x 3 physical controls [dv (m/s), dphi (rad), dtheta (rad)], the env's action units),
its total cost J* (the evaluator's ``total_cost``: ΣJ(k) + failure penalty, no discount, no
terminal cost), outcome and step count, how and when it was found, the budget spent, the library
versions and the result of the search that used no stored track (``unseeded_total``).

Records live in ``uav_penetration_env/benchmark/bestknown/records/<scenario.hash>.json``
(package data). :func:`replay_record` flies the controls through the env exactly as the evaluator
flies a policy (:func:`~uav_penetration_env.benchmark.evaluate.run_episode`, seed 0), so the
replayed ``total_cost`` is the number every leaderboard row is compared with (docs/best-known.md).

DECISION (docs/best-known.md §2): the controls are stored as physical controls, not
the search's normalised [-1, 1] variables, so a record replays through ``env.step`` with no
knowledge of the search; JSON floats are written with ``repr`` (Python's shortest round-trip
form), so ``json.loads`` gives back the identical float64 values.
"""

from __future__ import annotations

import copy
import datetime as dt
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from uav_penetration_env.atomic import write_text_atomic
from uav_penetration_env.scenario import Scenario, load_scenario
from uav_penetration_env.types import FloatArray

RECORDS_DIR = Path(__file__).resolve().parent / "records"
FORMAT = "uav-penetration-best-known/1"
REPLAY_TOLERANCE = 1e-12  # relative; exactly 0 on the machine that recorded the file
VERSION_LIBRARIES = ("numpy", "numba", "cmaes")

__all__ = [
    "FORMAT",
    "RECORDS_DIR",
    "REPLAY_TOLERANCE",
    "BestKnownRecord",
    "RecordError",
    "Replay",
    "ReplayPolicy",
    "best_known_total",
    "library_versions",
    "load_record",
    "read_record",
    "record_path",
    "records",
    "relative_difference",
    "replay_controls",
    "replay_record",
    "utc_now",
    "write_record",
]


class RecordError(ValueError):
    """A record file that does not parse, or whose content contradicts itself (one line)."""


@dataclass(frozen=True)
class BestKnownRecord:
    """The best control sequence known for one scenario (docs/best-known.md §2).

    Attributes:
        scenario_name: the scenario's name.
        scenario_hash: ``Scenario.hash`` (16 hex digits); the file is named after it.
        scenario: the scenario's content (``Scenario.to_dict()``), so a record replays on its own.
        total_cost: J*, the evaluator's ``total_cost`` of the replayed controls.
        outcome: success | collided | out_of_area | truncated.
        steps: K, the number of transitions (the length of ``controls``).
        controls: (K, 3) physical controls [m/s, rad, rad] (``env.step`` actions).
        found_by: how it was found: ``{"method": "offline-search", ...settings, starts}`` or
            ``{"method": "stored-episode", "policy", "policy_hash", "seed", "run_id", "store"}``.
        found_at: UTC time (ISO 8601) the record was written.
        budget: ``{"seconds": s, "evaluations": n}`` spent by the search (0 for a stored episode).
        versions: package, numpy, numba, cmaes and python versions of the writing process.
        unseeded_total: total cost the offline search reached from greedy and random starts alone
            (no stored track), or ``None`` when that search was not run.
        unseeded_budget: that search's ``{"seconds", "evaluations"}``.
        history: earlier totals of this file, newest last (``{"total_cost", "found_by", "found_at"}``).
    """

    scenario_name: str
    scenario_hash: str
    scenario: Mapping[str, Any]
    total_cost: float
    outcome: str
    steps: int
    controls: tuple[tuple[float, float, float], ...]
    found_by: Mapping[str, Any]
    found_at: str
    budget: Mapping[str, Any] = field(default_factory=dict)
    versions: Mapping[str, str] = field(default_factory=dict)
    unseeded_total: float | None = None
    unseeded_budget: Mapping[str, Any] | None = None
    history: tuple[Mapping[str, Any], ...] = ()

    def __post_init__(self) -> None:
        if not (isinstance(self.scenario_hash, str) and len(self.scenario_hash) == 16):
            raise RecordError(f"scenario_hash: got {self.scenario_hash!r}, expected 16 hex digits")
        if not (isinstance(self.total_cost, float) and math.isfinite(self.total_cost)):
            raise RecordError(f"total_cost: got {self.total_cost!r}, expected a finite float")
        if len(self.controls) != self.steps or self.steps < 1:
            raise RecordError(
                f"controls: got {len(self.controls)} rows, expected steps = {self.steps} >= 1 rows of 3"
            )

    @property
    def control_array(self) -> FloatArray:
        """(K, 3) float64 copy of the controls."""
        return np.array(self.controls, dtype=np.float64).reshape(self.steps, 3)

    def to_json(self) -> str:
        """The file's text: indented JSON, floats in round-trip form, one control row per line."""
        data = asdict(self)
        data = {"format": FORMAT, **data}
        controls = data.pop("controls")
        body = json.dumps(data, indent=1, allow_nan=False)
        rows = ",\n".join("  " + json.dumps(list(row)) for row in controls)
        # The controls go last, one row per line, so a diff of two records stays readable.
        return body[:-2] + ',\n "controls": [\n' + rows + "\n ]\n}\n"

    @classmethod
    def from_json(cls, text: str, source: str = "record") -> BestKnownRecord:
        """Parse a record file's text.

        Raises:
            RecordError: not JSON, another format, a missing or unknown field, a malformed value.
        """
        try:
            data = json.loads(text)
        except json.JSONDecodeError as error:
            raise RecordError(f"{source}: not JSON ({error}); expected a best-known record") from None
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            got = data.get("format") if isinstance(data, dict) else type(data).__name__
            raise RecordError(f"{source}: format: got {got!r}, expected {FORMAT!r}")
        data.pop("format")
        names = {f for f in cls.__dataclass_fields__}
        unknown = sorted(set(data) - names)
        if unknown:
            raise RecordError(
                f"{source}: {unknown[0]}: unknown field, expected one of {', '.join(sorted(names))}"
            )
        try:
            data["controls"] = tuple(tuple(float(v) for v in row) for row in data["controls"])
            if any(len(row) != 3 for row in data["controls"]):
                raise RecordError(f"{source}: controls: got a row without 3 numbers, expected (K, 3)")
            data["history"] = tuple(data.get("history") or ())
            return cls(**data)
        except TypeError as error:
            raise RecordError(f"{source}: {error}; expected the fields of a best-known record") from None
        except KeyError as error:
            raise RecordError(f"{source}: {error.args[0]}: missing, expected a best-known record") from None

    def load_scenario(self) -> Scenario:
        """The recorded scenario, checked against the recorded hash.

        Raises:
            RecordError: the content no longer hashes to ``scenario_hash`` (the model, the scenario
                schema or a terrain file changed).
        """
        scenario = load_scenario(copy.deepcopy(dict(self.scenario)))
        if scenario.hash != self.scenario_hash:
            raise RecordError(
                f"scenario_hash: the recorded scenario {self.scenario_name!r} now hashes to "
                f"{scenario.hash}, expected {self.scenario_hash} (the scenario's content or schema changed)"
            )
        return scenario


# --- files --------------------------------------------------------------------------------------------


def record_path(scenario_hash: str, folder: str | Path | None = None) -> Path:
    """``<folder>/<scenario_hash>.json`` (default folder: the package's records)."""
    return Path(RECORDS_DIR if folder is None else folder) / f"{scenario_hash}.json"


def read_record(path: str | Path) -> BestKnownRecord:
    """Read one record file.

    Raises:
        RecordError: the file does not parse, or its name is not ``<scenario_hash>.json``.
    """
    path = Path(path)
    record = BestKnownRecord.from_json(path.read_text(encoding="utf-8"), str(path))
    if path.stem != record.scenario_hash:
        raise RecordError(
            f"{path}: scenario_hash: got {record.scenario_hash}, expected the file name {path.stem}"
        )
    return record


@cache
def _cached(scenario_hash: str, mtime_ns: int) -> BestKnownRecord:
    return read_record(record_path(scenario_hash))


def load_record(scenario_hash: str, folder: str | Path | None = None) -> BestKnownRecord | None:
    """The record of a scenario hash, or ``None`` when there is none.

    Args:
        scenario_hash: ``Scenario.hash`` (the ``scenario_hash`` of an episode row).
        folder: a records folder (default: the package's committed records).

    Raises:
        RecordError: a record file exists but does not parse.
    """
    path = record_path(str(scenario_hash), folder)
    if not path.is_file():
        return None
    if folder is None:  # the package's records are read once per file version
        return _cached(str(scenario_hash), path.stat().st_mtime_ns)
    return read_record(path)


def best_known_total(scenario_hash: str, folder: str | Path | None = None) -> float | None:
    """J* of a scenario hash (the record's ``total_cost``), or ``None`` without a record."""
    record = load_record(scenario_hash, folder)
    return None if record is None else record.total_cost


def records(folder: str | Path | None = None) -> list[BestKnownRecord]:
    """Every record of a folder, sorted by scenario name then hash."""
    paths = sorted(Path(RECORDS_DIR if folder is None else folder).glob("*.json"))
    found = [read_record(path) for path in paths]
    return sorted(found, key=lambda r: (r.scenario_name, r.scenario_hash))


def write_record(record: BestKnownRecord, folder: str | Path | None = None) -> Path:
    """Write a record atomically (whole or not at all) as ``<folder>/<hash>.json``."""
    path = record_path(record.scenario_hash, folder)
    write_text_atomic(path, record.to_json())
    _cached.cache_clear()
    return path


def utc_now() -> str:
    """The current UTC time, ISO 8601, whole seconds."""
    return dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat()


def library_versions() -> dict[str, str]:
    """Versions of the package and the libraries the search's numbers depend on."""
    from uav_penetration_env._version import __version__, installed_versions

    return {"uav-penetration": __version__, **installed_versions(VERSION_LIBRARIES)}


def relative_difference(value: float, reference: float) -> float:
    """|value - reference| / max(|reference|, tiny): the replay check's measure."""
    return abs(value - reference) / max(abs(reference), np.finfo(float).tiny)


# --- replay ---------------------------------------------------------------------------------------------


@dataclass
class ReplayPolicy:
    """A policy that flies a fixed control sequence (then holds course with zero controls).

    DECISION (docs/best-known.md §2): past the end of the sequence it returns zeros (keep speed,
    heading and pitch); a record's sequence always covers its episode, so this only matters for
    a shorter sequence under test.
    """

    controls: FloatArray
    index: int = 0

    def reset(self, model: Any, seed: Any = None) -> None:
        """Start the sequence again."""
        del model, seed
        self.index = 0

    def act(self, observation: Any, info: Mapping[str, Any]) -> FloatArray:
        """The next control of the sequence."""
        k = self.index
        self.index += 1
        if k < len(self.controls):
            return np.array(self.controls[k], dtype=np.float64)
        return np.zeros(3)

    def config(self) -> dict[str, Any]:
        """The configuration (a hash of the controls) for :func:`~..evaluate.policy_config`."""
        import hashlib

        digest = hashlib.sha256(np.ascontiguousarray(self.controls, dtype=np.float64).tobytes()).hexdigest()
        return {"class": "ReplayPolicy", "controls_sha256": digest[:16]}


@dataclass(frozen=True)
class Replay:
    """What flying a control sequence through the env gave.

    Attributes:
        total_cost: the evaluator's ``total_cost`` (ΣJ(k) + Σ penalty).
        outcome: the episode outcome.
        steps: K, transitions flown (the controls used are the first K).
        positions: (K + 1, 3) positions x, y, z [m] from the start state on (from the step rows).
        row: the evaluator's whole episode row.
    """

    total_cost: float
    outcome: str
    steps: int
    positions: FloatArray
    row: Mapping[str, Any]


def replay_controls(scenario: Scenario, controls: FloatArray | Sequence[Sequence[float]]) -> Replay:
    """Fly ``controls`` through the env exactly as the evaluator flies a policy (seed 0).

    Args:
        scenario: the scenario (its start must have no jitter, so the start state is the seed's).
        controls: (K, 3) physical controls.

    Returns:
        The :class:`Replay`.

    Raises:
        RuntimeError: the env raised while flying (the evaluator's error row, as one line).
    """
    from uav_penetration_env.benchmark.evaluate import EpisodeTask, run_episode

    policy = ReplayPolicy(np.asarray(controls, dtype=np.float64).reshape(-1, 3))
    row, steps = run_episode(EpisodeTask("best-known", policy, "replay", scenario, 0))
    if row.get("outcome") == "error":
        raise RuntimeError(f"replay of {scenario.name}: {str(row['error']).splitlines()[0]}")
    positions = np.array(
        [[s["x_km"] * 1000.0, s["y_km"] * 1000.0, s["z_m"]] for s in steps], dtype=np.float64
    )
    return Replay(float(row["total_cost"]), str(row["outcome"]), int(row["steps"]), positions, row)


def replay_record(record: BestKnownRecord) -> Replay:
    """Fly a record's controls through the env (:func:`replay_controls`) on its recorded scenario."""
    return replay_controls(record.load_scenario(), record.control_array)


def updated(record: BestKnownRecord, **changes: Any) -> BestKnownRecord:
    """A copy of ``record`` with ``changes`` (dataclasses.replace)."""
    return replace(record, **changes)
