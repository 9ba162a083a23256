"""UAV low-altitude penetration: a Gymnasium environment family and benchmark harness.

The model follows Luo, Liang & Li, "3D path planning for UAV penetration based on improved
holonic PSO" (J. Systems Engineering and Electronics, 2022) with the ambiguities resolved in
the project's model specification.
"""

from __future__ import annotations

__version__ = "0.1.0"
