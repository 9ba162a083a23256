"""A campaign file: a publication's parts, each a list of commands, read from YAML (docs/publishing.md §1).

A campaign names its results folder, where its commands write (store, output folder, rows,
rebuild folder), its parts in order, and how it is installed. Commands are lists of strings; an
item ``$NAME`` splices the list (or string) ``NAME``, ``${NAME}`` inside a string substitutes a
string. The names known are the campaign's ``lists``, its paths (``root``, ``store``, ``out``,
``rows``, ``check``) and, with an ``agents`` section, the finished agents (``agents``,
``random_agents``, ``warm_started``; :mod:`~uav_penetration_env.benchmark.campaign.agents`).

DECISION (docs/publishing.md §1, commands as data): a command is a list of strings, not a typed
step per command, so the file says exactly what is run and logged; the runner only gives a few
parts a behaviour (``derived``: rerun when earlier parts added rows; ``rebuild_check``: the
tables part's output compared with the rebuild from rows). A command that splices an empty list
(no finished agent of a regime yet) is left out, as the retired ``benchmarks/publish.py`` left it.

Every problem raises :class:`CampaignFileError` with one line naming the field and what it expects.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

INSTALL_MODES = ("replace", "folder")
CAMPAIGN_KEYS = ("name", "root", "layout", "lists", "agents", "parts", "install", "compute", "carry")
PART_KEYS = ("name", "commands", "derived", "rebuild_check", "waits_for_agents")
LAYOUT_KEYS = ("store", "out", "rows", "check")
AGENT_KEYS = ("models", "selection", "pending")
INSTALL_KEYS = ("target", "mode", "rows")
COMPUTE_KEYS = ("rl_root", "distill_root", "distill_names")
CARRY_KEYS = ("checkpoint", "seed_rows")
PATH_NAMES = ("root", *LAYOUT_KEYS)
AGENT_PATH = "models"  # the agents' folder, a path name with an agents section
AGENT_LISTS = ("agents", "random_agents", "warm_started")
_INLINE = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)\}")
_WHOLE = re.compile(r"^\$([A-Za-z_][A-Za-z0-9_]*)$")


class CampaignFileError(ValueError):
    """A campaign file that cannot be read: one line naming the field and the expected value."""


@dataclass(frozen=True)
class Layout:
    """Where a publication's commands write: its store, output folder, row stem and rebuild folder."""

    store: Path
    out: Path
    rows: Path
    check: Path


@dataclass(frozen=True)
class AgentSource:
    """The RL programme's finished agents a campaign flies (docs/rl.md §3).

    Attributes:
        models: the folder of the committed agents (``NAME.zip`` with its ``NAME.json`` sidecar).
        selection: the confirmation's record (``chosen: study|zoo``) naming the PPO paper set that
            warm-starts IHPSO; ``None`` or a missing file: every PPO paper agent.
        pending: a command printing the programme's unfinished steps, one per line (empty: finished);
            ``python`` as its first item is this interpreter.
    """

    models: Path
    selection: Path | None = None
    pending: tuple[str, ...] = ()


@dataclass(frozen=True)
class PartSpec:
    """One part as the file writes it: command templates before the names are filled in."""

    name: str
    commands: tuple[tuple[str, ...], ...]
    derived: bool = False
    rebuild_check: bool = False
    waits_for_agents: bool = False


@dataclass(frozen=True)
class Install:
    """How ``--install`` copies the output.

    Mode ``replace``: the generated files at the top of ``target`` (v2); ``folder``: ``target`` as
    a folder of its own without the exported rows (v3), whose rows are committed in ``rows`` (the
    checkpoint).
    """

    target: Path
    mode: str = "replace"
    rows: Path | None = None


@dataclass(frozen=True)
class ComputeSources:
    """What ``--compute`` adds below the parts: the RL programme's snapshot and the distilled networks."""

    rl_root: Path | None = None
    distill_root: Path | None = None
    distill_names: tuple[str, ...] | None = None


@dataclass(frozen=True)
class Carry:
    """Carrying a publication across sessions: its committed checkpoint and the rows a new store starts from."""

    checkpoint: Path
    seed_rows: tuple[Path, ...] = ()


@dataclass(frozen=True)
class CampaignSpec:
    """A campaign file, checked (paths relative to the repository)."""

    name: str
    root: Path
    layout: Layout
    parts: tuple[PartSpec, ...]
    install: Install
    lists: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    agents: AgentSource | None = None
    compute: ComputeSources = ComputeSources()
    carry: Carry | None = None

    @property
    def log(self) -> Path:
        """The compute log: one JSON line per attempt (``ROOT/compute.jsonl``)."""
        return self.root / "compute.jsonl"

    @property
    def order(self) -> tuple[str, ...]:
        """The parts' names, in order."""
        return tuple(part.name for part in self.parts)

    @property
    def derived(self) -> tuple[str, ...]:
        """The derived parts' names, in order (the campaign's last parts)."""
        return tuple(part.name for part in self.parts if part.derived)


def _fail(where: str, got: Any, expected: str) -> CampaignFileError:
    return CampaignFileError(f"{where}: got {got!r}, expected {expected}")


def _mapping(where: str, value: Any, keys: Sequence[str]) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        raise _fail(where, value, f"a mapping with keys among {', '.join(keys)}")
    unknown = [k for k in value if k not in keys]
    if unknown:
        raise _fail(f"{where}.{unknown[0]}", value[unknown[0]], f"no such key (known: {', '.join(keys)})")
    return dict(value)


def _text(where: str, value: Any) -> str:
    if not isinstance(value, str) or not value:
        raise _fail(where, value, "a non-empty string")
    return value


def _strings(where: str, value: Any) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, (str, int, float)) for v in value):
        raise _fail(where, value, "a list of strings")
    return tuple(str(v) for v in value)


def _flag(where: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise _fail(where, value, "true or false")
    return value


def _optional_path(where: str, value: Any) -> Path | None:
    return None if value is None else Path(_text(where, value))


def _part(where: str, value: Any) -> PartSpec:
    data = _mapping(where, value, PART_KEYS)
    name = _text(f"{where}.name", data.get("name"))
    commands = data.get("commands", [])
    if not isinstance(commands, list):
        raise _fail(f"{where}.commands", commands, "a list of commands, each a list of strings")
    templates = tuple(_strings(f"{where}.commands[{i}]", c) for i, c in enumerate(commands))
    if any(not t for t in templates):
        raise _fail(f"{where}.commands", commands, "non-empty commands")
    flags = {key: _flag(f"{where}.{key}", data.get(key, False)) for key in PART_KEYS[2:]}
    return PartSpec(name, templates, **flags)


def campaign_from_mapping(data: Any, source: str = "campaign") -> CampaignSpec:
    """Check a campaign read from YAML (``source`` prefixes the field names of the errors).

    Raises:
        CampaignFileError: an unknown key, a missing or mistyped field, two parts of one name, a
            derived part before a run part, or a command naming an unknown ``$NAME``.
    """
    data = _mapping(source, data, CAMPAIGN_KEYS)
    name = _text(f"{source}.name", data.get("name"))
    root = Path(_text(f"{source}.root", data.get("root")))
    given = _mapping(f"{source}.layout", data.get("layout") or {}, LAYOUT_KEYS)

    def where(key: str, default: Path) -> Path:
        return Path(_text(f"{source}.layout.{key}", given[key])) if key in given else default

    out = where("out", root / "out")
    layout = Layout(
        store=where("store", root / "leaderboard.sqlite"),
        out=out,
        rows=where("rows", out / "rows" / "leaderboard"),
        check=where("check", root / "from-rows"),
    )
    lists_data = data.get("lists") or {}
    if not isinstance(lists_data, Mapping):
        raise _fail(f"{source}.lists", lists_data, "a mapping of names to lists of strings")
    lists = {key: _strings(f"{source}.lists.{key}", value) for key, value in lists_data.items()}
    clash = [key for key in lists if key in (*PATH_NAMES, *AGENT_LISTS, AGENT_PATH)]
    if clash:
        raise _fail(
            f"{source}.lists.{clash[0]}", lists[clash[0]], "a name other than a path or an agent list"
        )
    agents = None
    if data.get("agents") is not None:
        a = _mapping(f"{source}.agents", data["agents"], AGENT_KEYS)
        agents = AgentSource(
            models=Path(_text(f"{source}.agents.models", a.get("models"))),
            selection=_optional_path(f"{source}.agents.selection", a.get("selection")),
            pending=_strings(f"{source}.agents.pending", a.get("pending") or []),
        )
    raw_parts = data.get("parts")
    if not isinstance(raw_parts, list) or not raw_parts:
        raise _fail(f"{source}.parts", raw_parts, "a non-empty list of parts")
    parts = tuple(_part(f"{source}.parts[{i}]", p) for i, p in enumerate(raw_parts))
    names = [p.name for p in parts]
    twice = [n for n in names if names.count(n) > 1]
    if twice:
        raise _fail(f"{source}.parts", twice[0], "each part name once")
    derived = [p.derived for p in parts]
    if any(derived) and not all(derived[derived.index(True) :]):
        raise _fail(f"{source}.parts", names, "the derived parts last (they read what the run parts wrote)")
    if any(p.waits_for_agents for p in parts) and agents is None:
        raise _fail(f"{source}.agents", None, "an agents section (a part waits for the agents)")
    inst = _mapping(f"{source}.install", data.get("install"), INSTALL_KEYS)
    mode = inst.get("mode", "replace")
    if mode not in INSTALL_MODES:
        raise _fail(f"{source}.install.mode", mode, f"one of {', '.join(INSTALL_MODES)}")
    install = Install(Path(_text(f"{source}.install.target", inst.get("target"))), mode,
                      _optional_path(f"{source}.install.rows", inst.get("rows")))  # fmt: skip
    comp = _mapping(f"{source}.compute", data.get("compute") or {}, COMPUTE_KEYS)
    distill_names = comp.get("distill_names")
    compute = ComputeSources(
        _optional_path(f"{source}.compute.rl_root", comp.get("rl_root")),
        _optional_path(f"{source}.compute.distill_root", comp.get("distill_root")),
        None if distill_names is None else _strings(f"{source}.compute.distill_names", distill_names),
    )
    carry = None
    if data.get("carry") is not None:
        c = _mapping(f"{source}.carry", data["carry"], CARRY_KEYS)
        carry = Carry(Path(_text(f"{source}.carry.checkpoint", c.get("checkpoint"))),
                      tuple(Path(p) for p in _strings(f"{source}.carry.seed_rows", c.get("seed_rows") or [])))  # fmt: skip
    paths = {*PATH_NAMES, *((AGENT_PATH,) if agents is not None else ())}
    for key, items in lists.items():
        _check_names(f"{source}.lists.{key}", items, paths, paths)
    known = {*lists, *paths, *(AGENT_LISTS if agents is not None else ())}
    for part in parts:
        for template in part.commands:
            _check_names(f"{source}.parts.{part.name}", template, known, paths)
    return CampaignSpec(name, root, layout, parts, install, lists, agents, compute, carry)


def _check_names(where: str, items: Sequence[str], known: set[str], paths: set[str]) -> None:
    """Every ``$NAME`` of ``items`` is in ``known``, every ``${NAME}`` a path."""
    for item in items:
        whole = _WHOLE.match(item)
        if whole and whole.group(1) not in known:
            raise _fail(where, item, f"a known name (known: {', '.join(sorted(known))})")
        for ref in _INLINE.findall(item):
            if ref not in paths:
                raise _fail(
                    where,
                    item,
                    f"${{NAME}} of a path ({', '.join(sorted(paths))}); a list is spliced as a whole item $NAME",
                )


def load_campaign_file(path: str | Path) -> CampaignSpec:
    """Read and check a campaign file (YAML).

    Raises:
        CampaignFileError: a missing or unreadable file, or a field that fails a check.
    """
    import yaml

    path = Path(path)
    if not path.is_file():
        raise CampaignFileError(f"{path}: not found; expected a campaign YAML file")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as error:
        raise CampaignFileError(f"{path}: not YAML ({str(error).splitlines()[0]})") from None
    return campaign_from_mapping(data, source=path.name)


def fill(template: Sequence[str], names: Mapping[str, str | Sequence[str]]) -> list[str] | None:
    """A command with its names filled in; ``None`` when it splices an empty list (left out).

    Args:
        template: the command as written (``$NAME`` items, ``${NAME}`` inside strings).
        names: each name's string or list of strings.
    """
    argv: list[str] = []
    for item in template:
        whole = _WHOLE.match(item)
        if whole:
            value = names[whole.group(1)]
            if isinstance(value, str):
                argv.append(value)
                continue
            if not value:
                return None
            argv.extend(value)
            continue
        argv.append(_INLINE.sub(lambda m: str(names[m.group(1)]), item))
    return argv
