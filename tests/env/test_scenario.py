"""Scenario files (model.md §7b): YAML round trip, the shipped paper scenario, profiles, validation."""

from __future__ import annotations

import copy
import dataclasses
import math
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest import tiny_scenario

from uav_penetration_env.build import build_scenario
from uav_penetration_env.catalogue import dem_scenario, random_scenario
from uav_penetration_env.scenario import (
    ConstantRCS,
    DEMTerrain,
    DiamondSquare,
    GaussianField,
    RadarModelConfig,
    RandomWalk,
    Scenario,
    ScenarioError,
    TerrainConfig,
    UAVConfig,
    load_scenario,
    paper_scenario,
)
from uav_penetration_env.scenario.schema import MAX_GRID_NODES, MAX_RADARS, MIN_TURN_DEG
from uav_penetration_env.suggest import did_you_mean

DELETE = object()  # marker: remove the key instead of setting it


def _paper_yaml_data() -> dict:
    """The shipped paper.yaml, parsed by PyYAML alone (independent of the loader under test)."""
    path = Path(str(resources.files("uav_penetration_env") / "scenarios" / "paper.yaml"))
    return yaml.safe_load(path.read_text())


def _with(base: dict, *changes: tuple[tuple, object]) -> dict:
    """A deep copy of ``base`` with each (key path, value) set, or removed for ``DELETE``."""
    data = copy.deepcopy(base)
    for path, value in changes:
        node = data
        for key in path[:-1]:
            node = node[key]
        if value is DELETE:
            del node[path[-1]]
        else:
            node[path[-1]] = value
    return data


# --- round trip -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "make",
    [
        pytest.param(lambda: paper_scenario("w1"), id="paper-w1"),
        pytest.param(lambda: paper_scenario("w2"), id="paper-w2"),
        pytest.param(lambda: paper_scenario().with_profile("paper"), id="paper-profile"),
        pytest.param(dem_scenario, id="dem"),
        pytest.param(lambda: random_scenario(np.random.default_rng(11), 0.7), id="random"),
        pytest.param(tiny_scenario, id="tiny"),
        pytest.param(
            lambda: tiny_scenario(terrain={"natural": {"method": "random_walk", "passes": 2}}),
            id="tiny-random-walk",
        ),
        pytest.param(lambda: tiny_scenario(uav={"rcs": {"model": "constant", "rcs_m2": 0.5}}), id="tiny-rcs"),
    ],
)
def test_yaml_round_trip_is_exact(make, tmp_path):
    scenario = make()
    path = scenario.to_yaml(tmp_path / "nested" / "scenario.yaml")
    loaded = load_scenario(path)
    assert loaded == scenario
    assert loaded.hash == scenario.hash
    # The file keeps the paper's units: km for x, y and metres for z.
    data = yaml.safe_load(path.read_text())
    assert data["goal"]["x_km"] == scenario.goal.x_km
    assert data["map"]["grid_m"] == scenario.map.grid_m


def test_load_scenario_accepts_a_mapping_or_a_scenario(tiny):
    assert load_scenario(tiny) is tiny
    assert load_scenario(tiny.to_dict()) == tiny


# --- the shipped paper scenario matches model.md §5/§9 ---------------------------------------------


def test_paper_yaml_holds_the_section5_values():
    s = paper_scenario()
    radars = [(r.name, r.x_km, r.y_km, r.z_m, r.mast_m, r.ref_range_km, r.ref_rcs_m2) for r in s.radars]
    assert radars == [
        ("R1", 11.0, 55.0, 234.0, None, 100.0, 0.1),
        ("R2", 35.0, 45.0, 397.0, None, 100.0, 0.1),
        ("R3", 55.0, 65.0, 468.8, None, 100.0, 0.1),
        ("R4", 90.0, 60.0, 450.6, None, 100.0, 0.1),
    ]
    mountains = [(m.x_km, m.y_km, m.height_m) for m in s.terrain.mountains]
    assert mountains == [(10.0, 10.0, 500.0), (40.0, 25.0, 650.0), (45.0, 50.0, 750.0)]
    assert s.terrain.mountain_decay_per_km2 == 0.04
    assert s.terrain.natural == GaussianField(height_m=200.0, correlation_km=5.0)
    assert s.cost.weights == (0.3, 0.4, 0.3)
    assert s.cost.third_term == "fuel"
    assert (s.map.x_km, s.map.y_km, s.map.grid_m, s.map.ceiling_m) == (
        (-25.0, 125.0),
        (-25.0, 125.0),
        500.0,
        3000.0,
    )
    assert (s.start.x_km, s.start.y_km, s.start.z_agl_m, s.start.speed_m_s) == (0.0, 0.0, 100.0, 10.0)
    assert s.start.heading_deg is None  # toward the goal
    assert (s.goal.x_km, s.goal.y_km, s.goal.radius_km) == (100.0, 100.0, 3.0)
    assert s.uav.speed_m_s == (5.0, 10.0)
    assert (s.uav.dv_max_m_s, s.uav.dheading_max_deg, s.uav.dpitch_max_deg, s.uav.pitch_max_deg) == (
        2.0,
        15.0,
        15.0,
        15.0,
    )
    assert s.uav.min_clearance_m == 30.0
    assert (s.time.dt_s, s.time.max_steps) == (300.0, 150)
    rm = s.radar_model
    assert (rm.false_alarm_prob, rm.reference_detection_prob, rm.effective_earth_radius_km) == (
        1e-6,
        0.5,
        8487.2,
    )
    assert (rm.min_range_m, rm.masking_softness_m, rm.fusion) == (100.0, 100.0, "max")
    assert s.profile == "benchmark"


def test_paper_yaml_agrees_with_the_schema_defaults():
    # model.md §7b: "This example is the schema: every key shown exists, with these defaults".
    s = paper_scenario()
    assert s.normalisation.payoff is not None  # provisional payoff constants are shipped
    defaults = Scenario()
    for field in (
        "profile",
        "map",
        "start",
        "goal",
        "uav",
        "time",
        "terrain",
        "radar_model",
        "radars",
        "cost",
    ):
        assert getattr(s, field) == getattr(defaults, field), field


def test_paper_scenario_w2_weights_and_hash():
    w1, w2 = paper_scenario("w1"), paper_scenario("w2")
    assert w2.cost.weights == (0.3, 0.5, 0.2)
    assert w1.hash != w2.hash
    assert len(w1.hash) == 16 and int(w1.hash, 16) >= 0
    # Only the weights (and the name) differ.
    assert w2.radars == w1.radars and w2.terrain == w1.terrain and w2.uav == w1.uav


def test_paper_scenario_unknown_weight_set():
    with pytest.raises(ScenarioError) as info:
        paper_scenario("w3")
    assert info.value.field == "weights"
    assert "'w3'" in str(info.value)


def test_hash_changes_with_any_field(tiny):
    assert tiny.hash == tiny_scenario().hash
    assert tiny.updated({"terrain": {"seed": 4}}).hash != tiny.hash
    assert tiny.updated({"radars": [{"name": "A", "x_km": 5, "y_km": 25, "z_m": 301}]}).hash != tiny.hash


# --- profile resolution (model.md §7a) ------------------------------------------------------------


def test_benchmark_profile_defaults(tiny):
    s = tiny.updated({"profile": "benchmark"})
    assert (s.detection, s.masking, s.normalisation_mode) == ("swerling1", "soft", "analytic")
    assert s.crash_penalty_per_step == 1.0


def test_paper_profile_defaults_use_the_stored_constant():
    stored = _paper_yaml_data()["normalisation"]["payoff"]["constants"]["crash_penalty_per_step"]
    s = paper_scenario().with_profile("paper")
    assert s.profile == "paper"
    assert (s.detection, s.masking, s.normalisation_mode) == ("ratio", "off", "payoff")
    assert s.crash_penalty_per_step == stored


def test_explicit_file_values_override_the_profile():
    paper = paper_scenario().with_profile("paper")
    s = paper.updated(
        {
            "radar_model": {"detection": "swerling1", "masking": "hard"},
            "normalisation": {"mode": "analytic"},
            "cost": {"crash_penalty_per_step": 2.5},
        }
    )
    assert (s.detection, s.masking, s.normalisation_mode, s.crash_penalty_per_step) == (
        "swerling1",
        "hard",
        "analytic",
        2.5,
    )
    b = paper_scenario().updated(
        {"radar_model": {"detection": "ratio", "masking": "off"}, "normalisation": {"mode": "payoff"}}
    )
    assert (b.detection, b.masking, b.normalisation_mode) == ("ratio", "off", "payoff")
    # A payoff normalisation under the benchmark profile takes the penalty from the constants.
    assert (
        b.crash_penalty_per_step
        == _paper_yaml_data()["normalisation"]["payoff"]["constants"]["crash_penalty_per_step"]
    )


def test_with_profile_none_or_same_is_identity(tiny):
    assert tiny.with_profile(None) is tiny
    assert tiny.with_profile(tiny.profile) is tiny


# --- broken inputs: each raises ScenarioError naming the field, the value and the expectation --------

PAPER = paper_scenario().to_dict()
NO_PAYOFF = _with(PAPER, (("normalisation", "payoff"), None))
GOAL_MARGIN_KM = 2 * 10.0 * 300.0 / math.radians(15.0) / 1000.0  # two turn radii, 22.9 km

BROKEN = [
    # (id, data, field, text naming the value, text naming the expectation)
    ("unknown-top-key", _with(PAPER, (("radar",), [])), "radar", "[]", "did you mean 'radars'"),
    (
        "unknown-nested-key",
        _with(PAPER, (("uav", "min_clearence_m"), 30)),
        "uav.min_clearence_m",
        "30",
        "did you mean 'min_clearance_m'",
    ),
    (
        "unknown-deep-key",
        _with(PAPER, (("uav", "fuel", "mass"), 20)),
        "uav.fuel.mass",
        "20",
        "did you mean 'mass_kg'",
    ),
    (
        "unknown-terrain-method",
        _with(PAPER, (("terrain", "natural"), {"method": "gausian_field"})),
        "terrain.natural.method",
        "'gausian_field'",
        "did you mean 'gaussian_field'",
    ),
    (
        "unknown-rcs-model",
        _with(PAPER, (("uav", "rcs"), {"model": "sphere"})),
        "uav.rcs.model",
        "'sphere'",
        "one of",
    ),
    (
        "weights-sum",
        _with(PAPER, (("cost", "weights"), [0.3, 0.3, 0.3])),
        "cost.weights",
        "0.3",
        "summing to 1",
    ),
    (
        "weights-negative",
        _with(PAPER, (("cost", "weights"), [-0.2, 0.7, 0.5])),
        "cost.weights",
        "-0.2",
        "non-negative",
    ),
    (
        "weights-length",
        _with(PAPER, (("cost", "weights"), [0.5, 0.5])),
        "cost.weights",
        "[0.5, 0.5]",
        "3 values",
    ),
    (
        "speed-negative",
        _with(PAPER, (("uav", "speed_m_s"), [-5.0, 10.0])),
        "uav.speed_m_s",
        "-5.0",
        "0 < v_min < v_max",
    ),
    (
        "speed-equal",
        _with(PAPER, (("uav", "speed_m_s"), [10.0, 10.0])),
        "uav.speed_m_s",
        "[10.0, 10.0]",
        "v_min < v_max",
    ),
    (
        "speed-reversed",
        _with(PAPER, (("uav", "speed_m_s"), [12.0, 10.0])),
        "uav.speed_m_s",
        "12.0",
        "v_min < v_max",
    ),
    (
        "speed-length",
        _with(PAPER, (("uav", "speed_m_s"), [5.0, 10.0, 15.0])),
        "uav.speed_m_s",
        "15.0",
        "2 values",
    ),
    ("dv-negative", _with(PAPER, (("uav", "dv_max_m_s"), -2.0)), "uav.dv_max_m_s", "-2.0", "positive"),
    ("pitch-max", _with(PAPER, (("uav", "pitch_max_deg"), 95.0)), "uav.pitch_max_deg", "95.0", "(0, 90]"),
    (
        "radar-outside-x",
        _with(PAPER, (("radars", 2, "x_km"), 140.0)),
        "radars[2].x_km",
        "140.0",
        "inside the map",
    ),
    (
        "radar-outside-y",
        _with(PAPER, (("radars", 1, "y_km"), -30.0)),
        "radars[1].y_km",
        "-30.0",
        "inside the map",
    ),
    (
        "radar-both-heights",
        _with(PAPER, (("radars", 0, "mast_m"), 20.0)),
        "radars[0].z_m",
        "234.0",
        "exactly one of z_m or mast_m",
    ),
    (
        "radar-no-height",
        _with(PAPER, (("radars", 3, "z_m"), DELETE)),
        "radars[3].z_m",
        "None",
        "exactly one of z_m or mast_m",
    ),
    ("radar-no-name", _with(PAPER, (("radars", 0, "name"), DELETE)), "radars[0].name", "None", "required"),
    (
        "radar-ref-range",
        _with(PAPER, (("radars", 1, "ref_range_km"), 0.0)),
        "radars[1].ref_range_km",
        "0.0",
        "positive",
    ),
    (
        "radar-negative-mast",
        _with(PAPER, (("radars", 0, "z_m"), DELETE), (("radars", 0, "mast_m"), -1.0)),
        "radars[0].mast_m",
        "-1.0",
        ">= 0",
    ),
    (
        "radar-duplicate-names",
        _with(PAPER, (("radars", 2, "name"), "R1")),
        "radars",
        "'R1', 'R2', 'R1', 'R4'",
        "unique radar names",
    ),
    ("goal-outside", _with(PAPER, (("goal", "x_km"), 130.0)), "goal.x_km", "130.0", "inside the map"),
    ("goal-near-edge", _with(PAPER, (("goal", "x_km"), 110.0)), "goal.x_km", "110.0", "two turn radii"),
    ("goal-near-edge-y", _with(PAPER, (("goal", "y_km"), 103.0)), "goal.y_km", "103.0", "22.9 km"),
    ("goal-radius", _with(PAPER, (("goal", "radius_km"), 0.0)), "goal.radius_km", "0.0", "positive"),
    ("start-outside", _with(PAPER, (("start", "x_km"), -26.0)), "start.x_km", "-26.0", "inside the map"),
    (
        "start-speed-high",
        _with(PAPER, (("start", "speed_m_s"), 12.0)),
        "start.speed_m_s",
        "12.0",
        "[5, 10] m/s",
    ),
    ("start-speed-low", _with(PAPER, (("start", "speed_m_s"), 4.0)), "start.speed_m_s", "4.0", "[5, 10] m/s"),
    ("start-pitch", _with(PAPER, (("start", "pitch_deg"), 20.0)), "start.pitch_deg", "20.0", "+-15 deg"),
    (
        "start-below-clearance",
        _with(PAPER, (("start", "z_agl_m"), 20.0)),
        "start.z_agl_m",
        "20.0",
        "min_clearance_m = 30",
    ),
    (
        "start-above-ceiling",
        _with(PAPER, (("start", "z_agl_m"), 3000.0)),
        "start.z_agl_m",
        "3000.0",
        "ceiling",
    ),
    ("type-string", _with(PAPER, (("map", "grid_m"), "500")), "map.grid_m", "'500'", "a finite number"),
    ("type-bool", _with(PAPER, (("time", "dt_s"), True)), "time.dt_s", "True", "a finite number"),
    (
        "type-nan",
        _with(PAPER, (("goal", "radius_km"), float("nan"))),
        "goal.radius_km",
        "nan",
        "a finite number",
    ),
    (
        "type-inf",
        _with(PAPER, (("uav", "dv_max_m_s"), float("inf"))),
        "uav.dv_max_m_s",
        "inf",
        "a finite number",
    ),
    (
        "type-neg-inf",
        _with(PAPER, (("radars", 0, "z_m"), float("-inf"))),
        "radars[0].z_m",
        "-inf",
        "a finite number",
    ),
    (
        "type-int-fraction",
        _with(PAPER, (("time", "max_steps"), 10.5)),
        "time.max_steps",
        "10.5",
        "an integer",
    ),
    ("type-int-bool", _with(PAPER, (("terrain", "seed"), False)), "terrain.seed", "False", "an integer"),
    (
        "type-bool-field",
        _with(PAPER, (("terrain", "randomize_terrain"), "yes")),
        "terrain.randomize_terrain",
        "'yes'",
        "true or false",
    ),
    ("type-string-field", _with(PAPER, (("name",), 5)), "name", "5", "a string"),
    ("type-list", _with(PAPER, (("map", "x_km"), 5.0)), "map.x_km", "5.0", "a list"),
    ("type-section", _with(PAPER, (("uav",), 5)), "uav", "5", "a mapping"),
    ("type-null", _with(PAPER, (("map", "grid_m"), None)), "map.grid_m", "None", "a finite number"),
    ("type-null-union", _with(PAPER, (("uav", "rcs"), None)), "uav.rcs", "None", "null is not allowed"),
    ("max-steps-zero", _with(PAPER, (("time", "max_steps"), 0)), "time.max_steps", "0", "an integer >= 1"),
    ("grid-not-dividing", _with(PAPER, (("map", "grid_m"), 700.0)), "map.grid_m", "700.0", "divides"),
    (
        "map-interval",
        _with(PAPER, (("map", "y_km"), [125.0, -25.0])),
        "map.y_km",
        "[125.0, -25.0]",
        "low < high",
    ),
    (
        "detection-name",
        _with(PAPER, (("radar_model", "detection"), "swerling2")),
        "radar_model.detection",
        "'swerling2'",
        "'swerling1'",
    ),
    (
        "masking-name",
        _with(PAPER, (("radar_model", "masking"), "partial")),
        "radar_model.masking",
        "'partial'",
        "'soft'",
    ),
    ("fusion-name", _with(PAPER, (("radar_model", "fusion"), "sum")), "radar_model.fusion", "'sum'", "'or'"),
    (
        "third-term-name",
        _with(PAPER, (("cost", "third_term"), "time")),
        "cost.third_term",
        "'time'",
        "'length'",
    ),
    (
        "normalisation-name",
        _with(PAPER, (("normalisation", "mode"), "minmax")),
        "normalisation.mode",
        "'minmax'",
        "'payoff'",
    ),
    ("profile-name", _with(PAPER, (("profile",), "papr")), "profile", "'papr'", "'paper'"),
    (
        "pfa",
        _with(PAPER, (("radar_model", "false_alarm_prob"), 1.5)),
        "radar_model.false_alarm_prob",
        "1.5",
        "(0, 1)",
    ),
    (
        "pd-ref",
        _with(PAPER, (("radar_model", "reference_detection_prob"), 1e-7)),
        "radar_model.reference_detection_prob",
        "1e-07",
        "false_alarm_prob",
    ),
    (
        "payoff-mode-no-constants",
        _with(NO_PAYOFF, (("normalisation", "mode"), "payoff")),
        "normalisation.payoff",
        "None",
        "payoff constants",
    ),
    (
        "paper-profile-no-constants",
        _with(NO_PAYOFF, (("profile",), "paper")),
        "normalisation.payoff",
        "None",
        "payoff constants",
    ),
    (
        "payoff-interval",
        _with(PAPER, (("normalisation", "payoff", "constants", "radar"), [1.0, 0.0])),
        "normalisation.payoff.constants.radar",
        "[1.0, 0.0]",
        "low < high",
    ),
    (
        "payoff-missing",
        _with(PAPER, (("normalisation", "payoff", "constants", "third"), DELETE)),
        "normalisation.payoff.constants.third",
        "None",
        "required",
    ),
    (
        "mountain-height",
        _with(PAPER, (("terrain", "mountains", 1, "height_m"), -5.0)),
        "terrain.mountains[1].height_m",
        "-5.0",
        "positive",
    ),
    (
        "decay",
        _with(PAPER, (("terrain", "mountain_decay_per_km2"), 0.0)),
        "terrain.mountain_decay_per_km2",
        "0.0",
        "positive",
    ),
    (
        "roughness",
        _with(PAPER, (("terrain", "natural"), {"method": "diamond_square", "roughness": 1.0})),
        "terrain.natural.roughness",
        "1.0",
        "(0, 1)",
    ),
    (
        "passes",
        _with(PAPER, (("terrain", "natural"), {"method": "random_walk", "passes": -1})),
        "terrain.natural.passes",
        "-1",
        "an integer in [0, 1000]",
    ),
    (
        "huge-number",
        _with(PAPER, (("radars", 0, "z_m"), 1e308)),
        "radars[0].z_m",
        "1e+308",
        "a finite number of magnitude at most 1e+12",
    ),
    (
        "huge-correlation",
        _with(PAPER, (("terrain", "natural", "correlation_km"), 1e9)),
        "terrain.natural.correlation_km",
        "1000000000.0",
        "at most the map's longer side",
    ),
    (
        "idle-fraction",
        _with(PAPER, (("uav", "fuel", "idle_thrust_fraction"), 1.0)),
        "uav.fuel.idle_thrust_fraction",
        "1.0",
        "[0, 1)",
    ),
    # Values that raised raw TypeError, OSError, OverflowError, MemoryError or ZeroDivisionError.
    *(
        (
            f"method-as-{kind}",
            _with(PAPER, (("terrain", "natural"), {"method": tag})),
            "terrain.natural.method",
            repr(tag),
            "a known method",
        )
        for kind, tag in (("list", [1, 2]), ("mapping", {"a": 1}))
    ),
    *(
        (
            f"dem-file-{kind}",
            _with(PAPER, (("terrain", "natural"), {"method": "dem", "file": file})),
            "terrain.natural.file",
            repr(file)[:20],
            expected,
        )
        for kind, file, expected in (
            ("too-long", "x" * 5000, "at most 4096 bytes"),
            ("name-too-long", "dem/" + "x" * 300 + ".npz", "255 bytes a name"),
            ("nul-byte", "a\x00b.npz", "no NUL byte"),
            ("empty", "", "not empty"),
        )
    ),
    (
        "rcs-path-nul",
        _with(PAPER, (("uav", "rcs"), {"model": "table", "path": "t\x00.csv"})),
        "uav.rcs.path",
        "'t\\x00.csv'",
        "no NUL byte",
    ),
    (
        "map-beyond-the-earth",
        _with(PAPER, (("map", "x_km"), [-1e308, 125])),
        "map.x_km[0]",
        "-1e+308",
        "magnitude at most 1e+12",
    ),
    ("map-of-1e6-km", _with(PAPER, (("map", "x_km"), [-1e6, 125])), "map.x_km", "-1000000.0", "+-20,000 km"),
    (
        "map-too-many-nodes",
        _with(PAPER, (("map", "x_km"), [-10_000, 10_000])),
        "map.grid_m",
        "500",
        "at most 4,000,000 grid nodes",
    ),
    (
        "grid-spacing-denormal",
        _with(PAPER, (("map", "grid_m"), 5e-324)),
        "map.grid_m",
        "5e-324",
        "grid nodes",
    ),
    (
        "turn-rate-denormal",
        _with(PAPER, (("uav", "dheading_max_deg"), 5e-324)),
        "uav.dheading_max_deg",
        "5e-324",
        "[0.01, 90] degrees",
    ),
    (
        "too-many-radars",
        _with(
            PAPER,
            (
                ("radars",),
                [{"name": f"R{i}", "x_km": float(i), "y_km": 50.0, "mast_m": 20.0} for i in range(65)],
            ),
        ),
        "radars",
        "65 radars",
        "at most 64 radars",
    ),
    (
        "radars-times-nodes",
        _with(
            PAPER,
            (("map", "grid_m"), 100.0),
            (
                ("radars",),
                [{"name": f"R{i}", "x_km": float(i), "y_km": 50.0, "mast_m": 20.0} for i in range(8)],
            ),
        ),
        "radars",
        "8 radars on 2,253,001 grid nodes",
        "radars x grid nodes <= 16,000,000",
    ),
]


@pytest.mark.parametrize(
    ("data", "field", "value_text", "expected_text"), [b[1:] for b in BROKEN], ids=[b[0] for b in BROKEN]
)
def test_broken_input_names_field_value_and_expectation(data, field, value_text, expected_text):
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(data)
    error = info.value
    assert error.field == field
    message = str(error)
    assert message.startswith(f"{field}: got ")
    assert value_text in message
    assert expected_text in message


def test_the_size_limits_admit_what_they_promise():
    # The largest grid, the most radars, and many radars with masking off (no floors) are valid.
    side = math.isqrt(MAX_GRID_NODES) - 1  # cells per axis at 1 km
    Scenario.from_dict(
        _with(PAPER, (("map",), {"x_km": [-25, side - 25], "y_km": [-25, side - 25], "grid_m": 1000}))
    )
    many = [{"name": f"R{i}", "x_km": float(i), "y_km": 50.0, "mast_m": 20.0} for i in range(MAX_RADARS)]
    Scenario.from_dict(_with(PAPER, (("radars",), many)))
    fine = _with(PAPER, (("map", "grid_m"), 100.0), (("radars",), many[:8]))
    Scenario.from_dict(_with(fine, (("radar_model", "masking"), "off")))
    assert UAVConfig(dheading_max_deg=MIN_TURN_DEG).dheading_max_deg == MIN_TURN_DEG


@pytest.mark.parametrize("path", [("time", "max_steps"), ("terrain", "seed")])
@pytest.mark.parametrize("value", [float("inf"), float("nan")], ids=["inf", "nan"])
def test_non_finite_integer_field_raises_scenario_error(path, value):
    # YAML's .inf / .nan in an integer field (K_max, the terrain seed).
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(_with(PAPER, (path, value)))
    assert info.value.field == ".".join(path)


def test_broken_table_bases_are_valid():
    # Every broken case differs from a valid scenario only by the change it names.
    assert Scenario.from_dict(PAPER) == paper_scenario()
    Scenario.from_dict(NO_PAYOFF)


def test_goal_edge_margin_is_two_turn_radii():
    # 2 v_max dt / dphi_max = 2 * 10 * 300 / (15° in rad) = 22.92 km: a goal 23 km inside passes,
    # 22 km inside fails.
    assert paper_scenario().goal_edge_margin_km == pytest.approx(GOAL_MARGIN_KM, rel=1e-12)
    Scenario.from_dict(_with(PAPER, (("goal", "x_km"), 102.0)))
    with pytest.raises(ScenarioError):
        Scenario.from_dict(_with(PAPER, (("goal", "x_km"), 103.0)))
    with pytest.raises(ScenarioError):
        Scenario.from_dict(_with(PAPER, (("goal", "y_km"), -3.0)))


def test_valid_edge_values_are_accepted():
    # Boundaries that the spec allows: start at v_min, z_agl exactly the clearance, |pitch| = pitch_max.
    Scenario.from_dict(
        _with(
            PAPER,
            (("start", "speed_m_s"), 5.0),
            (("start", "pitch_deg"), -15.0),
            (("start", "z_agl_m"), 30.0),
        )
    )
    Scenario.from_dict(_with(PAPER, (("radars", 0, "z_m"), DELETE), (("radars", 0, "mast_m"), 0.0)))
    Scenario.from_dict(_with(PAPER, (("time", "max_steps"), 10.0)))  # an integral float is an integer


def test_radar_below_terrain_fails_at_build(tiny):
    # A radar on the tiny scenario's 400 m peak with its antenna at 300 m above datum.
    scenario = tiny.updated({"radars": [{"name": "A", "x_km": 12, "y_km": 14, "z_m": 300}]})
    with pytest.raises(ScenarioError) as info:
        build_scenario(scenario)
    assert info.value.field == "radars[0].z_m"
    assert info.value.value == 300.0
    assert "at or above the terrain" in str(info.value)


def test_radar_second_in_list_below_terrain_names_its_index(tiny):
    scenario = tiny.updated(
        {
            "radars": [
                {"name": "A", "x_km": 5, "y_km": 25, "z_m": 300},
                {"name": "B", "x_km": 12, "y_km": 14, "z_m": 10},
            ]
        }
    )
    with pytest.raises(ScenarioError) as info:
        build_scenario(scenario)
    assert info.value.field == "radars[1].z_m"


# --- files --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "field", "words"),
    [
        (None, "path", ""),  # no file at all
        ("map: {x_km: [0, 1]\nstart: [", "path", "valid YAML"),
        ("- 1\n- 2\n", None, "mapping"),
        ("42\n", None, "mapping"),
        ("just a string\n", None, "mapping"),
        (yaml.safe_dump(_with(PAPER, (("goal", "radius_km"), -1.0))), "goal.radius_km", ""),
    ],
    ids=["missing", "invalid-yaml", "list", "number", "string", "bad-field"],
)
def test_a_bad_file_is_refused_naming_the_path_and_field(tmp_path, text, field, words):
    path = tmp_path / "scenario.yaml"
    if text is not None:
        path.write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    if field is not None:
        assert info.value.field == field
    assert str(path) in str(info.value)
    assert words in str(info.value)


def test_empty_file_is_the_default_scenario(tmp_path):
    path = tmp_path / "empty.yaml"
    path.write_text("")
    assert load_scenario(path) == Scenario()


def test_to_yaml_unwritable_path_raises(tmp_path, tiny):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    with pytest.raises(ScenarioError) as info:
        tiny.to_yaml(blocker / "scenario.yaml")
    assert info.value.field == "path"
    assert str(blocker / "scenario.yaml") in str(info.value)


# --- updated() ----------------------------------------------------------------------------------------


def test_updated_switching_a_tagged_union_starts_from_the_variant_defaults(tiny):
    assert tiny.terrain.natural.height_m == 150.0  # the fixture's gaussian field
    walk = tiny.updated({"terrain": {"natural": {"method": "random_walk"}}})
    assert walk.terrain.natural == RandomWalk()  # height 200, 1 pass: not the old 150 m
    square = tiny.updated({"terrain": {"natural": {"method": "diamond_square", "roughness": 0.7}}})
    assert square.terrain.natural == DiamondSquare(roughness=0.7)
    constant = tiny.updated({"uav": {"rcs": {"model": "constant"}}})
    assert constant.uav.rcs == ConstantRCS()
    # Other terrain fields survive the switch.
    assert walk.terrain.seed == tiny.terrain.seed and walk.terrain.mountains == tiny.terrain.mountains


def test_updated_same_variant_merges(tiny):
    s = tiny.updated({"terrain": {"natural": {"correlation_km": 3}}})
    assert s.terrain.natural == GaussianField(height_m=150.0, correlation_km=3.0)
    same_tag = tiny.updated({"terrain": {"natural": {"method": "gaussian_field", "correlation_km": 3}}})
    assert same_tag == s


def test_updated_validates(tiny):
    with pytest.raises(ScenarioError) as info:
        tiny.updated({"uav": {"dv_max_m_s": -1}})
    assert info.value.field == "uav.dv_max_m_s"
    assert tiny.uav.dv_max_m_s == 2.0  # frozen: the original is untouched


# --- the converter and the field rules (scenario/convert.py, scenario/rules.py) --------------------------


def test_unknown_key_hint_is_the_shared_did_you_mean():
    # 'radar' is close to two keys (difflib ratios 0.91 and 0.63 >= 0.6): suggest.py lists both, best first.
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict({"radar": []})
    keys = [f.name for f in dataclasses.fields(Scenario)]
    assert info.value.expected == f"a known key ({did_you_mean('radar', keys)}allowed: {', '.join(keys)})"
    assert "did you mean 'radars', 'radar_model'? " in info.value.expected


def test_unknown_tag_hint_is_the_shared_did_you_mean():
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict({"uav": {"rcs": {"model": "constnt"}}})
    assert info.value.field == "uav.rcs.model"
    assert (
        info.value.expected == "a known model (did you mean 'constant'? one of primitives, constant, table)"
    )


def test_a_variant_without_its_tag_is_the_unions_first_variant():
    s = Scenario.from_dict({"terrain": {"natural": {"height_m": 50.0}}})
    assert s.terrain.natural == GaussianField(height_m=50.0)
    with pytest.raises(ScenarioError) as info:  # the first variant's keys only
        Scenario.from_dict({"terrain": {"natural": {"roughness": 0.5}}})
    assert info.value.field == "terrain.natural.roughness"


def test_field_rules_run_in_field_order_before_cross_field_checks():
    # Three bad values: min_range_m is the first field with a broken rule; the reference
    # probability (checked against false_alarm_prob, a cross-field check) comes after all rules.
    with pytest.raises(ScenarioError) as info:
        RadarModelConfig(false_alarm_prob=0.5, reference_detection_prob=0.1, min_range_m=-1.0, fusion="sum")
    assert (info.value.field, info.value.value) == ("min_range_m", -1.0)
    with pytest.raises(ScenarioError) as info:
        RadarModelConfig(false_alarm_prob=0.5, reference_detection_prob=0.1)
    assert info.value.field == "reference_detection_prob"


def test_field_rules_skip_null_and_show_tuples_as_lists():
    assert TerrainConfig(threat_altitude_scale_m=None).threat_altitude_scale_m is None
    with pytest.raises(ScenarioError) as info:
        TerrainConfig(threat_altitude_scale_m=0.0)
    assert (info.value.field, info.value.expected) == ("threat_altitude_scale_m", "a positive number")
    with pytest.raises(ScenarioError) as info:
        DEMTerrain(lat_deg=(10.0, 95.0))  # a valid interval, outside [-90, 90]: the second rule
    assert (info.value.value, info.value.expected) == ([10.0, 95.0], "latitudes in [-90, 90]")
