"""Synthetic swarms for IHPSO's termination test (eq. 33): Gaussian clumps and single clouds.

Moved from the retired study script ``benchmarks/ihpso_mechanisms.py`` (docs/optimizers.md §5),
whose table used the same generators.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

SWARM_SIZE, N_GROUPS = 100, 5
SEPARATION = (
    10.0  # clump centres, in standard deviations of a clump: far enough apart that eq. 33's test must see two
)


def clump_centres(n_clumps: int, dim: int, rng: np.random.Generator) -> np.ndarray:
    """Centres pairwise exactly ``SEPARATION`` apart in a random plane: 2 on a line, 3 an equilateral triangle.

    Returns:
        (n_clumps, dim) centres.
    """
    if n_clumps not in (2, 3):
        raise ValueError(f"n_clumps: got {n_clumps!r}, expected 2 or 3")
    basis, _ = np.linalg.qr(rng.normal(size=(dim, 2)))
    planar = (
        np.array([[-0.5, 0.0], [0.5, 0.0]])
        if n_clumps == 2
        else np.array([[0.0, 0.0], [1.0, 0.0], [0.5, math.sqrt(3) / 2]])
    )
    return SEPARATION * planar @ basis.T


def clumps(sizes: tuple[int, ...], dim: int, rng: np.random.Generator) -> np.ndarray:
    """(sum(sizes), dim) Gaussian clumps (standard deviation 1) around :func:`clump_centres`, shuffled."""
    centres = clump_centres(len(sizes), dim, rng)
    points = np.vstack([c + rng.normal(size=(size, dim)) for c, size in zip(centres, sizes, strict=True)])
    return points[rng.permutation(points.shape[0])]


def cloud(kind: str, dim: int, rng: np.random.Generator) -> np.ndarray:
    """(100, dim) single cloud: ``"uniform"`` in the unit cube or ``"gaussian"``."""
    return rng.random((SWARM_SIZE, dim)) if kind == "uniform" else rng.normal(size=(SWARM_SIZE, dim))


def termination_pass_rate(make: Any, draws: int, seed: int, **test_options: Any) -> float:
    """Share of ``draws`` swarms ``make(rng)`` on which eq. 33 (``termination_test``, G = 5) passes."""
    from optimizers.ihpso import termination_test

    rng = np.random.default_rng(seed)
    return float(np.mean([termination_test(make(rng), N_GROUPS, **test_options) for _ in range(draws)]))
