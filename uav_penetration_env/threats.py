"""Threat dynamics of one episode: which radars exist, where they are, when they switch on, what is known.

A dynamic scenario (``Scenario.is_dynamic``, docs/dynamic.md) declares per radar what the prior map
holds (``prior``), whether and when it switches on (``on_step``, ``trigger_range_km``), whether it
exists at all (``presence_prob``) and how it moves (``route_km``, ``speed_m_s``). This module turns
those declarations into an episode's truth and belief, as plain radar lists the physics scores:

- :func:`draw_threats` draws what is random from the episode's generator (presence, switch-on steps,
  the prior sites of uncertain radars), always in the same order, so a seed fixes the episode;
- :class:`ThreatState` holds, step by step, which radars are on (the truth the env scores J on) and
  which the planner knows (the belief it plans on), and updates both after each step from the
  UAV's new state: a radar switches on when its time comes or the UAV comes within its trigger
  range; a radar is revealed when it illuminates the UAV (line of sight, within the warning
  receiver's range) or detects it.

The module knows no physics: line of sight and detection come in as arrays the model computed.
Imports: scenario only (scenario -> threats -> env).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from uav_penetration_env.scenario import Radar, Scenario

DETECTED = 0.5  # a radar's detection probability above this reveals it (the env's "detected" bound)
ILLUMINATED = 0.5  # a line-of-sight factor above this counts as seen past the terrain


@dataclass(frozen=True)
class ThreatDraw:
    """What one episode drew for its radars (one entry per scenario radar, in scenario order).

    Attributes:
        exists: whether the radar is in this episode (``presence_prob``; always True without one).
        on_step: the step it switches on at (from ``on_step``); None when it is on from the start or
            switches on by range.
        prior_site_km: the site the prior map shows (x, y) [km]: the true one for a known radar, the
            true one plus the drawn error for an uncertain one, None for an unknown one.
    """

    exists: tuple[bool, ...]
    on_step: tuple[int | None, ...]
    prior_site_km: tuple[tuple[float, float] | None, ...]


def draw_threats(scenario: Scenario, rng: np.random.Generator) -> ThreatDraw:
    """Draw an episode's random threat facts from ``rng`` (docs/dynamic.md §2).

    Each radar draws, in scenario order, only what it declares: a uniform number against
    ``presence_prob``, an integer step in ``on_step``'s range, and a normal (x, y) offset of sigma
    ``position_error_km``. A static scenario draws nothing, so the generator is left as it was.
    """
    exists, on_steps, sites = [], [], []
    for radar in scenario.radars:
        exists.append(True if radar.presence_prob is None else bool(rng.random() < radar.presence_prob))
        on_steps.append(
            None if radar.on_step is None else int(rng.integers(radar.on_step[0], radar.on_step[1] + 1))
        )
        if radar.prior == "unknown":
            sites.append(None)
        elif radar.prior == "uncertain":
            assert radar.position_error_km is not None  # the schema pairs them
            dx, dy = rng.normal(0.0, radar.position_error_km, 2)
            sites.append((radar.x_km + float(dx), radar.y_km + float(dy)))
        else:
            sites.append((radar.x_km, radar.y_km))
    return ThreatDraw(tuple(exists), tuple(on_steps), tuple(sites))


def route_position(radar: Radar, seconds: float) -> tuple[float, float]:
    """Where a mobile radar is ``seconds`` after the episode starts (x, y) [km]; a fixed radar's site.

    DECISION (docs/dynamic.md §2): a mobile radar runs from its site through ``route_km`` and back,
    at ``speed_m_s``, forever (out and back along the polyline), so it stays on its declared road.
    """
    if radar.route_km is None or radar.speed_m_s is None:
        return radar.x_km, radar.y_km
    points = [(radar.x_km, radar.y_km), *radar.route_km]
    legs = [math.dist(a, b) for a, b in itertools.pairwise(points)]
    total = sum(legs)
    if total == 0.0:
        return radar.x_km, radar.y_km
    travelled = (radar.speed_m_s * seconds / 1000.0) % (2.0 * total)
    if travelled > total:  # on the way back
        travelled = 2.0 * total - travelled
    for (a, b), leg in zip(itertools.pairwise(points), legs, strict=True):
        if travelled <= leg and leg > 0.0:
            t = travelled / leg
            return a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])
        travelled -= leg
    return points[-1]


@dataclass
class ThreatState:
    """The truth and the belief of one episode's threats, advanced once per step (docs/dynamic.md §3).

    DECISION (docs/dynamic.md §3): threats change only between planning steps: the radars on at
    step k, at their step-k positions, score the whole transition k -> k+1; switch-ons and reveals
    decided from the state reached at k+1 act from step k+1 on.

    DECISION (docs/dynamic.md §3): the belief holds every radar of the prior map (known and
    uncertain ones, on or not yet on: a pop-up radar whose site is known is planned around from the
    start) and every revealed radar. Known and revealed radars are tracked: the belief has their
    true position, a mobile one's included. An uncertain radar sits at its prior site until revealed.

    Args:
        scenario: the dynamic scenario (its radars in order).
        draw: the episode's :class:`ThreatDraw`.
    """

    scenario: Scenario
    draw: ThreatDraw
    step: int = 0
    triggered: list[bool] = field(default_factory=list)
    revealed: list[bool] = field(default_factory=list)

    def __post_init__(self) -> None:
        radars = self.scenario.radars
        self.triggered = [False] * len(radars)
        self.revealed = [r.prior in (None, "known") for r in radars]

    def position(self, index: int) -> tuple[float, float]:
        """The true site of radar ``index`` at the current step (x, y) [km]."""
        return route_position(self.scenario.radars[index], self.step * self.scenario.time.dt_s)

    def is_on(self, index: int) -> bool:
        """Whether radar ``index`` exists and radiates at the current step."""
        radar = self.scenario.radars[index]
        if not self.draw.exists[index]:
            return False
        if radar.trigger_range_km is not None:
            return self.triggered[index]
        on_step = self.draw.on_step[index]
        return on_step is None or self.step >= on_step

    def truth_indices(self) -> tuple[int, ...]:
        """The radars the env scores at the current step (scenario indices)."""
        return tuple(i for i in range(len(self.scenario.radars)) if self.is_on(i))

    def belief_indices(self) -> tuple[int, ...]:
        """The radars the planner knows of at the current step (scenario indices)."""
        return tuple(
            i
            for i, radar in enumerate(self.scenario.radars)
            if self.revealed[i] or (radar.prior == "uncertain" and self.draw.exists[i])
        )

    def truth_radars(self) -> tuple[Radar, ...]:
        """The static radars the env scores at the current step, at their true positions."""
        return tuple(self.scenario.radars[i].at(*self.position(i)) for i in self.truth_indices())

    def belief_radars(self) -> tuple[Radar, ...]:
        """The static radars the planner plans on: tracked ones at their true, uncertain ones at their prior sites."""
        out = []
        for i in self.belief_indices():
            site = self.position(i) if self.revealed[i] else self.draw.prior_site_km[i]
            assert site is not None  # an unrevealed belief radar is an uncertain one, which has a prior site
            out.append(self.scenario.radars[i].at(*site))
        return tuple(out)

    def advance(self, uav_xy_km: tuple[float, float], seen: np.ndarray, detection: np.ndarray) -> tuple[str, ...]:
        """Move to the next step: switch radars on, reveal those that saw the UAV; the names revealed.

        Args:
            uav_xy_km: the UAV's horizontal position at the new step [km].
            seen: (len(truth_indices()),) line-of-sight factor in [0, 1] of each radar that was on,
                at the new state (the model's visibility, horizon and terrain masking).
            detection: (len(truth_indices()),) each such radar's detection probability there.

        Returns:
            The names of the radars revealed by this step, in scenario order.
        """
        sensing = self.scenario.sensing_config
        revealed_now = []
        for slot, i in enumerate(self.truth_indices()):
            if self.revealed[i]:
                continue
            x, y = self.position(i)
            in_range = math.dist((x, y), uav_xy_km) <= sensing.warning_range_km
            illuminated = in_range and float(seen[slot]) > ILLUMINATED
            detected = sensing.reveal_on_detection and float(detection[slot]) > DETECTED
            if illuminated or detected:
                self.revealed[i] = True
                revealed_now.append(self.scenario.radars[i].name)
        self.step += 1
        for i, radar in enumerate(self.scenario.radars):
            if radar.trigger_range_km is not None and not self.triggered[i]:
                x, y = self.position(i)
                self.triggered[i] = math.dist((x, y), uav_xy_km) <= radar.trigger_range_km
        return tuple(revealed_now)
