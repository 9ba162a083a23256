"""The penetration model's physics, compiled: scalar relations composed in batch loop kernels.

STYLE.md §2b. Every physical relation of model.md §1-7a is written once here as a small scalar
function (``@njit(inline="always")``); the batch kernels below loop over rows (``prange``), and
inside a row over horizon steps, segment samples, peaks and radars. :class:`PenetrationModel`'s
``step``, ``costs``, ``rollout_cost``, ``state_threats`` and ``observe`` all call these kernels,
so the physics exists once at run time. The scenario travels as one :class:`ModelArrays` (a few
typed arrays: the pool geometry, the RCS table, and the named :class:`ModelConstants` and
:class:`ModelOptions` packed into a float vector ``params`` and an integer vector ``options``,
indexed by the ``P_*`` / ``O_*`` positions of their fields);
options (profile, masking, fusion, third term) are run-time values, so one compiled copy serves
every scenario.

Float arithmetic follows the numpy formulation (tests/numpy_model.py) operation by operation.
DECISION (model.md §8): results agree with it to ~1e-15 relative, not bit for bit, because numpy
evaluates ``exp``, ``arctan2``, ``tanh`` and ``**`` with its own SIMD routines (AVX-512 / SVML on
x86) where compiled code calls the C library; both are within an ulp of the exact value. No
``fastmath``: every row is computed alone in a fixed order, so results do not depend on the number
of threads.

Compile cache: ``cache=True``, in a folder named by a digest of the compiled sources
(:mod:`uav_penetration_env.compile_cache`).
"""

from __future__ import annotations

import math
import os
from typing import NamedTuple

# DECISION (model.md §8, idle threads): numba's OpenMP threads sleep between parallel kernels rather
# than spin (OMP_WAIT_POLICY=PASSIVE unless the user set it). Spinning threads take the cores a busy
# machine's other work needs and wait for cores themselves: with two busy processes on 2 cores an
# MPC planner's 100 x 5 rollout ran 0.03-0.43 M particle-steps/s on 2 spinning threads against
# 0.51-1.28 M on one, and 0.68-1.50 M on 2 sleeping threads. OpenMP reads it when its runtime loads
# (numba's first parallel kernel), so setting it here, on import, is early enough.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numba
import numpy as np
from numba import njit, prange, vectorize

from uav_penetration_env import compile_cache
from uav_penetration_env.observation import (
    ALTITUDE_AGL,
    ALTITUDE_CEILING,
    GOAL_BEARING,
    GOAL_DISTANCE,
    GOAL_OFFSET,
    HEADING,
    OBSERVATION_LIMIT,
    OBSERVATION_SIZE,
    OBSERVED_RADARS,
    PITCH,
    POSITION,
    RADAR_BEARING_COS,
    RADAR_BEARING_SIN,
    RADAR_FEATURES,
    RADAR_HEIGHT,
    RADAR_PRESENT,
    RADAR_RANGE,
    RADAR_THREAT,
    RADAR_VISIBLE,
    RADARS,
    SPEED,
    STEP_FRACTION,
    TERRAIN,
    TERRAIN_ACROSS_M,
    TERRAIN_AHEAD_M,
)
from uav_penetration_env.terminal_kernels import terminal_value

# The compile cache's folder is set by ``compile_cache`` (imported above, before any compiled function).
COMPILE_CACHE_DIR = compile_cache.COMPILE_CACHE_DIR


# DECISION (model.md §8): batches smaller than this run on the calling thread alone (the serial twin
# of a kernel: the same row function in a plain loop). Waking the thread pool costs more than a
# few rows of physics, and on a busy machine a parallel launch waits for a core: beside two busy
# processes on 2 cores the vector env's 256-row step ran 0.41-0.99x its one-thread rate on two
# threads, and a planner's 100 x 5 rollout once 0.76x on an idle machine, while 10 000 rows kept
# 1.26-1.79x in every run (benchmarks/bench_contention.py). Results are the same either way.
SERIAL_BELOW_ROWS = 512


def run_kernel(parallel_kernel, serial_kernel, rows: int, *args, threads: int | None = None) -> None:
    """Call the parallel batch kernel, or its serial twin when ``rows < SERIAL_BELOW_ROWS`` or ``threads == 1``.

    ``threads`` (a model's ``threads=``): the compiled threads of this call; None keeps numba's
    current count (all cores in a main process, one in the harness's workers).
    """
    if rows < SERIAL_BELOW_ROWS or threads == 1:
        serial_kernel(*args)
    else:
        with_threads(threads, parallel_kernel, *args)


def with_threads(threads: int | None, kernel, *args) -> None:
    """Call ``kernel(*args)`` on ``threads`` compiled threads (capped at numba's pool), then restore the count.

    numba's thread count belongs to the calling thread, so a setting here never leaks into other
    code of the process, nor into another Python thread's kernels.
    """
    if threads is None:
        kernel(*args)
        return
    previous = numba.get_num_threads()
    numba.set_num_threads(min(int(threads), numba.config.NUMBA_NUM_THREADS))
    try:
        kernel(*args)
    finally:
        numba.set_num_threads(previous)


def check_threads(threads: object) -> int | None:
    """``threads`` as given to a model or env: None or an integer >= 1.

    Raises:
        ValueError: anything else (a bool, a float, zero, a negative count).
    """
    if threads is None:
        return None
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise ValueError(f"threads: got {threads!r}, expected None or an integer >= 1")
    return int(threads)


def limit_worker_threads(threads: int | None = None) -> int:
    """The compiled threads of an episode: ``threads`` when given, else one per worker process.

    Episodes run in parallel worker processes (joblib/loky, dask); a kernel spreading its batch
    over every core in each of them would oversubscribe the machine, so a worker uses one thread
    unless the user set ``NUMBA_NUM_THREADS``. The main process keeps numba's default (all cores).
    ``threads`` (``uav-bench run --threads``) overrides both, capped at the cores numba knows.
    Where the count is set (a worker, or ``threads`` given), NumPy's and SciPy's BLAS pools get the
    same count (:func:`uav_penetration_env.threads.limit_blas_threads`, model.md §8).

    Returns:
        The thread count now in force.
    """
    import multiprocessing

    from uav_penetration_env.threads import limit_blas_threads

    if threads is not None:
        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
        limit_blas_threads(numba.get_num_threads())
        return numba.get_num_threads()
    in_worker = multiprocessing.parent_process() is not None or (
        multiprocessing.current_process().name != "MainProcess"
    )
    if in_worker:
        if "NUMBA_NUM_THREADS" not in os.environ:
            numba.set_num_threads(1)
        limit_blas_threads(numba.get_num_threads())
    return numba.get_num_threads()


# --- the scenario as typed arrays ---------------------------------------------------------------

class ModelConstants(NamedTuple):
    """The float constants the kernels read (SI units); the field order is that of ``ModelArrays.params``.

    The one list of the constants' names: :func:`pack` lays them out in this order and each
    ``P_*`` index below is its field's position, so a name cannot point at another slot. The
    kernels read the packed vector rather than the tuple because numba's access to a tuple
    argument of this size was measured 2-3x slower per call.
    """

    dt: float  # planning period [s]
    speed_min: float  # [m/s]
    speed_max: float
    dv_max: float  # per-step control limits [m/s], [rad], [rad]
    dheading_max: float
    dpitch_max: float
    pitch_max: float  # [rad]
    grid_x0: float  # terrain grid origin and spacing [m]
    grid_y0: float
    grid_dx: float
    clearance: float  # minimum height above the terrain [m]
    x_min: float  # map bounds [m]
    x_max: float
    y_min: float
    y_max: float
    ceiling: float  # [m]
    mountain_decay: float  # lambda of eq. 6 [1/km^2]
    threat_altitude_scale: float  # s of the terrain threat's fade [m] (1 when there is no fade)
    min_range: float  # [m]
    horizon_scale: float  # sqrt(2 R_eff) [sqrt(m)]
    softness: float  # soft-masking scale [m]
    log_false_alarm: float  # ln P_fa
    snr_ref: float
    tsfc: float  # fuel model (model.md §6.1)
    weight: float
    level_thrust: float
    idle_thrust: float
    max_thrust: float
    potential_per_m: float
    terrain_lo: float  # normalisation bounds (model.md §7)
    terrain_hi: float
    radar_lo: float
    radar_hi: float
    third_lo: float
    third_hi: float
    w_terrain: float  # cost weights
    w_radar: float
    w_third: float
    crash_per_step: float
    max_step_length: float  # [m]
    map_side: float  # the larger map extent [m]


class ModelOptions(NamedTuple):
    """The integer options the kernels read; the field order is that of ``ModelArrays.options``."""

    detection: int  # DETECTION[...]
    masking: int  # MASKING[...]
    fusion: int  # FUSION[...]
    third: int  # THIRD_TERM[...]
    altitude_fade: int  # 1 when the terrain threat fades with height
    max_steps: int  # K_max


def pack(values: ModelConstants | ModelOptions) -> np.ndarray:
    """``values`` as the contiguous vector the kernels index with ``P_*`` (float64) or ``O_*`` (int64)."""
    dtype = np.int64 if isinstance(values, ModelOptions) else np.float64
    return np.array(values, dtype=dtype)


def _param(name: str) -> int:
    return ModelConstants._fields.index(name)


def _option(name: str) -> int:
    return ModelOptions._fields.index(name)


# Indices into ModelArrays.params (float64): module-level integers, which numba compiles as constants.
P_DT = _param("dt")
P_SPEED_MIN = _param("speed_min")
P_SPEED_MAX = _param("speed_max")
P_DV_MAX = _param("dv_max")
P_DHEADING_MAX = _param("dheading_max")
P_DPITCH_MAX = _param("dpitch_max")
P_PITCH_MAX = _param("pitch_max")
P_GRID_X0 = _param("grid_x0")
P_GRID_Y0 = _param("grid_y0")
P_GRID_DX = _param("grid_dx")
P_CLEARANCE = _param("clearance")
P_X_MIN = _param("x_min")
P_X_MAX = _param("x_max")
P_Y_MIN = _param("y_min")
P_Y_MAX = _param("y_max")
P_CEILING = _param("ceiling")
P_MOUNTAIN_DECAY = _param("mountain_decay")
P_THREAT_ALTITUDE_SCALE = _param("threat_altitude_scale")
P_MIN_RANGE = _param("min_range")
P_HORIZON_SCALE = _param("horizon_scale")
P_SOFTNESS = _param("softness")
P_LOG_FALSE_ALARM = _param("log_false_alarm")
P_SNR_REF = _param("snr_ref")
P_TSFC = _param("tsfc")
P_WEIGHT = _param("weight")
P_LEVEL_THRUST = _param("level_thrust")
P_IDLE_THRUST = _param("idle_thrust")
P_MAX_THRUST = _param("max_thrust")
P_POTENTIAL_PER_M = _param("potential_per_m")
P_TERRAIN_LO = _param("terrain_lo")
P_TERRAIN_HI = _param("terrain_hi")
P_RADAR_LO = _param("radar_lo")
P_RADAR_HI = _param("radar_hi")
P_THIRD_LO = _param("third_lo")
P_THIRD_HI = _param("third_hi")
P_W_TERRAIN = _param("w_terrain")
P_W_RADAR = _param("w_radar")
P_W_THIRD = _param("w_third")
P_CRASH_PER_STEP = _param("crash_per_step")
P_MAX_STEP_LENGTH = _param("max_step_length")
P_MAP_SIDE = _param("map_side")
N_PARAMS = len(ModelConstants._fields)

# Indices into ModelArrays.options (int64), and their values.
O_DETECTION = _option("detection")
O_MASKING = _option("masking")
O_FUSION = _option("fusion")
O_THIRD = _option("third")
O_ALTITUDE_FADE = _option("altitude_fade")
O_MAX_STEPS = _option("max_steps")
N_OPTIONS = len(ModelOptions._fields)
DETECTION = {"ratio": 0, "swerling1": 1}
MASKING = {"off": 0, "hard": 1, "soft": 2}
FUSION = {"max": 0, "or": 1}
THIRD_TERM = {"fuel": 0, "length": 1}

# Columns of the transition kernel's scalar output (B, N_SCALARS).
(
    S_J,
    S_PENALTY,
    S_TERRAIN,
    S_RADAR,
    S_THIRD,
    S_TERRAIN_N,
    S_RADAR_N,
    S_THIRD_N,
    S_FUEL,
    S_GOAL_BEFORE,
    S_GOAL_AFTER,
    S_DETECTION,
    S_ALTITUDE_AGL,
    N_SCALARS,
) = range(14)
# Columns of the transition kernel's flag output (B, N_FLAGS).
F_REACHED, F_COLLIDED, F_OUT_OF_AREA, F_TERMINATED, F_TRUNCATED, N_FLAGS = range(6)

FAR_RANGE_RATIO = 5.0  # observed R / R_ref is capped here; a missing radar reads as this far

RCS_ROWS, RCS_COLUMNS = 181, 361  # elevation -90..90 deg, azimuth -180..180 deg (model.md §5.2)
_DEGREES_PER_RADIAN = 180.0 / math.pi  # numpy's rad2deg multiplies by this constant


class ModelArrays(NamedTuple):
    """Everything the kernels read about a scenario pool (P scenarios, M radar slots, I peaks).

    Attributes:
        terrain: (P, nx, ny) terrain heights [m].
        floors: (L, nx, ny) radar visibility floors [m] (model.md §4.4), one layer per radar.
        radar_xyz: (P, M, 3) radar positions [m].
        radar_present: (P, M) 1/0 presence of each radar slot.
        ref_range: (P, M) reference range R_ref [m].
        ref_rcs: (P, M) reference RCS sigma_ref [m^2].
        floor_layer: (P, M) layer of ``floors`` of each radar (int64).
        mountain_centres: (P, I, 2) peak centres [km].
        mountain_present: (P, I) 1/0 presence of each peak slot.
        goal: (P, 3) goal x, y, radius [m].
        rcs_table: (181, 361) RCS table [dBsm] (model.md §5.2).
        sample_t: (S,) segment sample fractions j/S, j = 1..S (model.md §8).
        params: (N_PARAMS,) float constants, :class:`ModelConstants` packed (indexed by ``P_*``).
        options: (N_OPTIONS,) integer options, :class:`ModelOptions` packed (indexed by ``O_*``).
    """

    terrain: np.ndarray
    floors: np.ndarray
    radar_xyz: np.ndarray
    radar_present: np.ndarray
    ref_range: np.ndarray
    ref_rcs: np.ndarray
    floor_layer: np.ndarray
    mountain_centres: np.ndarray
    mountain_present: np.ndarray
    goal: np.ndarray
    rcs_table: np.ndarray
    sample_t: np.ndarray
    params: np.ndarray
    options: np.ndarray


# --- scalar physics --------------------------------------------------------------------------------


@njit(inline="always", cache=True)
def clip(value, low, high):
    """np.clip for one float: min(max(value, low), high)."""
    return min(max(value, low), high)


@njit(inline="always", cache=True)
def wrap_angle(angle):
    """Wrap an angle to (-pi, pi] exactly as ``kinematics.wrap_angle`` (numpy's float remainder)."""
    # Python's float % is numpy's np.mod: fmod moved to the divisor's sign, +0.0 when exact.
    rem = (angle + np.pi) % (2.0 * np.pi)
    wrapped = rem - np.pi
    if wrapped <= -np.pi:
        wrapped += 2.0 * np.pi
    return wrapped


@njit(inline="always", cache=True)
def kinematics(x, y, z, speed, heading, pitch, dv, dheading, dpitch, params):
    """Action-then-move point-mass step (model.md §1, paper eq. 1 corrected, A2); controls clipped."""
    dv = clip(dv, -params[P_DV_MAX], params[P_DV_MAX])
    dheading = clip(dheading, -params[P_DHEADING_MAX], params[P_DHEADING_MAX])
    dpitch = clip(dpitch, -params[P_DPITCH_MAX], params[P_DPITCH_MAX])
    new_speed = clip(speed + dv, params[P_SPEED_MIN], params[P_SPEED_MAX])
    new_heading = wrap_angle(heading + dheading)
    new_pitch = clip(pitch + dpitch, -params[P_PITCH_MAX], params[P_PITCH_MAX])
    step = new_speed * params[P_DT]
    horizontal = step * math.cos(new_pitch)
    return (
        x + horizontal * math.cos(new_heading),
        y + horizontal * math.sin(new_heading),
        z + step * math.sin(new_pitch),
        new_speed,
        new_heading,
        new_pitch,
    )


@njit(inline="always", cache=True)
def grid_value(values, layer, x, y, params):
    """Bilinear value of grid ``values[layer]`` at (x, y) [m], edge values held outside (model.md §2.1)."""
    nx = values.shape[1]
    ny = values.shape[2]
    fi = clip((x - params[P_GRID_X0]) / params[P_GRID_DX], 0.0, nx - 1.0)
    fj = clip((y - params[P_GRID_Y0]) / params[P_GRID_DX], 0.0, ny - 1.0)
    i0 = min(int(fi), nx - 2)
    j0 = min(int(fj), ny - 2)
    ti = fi - i0
    tj = fj - j0
    v00 = values[layer, i0, j0]
    v01 = values[layer, i0, j0 + 1]
    v10 = values[layer, i0 + 1, j0]
    v11 = values[layer, i0 + 1, j0 + 1]
    return (v00 + (v01 - v00) * tj) * (1.0 - ti) + (v10 + (v11 - v10) * tj) * ti


@njit(inline="always", cache=True)
def terrain_threat(arrays, p, x, y, altitude_agl):
    """Th_e = max_i exp(-lambda |p - c_i|^2) (km), faded by exp(-max(z_agl, 0) / s) if set (eq. 6, §3)."""
    params = arrays.params
    x_km = x / 1000.0
    y_km = y / 1000.0
    decay = params[P_MOUNTAIN_DECAY]
    threat = 0.0
    for i in range(arrays.mountain_centres.shape[1]):
        dx = x_km - arrays.mountain_centres[p, i, 0]
        dy = y_km - arrays.mountain_centres[p, i, 1]
        shape = math.exp(-decay * (dx * dx + dy * dy)) * arrays.mountain_present[p, i]
        if i == 0 or shape > threat:
            threat = shape
    if arrays.options[O_ALTITUDE_FADE]:
        threat = threat * math.exp(-max(altitude_agl, 0.0) / params[P_THREAT_ALTITUDE_SCALE])
    return threat


@njit(inline="always", cache=True)
def aspect_angles(ux, uy, uz, cos_h, sin_h, cos_p, sin_p):
    """Body-frame azimuth in (-pi, pi] and elevation of a unit direction (model.md §5.1)."""
    horizontal = ux * cos_h + uy * sin_h
    a = horizontal * cos_p + uz * sin_p
    b = uy * cos_h - ux * sin_h
    c = uz * cos_p - horizontal * sin_p
    az = math.atan2(b, a)
    if az == -np.pi:
        az = np.pi
    el = math.atan2(c, math.hypot(a, b))
    return az, el


@njit(inline="always", cache=True)
def rcs_value(table, az, el):
    """RCS [m^2] at body-frame aspect (az, el), bilinear in dBsm, azimuth wrapped (model.md §5.2)."""
    col = az * _DEGREES_PER_RADIAN + 180.0
    col -= 360.0 * math.floor(col / 360.0)
    row = clip(el * _DEGREES_PER_RADIAN + 90.0, 0.0, 180.0)
    col0 = min(int(col), RCS_COLUMNS - 2)
    row0 = min(int(row), RCS_ROWS - 2)
    frac_col = col - col0
    frac_row = row - row0
    v00 = table[row0, col0]
    v01 = table[row0, col0 + 1]
    v10 = table[row0 + 1, col0]
    v11 = table[row0 + 1, col0 + 1]
    low = v00 + frac_col * (v01 - v00)
    high = v10 + frac_col * (v11 - v10)
    dbsm = low * (1.0 - frac_row) + high * frac_row
    return 10.0 ** (dbsm / 10.0)


@njit(inline="always", cache=True)
def detection_ratio(sigma, ref_rcs, ref_range, distance):
    """D = (sigma / sigma_ref) (R_ref / R)^4 (model.md §4.2)."""
    ratio = ref_range / distance
    ratio = ratio * ratio
    return (sigma / ref_rcs) * (ratio * ratio)


@njit(inline="always", cache=True)
def horizon_range(radar_z, z, params):
    """Radar horizon R_lim = sqrt(2 R_eff) (sqrt(z_m) + sqrt(max(z, 0))) [m] (eq. 12)."""
    return params[P_HORIZON_SCALE] * (math.sqrt(max(radar_z, 0.0)) + math.sqrt(max(z, 0.0)))


@njit(inline="always", cache=True)
def visibility(z, floor, softness):
    """P_vis = logistic((z - V) / s) in its tanh form; the hard step z >= V for s = 0 (model.md §4.4)."""
    if softness <= 0.0:
        return 1.0 if z >= floor else 0.0
    return 0.5 + 0.5 * math.tanh((z - floor) / (2.0 * softness))


@njit(inline="always", cache=True)
def swerling1(ratio, params):
    """Swerling-I P_d = exp(ln P_fa / (1 + SNR_ref D)) (model.md §4.6)."""
    return math.exp(params[P_LOG_FALSE_ALARM] / (1.0 + params[P_SNR_REF] * ratio))


@njit(inline="always", cache=True)
def radar_threat(arrays, p, m, x, y, z, cos_h, sin_h, cos_p, sin_p):
    """Radar ``m``'s threat (D or P_d) and visibility of a UAV at (x, y, z) with the given attitude.

    Model.md §4-5: range (floored at the minimum range), body-frame aspect, RCS, ratio D, the
    horizon and terrain masking; the ``paper`` profile keeps D where it counts (eqs. 11/13: D >= 1
    inside the horizon and, with masking on, in sight; else 0), the ``benchmark`` profile turns it
    into the Swerling-I probability times the visibility. One radar at a time, so a changed radar
    can be re-priced alone (the lattice's incremental rebuild, model.md §7e.2).
    """
    params = arrays.params
    options = arrays.options
    masking = options[O_MASKING]
    softness = params[P_SOFTNESS] if masking == 2 else 0.0
    ox = arrays.radar_xyz[p, m, 0] - x
    oy = arrays.radar_xyz[p, m, 1] - y
    oz = arrays.radar_xyz[p, m, 2] - z
    distance = max(math.sqrt(ox * ox + oy * oy + oz * oz), params[P_MIN_RANGE])
    az, el = aspect_angles(ox / distance, oy / distance, oz / distance, cos_h, sin_h, cos_p, sin_p)
    sigma = rcs_value(arrays.rcs_table, az, el)
    ratio = detection_ratio(sigma, arrays.ref_rcs[p, m], arrays.ref_range[p, m], distance)
    in_horizon = distance <= horizon_range(arrays.radar_xyz[p, m, 2], z, params)
    if masking == 0:
        seen = 1.0 if in_horizon else 0.0
    else:
        floor = grid_value(arrays.floors, arrays.floor_layer[p, m], x, y, params)
        seen = visibility(z, floor, softness)
    seen = seen * arrays.radar_present[p, m]
    if options[O_DETECTION] == 0:
        if ratio >= 1.0 and in_horizon and seen >= 0.5:
            return ratio, seen
        return 0.0, seen
    return seen * swerling1(ratio, params), seen


@njit(inline="always", cache=True)
def radar_threats(arrays, p, x, y, z, heading, pitch, per_radar, visible):
    """Per-radar threat (D or P_d) and visibility into the (M,) rows given; returns P_d of the network.

    Each radar by :func:`radar_threat`; the network's detection is 1 when any D counts (the
    ``paper`` profile, eqs. 11/13) or the largest P_d (the ``benchmark`` profile).
    """
    ratio_detection = arrays.options[O_DETECTION] == 0
    cos_h = math.cos(heading)
    sin_h = math.sin(heading)
    cos_p = math.cos(pitch)
    sin_p = math.sin(pitch)
    detection = 0.0
    for m in range(arrays.radar_xyz.shape[1]):
        threat, seen = radar_threat(arrays, p, m, x, y, z, cos_h, sin_h, cos_p, sin_p)
        visible[m] = seen
        per_radar[m] = threat
        if ratio_detection:
            if threat > 0.0:  # a ratio D >= 1 that counts
                detection = 1.0
        elif m == 0 or threat > detection:
            detection = threat
    return detection


@njit(inline="always", cache=True)
def fuse(per_radar, rule):
    """Network threat: ``max`` (eq. 14, rule 0) or ``or`` = 1 - prod(1 - P_d) (rule 1); 0 with no radar."""
    count = per_radar.shape[0]
    if count == 0:
        return 0.0
    if rule == 1:
        product = 1.0 - per_radar[0]
        for m in range(1, count):
            product = product * (1.0 - per_radar[m])
        return 1.0 - product
    fused = per_radar[0]
    for m in range(1, count):
        if per_radar[m] > fused:
            fused = per_radar[m]
    return fused


@njit(inline="always", cache=True)
def fuel_burned(pitch, params):
    """C_fuel = eta dt clip(T_level + W sin theta, T_idle, T_max) [kg] (model.md §6.1)."""
    thrust = clip(
        params[P_LEVEL_THRUST] + params[P_WEIGHT] * math.sin(pitch),
        params[P_IDLE_THRUST],
        params[P_MAX_THRUST],
    )
    return params[P_TSFC] * params[P_DT] * thrust


@njit(inline="always", cache=True)
def third_term(kind, fuel, step_length, before, after, params):
    """C(k): fuel plus the progress potential, or path length plus progress (model.md §6.2)."""
    change = after - before
    if kind == 1:
        return step_length + change
    return fuel + params[P_POTENTIAL_PER_M] * change


@njit(inline="always", cache=True)
def failure_penalty(failed, k_next, max_steps, per_step):
    """per_step (K_max - k + 1) for a failed step, else 0 (model.md §7a)."""
    if not failed:
        return 0.0
    return per_step * max(max_steps - k_next + 1, 0)


@njit(inline="always", cache=True)
def segment_events(arrays, p, start, end):
    """The events of the segment ``start -> end`` in flight order (model.md §7a).

    The terrain is sampled along the segment (``arrays.sample_t``); the goal counts as reached
    when the segment passes within its radius before any terrain hit; a hit is a collision unless
    the goal came first; leaving the map or the ceiling at ``end`` counts only without either.
    Returns (reached, collided, out_of_area, the terrain height under ``end``).
    """
    params = arrays.params
    sample_t = arrays.sample_t
    samples = sample_t.shape[0]
    dx = end[0] - start[0]
    dy = end[1] - start[1]
    dz = end[2] - start[2]
    clearance = params[P_CLEARANCE]
    first_hit_t = np.inf
    hit = False
    ground = 0.0
    for j in range(samples):
        t = sample_t[j]
        ground = grid_value(arrays.terrain, p, start[0] + t * dx, start[1] + t * dy, params)
        if not hit and start[2] + t * dz < ground + clearance:
            hit = True
            first_hit_t = t
    gx = arrays.goal[p, 0]
    gy = arrays.goal[p, 1]
    radius = arrays.goal[p, 2]
    to_goal_x = gx - start[0]
    to_goal_y = gy - start[1]
    travel_sq = dx * dx + dy * dy
    closest_t = clip((to_goal_x * dx + to_goal_y * dy) / max(travel_sq, 1e-12), 0.0, 1.0)
    miss_x = to_goal_x - closest_t * dx
    miss_y = to_goal_y - closest_t * dy
    reached = (miss_x * miss_x + miss_y * miss_y <= radius * radius) and closest_t < first_hit_t
    collided = hit and not reached
    x = end[0]
    y = end[1]
    z = end[2]
    outside = (
        x < params[P_X_MIN]
        or x > params[P_X_MAX]
        or y < params[P_Y_MIN]
        or y > params[P_Y_MAX]
        or z > params[P_CEILING]
    )
    out_of_area = outside and not reached and not collided
    return reached, collided, out_of_area, ground


@njit(inline="always", cache=True)
def weighted_cost(params, terrain_n, threat_r, third_n):
    """(radar_n, J): the normalised radar term and the weighted cost J of eq. 37 from the normalised terms (model.md §7)."""
    radar_n = (threat_r - params[P_RADAR_LO]) / (params[P_RADAR_HI] - params[P_RADAR_LO])
    cost = params[P_W_TERRAIN] * terrain_n + params[P_W_RADAR] * radar_n + params[P_W_THIRD] * third_n
    return radar_n, cost


@njit(inline="always", cache=True)
def transition(arrays, p, start, end, k_next, per_radar, visible, scalars, flags):
    """Score one transition ``start -> end`` (6-vectors) taken into step ``k_next`` (model.md §7a).

    Events along the segment in flight order, the state threats at ``end``, the third term, the
    normalised weighted cost J and the failure penalty; writes ``scalars`` (N_SCALARS,), ``flags``
    (N_FLAGS,), ``per_radar`` and ``visible`` (M,). Returns J + penalty.
    """
    params = arrays.params
    options = arrays.options
    reached, collided, out_of_area, ground = segment_events(arrays, p, start, end)
    gx = arrays.goal[p, 0]
    gy = arrays.goal[p, 1]
    x = end[0]
    y = end[1]
    z = end[2]
    terminated = reached or collided or out_of_area
    max_steps = options[O_MAX_STEPS]
    truncated = k_next >= max_steps and not terminated

    altitude_agl = z - ground
    threat_e = terrain_threat(arrays, p, x, y, altitude_agl)
    detection = radar_threats(arrays, p, x, y, z, end[4], end[5], per_radar, visible)
    threat_r = fuse(per_radar, options[O_FUSION])

    fuel = fuel_burned(end[5], params)
    before = math.hypot(gx - start[0], gy - start[1])
    after = math.hypot(gx - x, gy - y)
    third = third_term(options[O_THIRD], fuel, end[3] * params[P_DT], before, after, params)

    terrain_n = (threat_e - params[P_TERRAIN_LO]) / (params[P_TERRAIN_HI] - params[P_TERRAIN_LO])
    third_n = (third - params[P_THIRD_LO]) / (params[P_THIRD_HI] - params[P_THIRD_LO])
    radar_n, cost = weighted_cost(params, terrain_n, threat_r, third_n)
    penalty = failure_penalty(collided or out_of_area, k_next, max_steps, params[P_CRASH_PER_STEP])

    scalars[S_J] = cost
    scalars[S_PENALTY] = penalty
    scalars[S_TERRAIN] = threat_e
    scalars[S_RADAR] = threat_r
    scalars[S_THIRD] = third
    scalars[S_TERRAIN_N] = terrain_n
    scalars[S_RADAR_N] = radar_n
    scalars[S_THIRD_N] = third_n
    scalars[S_FUEL] = fuel
    scalars[S_GOAL_BEFORE] = before
    scalars[S_GOAL_AFTER] = after
    scalars[S_DETECTION] = detection
    scalars[S_ALTITUDE_AGL] = altitude_agl
    flags[F_REACHED] = reached
    flags[F_COLLIDED] = collided
    flags[F_OUT_OF_AREA] = out_of_area
    flags[F_TERMINATED] = terminated
    flags[F_TRUNCATED] = truncated
    return cost + penalty


# --- batch kernels ---------------------------------------------------------------------------------


@njit(inline="always", cache=True)
def transition_row(arrays, b, states, moves, moves_are_controls, k_next, index, out):
    """Row ``b`` of :func:`transition_batch`: kinematics (or the given next state), then :func:`transition`.

    ``out``: the outputs ``(next_states, per_radar, visible, scalars, flags)`` of :func:`transition_batch`.
    """
    next_states, per_radar, visible, scalars, flags = out
    s = states[b]
    if moves_are_controls:
        x, y, z, v, h, pt = kinematics(
            s[0], s[1], s[2], s[3], s[4], s[5], moves[b, 0], moves[b, 1], moves[b, 2], arrays.params
        )
        next_states[b, 0] = x
        next_states[b, 1] = y
        next_states[b, 2] = z
        next_states[b, 3] = v
        next_states[b, 4] = h
        next_states[b, 5] = pt
    else:
        for i in range(6):
            next_states[b, i] = moves[b, i]
    transition(arrays, index[b], s, next_states[b], k_next[b], per_radar[b], visible[b], scalars[b], flags[b])


@njit(parallel=True, cache=True)
def transition_batch(arrays, states, moves, moves_are_controls, k_next, index, out):
    """Transitions of a batch (``PenetrationModel.step`` / ``costs``), rows spread over the threads.

    Args:
        arrays: the :class:`ModelArrays`.
        states: (B, 6) states before the step.
        moves: (B, 3) controls when ``moves_are_controls``, else (B, 6) the next states.
        moves_are_controls: fly the controls (``step``) or score the given next states (``costs``).
        k_next: (B,) step index after the transition (int64).
        index: (B,) pool index of each row (int64).
        out: the outputs, written: ``(next_states, per_radar, visible, scalars, flags)``, of shapes
            (B, 6) the next states, (B, M) per-radar threat, (B, M) visibility, (B, N_SCALARS),
            (B, N_FLAGS) bool.
    """
    for b in prange(states.shape[0]):
        transition_row(arrays, b, states, moves, moves_are_controls, k_next, index, out)


@njit(cache=True)
def transition_rows(arrays, states, moves, moves_are_controls, k_next, index, out):
    """:func:`transition_batch` on the calling thread (small batches: a single env's step)."""
    for b in range(states.shape[0]):
        transition_row(arrays, b, states, moves, moves_are_controls, k_next, index, out)


@njit(parallel=True, cache=True)
def rollout_batch(arrays, state, controls, step, discount, terminal, p, total):
    """Discounted window costs of (B, H, 3) control sequences from one state (eq. 37, model.md §7-8).

    Each row sums gamma^j (J + penalty) until it terminates or the episode reaches K_max, then adds
    gamma^H times the terminal cost of its end pose (``terminal``, a :class:`terminal_kernels.TerminalCost`:
    none, straight-line or Dubins distance, or the lattice value function; model.md §7e) if it is
    still flying when a window that ends before K_max is over. Writes ``total`` (B,).
    """
    params = arrays.params
    max_steps = arrays.options[O_MAX_STEPS]
    horizon = controls.shape[1]
    steps = max(0, min(horizon, max_steps - step))
    radars = arrays.radar_xyz.shape[1]
    for b in prange(controls.shape[0]):
        current = np.empty(6)
        nxt = np.empty(6)
        per_radar = np.empty(radars)
        visible = np.empty(radars)
        scalars = np.empty(N_SCALARS)
        flags = np.empty(N_FLAGS, dtype=np.bool_)
        for i in range(6):
            current[i] = state[i]
        cost = 0.0
        weight = 1.0
        flying = True
        for j in range(steps):
            x, y, z, v, h, pt = kinematics(
                current[0],
                current[1],
                current[2],
                current[3],
                current[4],
                current[5],
                controls[b, j, 0],
                controls[b, j, 1],
                controls[b, j, 2],
                params,
            )
            nxt[0] = x
            nxt[1] = y
            nxt[2] = z
            nxt[3] = v
            nxt[4] = h
            nxt[5] = pt
            step_cost = transition(arrays, p, current, nxt, step + j + 1, per_radar, visible, scalars, flags)
            cost += weight * step_cost
            for i in range(6):
                current[i] = nxt[i]
            weight *= discount
            if flags[F_TERMINATED]:
                flying = False
                break
        if flying and terminal.kind != 0 and step + horizon < max_steps:
            cost += weight * terminal_value(
                terminal, current[0], current[1], current[4], arrays.goal[p, 0], arrays.goal[p, 1]
            )
        total[b] = cost


@njit(inline="always", cache=True)
def state_threats_row(arrays, b, states, index, per_radar, visible):
    """Row ``b``'s state-only threats: per-radar threat and visibility into their rows; returns (Th_e, P_d, z_agl)."""
    s = states[b]
    p = index[b]
    agl = s[2] - grid_value(arrays.terrain, p, s[0], s[1], arrays.params)
    terrain = terrain_threat(arrays, p, s[0], s[1], agl)
    detection = radar_threats(arrays, p, s[0], s[1], s[2], s[4], s[5], per_radar[b], visible[b])
    return terrain, detection, agl


@njit(cache=True)
def threats_batch(arrays, states, index, terrain, per_radar, visible, detection, altitude_agl):
    """State-only threats of a batch: Th_e (B,), per-radar threat and visibility (B, M), P_d (B,), z_agl (B,)."""
    for b in range(states.shape[0]):
        terrain[b], detection[b], altitude_agl[b] = state_threats_row(arrays, b, states, index, per_radar, visible)


@njit(cache=True)
def reset_observe_rows(
    arrays, rows, states, index, step_fraction, ahead, across, per_radar, visible, scalars, flags, scratch, obs
):  # fmt: skip
    """The rows ``rows`` of full-size arrays as a reset reports them, observed: the vector env's autoresets.

    Each row gets the state-only quantities of :func:`threats_batch` (``scalars``' ``S_TERRAIN``,
    ``S_RADAR`` fused by :func:`fuse`, ``S_DETECTION``, ``S_ALTITUDE_AGL``; ``per_radar`` and
    ``visible``), 0 in the transition's columns (J, penalty, the third term, the normalised terms,
    fuel), no event flag, and its observation (:func:`observe_row` with those per-radar arrays and
    ``step_fraction``). ``S_GOAL_BEFORE`` / ``S_GOAL_AFTER`` are left for the caller (numpy's
    ``hypot``, as ``PenetrationModel.goal_distance``). Shapes as in :func:`step_observe_batch`.
    """
    fusion = arrays.options[O_FUSION]
    for i in range(rows.shape[0]):
        b = rows[i]
        terrain, detection, agl = state_threats_row(arrays, b, states, index, per_radar, visible)
        for column in (S_J, S_PENALTY, S_THIRD, S_TERRAIN_N, S_RADAR_N, S_THIRD_N, S_FUEL):
            scalars[b, column] = 0.0
        scalars[b, S_TERRAIN] = terrain
        scalars[b, S_RADAR] = fuse(per_radar[b], fusion)
        scalars[b, S_DETECTION] = detection
        scalars[b, S_ALTITUDE_AGL] = agl
        for f in range(N_FLAGS):
            flags[b, f] = False
        observe_row(arrays, b, states, step_fraction, index, per_radar, visible, ahead, across, scratch, obs)


@njit(cache=True)
def heights_batch(arrays, x, y, index, out):
    """Terrain height [m] at points (x, y) [m] of pool scenario ``index`` (all (N,))."""
    for n in range(x.shape[0]):
        out[n] = grid_value(arrays.terrain, index[n], x[n], y[n], arrays.params)


def observe_scratch_width(radars: int) -> int:
    """Columns of the float64 scratch :func:`observe_row` works in: the observation, then 2 per radar slot."""
    return OBSERVATION_SIZE + 2 * radars


@njit(inline="always", cache=True)
def terrain_ahead(terrain, p, x, y, z, cos_h, sin_h, ahead, across, params, obs):
    """The observation's terrain slots: 5 x 5 samples on a heading-aligned grid (ahead-major, across = to the left)."""
    for a in range(ahead.shape[0]):
        for c in range(across.shape[0]):
            px = x + ahead[a] * cos_h - across[c] * sin_h
            py = y + ahead[a] * sin_h + across[c] * cos_h
            height = grid_value(terrain, p, px, py, params)
            obs[TERRAIN + a * across.shape[0] + c] = (height - z) / 1000.0


@njit(inline="always", cache=True)
def observe_row(arrays, b, states, step_fraction, index, per_radar, visible, ahead, across, scratch, out):
    """Row ``b`` of :func:`observe_batch`; ``scratch[b]`` (:func:`observe_scratch_width` floats) is its work space.

    The work space is handed in rather than allocated here: three small heap allocations per row
    cost about a fifth of the row's observation.
    """
    params = arrays.params
    ratio_detection = arrays.options[O_DETECTION] == 0
    radars = arrays.radar_xyz.shape[1]
    x_span = params[P_X_MAX] - params[P_X_MIN]
    y_span = params[P_Y_MAX] - params[P_Y_MIN]
    side = params[P_MAP_SIDE]
    work = scratch[b]
    obs = work[:OBSERVATION_SIZE]
    obs[:] = 0.0
    p = index[b]
    x = states[b, 0]
    y = states[b, 1]
    z = states[b, 2]
    heading = states[b, 4]
    cos_h = math.cos(heading)
    sin_h = math.sin(heading)
    ground = grid_value(arrays.terrain, p, x, y, params)
    obs[POSITION] = (x - params[P_X_MIN]) / x_span
    obs[POSITION + 1] = (y - params[P_Y_MIN]) / y_span
    obs[ALTITUDE_AGL] = (z - ground) / 1000.0
    obs[ALTITUDE_CEILING] = z / params[P_CEILING]
    obs[SPEED] = (states[b, 3] - params[P_SPEED_MIN]) / (params[P_SPEED_MAX] - params[P_SPEED_MIN])
    obs[HEADING] = cos_h
    obs[HEADING + 1] = sin_h
    obs[PITCH] = states[b, 5] / params[P_PITCH_MAX]
    gx = arrays.goal[p, 0] - x
    gy = arrays.goal[p, 1] - y
    obs[GOAL_OFFSET] = gx / side
    obs[GOAL_OFFSET + 1] = gy / side
    obs[GOAL_DISTANCE] = math.hypot(gx, gy) / side
    relative = math.atan2(gy, gx) - heading
    obs[GOAL_BEARING] = math.cos(relative)
    obs[GOAL_BEARING + 1] = math.sin(relative)
    terrain_ahead(arrays.terrain, p, x, y, z, cos_h, sin_h, ahead, across, params, obs)
    # The nearest radars (stable order by range; absent slots last), 7 features each.
    distance = work[OBSERVATION_SIZE : OBSERVATION_SIZE + radars]
    taken = work[OBSERVATION_SIZE + radars : OBSERVATION_SIZE + 2 * radars]  # 1.0 once a slot is listed
    taken[:] = 0.0
    for m in range(radars):
        ox = arrays.radar_xyz[p, m, 0] - x
        oy = arrays.radar_xyz[p, m, 1] - y
        oz = arrays.radar_xyz[p, m, 2] - z
        distance[m] = math.sqrt(ox * ox + oy * oy + oz * oz) if arrays.radar_present[p, m] > 0 else np.inf
    for slot in range(OBSERVED_RADARS):
        base = RADARS + slot * RADAR_FEATURES
        obs[base + RADAR_RANGE] = FAR_RANGE_RATIO
        best = -1
        for m in range(radars):
            if taken[m] == 0.0 and (best < 0 or distance[m] < distance[best]):
                best = m
        if best < 0:
            continue
        taken[best] = 1.0
        if not arrays.radar_present[p, best] > 0:
            continue
        ox = arrays.radar_xyz[p, best, 0] - x
        oy = arrays.radar_xyz[p, best, 1] - y
        bearing = math.atan2(oy, ox) - heading
        threat = per_radar[b, best]
        if ratio_detection:
            threat = min(threat, 1.0)
        obs[base + RADAR_PRESENT] = arrays.radar_present[p, best]
        obs[base + RADAR_RANGE] = min(distance[best] / arrays.ref_range[p, best], FAR_RANGE_RATIO)
        obs[base + RADAR_BEARING_COS] = math.cos(bearing)
        obs[base + RADAR_BEARING_SIN] = math.sin(bearing)
        obs[base + RADAR_HEIGHT] = (arrays.radar_xyz[p, best, 2] - z) / 1000.0
        obs[base + RADAR_VISIBLE] = visible[b, best]
        obs[base + RADAR_THREAT] = threat
    obs[STEP_FRACTION] = step_fraction[b]
    for i in range(OBSERVATION_SIZE):
        out[b, i] = clip(obs[i], -OBSERVATION_LIMIT, OBSERVATION_LIMIT)


@njit(parallel=True, cache=True)
def observe_batch(arrays, states, step_fraction, index, per_radar, visible, ahead, across, scratch, out):
    """The 67-slot observation of model.md §7a, clipped to +-10, into ``out`` (B, 67) float32.

    ``per_radar`` / ``visible`` (B, M) are the threat and visibility of each radar at the state;
    ``step_fraction`` (B,) is k / K_max; ``ahead`` / ``across`` (5,) the terrain sample offsets [m];
    ``scratch`` (B, :func:`observe_scratch_width`) float64 work space. Rows are spread over the threads.
    """
    for b in prange(states.shape[0]):
        observe_row(arrays, b, states, step_fraction, index, per_radar, visible, ahead, across, scratch, out)


@njit(cache=True)
def observe_rows(arrays, states, step_fraction, index, per_radar, visible, ahead, across, scratch, out):
    """:func:`observe_batch` on the calling thread (small batches)."""
    for b in range(states.shape[0]):
        observe_row(arrays, b, states, step_fraction, index, per_radar, visible, ahead, across, scratch, out)


@njit(inline="always", cache=True)
def step_observe_row(
    arrays, b, states, controls, k_next, index, step_fraction, ahead, across,
    next_states, per_radar, visible, scalars, flags, scratch, obs,
):  # fmt: skip
    """Row ``b`` of :func:`step_observe_batch`: :func:`transition_row` flying the controls, then :func:`observe_row`."""
    transition_row(arrays, b, states, controls, True, k_next, index, (next_states, per_radar, visible, scalars, flags))
    observe_row(arrays, b, next_states, step_fraction, index, per_radar, visible, ahead, across, scratch, obs)


@njit(parallel=True, cache=True)
def step_observe_batch(
    arrays, rows, states, controls, k_next, index, step_fraction, ahead, across,
    next_states, per_radar, visible, scalars, flags, scratch, obs,
):  # fmt: skip
    """The vector env's step of the rows ``rows`` in one pass: fly, score, observe (rows over the threads).

    The numbers of :func:`transition_batch` followed by :func:`observe_batch` on the new states
    with the transition's per-radar arrays, computed row by row in one kernel (one call, each
    row's data touched once). Every array but ``rows`` is full size (N rows); only the rows listed
    are read and written.

    Args:
        arrays: the :class:`ModelArrays`.
        rows: (B,) the rows to step (int64).
        states: (N, 6) states before the step.
        controls: (N, 3) controls (clipped to the action box).
        k_next: (N,) step index after the transition (int64).
        index: (N,) pool index of each row (int64).
        step_fraction: (N,) k_next / K_max.
        ahead: (5,) the observation's terrain sample offsets ahead [m].
        across: (5,) the offsets across, positive to the left [m].
        next_states: (N, 6) out: the next states.
        per_radar: (N, M) out: per-radar threat.
        visible: (N, M) out: visibility.
        scalars: (N, N_SCALARS) out.
        flags: (N, N_FLAGS) out (bool).
        scratch: (N, :func:`observe_scratch_width`) float64 work space.
        obs: (N, 67) float32 out: the observations of the new states.
    """
    for i in prange(rows.shape[0]):
        step_observe_row(
            arrays, rows[i], states, controls, k_next, index, step_fraction, ahead, across,
            next_states, per_radar, visible, scalars, flags, scratch, obs,
        )  # fmt: skip


@njit(cache=True)
def step_observe_rows(
    arrays, rows, states, controls, k_next, index, step_fraction, ahead, across,
    next_states, per_radar, visible, scalars, flags, scratch, obs,
):  # fmt: skip
    """:func:`step_observe_batch` on the calling thread."""
    for i in range(rows.shape[0]):
        step_observe_row(
            arrays, rows[i], states, controls, k_next, index, step_fraction, ahead, across,
            next_states, per_radar, visible, scalars, flags, scratch, obs,
        )  # fmt: skip


@njit(cache=True)
def fuse_rows(per_radar, rule, out):
    """Network threat of each row of ``per_radar`` (B, M) into ``out`` (B,) (:func:`fuse`)."""
    for b in range(per_radar.shape[0]):
        out[b] = fuse(per_radar[b], rule)


@vectorize(["float64(float64)"], cache=True)
def wrap_angles(angle):
    """:func:`wrap_angle` as a ufunc (any shape)."""
    return wrap_angle(angle)


# --- one env step or reset in one call (the single env's hot path) ---------------------------------


@njit(cache=True)
def env_step_one(
    arrays, action, high, states, step_index, index, next_states, per_radar, visible, scalars, flags, obs
):
    """A single env's step in one compiled call: check and clip the action, fly it, observe.

    One call instead of three because a call's fixed cost (about 9 us, mostly unpacking
    ``arrays``) exceeds a row's physics. ``action`` / ``high`` (3,): the float64 action and the
    action box's upper corner (the action is clipped as ``np.clip`` does on finite values);
    ``step_index``: k before the step; ``obs`` (1, 67) float32 out: the observation of the new
    state (:func:`observe_row` with the transition's per-radar arrays and (k + 1) / K_max). The
    other arguments are those of :func:`transition_rows` for one row.

    Returns:
        False (and nothing written) when the action holds a NaN or infinite entry.
    """
    for i in range(3):
        if not math.isfinite(action[i]):
            return False
    controls = np.empty((1, 3))
    for i in range(3):
        controls[0, i] = clip(action[i], -high[i], high[i])
    k_next = np.empty(1, dtype=np.int64)
    k_next[0] = step_index + 1
    transition_row(arrays, 0, states, controls, True, k_next, index, (next_states, per_radar, visible, scalars, flags))
    fraction = np.empty(1)
    fraction[0] = k_next[0] / float(arrays.options[O_MAX_STEPS])
    scratch = np.empty((1, OBSERVATION_SIZE + 2 * arrays.radar_xyz.shape[1]))
    observe_row(
        arrays, 0, next_states, fraction, index, per_radar, visible, TERRAIN_AHEAD_M, TERRAIN_ACROSS_M,
        scratch, obs,
    )  # fmt: skip
    return True


@njit(cache=True)
def env_reset_one(arrays, states, step_index, index, per_radar, visible, obs):
    """A single env's reset (or ``set_state``) in one compiled call: :func:`threats_batch`, then observe.

    ``states`` (1, 6); ``step_index``: k; ``per_radar`` / ``visible`` (1, M) out as in
    :func:`threats_batch`; ``obs`` (1, 67) float32 out: the observation with the state's own
    per-radar arrays and k / K_max.

    Returns:
        (terrain threat Th_e, fused radar threat Th_r (:func:`fuse`), detection probability,
        altitude above the terrain [m]) of the state.
    """
    terrain = np.empty(1)
    detection = np.empty(1)
    altitude_agl = np.empty(1)
    threats_batch(arrays, states, index, terrain, per_radar, visible, detection, altitude_agl)
    fraction = np.empty(1)
    fraction[0] = step_index / float(arrays.options[O_MAX_STEPS])
    scratch = np.empty((1, OBSERVATION_SIZE + 2 * arrays.radar_xyz.shape[1]))
    observe_row(
        arrays, 0, states, fraction, index, per_radar, visible, TERRAIN_AHEAD_M, TERRAIN_ACROSS_M,
        scratch, obs,
    )  # fmt: skip
    return terrain[0], fuse(per_radar[0], arrays.options[O_FUSION]), detection[0], altitude_agl[0]
