"""Scenario files: frozen dataclasses, YAML load/save and validation (model.md §7b).

A scenario is data. The dataclasses mirror the YAML schema field by field and keep the paper's
units (x, y in km, z in m, angles in degrees), so ``load_scenario(s.to_yaml(path)) == s`` holds
exactly. The conversion to SI happens once, when the physics model is built, through the
``from_scenario`` constructors of the SI parameter dataclasses (``kinematics.UAVLimits``, ...).

Every invalid value raises :class:`ScenarioError` naming the field path (``radars[2].x_km``), the
value received and what was expected; an unknown key suggests the closest valid one.
"""

from __future__ import annotations

import dataclasses
import difflib
import hashlib
import json
import math
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, replace
from functools import cache, cached_property
from importlib import resources
from pathlib import Path
from typing import Any, ClassVar, Union, get_args, get_origin

import numpy as np
import yaml

from uav_penetration_env.files import file_digest

__all__ = [
    "BENCHMARK",
    "PAPER",
    "ConstantRCS",
    "CostConfig",
    "DEMTerrain",
    "DiamondSquare",
    "FlatTerrain",
    "FuelConfig",
    "GaussianField",
    "GaussianHill",
    "GoalConfig",
    "Jitter",
    "MapConfig",
    "Mountain",
    "NormalisationConfig",
    "PayoffConstants",
    "PayoffNormalisation",
    "PrimitivesRCS",
    "Radar",
    "RadarModelConfig",
    "RandomWalk",
    "Scenario",
    "ScenarioError",
    "StartConfig",
    "TableRCS",
    "TerrainConfig",
    "TimeConfig",
    "UAVConfig",
    "load_scenario",
    "paper_scenario",
]

BENCHMARK = "benchmark"
PAPER = "paper"
PROFILES = (BENCHMARK, PAPER)


class ScenarioError(ValueError):
    """A scenario field holds an invalid value.

    Attributes:
        field: dotted path of the offending field, e.g. ``radars[2].x_km``.
        value: the value received.
        expected: what a valid value looks like.
    """

    def __init__(self, field: str, value: Any, expected: str) -> None:
        self.field = field
        self.value = value
        self.expected = expected
        super().__init__(f"{field}: got {value!r}, expected {expected}")

    def within(self, prefix: str) -> ScenarioError:
        """The same error with ``prefix`` prepended to the field path."""
        if not prefix:
            return self
        joined = f"{prefix}{self.field}" if self.field.startswith("[") else f"{prefix}.{self.field}"
        return ScenarioError(joined, self.value, self.expected)


# --- small validation helpers (raise with a field name relative to the dataclass) ----------------


def _require(condition: bool, field_name: str, value: Any, expected: str) -> None:
    if not condition:
        raise ScenarioError(field_name, value, expected)


def _positive(field_name: str, value: float) -> None:
    _require(value > 0, field_name, value, "a positive number")


def _non_negative(field_name: str, value: float) -> None:
    _require(value >= 0, field_name, value, "a number >= 0")


def _one_of(field_name: str, value: Any, options: tuple[Any, ...]) -> None:
    _require(value in options, field_name, value, "one of " + ", ".join(repr(o) for o in options))


def _interval(field_name: str, value: tuple[float, float]) -> None:
    _require(value[0] < value[1], field_name, list(value), "[low, high] with low < high")


# --- the schema -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MapConfig:
    """Map bounds, terrain grid spacing and altitude ceiling."""

    x_km: tuple[float, float] = (-25.0, 125.0)
    y_km: tuple[float, float] = (-25.0, 125.0)
    grid_m: float = 500.0
    ceiling_m: float = 3000.0  # DECISION (model.md §1)

    def __post_init__(self) -> None:
        _interval("x_km", self.x_km)
        _interval("y_km", self.y_km)
        _positive("grid_m", self.grid_m)
        _positive("ceiling_m", self.ceiling_m)
        for name, (low, high) in (("x_km", self.x_km), ("y_km", self.y_km)):
            cells = (high - low) * 1000.0 / self.grid_m
            _require(
                abs(cells - round(cells)) < 1e-6 and round(cells) >= 2,
                "grid_m",
                self.grid_m,
                f"a spacing that divides the {name} extent ({(high - low) * 1000.0:g} m) into >= 2 cells",
            )


@dataclass(frozen=True)
class Jitter:
    """Random start perturbation drawn from the env seed at each reset."""

    xy_km: float = 0.0
    heading_deg: float = 0.0

    def __post_init__(self) -> None:
        _non_negative("xy_km", self.xy_km)
        _non_negative("heading_deg", self.heading_deg)


@dataclass(frozen=True)
class StartConfig:
    """Initial state; ``heading_deg: null`` points the UAV at the goal."""

    x_km: float = 0.0
    y_km: float = 0.0
    z_agl_m: float = 100.0  # DECISION (model.md §1)
    heading_deg: float | None = None
    speed_m_s: float = 10.0
    pitch_deg: float = 0.0
    jitter: Jitter = Jitter()


@dataclass(frozen=True)
class GoalConfig:
    """Goal position and radius (reached on the segment's closest horizontal approach)."""

    x_km: float = 100.0
    y_km: float = 100.0
    radius_km: float = 3.0  # DECISION: v_max * dt (model.md §1)

    def __post_init__(self) -> None:
        _positive("radius_km", self.radius_km)


@dataclass(frozen=True)
class FuelConfig:
    """Point-mass fuel model (model.md §6.1)."""

    mass_kg: float = 20.0
    lift_to_drag: float = 10.0
    idle_thrust_fraction: float = 0.1
    tsfc_kg_per_n_s: float = 1.9e-6

    def __post_init__(self) -> None:
        _positive("mass_kg", self.mass_kg)
        _positive("lift_to_drag", self.lift_to_drag)
        _require(
            0 <= self.idle_thrust_fraction < 1,
            "idle_thrust_fraction",
            self.idle_thrust_fraction,
            "a number in [0, 1)",
        )
        _positive("tsfc_kg_per_n_s", self.tsfc_kg_per_n_s)


@dataclass(frozen=True)
class PrimitivesRCS:
    """The analytic physical-optics airframe of model.md §5.3."""

    TAG: ClassVar[str] = "primitives"
    model: str = "primitives"
    frequency_ghz: float = 3.0  # DECISION: S-band (model.md §5.3)

    def __post_init__(self) -> None:
        _positive("frequency_ghz", self.frequency_ghz)


@dataclass(frozen=True)
class ConstantRCS:
    """An aspect-independent radar cross section."""

    TAG: ClassVar[str] = "constant"
    model: str = "constant"
    rcs_m2: float = 0.1

    def __post_init__(self) -> None:
        _positive("rcs_m2", self.rcs_m2)


@dataclass(frozen=True)
class TableRCS:
    """A user table: CSV ``el_deg, az_deg, rcs_dbsm`` on the 1° grid, or a (181, 361) ``.npy``."""

    TAG: ClassVar[str] = "table"
    model: str = "table"
    path: str = ""

    def __post_init__(self) -> None:
        _require(bool(self.path), "path", self.path, "the path of an RCS table file")


RCSConfig = Union[PrimitivesRCS, ConstantRCS, TableRCS]  # noqa: UP007 (resolved at runtime by _convert)


@dataclass(frozen=True)
class UAVConfig:
    """Flight envelope, per-step control limits, fuel model and radar cross section."""

    speed_m_s: tuple[float, float] = (5.0, 10.0)  # v_min DECISION, v_max paper §5
    dv_max_m_s: float = 2.0  # DECISION (model.md §1)
    dheading_max_deg: float = 15.0  # paper §5
    dpitch_max_deg: float = 15.0  # paper §5
    pitch_max_deg: float = 15.0  # DECISION (model.md §1)
    min_clearance_m: float = 30.0  # DECISION (model.md §1)
    fuel: FuelConfig = FuelConfig()
    rcs: RCSConfig = PrimitivesRCS()

    def __post_init__(self) -> None:
        _require(
            0 < self.speed_m_s[0] < self.speed_m_s[1],
            "speed_m_s",
            list(self.speed_m_s),
            "[v_min, v_max] with 0 < v_min < v_max",
        )
        _positive("dv_max_m_s", self.dv_max_m_s)
        for name in ("dheading_max_deg", "dpitch_max_deg", "pitch_max_deg"):
            value = getattr(self, name)
            _require(0 < value <= 90, name, value, "an angle in (0, 90] degrees")
        _non_negative("min_clearance_m", self.min_clearance_m)


@dataclass(frozen=True)
class TimeConfig:
    """Planning period and episode length."""

    dt_s: float = 300.0  # paper §5: plan once every 5 min
    max_steps: int = 150  # K_max, DECISION (model.md §1)

    def __post_init__(self) -> None:
        _positive("dt_s", self.dt_s)
        _require(self.max_steps >= 1, "max_steps", self.max_steps, "an integer >= 1")


@dataclass(frozen=True)
class GaussianField:
    """Gaussian random field scaled to [0, height_m] (default natural terrain, model.md §2.3)."""

    TAG: ClassVar[str] = "gaussian_field"
    method: str = "gaussian_field"
    height_m: float = 200.0
    correlation_km: float = 5.0

    def __post_init__(self) -> None:
        _non_negative("height_m", self.height_m)
        _positive("correlation_km", self.correlation_km)


@dataclass(frozen=True)
class RandomWalk:
    """The paper's random-walk terrain with box smoothing (eqs. 4-5, corrected)."""

    TAG: ClassVar[str] = "random_walk"
    method: str = "random_walk"
    height_m: float = 200.0
    passes: int = 1

    def __post_init__(self) -> None:
        _non_negative("height_m", self.height_m)
        _require(self.passes >= 0, "passes", self.passes, "an integer >= 0")


@dataclass(frozen=True)
class GaussianHill:
    """One Gaussian bump at the map centre."""

    TAG: ClassVar[str] = "gaussian_hill"
    method: str = "gaussian_hill"
    height_m: float = 200.0
    sigma_km: float = 25.0

    def __post_init__(self) -> None:
        _non_negative("height_m", self.height_m)
        _positive("sigma_km", self.sigma_km)


@dataclass(frozen=True)
class DiamondSquare:
    """Diamond-square fractal terrain scaled to [0, height_m]."""

    TAG: ClassVar[str] = "diamond_square"
    method: str = "diamond_square"
    height_m: float = 200.0
    roughness: float = 0.5

    def __post_init__(self) -> None:
        _non_negative("height_m", self.height_m)
        _require(0 < self.roughness < 1, "roughness", self.roughness, "a number in (0, 1)")


@dataclass(frozen=True)
class FlatTerrain:
    """Flat ground at ``height_m`` above the datum."""

    TAG: ClassVar[str] = "flat"
    method: str = "flat"
    height_m: float = 0.0

    def __post_init__(self) -> None:
        _non_negative("height_m", self.height_m)


@dataclass(frozen=True)
class DEMTerrain:
    """A real elevation raster (model.md §2.5, §7d): a matplotlib sample file or an ``.npz`` path.

    The file holds ``array`` (heights, m) with ``latitude``/``longitude`` coordinate vectors, or the
    scalar extent ``xmin, xmax, ymin, ymax`` in degrees (matplotlib's ``jacksboro_fault_dem.npz``
    layout). The window ``lat_deg`` x ``lon_deg`` is projected to local metres (equirectangular
    about its centre) with the map origin at its south-west corner.
    """

    TAG: ClassVar[str] = "dem"
    method: str = "dem"
    file: str = "topobathy.npz"
    array: str = "topo"
    lat_deg: tuple[float, float] = (49.10, 49.98)
    lon_deg: tuple[float, float] = (-123.38, -122.02)
    sea_floor_m: float = 0.0
    band: int = 1  # GeoTIFF band to read (1-based)
    nodata: float | None = None  # a missing-data value the file does not declare (model.md §2.5)
    fill_max_cells: int = 0  # fill holes of at most this many raster cells; 0 refuses any hole

    def __post_init__(self) -> None:
        _require(isinstance(self.band, int) and self.band >= 1, "band", self.band, "a band number >= 1")
        _require(
            self.nodata is None or math.isfinite(self.nodata), "nodata", self.nodata, "a finite height or null"
        )
        _require(
            isinstance(self.fill_max_cells, int) and self.fill_max_cells >= 0,
            "fill_max_cells",
            self.fill_max_cells,
            "a whole number of cells >= 0",
        )
        _interval("lat_deg", self.lat_deg)
        _interval("lon_deg", self.lon_deg)
        _require(
            -90 <= self.lat_deg[0] and self.lat_deg[1] <= 90,
            "lat_deg",
            list(self.lat_deg),
            "latitudes in [-90, 90]",
        )
        _require(
            -180 <= self.lon_deg[0] and self.lon_deg[1] <= 360,
            "lon_deg",
            list(self.lon_deg),
            "longitudes in [-180, 360]",
        )


NaturalTerrain = Union[GaussianField, RandomWalk, GaussianHill, DiamondSquare, FlatTerrain, DEMTerrain]  # noqa: UP007


@dataclass(frozen=True)
class Mountain:
    """A peak of eq. 2-3: centre [km] and height [m]."""

    x_km: float
    y_km: float
    height_m: float

    def __post_init__(self) -> None:
        _positive("height_m", self.height_m)


PAPER_MOUNTAINS = (Mountain(10.0, 10.0, 500.0), Mountain(40.0, 25.0, 650.0), Mountain(45.0, 50.0, 750.0))


@dataclass(frozen=True)
class TerrainConfig:
    """Natural terrain, mountains and the terrain-threat options (model.md §2-3)."""

    seed: int = 7
    randomize_terrain: bool = False
    natural: NaturalTerrain = GaussianField()
    mountains: tuple[Mountain, ...] = PAPER_MOUNTAINS
    mountain_decay_per_km2: float = 0.04  # lambda, DECISION (model.md §2.2, A11)
    threat_altitude_scale_m: float | None = None

    def __post_init__(self) -> None:
        _require(self.seed >= 0, "seed", self.seed, "an integer >= 0")
        _positive("mountain_decay_per_km2", self.mountain_decay_per_km2)
        if self.threat_altitude_scale_m is not None:
            _positive("threat_altitude_scale_m", self.threat_altitude_scale_m)


@dataclass(frozen=True)
class RadarModelConfig:
    """Detection physics shared by all radars; ``null`` fields come from the profile."""

    detection: str | None = None  # swerling1 | ratio
    false_alarm_prob: float = 1.0e-6
    reference_detection_prob: float = 0.5
    effective_earth_radius_km: float = 8487.2  # DECISION: 4120^2 / 2 m (model.md §4.3)
    min_range_m: float = 100.0
    masking: str | None = None  # soft | hard | off
    masking_softness_m: float = 100.0
    fusion: str = "max"  # max (eq. 14) | or

    def __post_init__(self) -> None:
        if self.detection is not None:
            _one_of("detection", self.detection, ("swerling1", "ratio"))
        if self.masking is not None:
            _one_of("masking", self.masking, ("soft", "hard", "off"))
        _one_of("fusion", self.fusion, ("max", "or"))
        _require(
            0 < self.false_alarm_prob < 1,
            "false_alarm_prob",
            self.false_alarm_prob,
            "a probability in (0, 1)",
        )
        _require(
            self.false_alarm_prob < self.reference_detection_prob < 1,
            "reference_detection_prob",
            self.reference_detection_prob,
            f"a probability in (false_alarm_prob={self.false_alarm_prob}, 1)",
        )
        _positive("effective_earth_radius_km", self.effective_earth_radius_km)
        _positive("min_range_m", self.min_range_m)
        _non_negative("masking_softness_m", self.masking_softness_m)


@dataclass(frozen=True)
class Radar:
    """A ground radar: position [km], antenna altitude above datum ``z_m`` or ``mast_m`` above terrain."""

    name: str
    x_km: float
    y_km: float
    z_m: float | None = None
    mast_m: float | None = None
    ref_range_km: float = 100.0  # R_ref: range at which sigma_ref gives D = 1 (model.md §4.2)
    ref_rcs_m2: float = 0.1  # sigma_ref

    OMIT_NONE: ClassVar[tuple[str, ...]] = ("z_m", "mast_m")

    def __post_init__(self) -> None:
        _require((self.z_m is None) != (self.mast_m is None), "z_m", self.z_m, "exactly one of z_m or mast_m")
        if self.mast_m is not None:
            _non_negative("mast_m", self.mast_m)
        _positive("ref_range_km", self.ref_range_km)
        _positive("ref_rcs_m2", self.ref_rcs_m2)


PAPER_RADARS = (
    Radar("R1", 11.0, 55.0, z_m=234.0),
    Radar("R2", 35.0, 45.0, z_m=397.0),
    Radar("R3", 55.0, 65.0, z_m=468.8),
    Radar("R4", 90.0, 60.0, z_m=450.6),
)


@dataclass(frozen=True)
class CostConfig:
    """Objective weights (omega_e, omega_r, omega_C), third term and crash penalty (model.md §6-7a)."""

    weights: tuple[float, float, float] = (0.3, 0.4, 0.3)
    third_term: str = "fuel"  # fuel | length (A24)
    crash_penalty_per_step: float | None = None

    def __post_init__(self) -> None:
        _require(
            all(w >= 0 for w in self.weights), "weights", list(self.weights), "three non-negative weights"
        )
        _require(abs(sum(self.weights) - 1.0) < 1e-9, "weights", list(self.weights), "weights summing to 1")
        _one_of("third_term", self.third_term, ("fuel", "length"))
        if self.crash_penalty_per_step is not None:
            _non_negative("crash_penalty_per_step", self.crash_penalty_per_step)


@dataclass(frozen=True)
class PayoffConstants:
    """Eq. 39's (min, max) per raw term and the paper profile's crash penalty per step."""

    terrain: tuple[float, float]
    radar: tuple[float, float]
    third: tuple[float, float]
    crash_penalty_per_step: float

    def __post_init__(self) -> None:
        for name in ("terrain", "radar", "third"):
            _interval(name, getattr(self, name))
        _non_negative("crash_penalty_per_step", self.crash_penalty_per_step)


@dataclass(frozen=True)
class PayoffNormalisation:
    """Payoff-table constants with their provenance (written by ``uav-bench calibrate``)."""

    constants: PayoffConstants
    provenance: tuple[tuple[str, Any], ...] = ()

    MAPPINGS: ClassVar[tuple[str, ...]] = ("provenance",)


@dataclass(frozen=True)
class NormalisationConfig:
    """``analytic`` (fixed bounds) or ``payoff`` (eq. 39) normalisation; ``null`` = from the profile."""

    mode: str | None = None
    payoff: PayoffNormalisation | None = None

    def __post_init__(self) -> None:
        if self.mode is not None:
            _one_of("mode", self.mode, ("analytic", "payoff"))


@dataclass(frozen=True)
class Scenario:
    """A complete penetration scenario in the paper's units (model.md §7b)."""

    name: str = "scenario"
    profile: str = BENCHMARK
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

    def __post_init__(self) -> None:
        _one_of("profile", self.profile, PROFILES)
        (x_lo, x_hi), (y_lo, y_hi) = self.map.x_km, self.map.y_km

        def require_inside(prefix: str, x: float, y: float) -> None:
            # Name the coordinate that is out of range; the value shows the point.
            field = f"{prefix}.x_km" if not x_lo <= x <= x_hi else f"{prefix}.y_km"
            bounds = f"inside the map x in [{x_lo:g}, {x_hi:g}] km, y in [{y_lo:g}, {y_hi:g}] km"
            _require(x_lo <= x <= x_hi and y_lo <= y <= y_hi, field, (x, y), bounds)

        require_inside("start", self.start.x_km, self.start.y_km)
        require_inside("goal", self.goal.x_km, self.goal.y_km)
        # The goal must leave room for two turn radii to every edge, so a planner can always turn
        # toward it without leaving the map (model.md §1).
        margin = self.goal_edge_margin_km
        x_edge = min(self.goal.x_km - x_lo, x_hi - self.goal.x_km)
        y_edge = min(self.goal.y_km - y_lo, y_hi - self.goal.y_km)
        edge = min(x_edge, y_edge)
        _require(
            edge >= margin - 1e-9,
            "goal.x_km" if x_edge <= y_edge else "goal.y_km",
            (self.goal.x_km, self.goal.y_km),
            f"a goal at least {margin:.1f} km (two turn radii) inside every map edge; it is {edge:.1f} km from one",
        )
        v_min, v_max = self.uav.speed_m_s
        _require(
            v_min <= self.start.speed_m_s <= v_max,
            "start.speed_m_s",
            self.start.speed_m_s,
            f"a speed in [{v_min:g}, {v_max:g}] m/s",
        )
        pitch_max = self.uav.pitch_max_deg
        _require(
            abs(self.start.pitch_deg) <= pitch_max,
            "start.pitch_deg",
            self.start.pitch_deg,
            f"a pitch within +-{pitch_max:g} deg",
        )
        _require(
            self.start.z_agl_m >= self.uav.min_clearance_m,
            "start.z_agl_m",
            self.start.z_agl_m,
            f"at least uav.min_clearance_m = {self.uav.min_clearance_m:g} m above the terrain",
        )
        _require(
            self.start.z_agl_m < self.map.ceiling_m,
            "start.z_agl_m",
            self.start.z_agl_m,
            f"below the ceiling {self.map.ceiling_m:g} m",
        )
        for i, radar in enumerate(self.radars):
            require_inside(f"radars[{i}]", radar.x_km, radar.y_km)
        names = [r.name for r in self.radars]
        _require(len(set(names)) == len(names), "radars", names, "unique radar names")
        if self.normalisation_mode == "payoff":
            _require(
                self.normalisation.payoff is not None,
                "normalisation.payoff",
                None,
                "payoff constants for the 'payoff' normalisation (run `uav-bench calibrate`)",
            )

    # --- profile resolution (model.md §7a: null fields come from the profile) --------------------

    @property
    def detection(self) -> str:
        """Effective radar detection model: ``swerling1`` or ``ratio``."""
        if self.radar_model.detection is not None:
            return self.radar_model.detection
        return "ratio" if self.profile == PAPER else "swerling1"

    @property
    def masking(self) -> str:
        """Effective terrain masking: ``soft``, ``hard`` or ``off`` (eq. 12 only)."""
        if self.radar_model.masking is not None:
            return self.radar_model.masking
        return "off" if self.profile == PAPER else "soft"

    @property
    def normalisation_mode(self) -> str:
        """Effective normalisation: ``analytic`` or ``payoff``."""
        if self.normalisation.mode is not None:
            return self.normalisation.mode
        return "payoff" if self.profile == PAPER else "analytic"

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
        return _rebuild(self, {"profile": profile})

    def updated(self, changes: Mapping[str, Any]) -> Scenario:
        """A copy with ``changes`` (a nested mapping in file units) merged in and re-validated."""
        return _rebuild(self, changes)

    def to_dict(self) -> dict[str, Any]:
        """The scenario as plain YAML-ready data in the file's units."""
        return _to_plain(self)

    def to_yaml(self, path: str | Path) -> Path:
        """Write the scenario to ``path`` and return the path."""
        path = Path(path)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(
                yaml.safe_dump(self.to_dict(), sort_keys=False, default_flow_style=None, width=110)
            )
        except OSError as error:
            raise ScenarioError("path", str(path), f"a writable file path ({error.strerror})") from error
        return path

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Scenario:
        """Build and validate a scenario from plain data (file units)."""
        return _from_mapping(cls, data, "")

    @cached_property
    def hash(self) -> str:
        """A 16-hex-digit content hash of every field (weights and normalisation included).

        Computed once per (immutable) instance: envs look scenarios up by hash at every reset.
        """
        payload: Any = self.to_dict()
        files = self.input_files()
        if files:
            # DECISION: the content of every file the scenario reads is part of its identity
            # (model.md §7a); scenarios that read no file keep the hash of their fields alone.
            payload = [payload, {field: file_digest(name) for field, name in files.items()}]
        text = json.dumps(payload, sort_keys=True, separators=(",", ":"), default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def input_files(self) -> dict[str, str]:
        """The files this scenario reads, by field path (a DEM raster, an RCS table)."""
        files = {}
        if isinstance(self.terrain.natural, DEMTerrain):
            files["terrain.natural.file"] = self.terrain.natural.file
        if isinstance(self.uav.rcs, TableRCS):
            files["uav.rcs.path"] = self.uav.rcs.path
        return files


# --- generic dict <-> dataclass conversion ---------------------------------------------------------


@cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _suggest(key: str, allowed: list[str]) -> str:
    close = difflib.get_close_matches(key, allowed, n=1, cutoff=0.5)
    hint = f"did you mean '{close[0]}'? " if close else ""
    return f"a known key ({hint}allowed: {', '.join(allowed)})"


def _from_mapping(cls: type, data: Any, path: str) -> Any:
    if isinstance(data, cls):
        return data
    if not isinstance(data, Mapping):
        raise ScenarioError(path or "scenario", data, f"a mapping of {cls.__name__} fields")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    hints = _hints(cls)
    kwargs: dict[str, Any] = {}
    for key, value in data.items():
        if key not in fields:
            raise ScenarioError(_join(path, str(key)), value, _suggest(str(key), list(fields)))
        kwargs[key] = _convert(hints[key], value, _join(path, key), cls, key)
    for name, f in fields.items():
        if (
            name not in kwargs
            and f.default is dataclasses.MISSING
            and f.default_factory is dataclasses.MISSING
        ):
            raise ScenarioError(_join(path, name), None, "a value (this field is required)")
    try:
        return cls(**kwargs)
    except ScenarioError as error:
        raise error.within(path) from None


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _is_union(tp: Any) -> bool:
    return get_origin(tp) in (Union, types.UnionType)


def _convert(tp: Any, value: Any, path: str, owner: type, name: str) -> Any:
    if _is_union(tp):
        options = [a for a in get_args(tp) if a is not type(None)]
        if value is None:
            if len(options) < len(get_args(tp)):
                return None
            raise ScenarioError(path, value, "a value (null is not allowed here)")
        if len(options) == 1:
            return _convert(options[0], value, path, owner, name)
        return _convert_tagged(options, value, path)
    if dataclasses.is_dataclass(tp):
        return _from_mapping(tp, value, path)
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ScenarioError(path, value, "a finite number")
        return float(value)
    if tp is int:
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
            or float(value) != int(value)
        ):
            raise ScenarioError(path, value, "an integer")
        return int(value)
    if tp is bool:
        if not isinstance(value, bool):
            raise ScenarioError(path, value, "true or false")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise ScenarioError(path, value, "a string")
        return value
    if get_origin(tp) is tuple:
        args = get_args(tp)
        if name in getattr(owner, "MAPPINGS", ()):
            if not isinstance(value, Mapping):
                raise ScenarioError(path, value, "a mapping")
            return tuple((str(k), _plain_scalar(v, f"{path}.{k}")) for k, v in value.items())
        if not isinstance(value, (list, tuple)):
            raise ScenarioError(path, value, f"a list ({_describe_tuple(args)})")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(args[0], v, f"{path}[{i}]", owner, name) for i, v in enumerate(value))
        if len(value) != len(args):
            raise ScenarioError(path, list(value), f"a list of {len(args)} values ({_describe_tuple(args)})")
        return tuple(
            _convert(a, v, f"{path}[{i}]", owner, name)
            for i, (a, v) in enumerate(zip(args, value, strict=True))
        )
    if tp is Any:
        return _plain_scalar(value, path)
    raise TypeError(f"unsupported schema type {tp!r} at {path}")  # a bug in the schema, not user input


def _describe_tuple(args: tuple[Any, ...]) -> str:
    if len(args) == 2 and args[1] is Ellipsis:
        return f"items of {getattr(args[0], '__name__', args[0])}"
    return ", ".join(getattr(a, "__name__", str(a)) for a in args)


def _convert_tagged(options: list[type], value: Any, path: str) -> Any:
    """A union of dataclasses told apart by their first field (``method`` or ``model``)."""
    tag_field = dataclasses.fields(options[0])[0].name
    tags = {opt.TAG: opt for opt in options}
    if not isinstance(value, Mapping):
        raise ScenarioError(path, value, f"a mapping with '{tag_field}' in {sorted(tags)}")
    tag = value.get(tag_field, options[0].TAG)
    if tag not in tags:
        close = difflib.get_close_matches(str(tag), list(tags), n=1, cutoff=0.5)
        hint = f"did you mean '{close[0]}'? " if close else ""
        raise ScenarioError(
            f"{path}.{tag_field}", tag, f"a known {tag_field} ({hint}one of {', '.join(tags)})"
        )
    return _from_mapping(tags[tag], value, path)


def _plain_scalar(value: Any, path: str) -> Any:
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (list, tuple)):
        return tuple(_plain_scalar(v, path) for v in value)
    raise ScenarioError(path, value, "a scalar, string or list")


def _to_plain(obj: Any) -> Any:
    if dataclasses.is_dataclass(obj):
        out: dict[str, Any] = {}
        for f in dataclasses.fields(obj):
            value = getattr(obj, f.name)
            if value is None and f.name in getattr(obj, "OMIT_NONE", ()):
                continue
            if f.name in getattr(obj, "MAPPINGS", ()):
                out[f.name] = {k: _to_plain(v) for k, v in value}
            else:
                out[f.name] = _to_plain(value)
        return out
    if isinstance(obj, tuple):
        return [_to_plain(v) for v in obj]
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return obj


def _deep_merge(base: dict[str, Any], changes: Mapping[str, Any]) -> dict[str, Any]:
    merged = dict(base)
    for key, value in changes.items():
        if isinstance(value, Mapping) and isinstance(merged.get(key), dict):
            current = merged[key]
            # A tagged union switched to another variant starts from that variant's defaults.
            tag = next((t for t in ("method", "model") if t in value and t in current), None)
            if tag is not None and value[tag] != current[tag]:
                merged[key] = dict(value)
            else:
                merged[key] = _deep_merge(current, value)
        else:
            merged[key] = value
    return merged


def _rebuild(scenario: Scenario, changes: Mapping[str, Any]) -> Scenario:
    return Scenario.from_dict(_deep_merge(scenario.to_dict(), changes))


# --- loading ------------------------------------------------------------------------------------------


def load_scenario(source: str | Path | Mapping[str, Any] | Scenario) -> Scenario:
    """Load a scenario from a YAML path, a mapping or a :class:`Scenario` (returned as is).

    Raises:
        ScenarioError: the file is missing or unreadable, is not valid YAML, or a field is invalid.
    """
    if isinstance(source, Scenario):
        return source
    if isinstance(source, Mapping):
        return Scenario.from_dict(source)
    path = Path(source)
    try:
        text = path.read_text()
    except OSError as error:
        raise ScenarioError("path", str(path), f"a readable scenario file ({error.strerror})") from error
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise ScenarioError("path", str(path), f"valid YAML ({error})") from error
    try:
        return Scenario.from_dict(data if data is not None else {})
    except ScenarioError as error:
        raise ScenarioError(error.field, error.value, f"{error.expected} (in {path})") from None


def _bundled(name: str) -> Path:
    return Path(str(resources.files("uav_penetration_env") / "scenarios" / name))


PAPER_WEIGHTS = {"w1": (0.3, 0.4, 0.3), "w2": (0.3, 0.5, 0.2)}


def paper_scenario(weights: str = "w1") -> Scenario:
    """The paper's §5 scenario (``scenarios/paper.yaml``); ``weights`` ``"w1"`` = 0.3/0.4/0.3, ``"w2"`` = 0.3/0.5/0.2."""
    if weights not in PAPER_WEIGHTS:
        raise ScenarioError("weights", weights, "'w1' (0.3/0.4/0.3) or 'w2' (0.3/0.5/0.2)")
    scenario = _load_bundled("paper.yaml")
    if weights == "w2":
        scenario = replace(
            scenario, name=f"{scenario.name}-w2", cost=replace(scenario.cost, weights=PAPER_WEIGHTS["w2"])
        )
    return scenario


@cache
def _load_bundled(name: str) -> Scenario:
    return load_scenario(_bundled(name))
