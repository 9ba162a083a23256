"""The scenario catalogue: names, procedural scenarios (model.md §7c) and the real-terrain DEM scenario (§7d).

Scenario names resolve here and only here (:func:`resolve_scenarios`, :func:`resolve_scenario`):
the envs, ``uav-bench`` and ``uav-bench train`` all accept ``paper``, ``paper-w2``, ``dem``,
``random:SEED``, ``random:A-B`` (the CLI's plural flags) or a YAML path, and their help strings
come from :data:`SCENARIO_HELP`.

Both are rules written as code. ``random_scenario`` draws everything from one
``numpy.random.Generator`` (same generator state, same scenario, bit for bit) and rejects drafts
until the result validates and a straight climbing route over the terrain exists.
``dem_scenario`` returns the shipped ``scenarios/dem.yaml``, which ``generate_dem_scenario``
reproduces from matplotlib's bundled DEM.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from uav_penetration_env.scenario import (
    DEMTerrain,
    GaussianField,
    GoalConfig,
    MapConfig,
    Mountain,
    NormalisationConfig,
    Radar,
    Scenario,
    ScenarioError,
    StartConfig,
    TerrainConfig,
    TimeConfig,
    _load_bundled,
    load_scenario,
    paper_scenario,
)
from uav_penetration_env.scenario.errors import shown
from uav_penetration_env.suggest import did_you_mean
from uav_penetration_env.types import FloatArray

if TYPE_CHECKING:
    from uav_penetration_env.terrain import GridSpec

HELD_OUT_SEEDS = range(10_000, 10_050)  # model.md §7c: the held-out evaluation set at difficulty 0.5
RANDOM_SQUARE_KM = (0.0, 100.0)
MAX_RADARS = 8  # 2 + round(6 d) at d = 1


def _composed_heights(scenario: Scenario) -> tuple[FloatArray, GridSpec]:
    """Terrain heights without touching the disk cache (rejection sampling builds many drafts)."""
    # The builder is imported where a scenario is drawn, so that naming scenarios (the CLI) stays light.
    from uav_penetration_env.build import compose_terrain, grid_for

    return compose_terrain(scenario), grid_for(scenario)


def straight_climb_feasible(scenario: Scenario, heights: FloatArray, grid: GridSpec) -> bool:
    """Can the UAV fly the straight start-goal line, climbing at most at pitch_max, clear of terrain?

    The route is sampled every half grid cell; the UAV starts ``z_agl_m`` above the terrain and may
    climb by tan(pitch_max) per metre flown. The required altitude must stay below the ceiling.
    """
    from uav_penetration_env.terrain import bilinear

    start = np.array([scenario.start.x_km, scenario.start.y_km]) * 1000.0
    goal = np.array([scenario.goal.x_km, scenario.goal.y_km]) * 1000.0
    length = float(np.hypot(*(goal - start)))
    count = max(2, math.ceil(length / (0.5 * grid.dx_m)) + 1)
    s = np.linspace(0.0, length, count)
    points = start + (s / length)[:, None] * (goal - start)
    ground = bilinear(heights, *grid.fractional_index(points[:, 0], points[:, 1]))
    clearance = scenario.uav.min_clearance_m
    z0 = ground[0] + scenario.start.z_agl_m
    reachable = z0 + s * math.tan(math.radians(scenario.uav.pitch_max_deg))
    return bool(
        np.all(reachable >= ground + clearance) and np.max(ground) + clearance < scenario.map.ceiling_m
    )


def _distance_to_segment(points: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    ab = b - a
    t = np.clip(((points - a) @ ab) / (ab @ ab), 0.0, 1.0)
    return np.hypot(*(points - (a + t[:, None] * ab)).T)


def random_scenario(rng: np.random.Generator, difficulty: float = 0.5, name: str | None = None) -> Scenario:
    """A procedurally generated scenario on the paper's map (model.md §7c).

    From ``rng`` alone: a new natural terrain seed; 2 + round(4 d) mountains of 300-900 m, at least
    one within 10 km of the start-goal line; 2 + round(6 d) radars on high ground (the highest of
    8 candidate sites each, mast 10-30 m, ``ref_range_km`` = 60 + 80 d, sigma_ref 0.1 m^2), at least
    half within 30 km of the straight route; start and goal at opposite corners of the
    [0, 100] km square (one diagonal, either direction); weights 0.3/0.4/0.3. Drafts are rejected
    until the scenario validates and :func:`straight_climb_feasible` holds.

    Args:
        rng: the only source of randomness.
        difficulty: d in [0, 1].
        name: the scenario name (default ``random-d<d>``).

    Raises:
        ScenarioError: ``difficulty`` outside [0, 1].
    """
    if not 0.0 <= difficulty <= 1.0 or not math.isfinite(difficulty):
        raise ScenarioError("difficulty", difficulty, "a number in [0, 1]")
    n_mountains = 2 + round(4 * difficulty)
    n_radars = 2 + round(6 * difficulty)
    ref_range_km = 60.0 + 80.0 * difficulty
    name = name or f"random-d{difficulty:.2f}"
    for _ in range(1000):
        draft, start, goal = _draft(rng, name, n_mountains)
        heights, grid = _composed_heights(draft)
        radars = _radar_sites(rng, start, goal, n_radars, ref_range_km, heights, grid)
        scenario = replace(draft, radars=tuple(radars))
        if straight_climb_feasible(scenario, heights, grid):
            return scenario
    raise RuntimeError("random_scenario: no feasible scenario in 1000 drafts")  # never seen; a safety net


def _draft(rng: np.random.Generator, name: str, n_mountains: int) -> tuple[Scenario, FloatArray, FloatArray]:
    """A radar-less draft of :func:`random_scenario`: corners for start and goal, mountains, terrain seed."""
    low, high = RANDOM_SQUARE_KM
    corners = [(low, low), (high, high)] if rng.random() < 0.5 else [(low, high), (high, low)]
    if rng.random() < 0.5:
        corners.reverse()
    start, goal = np.array(corners[0]), np.array(corners[1])
    route = goal - start
    normal = np.array([-route[1], route[0]]) / np.hypot(*route)
    # The first mountain sits near the route; the others anywhere in the square.
    centres = rng.uniform(low, high, size=(n_mountains, 2))
    centres[0] = start + rng.uniform(0.2, 0.8) * route + rng.uniform(-10.0, 10.0) * normal
    peaks = rng.uniform(300.0, 900.0, size=n_mountains)
    terrain = TerrainConfig(
        seed=int(rng.integers(2**31)),
        natural=GaussianField(),
        mountains=tuple(
            Mountain(round(float(x), 3), round(float(y), 3), round(float(h), 1))
            for (x, y), h in zip(centres, peaks, strict=True)
        ),
    )
    draft = Scenario(
        name=name,
        start=StartConfig(x_km=float(start[0]), y_km=float(start[1])),
        goal=GoalConfig(x_km=float(goal[0]), y_km=float(goal[1])),
        terrain=terrain,
        radars=(),
    )
    return draft, start, goal


def _radar_sites(
    rng: np.random.Generator,
    start: FloatArray,
    goal: FloatArray,
    n_radars: int,
    ref_range_km: float,
    heights: FloatArray,
    grid: Any,
) -> list[Radar]:
    """The radars of :func:`random_scenario`: half of them (rounded up) near the route, each the highest of 8 candidates."""
    from uav_penetration_env.terrain import bilinear

    low, high = RANDOM_SQUARE_KM
    route = goal - start
    normal = np.array([-route[1], route[0]]) / np.hypot(*route)
    near = math.ceil(n_radars / 2)
    radars = []
    for i in range(n_radars):
        if i < near:
            along = rng.uniform(0.0, 1.0, size=8)
            across = rng.uniform(-30.0, 30.0, size=8)
            candidates = start + along[:, None] * route + across[:, None] * normal
            candidates = candidates[_distance_to_segment(candidates, start, goal) <= 30.0]
            candidates = np.clip(candidates, low, high) if len(candidates) else start[None] + 0.5 * route
        else:
            candidates = rng.uniform(low, high, size=(8, 2))
        ground = bilinear(
            heights, *grid.fractional_index(candidates[:, 0] * 1000.0, candidates[:, 1] * 1000.0)
        )
        x, y = candidates[int(np.argmax(ground))]
        mast = rng.uniform(10.0, 30.0)
        radars.append(
            Radar(
                f"R{i + 1}",
                round(float(x), 3),
                round(float(y), 3),
                mast_m=round(float(mast), 1),
                ref_range_km=ref_range_km,
                ref_rcs_m2=0.1,
            )
        )
    return radars


# --- the DEM scenario -------------------------------------------------------------------------------

DEM_START_KM = (25.0, 25.0)
DEM_GOAL_KM = (73.0, 73.0)
DEM_RADAR_MAST_M = 20.0
DEM_PEAK_SEPARATION_KM = 15.0


def generate_dem_scenario() -> Scenario:
    """Build the real-terrain scenario from matplotlib's ``topobathy.npz`` by the rule of model.md §7d.

    The window lat 49.10-49.98, lon -123.38..-122.02 is projected to local metres and cut to whole
    grid cells; mountains (terrain threat only) are the 3 highest local maxima at least 15 km apart;
    radars (mast 20 m) stand on the highest node of each quadrant; start (25, 25) km, goal
    (73, 73) km; everything else as the paper scenario.
    """
    from scipy import ndimage

    from uav_penetration_env.build import grid_for
    from uav_penetration_env.dem import dem_heights, window_extent_km

    paper = _load_bundled("paper.yaml")
    natural = DEMTerrain()
    width, height = window_extent_km(natural)
    cell = paper.map.grid_m / 1000.0
    map_config = MapConfig(
        x_km=(0.0, math.floor(width / cell) * cell),
        y_km=(0.0, math.floor(height / cell) * cell),
        grid_m=paper.map.grid_m,
        ceiling_m=paper.map.ceiling_m,
    )
    draft = replace(
        paper,
        map=map_config,
        start=replace(paper.start, x_km=DEM_START_KM[0], y_km=DEM_START_KM[1]),
        goal=replace(paper.goal, x_km=DEM_GOAL_KM[0], y_km=DEM_GOAL_KM[1]),
    )
    grid = grid_for(draft)
    heights = dem_heights(natural, grid)
    x_km, y_km = grid.x_nodes / 1000.0, grid.y_nodes / 1000.0

    is_peak = (heights == ndimage.maximum_filter(heights, size=3, mode="nearest")) & (
        heights > natural.sea_floor_m
    )
    order = np.argsort(-heights[is_peak], kind="stable")
    candidates = np.argwhere(is_peak)[order]
    mountains: list[Mountain] = []
    for i, j in candidates:
        x, y = float(x_km[i]), float(y_km[j])
        if all(math.hypot(x - m.x_km, y - m.y_km) >= DEM_PEAK_SEPARATION_KM for m in mountains):
            mountains.append(Mountain(x, y, round(float(heights[i, j]), 1)))
        if len(mountains) == 3:
            break

    radars = []
    half_i, half_j = grid.nx // 2, grid.ny // 2
    quadrants = [
        (slice(0, half_i), slice(0, half_j)),
        (slice(half_i, None), slice(0, half_j)),
        (slice(0, half_i), slice(half_j, None)),
        (slice(half_i, None), slice(half_j, None)),
    ]
    for q, (si, sj) in enumerate(quadrants):
        block = heights[si, sj]
        i, j = np.unravel_index(int(np.argmax(block)), block.shape)
        i += si.start
        j += sj.start
        radars.append(Radar(f"R{q + 1}", float(x_km[i]), float(y_km[j]), mast_m=DEM_RADAR_MAST_M))

    return replace(
        draft,
        name="dem-topobathy",
        # The paper scenario's payoff constants were calibrated on its own terrain; they do not carry over.
        normalisation=NormalisationConfig(),
        terrain=replace(paper.terrain, natural=natural, mountains=tuple(mountains)),
        radars=tuple(radars),
    )


def dem_scenario() -> Scenario:
    """The shipped real-terrain scenario (``scenarios/dem.yaml``; see :func:`generate_dem_scenario`)."""
    return _load_bundled("dem.yaml")


# --- names --------------------------------------------------------------------------------------------

# The threats paper-dynamic adds to the paper's four known radars (docs/dynamic.md §5): one of each kind.
PAPER_DYNAMIC_THREATS = (
    {"name": "U1", "x_km": 62.0, "y_km": 70.0, "mast_m": 10.0, "prior": "unknown"},
    {"name": "U2", "x_km": 45.0, "y_km": 30.0, "mast_m": 10.0, "prior": "unknown", "presence_prob": 0.5},
    {"name": "P1", "x_km": 75.0, "y_km": 80.0, "mast_m": 10.0, "on_step": [10, 20]},
    {"name": "T1", "x_km": 30.0, "y_km": 20.0, "mast_m": 10.0, "prior": "unknown", "trigger_range_km": 25.0},
    {"name": "C1", "x_km": 85.0, "y_km": 88.0, "mast_m": 10.0, "prior": "uncertain", "position_error_km": 4.0},
    {"name": "M1", "x_km": 50.0, "y_km": 85.0, "mast_m": 10.0, "prior": "unknown",
     "route_km": [[50.0, 45.0]], "speed_m_s": 8.0},
)  # fmt: skip


def paper_dynamic_scenario() -> Scenario:
    """The paper scenario (weights w1) with :data:`PAPER_DYNAMIC_THREATS` added (docs/dynamic.md §5)."""
    paper = paper_scenario("w1")
    radars = [*paper.to_dict()["radars"], *PAPER_DYNAMIC_THREATS]
    return paper.updated({"name": "paper-2022-sec5-dynamic", "radars": radars})


NAMED_SCENARIOS: dict[str, Callable[[], Scenario]] = {
    "paper": lambda: paper_scenario("w1"),
    "paper-w2": lambda: paper_scenario("w2"),
    "dem": dem_scenario,
    "paper-dynamic": paper_dynamic_scenario,
}
RANDOM_PREFIX = "random:"
RANDOM_FORMS = ("random:SEED", "random:A-B")
SCENARIO_HELP = f"{', '.join([*NAMED_SCENARIOS, *RANDOM_FORMS])} or a YAML path"

ScenarioSpec = Scenario | Mapping[str, Any] | str | Path


def _is_file(spec: str) -> bool:
    """Whether ``spec`` names an existing file (False for a name the OS cannot take: too long, a NUL)."""
    try:
        return Path(spec).is_file()
    except (OSError, ValueError):
        return False


class UnknownScenarioError(ScenarioError):
    """A scenario name that is neither in the catalogue nor an existing file."""

    def __init__(self, name: str) -> None:
        super().__init__("scenario", name, SCENARIO_HELP)
        typed = shown(name)
        if Path(name).suffix.lower() in (".yaml", ".yml") or "/" in name or "\\" in name:
            # Meant as a file: say the file is missing rather than that a name is unknown.
            try:
                where = (
                    ""
                    if Path(name).parent.is_dir()
                    else f" (no folder {shown(str(Path(name).parent))} either)"
                )
            except (OSError, ValueError):
                where = " (not a path this system can open)"
            self.args = (
                f"no such scenario file {typed}{where} — expected an existing YAML file, or {SCENARIO_HELP}",
            )
            return
        hint = did_you_mean(name, [*NAMED_SCENARIOS, *RANDOM_FORMS])
        self.args = (f"unknown scenario {typed} — {hint}expected {SCENARIO_HELP}",)


def default_max_steps(name: str | None) -> int:
    """K_max (``time.max_steps``) of a catalogue scenario, or of a procedural one when ``name`` is None.

    The env ids register it as ``max_episode_steps`` (model.md §7a). Procedural scenarios keep the
    default time settings (:class:`TimeConfig`), so no scenario is generated to read it.
    """
    if name is None:
        return TimeConfig().max_steps
    return resolve_scenario(name).time.max_steps


def random_seeds(spec: str) -> range:
    """The seeds of ``random:SEED`` (one) or ``random:A-B`` (A..B inclusive), as a lazy ``range``.

    A ``range`` costs nothing to build, so a caller can count the seeds (``len``) before it
    generates any scenario.

    Raises:
        ScenarioError: not of either form, or A > B.
    """
    body = spec[len(RANDOM_PREFIX) :]
    low, _, high = body.partition("-")
    try:
        seeds = range(int(low), int(high) + 1) if high else range(int(low), int(low) + 1)
    except ValueError:
        raise ScenarioError("scenario", spec, "random:SEED or random:A-B (integers, A-B inclusive)") from None
    if not seeds or seeds[0] < 0:
        raise ScenarioError("scenario", spec, "random:SEED or random:A-B with 0 <= A <= B")
    return seeds


def resolve_scenarios(spec: ScenarioSpec, difficulty: float = 0.5) -> list[Scenario]:
    """The scenarios a name, a ``random:`` form, a YAML path, a mapping or a Scenario stands for.

    ``random:SEED`` is ``random_scenario(default_rng(SEED), difficulty, name="random-SEED")``;
    ``random:A-B`` is one such scenario per seed A..B.

    DECISION (api.md §4.6): a catalogue name always means the catalogue's scenario, even when a
    file of that name exists in the working folder (``./paper`` reaches the file), so that a command
    line means the same thing in every folder.

    Raises:
        UnknownScenarioError: a string that is neither a name, a ``random:`` form nor an existing
            file (with a did-you-mean).
        ScenarioError: a broken file, mapping or ``random:`` form, or ``difficulty`` outside [0, 1].
    """
    if isinstance(spec, str) and spec in NAMED_SCENARIOS:
        return [NAMED_SCENARIOS[spec]()]
    if isinstance(spec, str) and spec.startswith(RANDOM_PREFIX):
        return [
            random_scenario(np.random.default_rng(seed), difficulty, name=f"random-{seed}")
            for seed in random_seeds(spec)
        ]
    if isinstance(spec, str) and not _is_file(spec):
        raise UnknownScenarioError(str(spec))
    return [load_scenario(spec)]


def resolve_scenario(spec: ScenarioSpec, difficulty: float = 0.5) -> Scenario:
    """The one scenario ``spec`` stands for (see :func:`resolve_scenarios`).

    Raises:
        ScenarioError: as :func:`resolve_scenarios`, or ``random:A-B`` naming several scenarios.
    """
    scenarios = resolve_scenarios(spec, difficulty)
    if len(scenarios) != 1:
        raise ScenarioError("scenario", spec, f"one scenario, not {len(scenarios)} (use random:SEED)")
    return scenarios[0]
