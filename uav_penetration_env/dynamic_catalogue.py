"""Procedural dynamic scenarios: a procedural map whose threats are partly unknown, late, misplaced or mobile.

:func:`random_dynamic_scenario` draws :func:`~uav_penetration_env.catalogue.random_scenario` and
then, from the same generator, turns its radars into threats with dynamics
(:func:`with_threat_dynamics`), by the difficulty knobs of :class:`DynamicKnobs`
(docs/dynamic.md §5). The frozen dynamic suites are built from it (docs/suite.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from uav_penetration_env.catalogue import RANDOM_SQUARE_KM, random_scenario
from uav_penetration_env.scenario import Radar, Scenario, ScenarioError


@dataclass(frozen=True)
class DynamicKnobs:
    """How much of a procedural scenario's threat picture is hidden from the planner (docs/dynamic.md §5).

    Attributes:
        unknown_fraction: the share of the map's radars missing from the prior map, in [0, 1]
            (rounded to a whole number of radars).
        lateness: in [0, 1]: the unknown radars switch on at a step drawn in
            [lateness L / 2, lateness L], L the straight route's length in steps (0: on from the start).
        mobile: how many unknown mobile radars are added, each crossing the straight route.
        position_error_km: sigma of the prior sites of the known radars (0: known exactly).
    """

    unknown_fraction: float = 0.5
    lateness: float = 0.5
    mobile: int = 1
    position_error_km: float = 3.0

    def __post_init__(self) -> None:
        for name in ("unknown_fraction", "lateness"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0.0 <= value <= 1.0):
                raise ScenarioError(name, value, "a number in [0, 1]")
        if not (isinstance(self.mobile, int) and 0 <= self.mobile <= 4):
            raise ScenarioError("mobile", self.mobile, "an integer in [0, 4]")
        if not (isinstance(self.position_error_km, (int, float)) and 0.0 <= self.position_error_km <= 20.0):
            raise ScenarioError("position_error_km", self.position_error_km, "a number of km in [0, 20]")

    @property
    def label(self) -> str:
        """A short name of the knobs, for suite groups: ``u0.50-l0.50-m1-e3``."""
        return f"u{self.unknown_fraction:.2f}-l{self.lateness:.2f}-m{self.mobile}-e{self.position_error_km:g}"


def with_threat_dynamics(scenario: Scenario, rng: np.random.Generator, knobs: DynamicKnobs) -> Scenario:
    """``scenario`` with its radars turned into threats with dynamics by ``knobs``, drawn from ``rng``.

    DECISION (docs/dynamic.md §5): which radars are unknown is a uniform draw of
    ``round(unknown_fraction * n)`` of the n radars; each unknown radar switches on in the lateness
    window; every known radar sits on the prior map with the position error; each mobile radar
    starts 15-25 km to one side of a uniform point of the straight route and runs to the mirror
    point on the other side at 5-10 m/s, so it crosses the route.
    """
    n = len(scenario.radars)
    unknown = set(rng.permutation(n)[: round(knobs.unknown_fraction * n)].tolist())
    start = np.array([scenario.start.x_km, scenario.start.y_km])
    goal = np.array([scenario.goal.x_km, scenario.goal.y_km])
    step_km = scenario.uav.speed_m_s[1] * scenario.time.dt_s / 1000.0
    steps = math.dist(start, goal) / step_km
    first, last = round(knobs.lateness * steps / 2.0), round(knobs.lateness * steps)
    radars = []
    for i, radar in enumerate(scenario.radars):
        if i in unknown:
            on_step = (first, last) if last > 0 else None
            radars.append(replace(radar, prior="unknown", on_step=on_step))
        elif knobs.position_error_km > 0:
            radars.append(replace(radar, prior="uncertain", position_error_km=float(knobs.position_error_km)))
        else:
            radars.append(radar)
    radars += [_crossing_radar(rng, start, goal, scenario, index) for index in range(knobs.mobile)]
    return replace(scenario, radars=tuple(radars))


def _crossing_radar(
    rng: np.random.Generator, start: np.ndarray, goal: np.ndarray, scenario: Scenario, index: int
) -> Radar:
    """An unknown mobile radar that crosses the straight route (see :func:`with_threat_dynamics`)."""
    low, high = RANDOM_SQUARE_KM
    route = goal - start
    normal = np.array([-route[1], route[0]]) / np.hypot(*route)
    centre = start + rng.uniform(0.3, 0.7) * route
    side = rng.uniform(15.0, 25.0) * (1.0 if rng.random() < 0.5 else -1.0)
    a = np.clip(centre + side * normal, low, high)
    b = np.clip(centre - side * normal, low, high)
    template = scenario.radars[0] if scenario.radars else None
    return Radar(
        f"M{index + 1}",
        round(float(a[0]), 3),
        round(float(a[1]), 3),
        mast_m=10.0,
        ref_range_km=template.ref_range_km if template else 100.0,
        ref_rcs_m2=template.ref_rcs_m2 if template else 0.1,
        prior="unknown",
        route_km=((round(float(b[0]), 3), round(float(b[1]), 3)),),
        speed_m_s=round(float(rng.uniform(5.0, 10.0)), 2),
    )


def random_dynamic_scenario(
    rng: np.random.Generator, difficulty: float = 0.5, knobs: DynamicKnobs = DynamicKnobs(), name: str | None = None
) -> Scenario:
    """A procedural scenario (:func:`random_scenario` from ``rng``), then its threat dynamics from the same ``rng``.

    Raises:
        ScenarioError: ``difficulty`` outside [0, 1].
    """
    base = random_scenario(rng, difficulty, name=name or f"random-dynamic-d{difficulty:.2f}-{knobs.label}")
    return with_threat_dynamics(base, rng, knobs)
