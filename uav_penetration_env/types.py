"""Type aliases and codes shared by the pure physics modules, importable without the compiled code."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

# The terminal-cost forms of an MPC window (model.md §7e) and their codes in the compiled kernels
# (terminal_kernels.py): here, so that the MPC settings and the CLI can name them without loading numba.
TERMINAL_FORMS = {"none": 0, "distance": 1, "dubins": 2, "value": 3}
