"""``uav-bench run``'s settings other than the MPC ones, declared once: :class:`RunSettings`.

Each field is one setting: its default, kind, domain and help text. ``uav-bench run``'s flags, its
``--config`` keys, its defaults and its checks are generated from these fields
(:mod:`uav_penetration_env.settings_fields`); the MPC settings come from
:class:`~uav_penetration_env.mpc.MPCSettings` the same way (:mod:`.mpc_flags`). A new run setting
is one new field here.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from uav_penetration_env.benchmark.commands.common import DEFAULT_OUT, DEFAULT_STORE, path_argument
from uav_penetration_env.mpc import MPC_DEFAULTS, MPCSettings
from uav_penetration_env.settings_fields import setting

MAIN_JOB_POLICIES = ("ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism", "pso", "cem", "greedy")
SINGLE = (str, int, float)  # a config file's scalar (``seeds: 5``), kept as given
SINGLE_TEXT = "a single value"
NAMES_TEXT = "one or more names"


def _names(help: str, default: tuple[str, ...], **spec: Any) -> Any:
    """A list setting of names (``--policies a b`` or ``a,b``; a config file's string or list)."""
    return setting(default, str, help, NAMES_TEXT, many="+", split=True, **spec)


def _single(default: Any, help: str, **spec: Any) -> Any:
    """A one-value setting: a flag's text, or a config file's scalar (never a list or a mapping)."""
    return setting(default, SINGLE, help, SINGLE_TEXT, optional=default is None, **spec)


@dataclass(frozen=True)
class RunSettings:
    """What one ``uav-bench run`` does (api.md §4); the defaults are the main job's.

    Attributes:
        policies: policy names (:data:`MAIN_JOB_POLICIES`).
        scenarios: scenario specs (catalogue names, ``random:`` forms, YAML paths).
        profile: ``benchmark`` or ``paper`` (None: each scenario's own).
        weights: the objective weights as typed, ``terrain,radar,third`` (None: the scenarios').
        seeds: ``N`` or ``START:STOP``, as typed (:func:`~.common.parse_seeds`).
        jobs: worker processes (None: all cores; 0: all cores, -N: all but N-1).
        threads: compiled threads per worker (None: 1 per worker), >= 1.
        reference: the policy the report compares against (None: api.md §4.5's rule).
        replace_out: write into an ``out`` folder that holds another store's outputs.
        backend: ``loky``, ``dask`` or ``sequential``.
        scheduler: a dask scheduler address (None: a local cluster).
        store: the results store's path.
        out: the report's folder (used only where given: else the store's folder).
        difficulty: the difficulty of ``random:`` scenarios, in [0, 1].
        imports: plug-in modules to import (``--import``; the config key ``import``).
        suite: a frozen suite to run (None: ``scenarios``).
        members: with ``suite``, shell patterns of the members to run.
        report: write the leaderboards, figures and HTML report (``--no-report``: False).
        progress: show a progress bar (``--no-progress``: False).
        mpc: every planner's MPC settings (their own flags and keys: :mod:`.mpc_flags`).
        explicit: the keys set by a flag or the config file (a suite run needs to know whether
            ``--seeds`` was given).

    DECISION (api.md §4.6): each setting is declared once, as a field with its flag, key, help
    and domain; ``uav-bench run``'s flags, ``--config`` keys, defaults and checks are generated
    from the fields, so a flag cannot be parsed and then dropped.
    """

    policies: tuple[str, ...] = _names(
        "policy names KIND[PARAM=VALUE,...] (api.md §4.1): optimiser names (MPC), NAME[terminal=FORM] "
        "(NAME-eq37, NAME-ctg-FORM), greedy, random, lattice[clearance=N] (lattice-cN){plugin_forms}",
        MAIN_JOB_POLICIES,
    )
    scenarios: tuple[str, ...] = _names("{scenario_help}", ("paper",))
    profile: str | None = _single(
        None, "physics profile", choices=("benchmark", "paper"), default_text="each scenario's own"
    )
    # Checked by parse_weights (a config file may give a list of three numbers).
    weights: Any = setting(
        None, object, "objective weights terrain,radar,third, e.g. 0.3,0.5,0.2", optional=True, default_text=""
    )
    seeds: str | int = _single("5", "N (seeds 0..N-1) or START:STOP")
    jobs: int | None = setting(
        None, int, "worker processes", "an integer (0: all cores, -N: all but N-1)",
        optional=True, default_text="all cores",
    )  # fmt: skip
    threads: int | None = setting(
        None, int, "compiled threads per worker", "an integer >= 1", allowed=lambda v: v >= 1,
        optional=True, default_text="1 per worker; results do not change",
    )  # fmt: skip
    # Checked against --policies by run_reference.
    reference: Any = setting(
        None,
        object,
        "policy of --policies the report's paired tests and Δ compare against",
        optional=True,
        default_text="ihpso where stored, else greedy, else the policy on the most seeds",
    )
    backend: str = _single("loky", "loky, dask or sequential")
    scheduler: str | None = _single(
        None, "dask scheduler address (backend dask; none starts a local cluster)", default_text=""
    )
    store: str = _single(str(DEFAULT_STORE), "results store", parse=path_argument)
    out: str = _single(
        str(DEFAULT_OUT),
        "folder for the leaderboard and figures",
        parse=path_argument,
        default_text=f"the store's folder, {DEFAULT_OUT} for the default store",
    )
    difficulty: float = setting(
        0.5, float, "difficulty of random:... scenarios", "a number in [0, 1]", allowed=lambda v: 0.0 <= v <= 1.0
    )
    suite: str | None = _single(
        None,
        "run every member of a frozen suite (uavpen-v1, uavpen-heldout-v1; `uav-bench suite list`), each checked "
        "against its fingerprint; seeds per member by the suite rule unless --seeds (docs/suite.md)",
        default_text="",
    )
    members: tuple[str, ...] = _names(
        "with --suite: only the members matching these shell patterns (uavpen-v1/d0.25/*)", (), default_text=""
    )
    imports: tuple[str, ...] = setting(
        (), str, "a plug-in module to import (repeatable)", NAMES_TEXT,
        flag="--import", key="import", many="append", split=True, default_text="",
    )  # fmt: skip
    report: bool = setting(
        True,
        bool,
        "skip the leaderboards, figures and HTML report (the store is still written)",
        "true or false",
        flag="--no-report",
        key="",
        switch=False,
        default_text="",
    )
    progress: bool = setting(
        True, bool, "no progress bar", "true or false", flag="--no-progress", key="", switch=False, default_text=""
    )
    replace_out: bool | None = setting(
        None,
        bool,
        "write into an --out folder holding another store's tables and report, replacing them",
        "true or false",
        switch=True,
        default_text="",
    )
    mpc: MPCSettings = field(default=MPC_DEFAULTS)
    explicit: frozenset[str] = frozenset()


# Settings that would change a frozen suite's members (their hashes): refused with --suite.
SUITE_CONFLICTS = ("scenarios", "profile", "weights", "difficulty")
