"""The scenario schema: frozen dataclasses mirroring the YAML file field by field (model.md §7b).

The dataclasses keep the paper's units (x, y in km, z in m, angles in degrees), so
``load_scenario(s.to_yaml(path)) == s`` holds exactly; the conversion to SI happens once, when the
physics model is built, through the ``from_scenario`` constructors of the SI parameter
dataclasses (``kinematics.UAVLimits``, ...). Each field declares its own check
(:mod:`~uav_penetration_env.scenario.rules`); checks across fields live in ``__post_init__``.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import MISSING, dataclass, replace
from functools import cached_property
from pathlib import Path
from typing import Any, ClassVar, Union

from uav_penetration_env.files import file_digest
from uav_penetration_env.scenario.convert import deep_merge, from_mapping, to_plain
from uav_penetration_env.scenario.files import write_yaml
from uav_penetration_env.scenario.rules import (
    Checked,
    Rule,
    checked,
    interval,
    non_negative,
    one_of,
    positive,
    require,
    rule,
)

BENCHMARK = "benchmark"
PAPER = "paper"
PROFILES = (BENCHMARK, PAPER)

# The first field of each variant of a tagged union (convert.py): a switch of its value in
# `Scenario.updated` starts the variant from its defaults.
TAG_FIELDS = ("method", "model")

_ANGLE = Rule(lambda v: 0 < v <= 90, "an angle in (0, 90] degrees")

# DECISION (model.md §7b, "limits"): sizes far above any real scenario and far below what exhausts a machine.
# Map coordinates stay within half the Earth's circumference; the terrain grid has at most
# MAX_GRID_NODES nodes (32 MB a float64 layer: 2001 x 2001, e.g. 200 km at 100 m); a scenario has at
# most MAX_RADARS radars and, when it masks, radars x grid nodes <= MAX_FLOOR_NODES (128 MB of
# visibility floors, each built in about 1 s per million nodes before the first step); a UAV turns
# at least MIN_TURN_DEG per step (its turn radius then stays below 20 000 km at the paper's speed).
MAX_MAP_COORD_KM = 20_000.0
MAX_GRID_NODES = 4_000_000
MAX_RADARS = 64
MAX_FLOOR_NODES = 16_000_000
MIN_TURN_DEG = 0.01
# A Gaussian field correlates over at most the map's longer side (its smoothing kernel then spans the
# grid; a longer one costs time and memory for no more relief), and a random walk is smoothed at
# most MAX_SMOOTHING_PASSES times (each pass costs a sweep of the grid).
MAX_SMOOTHING_PASSES = 1000
MAX_PATH_BYTES = 4096  # Linux PATH_MAX; each name in it at most 255 bytes (NAME_MAX)
_MAP_COORDS = Rule(
    lambda v: all(abs(c) <= MAX_MAP_COORD_KM for c in v), f"bounds within +-{MAX_MAP_COORD_KM:,.0f} km"
)
# A peak or a radar may stand outside the map, but not farther than a map may reach (its squared
# distances would overflow float64 and the physics divide inf by inf).
_COORD = Rule(lambda v: abs(v) <= MAX_MAP_COORD_KM, f"a coordinate within +-{MAX_MAP_COORD_KM:,.0f} km")


def _is_path(value: str) -> bool:
    encoded = value.encode("utf-8", "surrogatepass")
    return (
        bool(value)
        and "\x00" not in value
        and len(encoded) <= MAX_PATH_BYTES
        and all(len(part) <= 255 for part in encoded.split(b"/"))
    )


_PATH_EXPECTED = f"a file path: not empty, no NUL byte, at most {MAX_PATH_BYTES} bytes and 255 bytes a name"


@dataclass(frozen=True)
class MapConfig(Checked):
    """Map bounds, terrain grid spacing and altitude ceiling."""

    x_km: tuple[float, float] = interval((-25.0, 125.0), _MAP_COORDS)
    y_km: tuple[float, float] = interval((-25.0, 125.0), _MAP_COORDS)
    grid_m: float = positive(500.0)
    ceiling_m: float = positive(3000.0)  # DECISION (model.md §1)

    def __post_init__(self) -> None:
        super().__post_init__()
        width_m, height_m = (self.x_km[1] - self.x_km[0]) * 1000.0, (self.y_km[1] - self.y_km[0]) * 1000.0
        nodes = (width_m / self.grid_m + 1.0) * (height_m / self.grid_m + 1.0)  # inf for a tiny spacing
        require(
            nodes <= MAX_GRID_NODES,
            "grid_m",
            self.grid_m,
            f"a spacing giving at most {MAX_GRID_NODES:,} grid nodes over the {width_m / 1000:g} x "
            f"{height_m / 1000:g} km map (this one gives {nodes:.3g})",
        )
        for name, (low, high) in (("x_km", self.x_km), ("y_km", self.y_km)):
            cells = (high - low) * 1000.0 / self.grid_m
            require(
                abs(cells - round(cells)) < 1e-6 and round(cells) >= 2,
                "grid_m",
                self.grid_m,
                f"a spacing that divides the {name} extent ({(high - low) * 1000.0:g} m) into >= 2 cells",
            )


@dataclass(frozen=True)
class Jitter(Checked):
    """Random start perturbation drawn from the env seed at each reset."""

    xy_km: float = non_negative(0.0)
    heading_deg: float = non_negative(0.0)


@dataclass(frozen=True)
class StartConfig(Checked):
    """Initial state; ``heading_deg: null`` points the UAV at the goal."""

    x_km: float = 0.0
    y_km: float = 0.0
    z_agl_m: float = 100.0  # DECISION (model.md §1)
    heading_deg: float | None = None
    speed_m_s: float = 10.0
    pitch_deg: float = 0.0
    jitter: Jitter = Jitter()


@dataclass(frozen=True)
class GoalConfig(Checked):
    """Goal position and radius (reached on the segment's closest horizontal approach)."""

    x_km: float = 100.0
    y_km: float = 100.0
    radius_km: float = positive(3.0)  # DECISION: v_max * dt (model.md §1)


@dataclass(frozen=True)
class FuelConfig(Checked):
    """Point-mass fuel model (model.md §6.1)."""

    mass_kg: float = positive(20.0)
    lift_to_drag: float = positive(10.0)
    idle_thrust_fraction: float = rule(0.1, lambda v: 0 <= v < 1, "a number in [0, 1)")
    tsfc_kg_per_n_s: float = positive(1.9e-6)


# --- radar cross section: a tagged union on `model` ---------------------------------------------------


@dataclass(frozen=True)
class PrimitivesRCS(Checked):
    """The analytic physical-optics airframe of model.md §5.3."""

    model: str = "primitives"
    frequency_ghz: float = positive(3.0)  # DECISION: S-band (model.md §5.3)


@dataclass(frozen=True)
class ConstantRCS(Checked):
    """An aspect-independent radar cross section."""

    model: str = "constant"
    rcs_m2: float = positive(0.1)


@dataclass(frozen=True)
class TableRCS(Checked):
    """A user table: CSV ``el_deg, az_deg, rcs_dbsm`` on the 1° grid, or a (181, 361) ``.npy``."""

    model: str = "table"
    path: str = rule("", _is_path, _PATH_EXPECTED)


RCSConfig = Union[PrimitivesRCS, ConstantRCS, TableRCS]  # noqa: UP007 (resolved at runtime by convert.py)


@dataclass(frozen=True)
class UAVConfig(Checked):
    """Flight envelope, per-step control limits, fuel model and radar cross section."""

    speed_m_s: tuple[float, float] = rule(  # v_min DECISION, v_max paper §5
        (5.0, 10.0), lambda v: 0 < v[0] < v[1], "[v_min, v_max] with 0 < v_min < v_max"
    )
    dv_max_m_s: float = positive(2.0)  # DECISION (model.md §1)
    dheading_max_deg: float = rule(  # paper §5
        15.0, lambda v: MIN_TURN_DEG <= v <= 90, f"an angle in [{MIN_TURN_DEG:g}, 90] degrees"
    )
    dpitch_max_deg: float = checked(15.0, _ANGLE)  # paper §5
    pitch_max_deg: float = checked(15.0, _ANGLE)  # DECISION (model.md §1)
    min_clearance_m: float = non_negative(30.0)  # DECISION (model.md §1)
    fuel: FuelConfig = FuelConfig()
    rcs: RCSConfig = PrimitivesRCS()


@dataclass(frozen=True)
class TimeConfig(Checked):
    """Planning period and episode length."""

    dt_s: float = positive(300.0)  # paper §5: plan once every 5 min
    max_steps: int = rule(150, lambda v: v >= 1, "an integer >= 1")  # K_max, DECISION (model.md §1)


# --- natural terrain: a tagged union on `method` (model.md §2) ----------------------------------------


@dataclass(frozen=True)
class GaussianField(Checked):
    """Gaussian random field scaled to [0, height_m] (default natural terrain, model.md §2.3)."""

    method: str = "gaussian_field"
    height_m: float = non_negative(200.0)
    correlation_km: float = positive(5.0)


@dataclass(frozen=True)
class RandomWalk(Checked):
    """The paper's random-walk terrain with box smoothing (eqs. 4-5, corrected)."""

    method: str = "random_walk"
    height_m: float = non_negative(200.0)
    passes: int = rule(1, lambda v: 0 <= v <= MAX_SMOOTHING_PASSES, f"an integer in [0, {MAX_SMOOTHING_PASSES}]")


@dataclass(frozen=True)
class GaussianHill(Checked):
    """One Gaussian bump at the map centre."""

    method: str = "gaussian_hill"
    height_m: float = non_negative(200.0)
    sigma_km: float = positive(25.0)


@dataclass(frozen=True)
class DiamondSquare(Checked):
    """Diamond-square fractal terrain scaled to [0, height_m]."""

    method: str = "diamond_square"
    height_m: float = non_negative(200.0)
    roughness: float = rule(0.5, lambda v: 0 < v < 1, "a number in (0, 1)")


@dataclass(frozen=True)
class FlatTerrain(Checked):
    """Flat ground at ``height_m`` above the datum."""

    method: str = "flat"
    height_m: float = non_negative(0.0)


@dataclass(frozen=True)
class DEMTerrain(Checked):
    """A real elevation raster (model.md §2.5, §7d): a matplotlib sample file, an ``.npz`` or a GeoTIFF.

    A GeoTIFF (``.tif``/``.tiff``, extra ``geo``) is read in its own geographic CRS with its declared
    nodata value; an ``.npz`` holds ``array`` (heights, m) with ``latitude``/``longitude`` coordinate vectors, or the
    scalar extent ``xmin, xmax, ymin, ymax`` in degrees (matplotlib's ``jacksboro_fault_dem.npz``
    layout). The window ``lat_deg`` x ``lon_deg`` is projected to local metres (equirectangular
    about its centre) with the map origin at its south-west corner.
    """

    method: str = "dem"
    file: str = rule("topobathy.npz", _is_path, _PATH_EXPECTED)
    array: str = "topo"
    lat_deg: tuple[float, float] = interval(
        (49.10, 49.98), Rule(lambda v: -90 <= v[0] and v[1] <= 90, "latitudes in [-90, 90]")
    )
    lon_deg: tuple[float, float] = interval(
        (-123.38, -122.02), Rule(lambda v: -180 <= v[0] and v[1] <= 360, "longitudes in [-180, 360]")
    )
    sea_floor_m: float = 0.0
    band: int = rule(1, lambda v: isinstance(v, int) and v >= 1, "a band number >= 1")  # GeoTIFF band
    # A missing-data value the file does not declare (model.md §2.5, "missing data").
    nodata: float | None = rule(None, math.isfinite, "a finite height or null")
    # Holes of at most this many raster cells under the map are filled; 0 refuses any hole.
    fill_max_cells: int = rule(0, lambda v: isinstance(v, int) and v >= 0, "a whole number of cells >= 0")


NaturalTerrain = Union[GaussianField, RandomWalk, GaussianHill, DiamondSquare, FlatTerrain, DEMTerrain]  # noqa: UP007


@dataclass(frozen=True)
class Mountain(Checked):
    """A peak of eq. 2-3: centre [km] and height [m]."""

    x_km: float = checked(MISSING, _COORD)
    y_km: float = checked(MISSING, _COORD)
    height_m: float = positive()


PAPER_MOUNTAINS = (Mountain(10.0, 10.0, 500.0), Mountain(40.0, 25.0, 650.0), Mountain(45.0, 50.0, 750.0))


@dataclass(frozen=True)
class TerrainConfig(Checked):
    """Natural terrain, mountains and the terrain-threat options (model.md §2-3)."""

    seed: int = rule(7, lambda v: v >= 0, "an integer >= 0")
    randomize_terrain: bool = False
    natural: NaturalTerrain = GaussianField()
    mountains: tuple[Mountain, ...] = PAPER_MOUNTAINS
    mountain_decay_per_km2: float = positive(0.04)  # lambda, DECISION (model.md §2.2, A11)
    threat_altitude_scale_m: float | None = positive(None)


# --- radars -----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RadarModelConfig(Checked):
    """Detection physics shared by all radars; ``null`` fields come from the profile."""

    detection: str | None = one_of(("swerling1", "ratio"), default=None)
    false_alarm_prob: float = rule(1.0e-6, lambda v: 0 < v < 1, "a probability in (0, 1)")
    reference_detection_prob: float = 0.5  # in (false_alarm_prob, 1): checked in __post_init__
    effective_earth_radius_km: float = positive(8487.2)  # DECISION: 4120^2 / 2 m (model.md §4.3)
    min_range_m: float = positive(100.0)
    masking: str | None = one_of(("soft", "hard", "off"), default=None)
    masking_softness_m: float = non_negative(100.0)
    fusion: str = one_of(("max", "or"), default="max")  # max (eq. 14) | or

    def __post_init__(self) -> None:
        super().__post_init__()
        require(
            self.false_alarm_prob < self.reference_detection_prob < 1,
            "reference_detection_prob",
            self.reference_detection_prob,
            f"a probability in (false_alarm_prob={self.false_alarm_prob}, 1)",
        )


PRIORS = ("known", "unknown", "uncertain")
DYNAMIC_FIELDS = ("prior", "position_error_km", "presence_prob", "on_step", "trigger_range_km", "route_km", "speed_m_s")


@dataclass(frozen=True)
class Radar(Checked):
    """A ground radar: position [km], antenna altitude above datum ``z_m`` or ``mast_m`` above terrain."""

    name: str
    x_km: float = checked(MISSING, _COORD)
    y_km: float = checked(MISSING, _COORD)
    z_m: float | None = None
    mast_m: float | None = non_negative(None)
    ref_range_km: float = positive(100.0)  # R_ref: range at which sigma_ref gives D = 1 (model.md §4.2)
    ref_rcs_m2: float = positive(0.1)  # sigma_ref
    # --- threat dynamics (docs/dynamic.md §2); every field null for a static radar on the prior map ---
    # What the planner's prior map holds: the site (known), nothing (unknown), or a site drawn with
    # a position error (uncertain); null means known.
    prior: str | None = one_of(PRIORS, default=None)
    position_error_km: float | None = positive(None)  # uncertain: sigma of the prior site, per axis
    presence_prob: float | None = rule(None, lambda v: 0 < v <= 1, "a probability in (0, 1]")  # unknown only
    on_step: tuple[int, int] | None = rule(  # switched on at a step drawn uniformly in [first, last]
        None,
        lambda v: isinstance(v[0], int) and isinstance(v[1], int) and 0 <= v[0] <= v[1],
        "[first, last] integer steps with 0 <= first <= last",
    )
    trigger_range_km: float | None = positive(None)  # switched on once the UAV comes this close
    route_km: tuple[tuple[float, float], ...] | None = rule(  # mobile: from (x_km, y_km) through these points
        None,
        lambda v: len(v) >= 1 and all(abs(c) <= MAX_MAP_COORD_KM for point in v for c in point),
        f"at least one [x_km, y_km] point, coordinates within +-{MAX_MAP_COORD_KM:,.0f} km",
    )
    speed_m_s: float | None = positive(None)  # mobile: ground speed along the route

    OMIT_NONE: ClassVar[tuple[str, ...]] = ("z_m", "mast_m", *DYNAMIC_FIELDS)

    def __post_init__(self) -> None:
        require((self.z_m is None) != (self.mast_m is None), "z_m", self.z_m, "exactly one of z_m or mast_m")
        super().__post_init__()
        uncertain = self.prior == "uncertain"
        require(
            uncertain == (self.position_error_km is not None),
            "position_error_km",
            self.position_error_km,
            "a position error in km exactly when prior is 'uncertain'",
        )
        require(
            self.presence_prob is None or self.prior == "unknown",
            "presence_prob",
            self.presence_prob,
            "null unless prior is 'unknown' (a radar on the prior map exists)",
        )
        require(
            (self.route_km is None) == (self.speed_m_s is None),
            "speed_m_s",
            self.speed_m_s,
            "a ground speed in m/s exactly when route_km is given",
        )
        require(
            self.on_step is None or self.trigger_range_km is None,
            "trigger_range_km",
            self.trigger_range_km,
            "null when on_step is given (a radar switches on by time or by range, not both)",
        )
        require(
            self.mast_m is not None or not (uncertain or self.route_km is not None),
            "z_m",
            self.z_m,
            "null with mast_m given for an uncertain or mobile radar (its antenna follows the terrain)",
        )

    @property
    def is_dynamic(self) -> bool:
        """Whether any threat-dynamics field is set (an explicit ``prior: known`` alone is static)."""
        return any(getattr(self, name) is not None for name in DYNAMIC_FIELDS if name != "prior") or (
            self.prior not in (None, "known")
        )

    def at(self, x_km: float, y_km: float) -> Radar:
        """This radar as a static one at ``(x_km, y_km)``: what the physics scores (docs/dynamic.md §3)."""
        return replace(
            self,
            x_km=x_km,
            y_km=y_km,
            prior=None,
            position_error_km=None,
            presence_prob=None,
            on_step=None,
            trigger_range_km=None,
            route_km=None,
            speed_m_s=None,
        )


PAPER_RADARS = (
    Radar("R1", 11.0, 55.0, z_m=234.0),
    Radar("R2", 35.0, 45.0, z_m=397.0),
    Radar("R3", 55.0, 65.0, z_m=468.8),
    Radar("R4", 90.0, 60.0, z_m=450.6),
)


@dataclass(frozen=True)
class SensingConfig(Checked):
    """How the UAV learns of threats that are not on its prior map (docs/dynamic.md §3).

    A radar is revealed when it illuminates the UAV (line of sight past the terrain, within the
    warning receiver's range) or, with ``reveal_on_detection``, when it detects it.
    """

    warning_range_km: float = positive(60.0)  # DECISION (docs/dynamic.md §3): a radar warning receiver's range
    reveal_on_detection: bool = True


SENSING_DEFAULTS = SensingConfig()


# --- objective ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CostConfig(Checked):
    """Objective weights (omega_e, omega_r, omega_C), third term and crash penalty (model.md §6-7a)."""

    weights: tuple[float, float, float] = checked(
        (0.3, 0.4, 0.3),
        Rule(lambda w: all(x >= 0 for x in w), "three non-negative weights"),
        Rule(lambda w: abs(sum(w) - 1.0) < 1e-9, "weights summing to 1"),
    )
    # Eqs. 18-21 weight fuel, the paper's §4.2 and §5 weight path length S instead (model.md A24).
    third_term: str = one_of(("fuel", "length"), default="fuel")
    crash_penalty_per_step: float | None = non_negative(None)


@dataclass(frozen=True)
class PayoffConstants(Checked):
    """Eq. 39's (min, max) per raw term and the paper profile's crash penalty per step."""

    terrain: tuple[float, float] = interval()
    radar: tuple[float, float] = interval()
    third: tuple[float, float] = interval()
    crash_penalty_per_step: float = non_negative()


@dataclass(frozen=True)
class PayoffNormalisation(Checked):
    """Payoff-table constants with their provenance (written by ``uav-bench calibrate``)."""

    constants: PayoffConstants
    provenance: tuple[tuple[str, Any], ...] = ()

    MAPPINGS: ClassVar[tuple[str, ...]] = ("provenance",)


@dataclass(frozen=True)
class NormalisationConfig(Checked):
    """``analytic`` (fixed bounds) or ``payoff`` (eq. 39) normalisation; ``null`` = from the profile."""

    mode: str | None = one_of(("analytic", "payoff"), default=None)
    payoff: PayoffNormalisation | None = None


# --- the scenario --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Scenario(Checked):
    """A complete penetration scenario in the paper's units (model.md §7b)."""

    name: str = "scenario"
    profile: str = one_of(PROFILES, default=BENCHMARK)
    map: MapConfig = MapConfig()
    start: StartConfig = StartConfig()
    goal: GoalConfig = GoalConfig()
    uav: UAVConfig = UAVConfig()
    time: TimeConfig = TimeConfig()
    terrain: TerrainConfig = TerrainConfig()
    radar_model: RadarModelConfig = RadarModelConfig()
    radars: tuple[Radar, ...] = PAPER_RADARS
    cost: CostConfig = CostConfig()
    normalisation: NormalisationConfig = NormalisationConfig()
    sensing: SensingConfig | None = None  # null: SENSING_DEFAULTS (read only by a dynamic scenario)

    OMIT_NONE: ClassVar[tuple[str, ...]] = ("sensing",)  # a static scenario's file and hash stay as they were

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_places()
        self._check_start()
        self._check_radars()
        self._check_threat_dynamics()
        if self.normalisation_mode == "payoff":
            require(
                self.normalisation.payoff is not None,
                "normalisation.payoff",
                None,
                "payoff constants for the 'payoff' normalisation (run `uav-bench calibrate`)",
            )

    def _require_inside(self, prefix: str, x: float, y: float) -> None:
        """Refuse a point outside the map, naming the coordinate that is out of range."""
        (x_lo, x_hi), (y_lo, y_hi) = self.map.x_km, self.map.y_km
        field = f"{prefix}.x_km" if not x_lo <= x <= x_hi else f"{prefix}.y_km"
        bounds = f"inside the map x in [{x_lo:g}, {x_hi:g}] km, y in [{y_lo:g}, {y_hi:g}] km"
        require(x_lo <= x <= x_hi and y_lo <= y <= y_hi, field, (x, y), bounds)

    def _check_places(self) -> None:
        """The start and goal inside the map, the goal two turn radii from every edge, the terrain's scale."""
        (x_lo, x_hi), (y_lo, y_hi) = self.map.x_km, self.map.y_km
        self._require_inside("start", self.start.x_km, self.start.y_km)
        self._require_inside("goal", self.goal.x_km, self.goal.y_km)
        natural = self.terrain.natural
        if isinstance(natural, GaussianField):
            side = max(x_hi - x_lo, y_hi - y_lo)
            require(
                natural.correlation_km <= side,
                "terrain.natural.correlation_km",
                natural.correlation_km,
                f"a correlation length of at most the map's longer side ({side:g} km)",
            )
        # The goal must leave room for two turn radii to every edge, so a planner can always turn
        # toward it without leaving the map (model.md §1).
        margin = self.goal_edge_margin_km
        x_edge = min(self.goal.x_km - x_lo, x_hi - self.goal.x_km)
        y_edge = min(self.goal.y_km - y_lo, y_hi - self.goal.y_km)
        edge = min(x_edge, y_edge)
        require(
            edge >= margin - 1e-9,
            "goal.x_km" if x_edge <= y_edge else "goal.y_km",
            (self.goal.x_km, self.goal.y_km),
            f"a goal at least {margin:.1f} km (two turn radii) inside every map edge; it is {edge:.1f} km from one",
        )

    def _check_start(self) -> None:
        """The start's speed, pitch and height within the airframe's limits and under the ceiling."""
        v_min, v_max = self.uav.speed_m_s
        require(
            v_min <= self.start.speed_m_s <= v_max,
            "start.speed_m_s",
            self.start.speed_m_s,
            f"a speed in [{v_min:g}, {v_max:g}] m/s",
        )
        pitch_max = self.uav.pitch_max_deg
        require(
            abs(self.start.pitch_deg) <= pitch_max,
            "start.pitch_deg",
            self.start.pitch_deg,
            f"a pitch within +-{pitch_max:g} deg",
        )
        require(
            self.start.z_agl_m >= self.uav.min_clearance_m,
            "start.z_agl_m",
            self.start.z_agl_m,
            f"at least uav.min_clearance_m = {self.uav.min_clearance_m:g} m above the terrain",
        )
        require(
            self.start.z_agl_m < self.map.ceiling_m,
            "start.z_agl_m",
            self.start.z_agl_m,
            f"below the ceiling {self.map.ceiling_m:g} m",
        )

    def _check_radars(self) -> None:
        """Radars inside the map, uniquely named, few enough for their masking floors."""
        (x_lo, x_hi), (y_lo, y_hi) = self.map.x_km, self.map.y_km
        for i, radar in enumerate(self.radars):
            self._require_inside(f"radars[{i}]", radar.x_km, radar.y_km)
        names = [r.name for r in self.radars]
        require(len(set(names)) == len(names), "radars", names, "unique radar names")
        require(
            len(self.radars) <= MAX_RADARS,
            "radars",
            f"{len(self.radars)} radars",
            f"at most {MAX_RADARS} radars (model.md §7b, limits)",
        )
        nodes = (round((x_hi - x_lo) * 1000.0 / self.map.grid_m) + 1) * (
            round((y_hi - y_lo) * 1000.0 / self.map.grid_m) + 1
        )
        require(
            self.masking == "off" or len(self.radars) * nodes <= MAX_FLOOR_NODES,
            "radars",
            f"{len(self.radars)} radars on {nodes:,} grid nodes",
            f"radars x grid nodes <= {MAX_FLOOR_NODES:,} when terrain masks (one visibility floor per radar): "
            "fewer radars, a coarser map.grid_m, or radar_model.masking: off",
        )

    def _check_threat_dynamics(self) -> None:
        """Mobile radars' routes inside the map, switch-on steps within the episode (docs/dynamic.md §2)."""
        for i, radar in enumerate(self.radars):
            for j, (x, y) in enumerate(radar.route_km or ()):
                self._require_inside(f"radars[{i}].route_km[{j}]", x, y)
            if radar.on_step is not None:
                require(
                    radar.on_step[1] < self.time.max_steps,
                    f"radars[{i}].on_step",
                    list(radar.on_step),
                    f"steps below time.max_steps = {self.time.max_steps}",
                )

    @property
    def is_dynamic(self) -> bool:
        """Whether any radar appears, moves, or is missing from or misplaced on the prior map."""
        return any(radar.is_dynamic for radar in self.radars)

    @property
    def sensing_config(self) -> SensingConfig:
        """The effective sensing settings (:data:`SENSING_DEFAULTS` when the file sets none)."""
        return SENSING_DEFAULTS if self.sensing is None else self.sensing

    # --- profile resolution (model.md §7a: null fields come from the profile) --------------------

    def _from_profile(self, explicit: Any, *, paper: Any, benchmark: Any) -> Any:
        """``explicit`` when the file sets it, else the profile's value."""
        if explicit is not None:
            return explicit
        return paper if self.profile == PAPER else benchmark

    @property
    def detection(self) -> str:
        """Effective radar detection model: ``swerling1`` or ``ratio``."""
        return self._from_profile(self.radar_model.detection, paper="ratio", benchmark="swerling1")

    @property
    def masking(self) -> str:
        """Effective terrain masking: ``soft``, ``hard`` or ``off`` (eq. 12 only)."""
        return self._from_profile(self.radar_model.masking, paper="off", benchmark="soft")

    @property
    def normalisation_mode(self) -> str:
        """Effective normalisation: ``analytic`` or ``payoff``."""
        return self._from_profile(self.normalisation.mode, paper="payoff", benchmark="analytic")

    @property
    def crash_penalty_per_step(self) -> float:
        """Effective failure penalty per remaining step (model.md §7a)."""
        if self.cost.crash_penalty_per_step is not None:
            return self.cost.crash_penalty_per_step
        if self.normalisation_mode == "payoff" and self.normalisation.payoff is not None:
            return self.normalisation.payoff.constants.crash_penalty_per_step
        return 1.0

    @property
    def goal_edge_margin_km(self) -> float:
        """Two turn radii, 2 v_max dt / dphi_max [km] (model.md §1)."""
        turn = math.radians(self.uav.dheading_max_deg)
        return 2.0 * self.uav.speed_m_s[1] * self.time.dt_s / turn / 1000.0

    # --- conversions --------------------------------------------------------------------------

    def with_profile(self, profile: str | None) -> Scenario:
        """The same scenario under another profile (``None`` keeps this one)."""
        if profile is None or profile == self.profile:
            return self
        return self.updated({"profile": profile})

    def updated(self, changes: Mapping[str, Any]) -> Scenario:
        """A copy with ``changes`` (a nested mapping in file units) merged in and re-validated."""
        return Scenario.from_dict(deep_merge(self.to_dict(), changes, TAG_FIELDS))

    def to_dict(self) -> dict[str, Any]:
        """The scenario as plain YAML-ready data in the file's units."""
        return to_plain(self)

    def to_yaml(self, path: str | Path) -> Path:
        """Write the scenario to ``path`` and return the path.

        Raises:
            ScenarioError: the path cannot be written.
        """
        return write_yaml(self.to_dict(), Path(path))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Scenario:
        """Build and validate a scenario from plain data (file units).

        Raises:
            ScenarioError: a key is unknown, a field is missing or invalid.
        """
        return from_mapping(cls, data)

    @cached_property
    def map_hash(self) -> str:
        """16 hex digits of the map alone: area, terrain, radars, start and goal (and the files read).

        Two scenarios that differ only in their name, profile, cost weights, normalisation, airframe
        or time limits share it (the paper scenario and its second weighting do): what a planner
        trained on one has seen of the other (docs/publishing.md §6, learned planners out of sample).
        """
        data = self.to_dict()
        payload: Any = {key: data[key] for key in ("map", "start", "goal", "terrain", "radars")}
        if self.input_digests:
            payload = [payload, dict(self.input_digests)]
        text = json.dumps(payload, sort_keys=True, separators=(",", ":"), default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    @cached_property
    def hash(self) -> str:
        """A 16-hex-digit content hash of every field (weights and normalisation included).

        It also covers the bytes of every file the scenario reads (:attr:`input_digests`), as they
        are when first digested. Computed once per (immutable) instance: envs look scenarios up by
        hash at every reset.
        """
        payload: Any = self.to_dict()
        if self.input_digests:
            # DECISION: the content of every file the scenario reads is part of its identity
            # (model.md §7a); scenarios that read no file keep the hash of their fields alone.
            payload = [payload, dict(self.input_digests)]
        text = json.dumps(payload, sort_keys=True, separators=(",", ":"), default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    @cached_property
    def input_digests(self) -> dict[str, str]:
        """SHA-256 (hex) of each file the scenario reads, by field path, taken once per instance.

        The hash is made of these digests, and the build reads only files whose bytes still have
        them (model.md §2.5, "identity by content"), so a scenario object never labels terrain
        built from other bytes than those it was hashed with.
        """
        return {field: file_digest(name) for field, name in self.input_files().items()}

    def input_files(self) -> dict[str, str]:
        """The files this scenario reads, by field path (a DEM raster, an RCS table)."""
        files = {}
        if isinstance(self.terrain.natural, DEMTerrain):
            files["terrain.natural.file"] = self.terrain.natural.file
        if isinstance(self.uav.rcs, TableRCS):
            files["uav.rcs.path"] = self.uav.rcs.path
        return files
