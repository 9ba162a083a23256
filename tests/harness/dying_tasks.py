"""Plain tasks for the worker-pool tests, light to import: a negative one ends its worker process."""

from __future__ import annotations

import os
import time


def fly(task: int) -> tuple[dict, list]:
    """A pool test's episode: a negative task ends its worker (exit code 3), others return their number."""
    if task < 0:
        os._exit(3)
    time.sleep(0.05 * (task % 3))  # finish out of order, as episodes do
    return {"task": task}, []


def died(task: int, reason: str) -> tuple[dict, list]:
    return {"task": task, "died": reason}, []
