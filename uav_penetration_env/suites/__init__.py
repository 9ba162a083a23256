"""Frozen, named benchmark suites: members, fingerprints and the guard that refuses a changed member.

A suite (docs/suite.md) is a YAML file shipped beside this module (``uavpen-v1.yaml``): a name,
a description and its members. Each member says how it is built (a catalogue name such as
``paper``, or a procedural scenario ``random_scenario(default_rng(seed), difficulty)``) and
carries a fingerprint frozen when the file was written (:func:`freeze_suite`):

* ``scenario_hash``: :attr:`Scenario.hash` of the built scenario (every field, and the content of
  every file it reads);
* ``terrain_hash`` and ``floors_hash``: SHA-256 (16 hex digits) of the BUILT terrain height grid
  and of the radars' visibility floors (:class:`~uav_penetration_env.build.BuiltScenario`), each
  value rounded to :data:`QUANTUM_M` first;
* ``replay_total_j``: the total cost ΣJ(k) + Σ penalty of one fixed control sequence replayed
  through the env: the greedy floor's episode (:func:`replay_total_j`), compared to a relative
  tolerance of :data:`TOTAL_J_RTOL`.

:func:`build_member` (and :func:`suite_scenarios`, which ``uav-bench run --suite`` uses) rebuilds
a member and raises :class:`SuiteMismatchError` when any field differs: a silent change to the
model, the terrain synthesis or the generator cannot pass unnoticed; it needs a new suite
version (``uav-bench suite freeze``), and old versions stay as they are.

DECISION (docs/suite.md §3): a procedural member is the catalogue's own scenario, named
``random-SEED`` as ``random:SEED`` and the Random env id name it; the suite's member name
(``uavpen-v1/d0.25/30000``) labels it in the suite only. The scenario hash includes the
scenario's name, so naming the scenario after the suite would give the same scenario a second
identity (another episode seed, another best-known record) in every suite version.
"""

from __future__ import annotations

import datetime as dt
import fnmatch
import hashlib
import json
import math
import os
import re
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from uav_penetration_env.scenario import Scenario
from uav_penetration_env.suggest import did_you_mean
from uav_penetration_env.types import FloatArray

SUITE_FOLDER = Path(__file__).resolve().parent
SUITE_SUFFIX = ".yaml"
FINGERPRINT_SCHEME = 1
# DECISION (docs/suite.md §2): heights and floors are rounded to 1 cm before hashing. A last-digit
# difference between machines moves a value by about 1e-12 m (10 ulp at 1 km); it changes the
# hash only if it carries a value across a rounding boundary, with probability about
# 2 x 1e-12 / 0.01 per value, i.e. about 1e-4 for a member's 6e5 values. A real change moves
# thousands of values by centimetres to metres and changes the hash with certainty; even a
# uniform 1 mm shift of one array moves a tenth of its values across a boundary.
QUANTUM_M = 0.01
# DECISION (docs/suite.md §2): the replayed total J is compared, not hashed: a relative tolerance
# of 1e-9 absorbs the last-digit differences of 150 summed steps (about 1e-14 relative) and still
# catches any change of the cost, the radar model or the kinematics, which moves it by far more.
TOTAL_J_RTOL = 1e-9
REPLAY_SEED = 0  # the env seed of the replay episode (the members have no start jitter)
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
)
SUITE_KEYS = ("suite", "description", "fingerprint", "frozen", "members")
FINGERPRINT_FIELDS = {
    "scenario_hash": "scenario hash",
    "terrain_hash": "terrain hash",
    "floors_hash": "floors hash",
    "replay_total_j": "replayed total J",
}
_NAME = re.compile(r"^[a-z][a-z0-9.-]*-v[0-9]+$")


class SuiteError(ValueError):
    """A suite file or suite name that cannot be used (unknown, unreadable, malformed)."""


class SuiteMismatchError(SuiteError):
    """A member built now differs from its frozen fingerprint.

    Attributes:
        suite: the suite's name.
        member: the member's name.
        field: the fingerprint field (``scenario_hash``, ``terrain_hash``, ``floors_hash``,
            ``replay_total_j``).
        got: the value computed now.
        frozen: the value in the suite file.
    """

    def __init__(self, suite: str, member: str, field: str, got: Any, frozen: Any) -> None:
        self.suite, self.member, self.field, self.got, self.frozen = suite, member, field, got, frozen
        relation = "!=" if field != "replay_total_j" else f"!= (rtol {TOTAL_J_RTOL:g})"
        super().__init__(
            f"suite {suite} member {member}: {FINGERPRINT_FIELDS[field]} {got!r} {relation} frozen {frozen!r}"
            " — the model, the terrain synthesis or the generator changed; freeze a new suite version "
            "(uav-bench suite freeze, docs/suite.md)"
        )


# --- members ---------------------------------------------------------------------------------------------


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

    @classmethod
    def from_dict(cls, data: Any, where: str) -> Recipe:
        """Parse ``{catalogue: NAME}`` or ``{difficulty: D, seed: S}``.

        Raises:
            SuiteError: naming ``where``, the value and the expected forms.
        """
        from uav_penetration_env.catalogue import NAMED_SCENARIOS

        expected = f"{{catalogue: NAME}} (one of {', '.join(NAMED_SCENARIOS)}) or {{difficulty: D, seed: S}}"
        if not isinstance(data, Mapping) or set(data) not in ({"catalogue"}, {"difficulty", "seed"}):
            raise SuiteError(f"{where}: got {data!r}, expected {expected}")
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
        return {"difficulty": self.difficulty, "seed": self.seed}

    @property
    def group(self) -> str:
        """``fixed`` for a catalogue scenario, ``d0.25``-style for a procedural one."""
        return FIXED_GROUP if self.catalogue is not None else f"d{self.difficulty:.2f}"

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
        return random_scenario(np.random.default_rng(self.seed), self.difficulty, name=f"random-{self.seed}")


@dataclass(frozen=True)
class Fingerprint:
    """What a member must reproduce (see the module docstring).

    Attributes:
        scenario_hash: 16 hex digits, :attr:`Scenario.hash`.
        terrain_hash: 16 hex digits of the built (nx, ny) terrain grid rounded to ``QUANTUM_M``.
        floors_hash: 16 hex digits of the built (M, nx, ny) visibility floors rounded likewise.
        replay_total_j: total cost of the replay episode (:func:`replay_total_j`).
    """

    scenario_hash: str
    terrain_hash: str
    floors_hash: str
    replay_total_j: float


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

    def by_scenario_hash(self) -> dict[str, SuiteMember]:
        """``scenario_hash -> member`` (the leaderboard finds a store's suite episodes with it)."""
        return {m.fingerprint.scenario_hash: m for m in self.members}

    def to_dict(self) -> dict[str, Any]:
        """The suite file's content."""
        return {
            "suite": self.name,
            "description": self.description,
            "fingerprint": dict(self.fingerprint),
            "frozen": dict(self.frozen),
            "members": [m.to_dict() for m in self.members],
        }


# --- files -------------------------------------------------------------------------------------------------


def suite_names() -> list[str]:
    """The names of the suites shipped with the package, sorted (``uavpen-v1``)."""
    return sorted(path.name[: -len(SUITE_SUFFIX)] for path in SUITE_FOLDER.glob(f"*{SUITE_SUFFIX}"))


def suite_path(name: str) -> Path:
    """The file of a shipped suite.

    Raises:
        SuiteError: an unknown name (with a did-you-mean and the known names).
    """
    names = suite_names()
    if name not in names:
        raise SuiteError(
            f"unknown suite {name!r} — {did_you_mean(name, names)}known suites: {', '.join(names) or 'none'}"
        )
    return SUITE_FOLDER / f"{name}{SUITE_SUFFIX}"


def load_suite(name: str | Path) -> Suite:
    """Read a suite: a shipped name (``uavpen-v1``) or the path of a suite file.

    Raises:
        SuiteError: an unknown name, an unreadable file, or a malformed entry (naming it).
    """
    text = str(name)
    path = Path(text) if text.endswith(SUITE_SUFFIX) and Path(text).is_file() else suite_path(text)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as error:
        raise SuiteError(f"suite file {path}: cannot read it ({error.strerror})") from None
    except yaml.YAMLError as error:
        raise SuiteError(f"suite file {path}: not valid YAML ({error})") from None
    return suite_from_dict(data, path)


def _require(data: Mapping[str, Any], keys: Sequence[str], where: str) -> None:
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
    _require(data, SUITE_KEYS, where)
    name = data["suite"]
    if not isinstance(name, str) or not _NAME.match(name):
        raise SuiteError(f"{where}: suite: got {name!r}, expected a versioned name like uavpen-v1")
    if not isinstance(data["members"], list) or not data["members"]:
        raise SuiteError(f"{where}: members: expected a non-empty list")
    members = []
    for index, entry in enumerate(data["members"]):
        at = f"{where}: members[{index}]"
        if not isinstance(entry, Mapping):
            raise SuiteError(f"{at}: got {entry!r}, expected a mapping")
        _require(entry, MEMBER_KEYS, at)
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
        fingerprint = Fingerprint(
            entry["scenario_hash"], entry["terrain_hash"], entry["floors_hash"], float(total)
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
    rules = dict(data["fingerprint"] or {})
    if rules.get("scheme") != FINGERPRINT_SCHEME:
        raise SuiteError(
            f"{where}: fingerprint.scheme: got {rules.get('scheme')!r}, expected {FINGERPRINT_SCHEME} "
            "(this version of the package computes fingerprints by that scheme only)"
        )
    return Suite(name, str(data["description"]), tuple(members), path, dict(data["frozen"] or {}), rules)


# --- fingerprints -----------------------------------------------------------------------------------------


def array_hash(values: FloatArray, quantum: float = QUANTUM_M) -> str:
    """16 hex digits of SHA-256 over an array's shape and its values rounded to ``quantum``.

    Args:
        values: any float array (heights, floors) [m].
        quantum: the rounding step [m] (:data:`QUANTUM_M`).

    Raises:
        ValueError: a NaN or infinite value.
    """
    array = np.asarray(values, dtype=np.float64)
    if not np.all(np.isfinite(array)):
        raise ValueError(
            f"values: got {int(np.sum(~np.isfinite(array)))} non-finite values, expected finite heights"
        )
    steps = np.rint(array / quantum).astype("<i8")  # integers: no -0.0, no representation ambiguity
    digest = hashlib.sha256(json.dumps({"shape": list(array.shape), "quantum": quantum}).encode())
    digest.update(np.ascontiguousarray(steps).tobytes())
    return digest.hexdigest()[:16]


def replay_total_j(scenario: Scenario) -> float:
    """Total cost ΣJ(k) + Σ penalty (= −return) of the greedy floor's episode on ``scenario``.

    The replayed control sequence is the one the greedy floor
    (:class:`~uav_penetration_env.benchmark.policies.GreedyPolicy`, default settings) flies from
    the env's reset with seed :data:`REPLAY_SEED`; the sum is taken as the harness takes it (numpy
    sums of the step columns), so a stored greedy episode of the member has this total.

    DECISION (docs/suite.md §2): the greedy episode rather than an open-loop pseudo-random
    sequence, because a random sequence crashes into the terrain within a few steps and never
    meets most radars, while the greedy one flies to the goal past them, so the replay exercises
    kinematics, terrain, every radar, the cost and the normalisation along a whole route.
    """
    from uav_penetration_env.benchmark.policies import GreedyPolicy
    from uav_penetration_env.env import UAVPenetrationEnv

    env = UAVPenetrationEnv(scenario)
    observation, info = env.reset(seed=REPLAY_SEED)
    policy = GreedyPolicy()
    policy.reset(env.model, None)
    costs, penalties = [], []
    done = False
    while not done:
        observation, _, terminated, truncated, info = env.step(policy.act(observation, info))
        costs.append(info["J"])
        penalties.append(info["penalty"])
        done = terminated or truncated
    return float(np.array(costs, dtype=np.float64).sum() + np.array(penalties, dtype=np.float64).sum())


def fingerprint(scenario: Scenario) -> Fingerprint:
    """The fingerprint of a scenario as built now (terrain and floors from the build cache)."""
    from uav_penetration_env.build import build_scenario

    built = build_scenario(scenario)
    return Fingerprint(
        scenario_hash=scenario.hash,
        terrain_hash=array_hash(built.terrain),
        floors_hash=array_hash(built.floors),
        replay_total_j=replay_total_j(scenario),
    )


def check_fingerprint(suite: str, member: SuiteMember, scenario: Scenario, *, replay: bool = True) -> None:
    """Compare ``scenario`` (the member built now) with the member's frozen fingerprint.

    The fields are checked in the order scenario hash, terrain hash, floors hash, replayed total
    J; the first difference raises. The scenario hash is checked before anything is built.

    Args:
        suite: the suite's name (for the message).
        member: the member with its frozen fingerprint.
        scenario: the member's scenario built now.
        replay: also replay the greedy episode (about 0.05 s per member).

    Raises:
        SuiteMismatchError: naming the suite, the member, the field and both values.
    """
    from uav_penetration_env.build import build_scenario

    frozen = member.fingerprint
    if scenario.hash != frozen.scenario_hash:
        raise SuiteMismatchError(suite, member.name, "scenario_hash", scenario.hash, frozen.scenario_hash)
    built = build_scenario(scenario)
    for key, values in (("terrain_hash", built.terrain), ("floors_hash", built.floors)):
        got = array_hash(values)
        if got != getattr(frozen, key):
            raise SuiteMismatchError(suite, member.name, key, got, getattr(frozen, key))
    if replay:
        total = replay_total_j(scenario)
        if not math.isclose(total, frozen.replay_total_j, rel_tol=TOTAL_J_RTOL, abs_tol=0.0):
            raise SuiteMismatchError(suite, member.name, "replay_total_j", total, frozen.replay_total_j)


def build_member(suite: Suite | str, member: SuiteMember | str, *, verify: bool = True) -> Scenario:
    """The scenario of one member, checked against its frozen fingerprint.

    Args:
        suite: a :class:`Suite` or a suite name/path.
        member: a member or its name.
        verify: check the fingerprint (:func:`check_fingerprint`).

    Raises:
        SuiteError: an unknown suite or member.
        SuiteMismatchError: the member changed.
    """
    suite = suite if isinstance(suite, Suite) else load_suite(suite)
    member = member if isinstance(member, SuiteMember) else suite.member(member)
    scenario = member.recipe.build()
    if verify:
        check_fingerprint(suite.name, member, scenario)
    return scenario


def suite_scenarios(
    name: Suite | str, verify: bool = True, members: Sequence[str] | None = None
) -> list[Scenario]:
    """The scenarios of a suite's members (all, or those matching ``members`` patterns), verified.

    Raises:
        SuiteError: an unknown suite or a pattern matching no member.
        SuiteMismatchError: the first member that changed.
    """
    suite = name if isinstance(name, Suite) else load_suite(name)
    return [build_member(suite, member, verify=verify) for member in suite.select(members)]


@dataclass(frozen=True)
class MemberCheck:
    """The outcome of verifying one member: ``error`` is None when it reproduced."""

    member: SuiteMember
    seconds: float
    error: SuiteMismatchError | None = None


def verify_suite(suite: Suite | str, members: Sequence[str] | None = None) -> Iterable[MemberCheck]:
    """Check every selected member, yielding one :class:`MemberCheck` each (all are checked).

    Raises:
        SuiteError: an unknown suite or a pattern matching no member.
    """
    import time

    suite = suite if isinstance(suite, Suite) else load_suite(suite)
    for member in suite.select(members):
        started = time.perf_counter()
        try:
            build_member(suite, member)
            error = None
        except SuiteMismatchError as mismatch:
            error = mismatch
        yield MemberCheck(member, time.perf_counter() - started, error)


# --- the seed rule of a suite run -----------------------------------------------------------------------------

FIXED_MEMBER_SEEDS = 5  # seeds of a stochastic policy on a fixed member (issue 16)
PROCEDURAL_MEMBER_SEEDS = 1  # seeds of every policy on a procedural member


def random_start(scenario: Scenario) -> bool:
    """Whether the episode seed changes the scenario's start (jitter) or terrain (redraws)."""
    jitter = scenario.start.jitter
    return jitter.xy_km > 0 or jitter.heading_deg > 0 or scenario.terrain.randomize_terrain


def default_seeds(member: SuiteMember, scenario: Scenario, deterministic: bool) -> list[int]:
    """The episode seeds a policy flies on a member when ``--seeds`` is not given (docs/suite.md §4).

    Five seeds (0-4) on a fixed member (the paper scenario in both weightings, the DEM scenario)
    for a stochastic policy; one seed (0) for a deterministic policy there, since on a start
    without jitter every seed replicates one episode; one seed (0) on each procedural member, where
    the members themselves are the replicates.

    Args:
        member: the suite member.
        scenario: its built scenario.
        deterministic: whether the policy is deterministic
            (:func:`~uav_penetration_env.benchmark.policies.is_deterministic`).
    """
    if member.group != FIXED_GROUP:
        return list(range(PROCEDURAL_MEMBER_SEEDS))
    if deterministic and not random_start(scenario):
        return [0]
    return list(range(FIXED_MEMBER_SEEDS))


# --- freezing a new version ----------------------------------------------------------------------------------


def recipes_from_dict(data: Any, where: str = "recipe") -> tuple[str, str, list[Recipe]]:
    """Parse a recipe file (``suite``, ``description``, ``members``) into the recipes of its members.

    Each member entry is ``{catalogue: NAME}``, ``{difficulty: D, seed: S}`` or
    ``{difficulty: D, seeds: A-B}`` (A..B inclusive).

    Raises:
        SuiteError: naming the bad entry.
    """
    keys = ("suite", "description", "members")
    if not isinstance(data, Mapping):
        raise SuiteError(f"{where}: expected a mapping with keys {', '.join(keys)}")
    _require(data, keys, where)
    recipes = []
    for index, entry in enumerate(data["members"] or []):
        at = f"{where}: members[{index}]"
        if isinstance(entry, Mapping) and "seeds" in entry:
            low, _, high = str(entry["seeds"]).partition("-")
            try:
                seeds = range(int(low), int(high or low) + 1)
            except ValueError:
                raise SuiteError(
                    f"{at}.seeds: got {entry['seeds']!r}, expected A-B (integers, inclusive)"
                ) from None
            rest = {k: v for k, v in entry.items() if k != "seeds"}
            recipes += [Recipe.from_dict({**rest, "seed": seed}, at) for seed in seeds]
        else:
            recipes.append(Recipe.from_dict(entry, at))
    if not recipes:
        raise SuiteError(f"{where}: members: expected at least one member")
    return str(data["suite"]), str(data["description"]), recipes


def freeze_suite(
    name: str,
    description: str,
    recipes: Sequence[Recipe],
    out_dir: str | Path = SUITE_FOLDER,
    *,
    progress: Any = None,
) -> Path:
    """Build every member, fingerprint it and write ``out_dir/NAME.yaml``; never overwrite.

    Args:
        name: the new suite's versioned name (``uavpen-v2``).
        description: one paragraph for the file and ``uav-bench suite list``.
        recipes: the members, in order.
        out_dir: the folder (default: the package's suites, where :func:`suite_names` looks).
        progress: called with each member's name after it is fingerprinted (a progress bar).

    Returns:
        The written file.

    Raises:
        SuiteError: a malformed or taken name (a shipped suite or an existing file), or two
            recipes giving one member.
    """
    if not _NAME.match(name):
        raise SuiteError(
            f"suite name: got {name!r}, expected a versioned name like uavpen-v2 (a-z, 0-9, ., -)"
        )
    if name in suite_names():
        raise SuiteError(f"suite {name} already exists ({suite_path(name)}); a new version needs a new name")
    path = Path(out_dir) / f"{name}{SUITE_SUFFIX}"
    if path.exists():
        raise SuiteError(f"suite file {path} already exists; a frozen suite is never overwritten")
    from uav_penetration_env import __version__
    from uav_penetration_env.benchmark.provenance import git_commit

    members = []
    for recipe in recipes:
        scenario = recipe.build()
        members.append(
            SuiteMember(recipe.member_name(name), recipe.group, recipe, scenario.name, fingerprint(scenario))
        )
        if progress is not None:
            progress(members[-1].name)
    suite = Suite(
        name,
        description,
        tuple(members),
        frozen={
            "date": dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat(),
            "package_version": __version__,
            "commit": git_commit(),
            "versions": _versions(),
        },
        fingerprint=fingerprint_rules(),
    )
    suite_from_dict(suite.to_dict())  # the file must read back: names, hashes and recipes are distinct
    header = (
        f"# {name}: a frozen benchmark suite (docs/suite.md). Written by `uav-bench suite freeze`;\n"
        "# never edit it: any change to a member is a new suite version.\n"
    )
    text = header + yaml.safe_dump(suite.to_dict(), sort_keys=False, width=100, allow_unicode=True)
    _write_new(path, text)
    return path


def _versions() -> dict[str, str]:
    """The versions the fingerprints depend on: Python and the numerical libraries."""
    import platform
    from importlib import metadata

    versions = {"python": platform.python_version()}
    for name in ("numpy", "scipy", "numba", "matplotlib"):  # matplotlib ships the DEM raster
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def fingerprint_rules() -> dict[str, Any]:
    """The ``fingerprint`` block of a suite file: how the fields were computed and compared."""
    return {
        "scheme": FINGERPRINT_SCHEME,
        "quantum_m": QUANTUM_M,
        "replay": f"the greedy floor (GreedyPolicy, default settings) from env.reset(seed={REPLAY_SEED})",
        "replay_total_j_rtol": TOTAL_J_RTOL,
    }


def _write_new(path: Path, text: str) -> None:
    """Write ``text`` to a NEW file atomically: a temporary file hard-linked into place.

    ``os.link`` fails when ``path`` exists, so two freezes of one name cannot both succeed and a
    reader never sees a half-written file.

    Raises:
        SuiteError: the file exists (or appeared meanwhile) or the folder is not writable.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    descriptor, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(descriptor, "w", encoding="utf-8") as stream:
            stream.write(text)
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temporary, 0o644)
        os.link(temporary, path)
    except FileExistsError:
        raise SuiteError(f"suite file {path} already exists; a frozen suite is never overwritten") from None
    except OSError as error:
        raise SuiteError(f"suite file {path}: cannot write it ({error.strerror or error})") from None
    finally:
        Path(temporary).unlink(missing_ok=True)


__all__ = [
    "DIFFICULTY_GROUPS",
    "FIXED_GROUP",
    "QUANTUM_M",
    "TOTAL_J_RTOL",
    "Fingerprint",
    "MemberCheck",
    "Recipe",
    "Suite",
    "SuiteError",
    "SuiteMember",
    "SuiteMismatchError",
    "array_hash",
    "build_member",
    "check_fingerprint",
    "default_seeds",
    "fingerprint",
    "fingerprint_rules",
    "freeze_suite",
    "load_suite",
    "recipes_from_dict",
    "replay_total_j",
    "suite_from_dict",
    "suite_names",
    "suite_path",
    "suite_scenarios",
    "verify_suite",
]
