"""Radar cross section (RCS) of a small fixed-wing UAV as seen by each radar (model.md §5).

The paper (Luo, Liang & Li 2022) makes the radar threat depend on the UAV's aspect towards each
radar but publishes no RCS data (model.md §10, A21). This package supplies, as pure batched numpy,
one idea per module:

* ``grid``: the 1° table layout ``σ_dBsm[el, az]`` (model.md §5.2);
* ``lookup``: the body-frame aspect angles of the radars (§5.1) and the bilinear-in-dB lookup on
  the planner's hot path (§8): all the model needs at run time;
* ``airframe``: physical-optics primitives (flat plate, finite cylinder, hemispherical cap) and
  their incoherent sum for a generic small fixed-wing UAV (§5.3);
* ``table``: the offline build of the table, power-averaged over each cell, and the constant
  table (model ``constant``);
* ``table_file``: the loader of user tables (model ``table``, §5.4).

Angles are in radians unless a name ends in ``_deg``; areas in m²; tables in dBsm. Every public
name is re-exported here (``from uav_penetration_env import rcs; rcs.rcs_lookup(...)``).
"""

from __future__ import annotations

from uav_penetration_env.rcs.airframe import (
    SPEED_OF_LIGHT_M_S,
    AirframeRCS,
    Cap,
    Cylinder,
    Plate,
    Vector3,
    airframe_rcs,
    cap_rcs,
    cylinder_rcs,
    plate_rcs,
)
from uav_penetration_env.rcs.grid import TABLE_AZ_DEG, TABLE_EL_DEG, TABLE_SHAPE
from uav_penetration_env.rcs.lookup import aspect_angles, direction_from_aspect, rcs_lookup
from uav_penetration_env.rcs.table import build_rcs_table, constant_rcs_table
from uav_penetration_env.rcs.table_file import load_rcs_table

__all__ = [
    "SPEED_OF_LIGHT_M_S",
    "TABLE_AZ_DEG",
    "TABLE_EL_DEG",
    "TABLE_SHAPE",
    "AirframeRCS",
    "Cap",
    "Cylinder",
    "Plate",
    "Vector3",
    "airframe_rcs",
    "aspect_angles",
    "build_rcs_table",
    "cap_rcs",
    "constant_rcs_table",
    "cylinder_rcs",
    "direction_from_aspect",
    "load_rcs_table",
    "plate_rcs",
    "rcs_lookup",
]
