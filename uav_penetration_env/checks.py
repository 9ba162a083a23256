"""Argument checks of the model's public entry points: cheap, and naming argument, value and domain.

The compiled kernels trust their inputs: a NaN coordinate becomes an arbitrary grid index there,
and a step index past K_max a wrong penalty. So every public method of
:class:`~uav_penetration_env.model.PenetrationModel` passes its arguments through these helpers
first (api.md §2.4), and a value outside its domain raises ``ValueError`` (``TypeError`` for an
object that is no number at all) whose message starts with the argument's name, gives the value
(or the offending entry) and says what was expected. They cost a few microseconds per call
(``benchmarks/bench_checks.py`` measures them); the finiteness and range tests are compiled
loops, since ``np.isfinite(a).all()`` alone costs about 1.5 us on a six-number array.
"""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np
from numba import njit

from uav_penetration_env import compile_cache, kernels  # noqa: F401  (numba's cache folder first, then the compiled physics)


@njit(cache=True)
def _all_finite(flat: np.ndarray) -> bool:  # pragma: no cover - compiled
    """Whether every entry of a 1-D float64 array is finite (x - x is NaN for NaN and +-inf)."""
    for i in range(flat.size):
        value = flat[i]
        if value - value != 0.0:
            return False
    return True


@njit(cache=True)
def _all_within(flat: np.ndarray, low: int, high: int) -> bool:  # pragma: no cover - compiled
    """Whether every entry of a 1-D int64 array lies in [low, high]."""
    for i in range(flat.size):
        if flat[i] < low or flat[i] > high:
            return False
    return True


def all_finite(array: np.ndarray) -> bool:
    """Whether a contiguous float64 array has no NaN or infinite entry (compiled: < 1 us for small ones)."""
    return bool(_all_finite(array.reshape(-1)))


def _first_bad(array: np.ndarray) -> str:
    """``[i, j]=value`` of the first non-finite entry, for the message."""
    where = np.argwhere(~np.isfinite(array))[0]
    position = ", ".join(str(int(i)) for i in where)
    return f"[{position}]={array[tuple(where)]!r}"


def as_float_array(value: Any, name: str, expected: str) -> np.ndarray:
    """``value`` as a contiguous float64 array, or ``TypeError``/``ValueError`` naming ``name``."""
    if isinstance(value, np.ndarray) and value.dtype == np.float64 and value.flags.c_contiguous:
        return value  # the hot path: no copy, no conversion
    if isinstance(value, (str, bytes)) or value is None:
        raise TypeError(f"{name}: got {value!r}, expected {expected}")
    if np.iscomplexobj(value):  # numpy would drop the imaginary part with only a warning
        raise TypeError(f"{name}: got complex values, expected {expected} (real numbers)")
    try:
        array = np.asarray(value, dtype=np.float64)  # not ascontiguousarray: it makes 0-d arrays 1-d
        return array if array.flags.c_contiguous else np.ascontiguousarray(array)
    except (TypeError, ValueError) as error:
        raise TypeError(f"{name}: got {value!r} ({error}), expected {expected}") from None


def finite_array(value: Any, name: str, shape: tuple[int | None, ...], expected: str) -> np.ndarray:
    """A finite float64 array of ``shape`` (``None``: any length on that axis).

    Raises:
        TypeError: not numbers.
        ValueError: the wrong shape, or a NaN or infinite entry (named by its position).
    """
    array = as_float_array(value, name, expected)
    if array.ndim != len(shape):
        raise ValueError(f"{name}: got shape {array.shape}, expected {expected}")
    for wanted, got in zip(shape, array.shape, strict=True):  # a plain loop: cheaper than any(...)
        if wanted is not None and wanted != got:
            raise ValueError(f"{name}: got shape {array.shape}, expected {expected}")
    if not _all_finite(array.reshape(-1)):
        raise ValueError(f"{name}: got a non-finite entry {name}{_first_bad(array)}, expected {expected}")
    return array


def integer_array(value: Any, name: str, batch: int, low: int, high: int, expected: str) -> np.ndarray:
    """``value`` (a scalar or ``(batch,)``) as contiguous int64 ``(batch,)``, each in ``[low, high]``.

    Raises:
        TypeError: not integers (a float, even 2.0, a bool, a string).
        ValueError: another length, or a value outside ``[low, high]``.
    """
    if type(value) is int or (
        isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))
    ):
        if not low <= value <= high:
            raise ValueError(f"{name}: got {value!r}, expected {expected}")
        return np.full(batch, value, dtype=np.int64)
    array = value if isinstance(value, np.ndarray) else np.asarray(value)
    if array.dtype.kind not in "iu":
        raise TypeError(f"{name}: got {value!r}, expected {expected}")
    if array.shape == (batch,):
        rows = array if array.dtype == np.int64 and array.flags.c_contiguous else array.astype(np.int64)
    elif array.ndim == 0:
        rows = np.full(batch, array, dtype=np.int64)
    else:
        raise ValueError(f"{name}: got shape {array.shape}, expected a scalar or ({batch},): {expected}")
    if not _all_within(rows, low, high):
        raise ValueError(f"{name}: got values in [{rows.min()}, {rows.max()}], expected {expected}")
    return rows


def integer_scalar(value: Any, name: str, low: int, high: int, expected: str) -> int:
    """``value`` as an ``int`` in ``[low, high]`` (``TypeError`` for a non-integer, ``ValueError`` outside)."""
    if type(value) is not int and (
        not isinstance(value, numbers.Integral) or isinstance(value, (bool, np.bool_))
    ):
        raise TypeError(f"{name}: got {value!r}, expected {expected}")
    if not low <= value <= high:
        raise ValueError(f"{name}: got {value!r}, expected {expected}")
    return int(value)


def real_scalar(
    value: Any, name: str, low: float, high: float, expected: str, *, open_low: bool = False
) -> float:
    """``value`` as a finite ``float`` in ``[low, high]`` (``(low, high]`` with ``open_low``)."""
    if type(value) is not float and (
        not isinstance(value, numbers.Real) or isinstance(value, (bool, np.bool_))
    ):
        raise TypeError(f"{name}: got {value!r}, expected {expected}")
    number = float(value)
    if not (low < number if open_low else low <= number) or not number <= high:  # NaN fails both
        raise ValueError(f"{name}: got {value!r}, expected {expected}")
    return number
