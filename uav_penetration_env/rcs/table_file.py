"""User RCS tables read from a file (UAV model ``table``, model.md §5.4): CSV or ``.npy``, checked node by node."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from uav_penetration_env.rcs.grid import TABLE_AZ_DEG, TABLE_EL_DEG, TABLE_SHAPE
from uav_penetration_env.types import FloatArray

__all__ = ["load_rcs_table"]

_N_EL, _N_AZ = TABLE_SHAPE
_CSV_COLUMNS = ("el_deg", "az_deg", "rcs_dbsm")
# DECISION: a user table may give az = −180° and +180° or only one of them (the other is the same
# direction and is copied); when both are given they must agree to this tolerance [dB].
_SEAM_TOL_DB = 1e-6


def _check_table(table: FloatArray, source: str) -> FloatArray:
    if table.shape != TABLE_SHAPE:
        raise ValueError(
            f"{source}: got a table of shape {table.shape}, expected {TABLE_SHAPE} "
            "(el = -90..90 deg in rows, az = -180..180 deg in columns, step 1 deg)"
        )
    bad = ~np.isfinite(table)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise ValueError(
            f"{source}: {int(bad.sum())} non-finite RCS values (first at el={TABLE_EL_DEG[i]:.0f} deg, "
            f"az={TABLE_AZ_DEG[j]:.0f} deg), expected finite dBsm values"
        )
    seam = np.abs(table[:, -1] - table[:, 0])
    if seam.max() > _SEAM_TOL_DB:
        i = int(np.argmax(seam))
        raise ValueError(
            f"{source}: az=-180 and az=+180 deg differ by {seam[i]:.6g} dB at el={TABLE_EL_DEG[i]:.0f} deg, "
            "expected equal values (the same direction)"
        )
    return table


def _load_csv_table(path: Path) -> FloatArray:
    source = str(path)
    with path.open(newline="") as handle:
        header = [name.strip() for name in handle.readline().split(",")]
    missing = [name for name in _CSV_COLUMNS if name not in header]
    if missing:
        raise ValueError(
            f"{source}: missing column(s) {', '.join(missing)} in header {header}, "
            f"expected columns {', '.join(_CSV_COLUMNS)}"
        )
    try:
        data = np.loadtxt(
            path, delimiter=",", skiprows=1, usecols=[header.index(n) for n in _CSV_COLUMNS], ndmin=2
        )
    except ValueError as error:
        raise ValueError(f"{source}: unreadable row ({error}), expected numbers in every column") from error
    el, az, rcs = data.T
    off_grid = ~((el == np.round(el)) & (az == np.round(az)) & (np.abs(el) <= 90) & (np.abs(az) <= 180))
    if off_grid.any():
        k = int(np.argmax(off_grid))
        raise ValueError(
            f"{source}: row {k + 2} has el={el[k]:g}, az={az[k]:g} deg off the table grid, expected "
            "integer degrees with -90 <= el <= 90 and -180 <= az <= 180"
        )
    if not np.isfinite(rcs).all():
        k = int(np.argmin(np.isfinite(rcs)))
        raise ValueError(
            f"{source}: row {k + 2} has a non-finite rcs_dbsm ({rcs[k]}), expected a finite dBsm value"
        )
    flat = (el.astype(np.int64) + 90) * _N_AZ + (az.astype(np.int64) + 180)
    counts = np.bincount(flat, minlength=_N_EL * _N_AZ).reshape(TABLE_SHAPE)
    if (counts > 1).any():
        i, j = np.argwhere(counts > 1)[0]
        raise ValueError(
            f"{source}: {int((counts > 1).sum())} duplicated grid node(s) (first el={TABLE_EL_DEG[i]:.0f}, "
            f"az={TABLE_AZ_DEG[j]:.0f} deg), expected each (el, az) once"
        )
    table = np.full(TABLE_SHAPE, np.nan)
    table.flat[flat] = rcs
    seam_missing = counts[:, 0] == 0
    table[seam_missing, 0] = table[seam_missing, -1]
    seam_missing = counts[:, -1] == 0
    table[seam_missing, -1] = table[seam_missing, 0]
    missing_nodes = np.isnan(table)
    if missing_nodes.any():
        i, j = np.argwhere(missing_nodes)[0]
        raise ValueError(
            f"{source}: {int(missing_nodes.sum())} grid node(s) missing (first el={TABLE_EL_DEG[i]:.0f}, "
            f"az={TABLE_AZ_DEG[j]:.0f} deg), expected every el = -90..90 and az = -180..180 deg "
            "in 1 deg steps (az=+180 may be omitted)"
        )
    return _check_table(table, source)


def load_rcs_table(path: str | os.PathLike[str]) -> FloatArray:
    """Load a user RCS table (UAV model ``table``, model.md §5.4).

    Accepted formats:

    * ``.csv`` with a header naming the columns ``el_deg``, ``az_deg`` and ``rcs_dbsm`` (any order,
      other columns ignored) and one row per node of the 1° grid, el = −90…90°, az = −180…180°
      (az = +180° or −180° may be omitted: it is the same direction as the other);
    * ``.npy`` holding a (181, 361) array in dBsm laid out like `build_rcs_table`.

    Angles are body-frame az/el as in `aspect_angles`; measured data in other conventions must be
    converted first.

    Args:
        path: The file.

    Returns:
        (181, 361) RCS table [dBsm].

    Raises:
        FileNotFoundError: If the file does not exist.
        ValueError: If the format, columns, grid coverage or values are wrong; the message names the
            file, the problem and what was expected.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such RCS table file")
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return _load_csv_table(path)
    if suffix == ".npy":
        try:
            table = np.load(path, allow_pickle=False)
        except ValueError as error:
            raise ValueError(f"{path}: not a plain numeric .npy array ({error})") from error
        if not np.issubdtype(table.dtype, np.number):
            raise ValueError(f"{path}: got an array of dtype {table.dtype}, expected numbers in dBsm")
        return _check_table(np.asarray(table, dtype=np.float64), str(path))
    raise ValueError(f"{path}: unsupported file type {path.suffix!r}, expected .csv or .npy")
