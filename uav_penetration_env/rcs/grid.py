"""The RCS table's grid: 1° steps of body-frame elevation (rows) and azimuth (columns) (model.md §5.2).

Shared by the table's producers (``table``, ``table_file``) and its reader (``lookup``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["TABLE_AZ_DEG", "TABLE_EL_DEG", "TABLE_SHAPE"]

TABLE_EL_DEG = np.arange(-90.0, 91.0)  # [deg] table rows, el = −90…90 step 1°
TABLE_AZ_DEG = np.arange(-180.0, 181.0)  # [deg] table columns, az = −180…180 step 1° (last == first)
TABLE_EL_DEG.setflags(write=False)
TABLE_AZ_DEG.setflags(write=False)
TABLE_SHAPE = (TABLE_EL_DEG.size, TABLE_AZ_DEG.size)  # (181, 361)
