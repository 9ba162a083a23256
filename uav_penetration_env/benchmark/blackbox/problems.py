"""Black-box problems of the benchmark: the full-path problem and the MPC window problem (docs/blackbox.md §1).

A :class:`BlackBoxProblem` is what an optimisation library needs and nothing of the UAV: a batch
objective ``(n, d) -> (n,)``, the box, the dimension, the best-known value where there is one, and
an instance id. Two kinds:

* ``offline`` (:func:`offline_problem`): the whole episode's K_max x 3 controls, normalised to
  [-1, 1] per control, scored by the best-known search's objective
  (:class:`~uav_penetration_env.benchmark.bestknown.planner.EpisodeObjective`: the evaluator's
  total cost of the flight, best-known.md §1); its optimum is the scenario's best-known J*.
* ``window`` (:func:`window_problem`): one MPC planning window, the (3H,) controls in physical
  units inside the action box, scored by the planner's own objective
  (:func:`~uav_penetration_env.benchmark.policies.mpc_objective`, through
  :func:`~uav_penetration_env.benchmark.windows.window_at`), at a scenario's start state or at a
  stored episode's state (:func:`~uav_penetration_env.benchmark.windows.collect_windows`).

:func:`suite_problems` gives one problem per member of a frozen suite, the member's 1-based
position in the suite file as its instance id. The adapters to IOHprofiler and nevergrad are
:mod:`.ioh_adapter` and :mod:`.nevergrad_adapter` (extra ``blackbox``).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from uav_penetration_env.mpc import MPC_DEFAULTS, MPCSettings
from uav_penetration_env.scenario import Scenario
from uav_penetration_env.types import FloatArray

KINDS = ("offline", "window")


@dataclass(frozen=True, eq=False)
class BlackBoxProblem:
    """A box-constrained minimisation problem: batch objective, bounds, optimum, identity.

    Attributes:
        name: a stable identifier, ``<kind>/<scenario name>`` plus ``/k<step>`` for a window
            (``offline/paper-2022-sec5``, ``window/paper-2022-sec5/k0``); letters, digits and
            ``._/-`` only.
        kind: ``offline`` or ``window``.
        objective: the batch objective, ``(n, d)`` float64 points to ``(n,)`` costs (lower is better).
        lower: (d,) lower bounds.
        upper: (d,) upper bounds.
        optimum: the best-known cost, or ``None`` where none is recorded (every window problem,
            and an offline problem of a scenario without a record).
        optimum_x: (d,) the point that reaches ``optimum`` (``None`` with it).
        instance: the instance id (the member's 1-based position in its suite; 1 elsewhere).
        scenario: the scenario's name; ``scenario_hash`` its hash.
        suite_member: the suite member's name (``uavpen-v1/paper``), ``""`` outside a suite.
        step: the window's step index k (0 for an offline problem).
        metadata: a window problem's warm start ``x0`` (the source episode's next actions) and its
            ``settings`` (:class:`~uav_penetration_env.mpc.MPCSettings`); empty for an offline problem.
    """

    name: str
    kind: str
    objective: Any
    lower: FloatArray
    upper: FloatArray
    optimum: float | None = None
    optimum_x: FloatArray | None = None
    instance: int = 1
    scenario: str = ""
    scenario_hash: str = ""
    suite_member: str = ""
    step: int = 0
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def dimension(self) -> int:
        """d, the number of variables."""
        return int(self.lower.size)

    def __call__(self, x: FloatArray) -> FloatArray | float:
        """Cost of one point ``(d,)`` (a float) or of a batch ``(n, d)`` (an ``(n,)`` array).

        Raises:
            ValueError: ``x`` has another number of columns than ``dimension``.
        """
        points = np.asarray(x, dtype=np.float64)
        if points.ndim not in (1, 2) or points.shape[-1] != self.dimension:
            raise ValueError(
                f"x: got shape {points.shape}, expected ({self.dimension},) or (n, {self.dimension})"
            )
        costs = np.asarray(self.objective(np.atleast_2d(points)), dtype=np.float64)
        return float(costs[0]) if points.ndim == 1 else costs


def _check_instance(instance: object) -> int:
    if isinstance(instance, bool) or not isinstance(instance, (int, np.integer)) or int(instance) < 1:
        raise ValueError(f"instance: got {instance!r}, expected an integer >= 1")
    return int(instance)


def _scenario(scenario: Scenario | str) -> Scenario:
    """A scenario object from itself or any name the catalogue resolves (``paper``, ``random:7``)."""
    if isinstance(scenario, Scenario):
        return scenario
    from uav_penetration_env.catalogue import resolve_scenario

    return resolve_scenario(scenario)


def _safe(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._/-]", "-", text)


def offline_problem(
    scenario: Scenario | str, *, instance: int = 1, suite_member: str = "", records: str | None = None
) -> BlackBoxProblem:
    """The full-path problem of a scenario: every control of an episode at once (best-known.md §1).

    Args:
        scenario: a :class:`~uav_penetration_env.scenario.Scenario` or a catalogue name.
        instance: the instance id (an integer >= 1).
        suite_member: the suite member's name, when the scenario is one.
        records: a best-known records folder (default: the package's committed records).

    Returns:
        The problem over [-1, 1]^(3 K_max) (x times the action limits is the physical control);
        its optimum is the scenario's best-known total cost J*, ``None`` without a record.

    Raises:
        ScenarioError: a scenario whose start is jittered (one problem needs one start state).
        ValueError: ``instance`` is not an integer >= 1.
    """
    from uav_penetration_env.benchmark.bestknown import load_record
    from uav_penetration_env.benchmark.bestknown.compute import check_fixed_start
    from uav_penetration_env.benchmark.bestknown.planner import EpisodeObjective
    from uav_penetration_env.model import PenetrationModel

    instance = _check_instance(instance)
    scenario = _scenario(scenario)
    check_fixed_start(scenario)
    model = PenetrationModel(scenario)
    objective = EpisodeObjective(model, model.initial_state(None))
    record = load_record(scenario.hash, records)
    dimension = objective.dimension
    return BlackBoxProblem(
        name=_safe(f"offline/{scenario.name}"),
        kind="offline",
        objective=objective,
        lower=-np.ones(dimension),
        upper=np.ones(dimension),
        optimum=None if record is None else float(record.total_cost),
        optimum_x=None if record is None else objective.normalise(record.control_array),
        instance=instance,
        scenario=scenario.name,
        scenario_hash=scenario.hash,
        suite_member=suite_member,
    )


def window_problem(
    source: Scenario | str | Any,
    *,
    settings: MPCSettings = MPC_DEFAULTS,
    instance: int = 1,
    suite_member: str = "",
    **changes: Any,
) -> BlackBoxProblem:
    """The MPC window problem at a scenario's start state, or of a stored episode's window.

    Args:
        source: a :class:`~uav_penetration_env.benchmark.windows.Window` (from
            :func:`~uav_penetration_env.benchmark.windows.collect_windows`), or a scenario (object
            or catalogue name) whose start state (step 0, no jitter) is the window's state.
        settings: the planner's settings (H, gamma, the terminal cost) for a scenario source; a
            window keeps its own.
        instance: the instance id (an integer >= 1).
        suite_member: the suite member's name, when the scenario is one.
        **changes: fields of :class:`~uav_penetration_env.mpc.MPCSettings` replacing ``settings``'
            (``horizon=3``), for a scenario source.

    Returns:
        The problem over the (3H,) action box; no optimum (DECISION docs/blackbox.md §1).

    Raises:
        ValueError: a setting outside its domain, or ``instance`` not an integer >= 1.
    """
    from uav_penetration_env.benchmark.windows import Window, window_at

    instance = _check_instance(instance)
    if isinstance(source, Window):
        if changes:
            raise ValueError(
                f"changes: got {sorted(changes)}, expected none for a Window (it keeps its settings)"
            )
        window = source
        scenario_name, scenario_hash = window.scenario, window.scenario_hash
    else:
        from uav_penetration_env.model import PenetrationModel

        scenario = _scenario(source)
        model = PenetrationModel(scenario)
        window = window_at(model, model.initial_state(None), 0, [], settings, **changes)
        scenario_name, scenario_hash = scenario.name, scenario.hash
    bounds = window.objective.bounds
    return BlackBoxProblem(
        name=_safe(f"window/{scenario_name}/k{window.step}"),
        kind="window",
        objective=window.objective,
        lower=np.array(bounds.lb, dtype=np.float64),
        upper=np.array(bounds.ub, dtype=np.float64),
        instance=instance,
        scenario=scenario_name,
        scenario_hash=scenario_hash,
        suite_member=suite_member,
        step=window.step,
        metadata={"x0": np.array(window.x0), "settings": window.objective.settings},
    )


def suite_problems(
    suite: str,
    kind: str = "offline",
    *,
    members: Sequence[str] | None = None,
    verify: bool = True,
    settings: MPCSettings = MPC_DEFAULTS,
    **changes: Any,
) -> list[BlackBoxProblem]:
    """One problem per member of a frozen suite, its instance id the member's 1-based file position.

    Args:
        suite: a suite name (``uavpen-v1``) or path.
        kind: ``offline`` or ``window``.
        members: shell patterns of member names (default: every member).
        verify: check each member's fingerprint first (docs/suite.md).
        settings: the window problems' planner settings.
        **changes: fields of :class:`~uav_penetration_env.mpc.MPCSettings` (window problems).

    Raises:
        ValueError: an unknown ``kind``.
        SuiteError: an unknown suite, or a pattern matching no member.
        ScenarioError: an offline problem of a member whose start is jittered.
    """
    from uav_penetration_env.suites import build_member, load_suite

    if kind not in KINDS:
        raise ValueError(f"kind: got {kind!r}, expected one of {', '.join(KINDS)}")
    loaded = load_suite(suite)
    position = {member.name: i + 1 for i, member in enumerate(loaded.members)}
    problems = []
    for member in loaded.select(members):
        scenario = build_member(loaded, member, verify=verify)
        if kind == "offline":
            problems.append(
                offline_problem(scenario, instance=position[member.name], suite_member=member.name)
            )
        else:
            problems.append(
                window_problem(
                    scenario,
                    settings=settings,
                    instance=position[member.name],
                    suite_member=member.name,
                    **changes,
                )
            )
    return problems
