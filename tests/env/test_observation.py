"""The observation layout and the kernels' constants are each defined once, by name."""

from __future__ import annotations

import itertools

import numpy as np
from conftest import tiny_scenario

from uav_penetration_env import PenetrationModel, kernels, observation
from uav_penetration_env.observation import OBSERVATION_SIZE, SLOTS


def test_the_slots_tile_the_67_values_in_the_order_of_model_md():
    # model.md §7a's table: 0-1, 2, 3, 4, 5-6, 7, 8-9, 10, 11-12, 13-37, 38-65, 66.
    starts = [0, 2, 3, 4, 5, 7, 8, 10, 11, 13, 38, 66]
    assert [s.start for s in SLOTS.values()] == starts
    assert OBSERVATION_SIZE == 67
    assert all(a.stop == b.start for a, b in itertools.pairwise(SLOTS.values()))
    assert SLOTS["radars"].stop - SLOTS["radars"].start == observation.OBSERVED_RADARS * observation.RADAR_FEATURES


def test_the_named_blocks_are_views_of_their_slots():
    obs = np.arange(2 * OBSERVATION_SIZE, dtype=np.float32).reshape(2, OBSERVATION_SIZE)
    assert observation.terrain_block(obs).shape == (2, 5, 5)
    assert observation.terrain_block(obs)[1, 0, 0] == obs[1, SLOTS["terrain"].start]
    block = observation.radar_block(obs)
    assert block.shape == (2, 4, 7)
    assert block[0, 1, observation.RADAR_THREAT] == obs[0, SLOTS["radars"].start + 7 + 6]


def test_every_packed_index_is_its_fields_position():
    for names, prefix in ((kernels.ModelConstants._fields, "P_"), (kernels.ModelOptions._fields, "O_")):
        declared = {key for key in vars(kernels) if key.startswith(prefix) and key[2:].isupper()}
        assert declared == {prefix + name.upper() for name in names}
        for i, name in enumerate(names):
            assert getattr(kernels, prefix + name.upper()) == i
    assert kernels.N_PARAMS == len(kernels.ModelConstants._fields)
    assert kernels.N_OPTIONS == len(kernels.ModelOptions._fields)


def test_the_model_packs_its_named_constants():
    model = PenetrationModel(tiny_scenario(terrain={"threat_altitude_scale_m": 250.0}))
    params, options = model.arrays.params, model.arrays.options
    assert params.dtype == np.float64 and options.dtype == np.int64
    np.testing.assert_array_equal(params, list(model.constants))
    np.testing.assert_array_equal(options, list(model.options))
    assert params[kernels.P_CEILING] == model.ceiling == model.scenario.map.ceiling_m
    assert options[kernels.O_MAX_STEPS] == model.max_steps == model.scenario.time.max_steps
    assert model.threat_altitude_scale == 250.0 and options[kernels.O_ALTITUDE_FADE] == 1
    np.testing.assert_array_equal(model.bounds, np.array([*model.scenario.map.x_km, *model.scenario.map.y_km]) * 1000.0)
