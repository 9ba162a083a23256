"""The suite file's content as objects: recipes, fingerprints, members and suites, read from dicts.

A suite file (docs/suite.md §1) holds a name, a description, the fingerprint rules it was written
with, the provenance of its freeze and its members; each member records how it is built (a
:class:`Recipe`) and the :class:`Fingerprint` it must reproduce. This module parses and validates
that content; computing and checking fingerprints is :mod:`.fingerprint`, reading the shipped
files is :mod:`.loading`.

DECISION (docs/suite.md §3): a procedural member is the catalogue's own scenario, named
``random-SEED`` as ``random:SEED`` and the Random env id name it; the suite's member name
(``uavpen-v1/d0.25/30000``) labels it in the suite only. The scenario hash includes the
scenario's name, so naming the scenario after the suite would give the same scenario a second
identity (another episode seed, another best-known record) in every suite version.
"""

from __future__ import annotations

import base64
import binascii
import fnmatch
import math
import re
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from uav_penetration_env.scenario import Scenario, ScenarioError
from uav_penetration_env.suggest import did_you_mean

if TYPE_CHECKING:
    from uav_penetration_env.dynamic_catalogue import DynamicKnobs

# The scheme of the fingerprint block: a file written by another scheme is refused on reading,
# since its hashes were computed differently and cannot be compared with this package's.
# Scheme 2: each member stores the controls of its replay episode (``replay_actions``), which the
# check replays open loop; scheme 1 computed them again with the harness's greedy floor.
FINGERPRINT_SCHEME = 2
FIXED_GROUP = "fixed"
DIFFICULTY_GROUPS = ("d0.25", "d0.50", "d0.75")
MEMBER_KEYS = (
    "name",
    "group",
    "build",
    "scenario",
    "scenario_hash",
    "terrain_hash",
    "floors_hash",
    "replay_total_j",
    "replay_steps",
    "replay_actions",
)
# How ``replay_actions`` is written (the suite file's ``fingerprint.replay_actions`` says so too).
ACTIONS_ENCODING = (
    "base64 of zlib-compressed little-endian float64, column by column (dv, dphi, dtheta), one row per step"
)
ACTIONS_LINE = 96  # characters per line of the encoded controls in the suite file
SUITE_KEYS = ("suite", "description", "fingerprint", "frozen", "members")
# A suite name is versioned (``uavpen-v1``): a changed member is a new name, never an edit.
NAME_PATTERN = re.compile(r"^[a-z][a-z0-9.-]*-v[0-9]+$")


class SuiteError(ValueError):
    """A suite file or suite name that cannot be used (unknown, unreadable, malformed)."""


Controls = tuple[tuple[float, float, float], ...]


def encode_actions(actions: Controls) -> str:
    """The suite file's text of a control sequence: exact, compact (:data:`ACTIONS_ENCODING`).

    DECISION (docs/suite.md §2): the controls are stored bit for bit as float64, compressed and in
    base64, in lines of :data:`ACTIONS_LINE` characters. Rounding them (to float32 or to printed
    digits) would move the replayed total by far more than its tolerance; round-trip decimal text
    takes about three times the room. Column by column, the constant speed and turn columns of a
    greedy episode compress to almost nothing, so a member's 50-odd steps take about 550
    characters, close to the 8 bytes per step of its pitch column, which no exact encoding avoids.

    Args:
        actions: (n, 3) controls [dv (m/s), dphi (rad), dtheta (rad)], n >= 1.
    """
    columns = np.ascontiguousarray(np.asarray(actions, dtype="<f8").T)
    text = base64.b64encode(zlib.compress(columns.tobytes(), 9)).decode("ascii")
    return "\n".join(text[i : i + ACTIONS_LINE] for i in range(0, len(text), ACTIONS_LINE)) + "\n"


def decode_actions(text: Any, steps: Any, where: str) -> Controls:
    """The control sequence of :func:`encode_actions`' text, checked against its ``steps``.

    Raises:
        SuiteError: ``where.replay_actions`` (or ``.replay_steps``) naming what is wrong.
    """
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise SuiteError(f"{where}.replay_steps: got {steps!r}, expected an integer >= 1")
    expected = f"{steps} steps of controls as {ACTIONS_ENCODING}"
    if not isinstance(text, str):
        raise SuiteError(f"{where}.replay_actions: got {text!r}, expected {expected}")
    try:
        raw = zlib.decompress(base64.b64decode("".join(text.split()), validate=True))
    except (binascii.Error, ValueError, zlib.error):
        raise SuiteError(f"{where}.replay_actions: got undecodable text, expected {expected}") from None
    if len(raw) != 3 * 8 * steps:
        raise SuiteError(
            f"{where}.replay_actions: got {len(raw) // 8} numbers, expected {3 * steps} ({expected})"
        )
    columns = np.frombuffer(raw, dtype="<f8").reshape(3, steps)
    if not np.all(np.isfinite(columns)):
        raise SuiteError(f"{where}.replay_actions: got a non-finite control, expected {expected}")
    return tuple((float(dv), float(dphi), float(dtheta)) for dv, dphi, dtheta in columns.T)


def as_controls(actions: Any) -> Controls:
    """``actions`` ((n, 3) numbers) as the exact tuple a :class:`Fingerprint` holds.

    Raises:
        ValueError: not (n, 3) with n >= 1, or a non-finite control.
    """
    array = np.asarray(actions, dtype=np.float64)
    if array.ndim != 2 or array.shape[0] < 1 or array.shape[1] != 3 or not np.all(np.isfinite(array)):
        raise ValueError(f"replay_actions: got shape {array.shape}, expected (n >= 1, 3) finite controls")
    return tuple((float(dv), float(dphi), float(dtheta)) for dv, dphi, dtheta in array)



@dataclass(frozen=True)
class Recipe:
    """How a member is built: a catalogue name, or a procedural scenario of a difficulty and a seed.

    Attributes:
        catalogue: a name of :data:`~uav_penetration_env.catalogue.NAMED_SCENARIOS` (``paper``).
        difficulty: d in [0, 1] of :func:`~uav_penetration_env.catalogue.random_scenario`.
        seed: the generator seed of the procedural scenario.
    """

    catalogue: str | None = None
    difficulty: float | None = None
    seed: int | None = None
    dynamic: DynamicKnobs | None = None

    @classmethod
    def from_dict(cls, data: Any, where: str) -> Recipe:
        """Parse ``{catalogue: NAME}`` or ``{difficulty: D, seed: S}``, the latter with an optional ``dynamic`` mapping.

        ``dynamic`` holds the knobs of a procedural dynamic scenario
        (:class:`~uav_penetration_env.dynamic_catalogue.DynamicKnobs`: ``unknown_fraction``,
        ``lateness``, ``mobile``, ``position_error_km``; docs/dynamic.md §5).

        Raises:
            SuiteError: naming ``where``, the value and the expected forms.
        """
        from uav_penetration_env.catalogue import NAMED_SCENARIOS

        expected = (
            f"{{catalogue: NAME}} (one of {', '.join(NAMED_SCENARIOS)}) or {{difficulty: D, seed: S}} "
            "(with an optional dynamic: {unknown_fraction, lateness, mobile, position_error_km})"
        )
        forms = ({"catalogue"}, {"difficulty", "seed"}, {"difficulty", "seed", "dynamic"})
        if not isinstance(data, Mapping) or set(data) not in forms:
            raise SuiteError(f"{where}: got {data!r}, expected {expected}")
        if "dynamic" in data:
            static = cls.from_dict({k: v for k, v in data.items() if k != "dynamic"}, where)
            return replace(static, dynamic=_knobs(data["dynamic"], f"{where}.dynamic"))
        if "catalogue" in data:
            name = data["catalogue"]
            if name not in NAMED_SCENARIOS:
                raise SuiteError(
                    f"{where}.catalogue: got {name!r} — {did_you_mean(name, NAMED_SCENARIOS)}expected one of "
                    f"{', '.join(NAMED_SCENARIOS)}"
                )
            return cls(catalogue=str(name))
        difficulty, seed = data["difficulty"], data["seed"]
        if (
            isinstance(difficulty, bool)
            or not isinstance(difficulty, (int, float))
            or not 0 <= difficulty <= 1
        ):
            raise SuiteError(f"{where}.difficulty: got {difficulty!r}, expected a number in [0, 1]")
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise SuiteError(f"{where}.seed: got {seed!r}, expected an integer >= 0")
        return cls(difficulty=float(difficulty), seed=int(seed))

    def to_dict(self) -> dict[str, Any]:
        """The ``build`` mapping of the suite file."""
        if self.catalogue is not None:
            return {"catalogue": self.catalogue}
        if self.dynamic is not None:
            return {"difficulty": self.difficulty, "seed": self.seed, "dynamic": asdict(self.dynamic)}
        return {"difficulty": self.difficulty, "seed": self.seed}

    @property
    def group(self) -> str:
        """``fixed`` for a catalogue scenario, ``d0.25``-style for a procedural one (``d0.50-u0.50-l0.50-m1-e3`` dynamic)."""
        if self.catalogue is not None:
            return FIXED_GROUP
        return f"d{self.difficulty:.2f}" + ("" if self.dynamic is None else f"-{self.dynamic.label}")

    def member_name(self, suite: str) -> str:
        """The member's name in suite ``suite``: ``SUITE/paper`` or ``SUITE/d0.25/30000``."""
        if self.catalogue is not None:
            return f"{suite}/{self.catalogue}"
        return f"{suite}/{self.group}/{self.seed}"

    def build(self) -> Scenario:
        """The scenario (exactly what ``--scenarios NAME`` or ``random:SEED --difficulty D`` give)."""
        from uav_penetration_env.catalogue import NAMED_SCENARIOS, random_scenario

        if self.catalogue is not None:
            return NAMED_SCENARIOS[self.catalogue]()
        if self.dynamic is not None:
            from uav_penetration_env.dynamic_catalogue import random_dynamic_scenario

            name = f"random-{self.seed}-{self.dynamic.label}"
            return random_dynamic_scenario(np.random.default_rng(self.seed), self.difficulty, self.dynamic, name=name)
        return random_scenario(np.random.default_rng(self.seed), self.difficulty, name=f"random-{self.seed}")


def _knobs(data: Any, where: str) -> DynamicKnobs:
    """The :class:`DynamicKnobs` of a recipe's ``dynamic`` mapping.

    Raises:
        SuiteError: not a mapping of the knobs' fields, or a knob outside its domain.
    """
    from uav_penetration_env.dynamic_catalogue import DynamicKnobs

    names = [f.name for f in fields(DynamicKnobs)]
    if not isinstance(data, Mapping) or not set(data) <= set(names):
        raise SuiteError(f"{where}: got {data!r}, expected a mapping of some of {', '.join(names)}")
    try:
        return DynamicKnobs(**data)
    except ScenarioError as error:
        raise SuiteError(f"{where}.{error}") from None


@dataclass(frozen=True)
class Fingerprint:
    """What a member must reproduce (:mod:`uav_penetration_env.suites.fingerprint`).

    Attributes:
        scenario_hash: 16 hex digits, :attr:`Scenario.hash`.
        terrain_hash: 16 hex digits of the built (nx, ny) terrain grid rounded to ``QUANTUM_M``.
        floors_hash: 16 hex digits of the built (M, nx, ny) visibility floors rounded likewise.
        replay_total_j: total cost of the replay episode (:func:`replay_total_j`).
        replay_actions: the replay episode's controls, one (dv, dphi, dtheta) per step, exact: the
            check flies them open loop from ``env.reset(seed=REPLAY_SEED)``.
    """

    scenario_hash: str
    terrain_hash: str
    floors_hash: str
    replay_total_j: float
    replay_actions: Controls


@dataclass(frozen=True)
class SuiteMember:
    """One member of a suite.

    Attributes:
        name: the member's name (``uavpen-v1/d0.25/30000``).
        group: ``fixed`` or the procedural difficulty (``d0.25``).
        recipe: how it is built.
        scenario: the built scenario's own name (``random-30000``, ``paper-2022-sec5``).
        fingerprint: the frozen fingerprint.
    """

    name: str
    group: str
    recipe: Recipe
    scenario: str
    fingerprint: Fingerprint

    def to_dict(self) -> dict[str, Any]:
        """The member's entry of the suite file."""
        return {
            "name": self.name,
            "group": self.group,
            "build": self.recipe.to_dict(),
            "scenario": self.scenario,
            "scenario_hash": self.fingerprint.scenario_hash,
            "terrain_hash": self.fingerprint.terrain_hash,
            "floors_hash": self.fingerprint.floors_hash,
            "replay_total_j": self.fingerprint.replay_total_j,
            "replay_steps": len(self.fingerprint.replay_actions),
            "replay_actions": encode_actions(self.fingerprint.replay_actions),
        }


@dataclass(frozen=True)
class Suite:
    """A frozen suite as read from its file.

    Attributes:
        name: the suite's name (``uavpen-v1``).
        description: one paragraph.
        members: the members in file order.
        path: the file it was read from.
        frozen: provenance of the freeze (date, commit, versions).
        fingerprint: the fingerprint rules the file was written with (scheme, quantum, tolerance,
            replay).
    """

    name: str
    description: str
    members: tuple[SuiteMember, ...]
    path: Path | None = None
    frozen: Mapping[str, Any] = field(default_factory=dict)
    fingerprint: Mapping[str, Any] = field(default_factory=dict)

    @property
    def groups(self) -> list[str]:
        """The member groups in file order (``fixed``, ``d0.25``, ...)."""
        return list(dict.fromkeys(member.group for member in self.members))

    def member(self, name: str) -> SuiteMember:
        """The member called ``name``.

        Raises:
            SuiteError: no such member (with a did-you-mean).
        """
        for member in self.members:
            if member.name == name:
                return member
        names = [m.name for m in self.members]
        raise SuiteError(
            f"suite {self.name}: unknown member {name!r} — {did_you_mean(name, names)}see `uav-bench suite show {self.name}`"
        )

    def select(self, patterns: Sequence[str] | None) -> list[SuiteMember]:
        """The members whose name matches any shell pattern (``uavpen-v1/d0.25/*``); all for ``None``.

        Raises:
            SuiteError: a pattern that matches no member (with a did-you-mean).
        """
        if not patterns:
            return list(self.members)
        names = [m.name for m in self.members]
        for pattern in patterns:
            if not fnmatch.filter(names, pattern):
                raise SuiteError(
                    f"suite {self.name}: no member matches {pattern!r} — {did_you_mean(pattern, names)}"
                    f"members are named like {names[0]} or {names[-1]} (shell patterns allowed)"
                )
        return [m for m in self.members if any(fnmatch.fnmatchcase(m.name, p) for p in patterns)]

    def to_dict(self) -> dict[str, Any]:
        """The suite file's content."""
        return {
            "suite": self.name,
            "description": self.description,
            "fingerprint": dict(self.fingerprint),
            "frozen": dict(self.frozen),
            "members": [m.to_dict() for m in self.members],
        }



def require_keys(data: Mapping[str, Any], keys: Sequence[str], where: str) -> None:
    """Refuse a mapping with a key outside ``keys`` (with a did-you-mean) or without one of them."""
    for key in data:
        if key not in keys:
            raise SuiteError(
                f"{where}: unknown key {key!r} — {did_you_mean(key, keys)}allowed: {', '.join(keys)}"
            )
    for key in keys:
        if key not in data:
            raise SuiteError(f"{where}: missing key {key!r}")


def suite_from_dict(data: Any, path: Path | None = None) -> Suite:
    """A :class:`Suite` from the parsed content of a suite file.

    Raises:
        SuiteError: a missing or unknown key, a bad recipe, a duplicate member or scenario hash.
    """
    where = f"suite file {path}" if path else "suite"
    if not isinstance(data, Mapping):
        raise SuiteError(f"{where}: expected a mapping with keys {', '.join(SUITE_KEYS)}")
    require_keys(data, SUITE_KEYS, where)
    name = data["suite"]
    if not isinstance(name, str) or not NAME_PATTERN.match(name):
        raise SuiteError(f"{where}: suite: got {name!r}, expected a versioned name like uavpen-v1")
    if not isinstance(data["members"], list) or not data["members"]:
        raise SuiteError(f"{where}: members: expected a non-empty list")
    rules = dict(data["fingerprint"] or {})
    if rules.get("scheme") != FINGERPRINT_SCHEME:
        raise SuiteError(
            f"{where}: fingerprint.scheme: got {rules.get('scheme')!r}, expected {FINGERPRINT_SCHEME} "
            "(this version of the package computes fingerprints by that scheme only)"
        )
    members = []
    for index, entry in enumerate(data["members"]):
        at = f"{where}: members[{index}]"
        if not isinstance(entry, Mapping):
            raise SuiteError(f"{at}: got {entry!r}, expected a mapping")
        require_keys(entry, MEMBER_KEYS, at)
        recipe = Recipe.from_dict(entry["build"], f"{at}.build")
        expected_name = recipe.member_name(name)
        if entry["name"] != expected_name or entry["group"] != recipe.group:
            raise SuiteError(
                f"{at}: name/group {entry['name']!r}/{entry['group']!r} do not match its build; "
                f"expected {expected_name!r}/{recipe.group!r}"
            )
        total = entry["replay_total_j"]
        if isinstance(total, bool) or not isinstance(total, (int, float)) or not math.isfinite(total):
            raise SuiteError(f"{at}.replay_total_j: got {total!r}, expected a finite number")
        for key in ("scenario_hash", "terrain_hash", "floors_hash"):
            if not (isinstance(entry[key], str) and re.fullmatch(r"[0-9a-f]{16}", entry[key])):
                raise SuiteError(f"{at}.{key}: got {entry[key]!r}, expected 16 hex digits")
        actions = decode_actions(entry["replay_actions"], entry["replay_steps"], at)
        fingerprint = Fingerprint(
            entry["scenario_hash"], entry["terrain_hash"], entry["floors_hash"], float(total), actions
        )
        members.append(
            SuiteMember(entry["name"], entry["group"], recipe, str(entry["scenario"]), fingerprint)
        )
    for label, values in (
        ("member name", [m.name for m in members]),
        ("scenario hash", [m.fingerprint.scenario_hash for m in members]),
    ):
        repeated = sorted({v for v in values if values.count(v) > 1})
        if repeated:
            raise SuiteError(f"{where}: {label} {repeated[0]!r} appears twice; every member must be distinct")
    return Suite(name, str(data["description"]), tuple(members), path, dict(data["frozen"] or {}), rules)

