"""CPU and wall seconds of one call: the one clock of decision and setup times (api.md §4.12).

DECISION (api.md §4.12): CPU time is the process's (``time.process_time``), which counts the
compiled kernels' helper threads as well as the calling thread; the harness runs one compiled
thread per worker process by default, so in an episode it is the planning thread's time plus
whatever threads the planner itself starts. Wall time (``time.perf_counter``) stands beside it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Clock:
    """CPU and wall seconds of one timed call."""

    cpu: float
    wall: float


def timed(function: Callable[..., Any], *args: Any) -> tuple[Any, Clock]:
    """``function(*args)`` and its :class:`Clock` (process CPU and wall seconds)."""
    cpu, wall = time.process_time(), time.perf_counter()
    result = function(*args)
    return result, Clock(time.process_time() - cpu, time.perf_counter() - wall)


__all__ = ["Clock", "timed"]
