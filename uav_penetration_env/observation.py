"""The 67-value observation of model.md §7a: its named slots, in order (name -> slice).

The one definition of the layout: the compiled observation (``kernels.observe_row``), the model,
the env's observation space and the tests read the offsets here. The kernels use the integer
starts below, which numba compiles in as constants; this file names numba so that the compile
cache's digest (:mod:`uav_penetration_env.compile_cache`) covers it and a layout change recompiles.
"""

from __future__ import annotations

import numpy as np

OBSERVED_RADARS = 4  # the nearest radars observed
RADAR_FEATURES = 7  # values per observed radar
TERRAIN_AHEAD_M = np.array([0.0, 1500.0, 3000.0, 4500.0, 6000.0])  # outer index of the terrain samples
TERRAIN_ACROSS_M = np.array([-3000.0, -1500.0, 0.0, 1500.0, 3000.0])  # inner index, positive to the left

# (name, width) in slot order.
_LAYOUT = (
    ("position", 2),  # x, y as fractions of the map extent
    ("altitude_agl", 1),  # z - h(x, y) [km]
    ("altitude_ceiling", 1),  # z / ceiling
    ("speed", 1),  # (v - v_min) / (v_max - v_min)
    ("heading", 2),  # cos, sin of phi
    ("pitch", 1),  # theta / theta_max
    ("goal_offset", 2),  # (x_g - x) / L, (y_g - y) / L
    ("goal_distance", 1),  # horizontal distance to the goal / L
    ("goal_bearing", 2),  # cos, sin of (bearing to the goal - phi)
    ("terrain", len(TERRAIN_AHEAD_M) * len(TERRAIN_ACROSS_M)),  # (h - z) [km], ahead-major
    ("radars", OBSERVED_RADARS * RADAR_FEATURES),  # nearest first, RADAR_FEATURES values each
    ("step_fraction", 1),  # k / K_max
)


def _slots() -> dict[str, slice]:
    slots, start = {}, 0
    for name, width in _LAYOUT:
        slots[name] = slice(start, start + width)
        start += width
    return slots


SLOTS: dict[str, slice] = _slots()
OBSERVATION_SIZE = SLOTS["step_fraction"].stop
OBSERVATION_LIMIT = 10.0  # every slot is clipped to +-this

# First index of each slot, for the compiled observation.
POSITION = SLOTS["position"].start
ALTITUDE_AGL = SLOTS["altitude_agl"].start
ALTITUDE_CEILING = SLOTS["altitude_ceiling"].start
SPEED = SLOTS["speed"].start
HEADING = SLOTS["heading"].start
PITCH = SLOTS["pitch"].start
GOAL_OFFSET = SLOTS["goal_offset"].start
GOAL_DISTANCE = SLOTS["goal_distance"].start
GOAL_BEARING = SLOTS["goal_bearing"].start
TERRAIN = SLOTS["terrain"].start
RADARS = SLOTS["radars"].start
STEP_FRACTION = SLOTS["step_fraction"].start

# Offsets of one radar's values within its RADAR_FEATURES block.
RADAR_PRESENT, RADAR_RANGE, RADAR_BEARING_COS, RADAR_BEARING_SIN, RADAR_HEIGHT, RADAR_VISIBLE, RADAR_THREAT = range(
    RADAR_FEATURES
)


def radar_block(observation: np.ndarray) -> np.ndarray:
    """The radar slots of (..., 67) observations as (..., OBSERVED_RADARS, RADAR_FEATURES)."""
    return observation[..., SLOTS["radars"]].reshape(*observation.shape[:-1], OBSERVED_RADARS, RADAR_FEATURES)


def terrain_block(observation: np.ndarray) -> np.ndarray:
    """The terrain slots of (..., 67) observations as (..., ahead, across)."""
    shape = (*observation.shape[:-1], len(TERRAIN_AHEAD_M), len(TERRAIN_ACROSS_M))
    return observation[..., SLOTS["terrain"]].reshape(shape)
