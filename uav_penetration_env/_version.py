"""The package version: a leaf module, so modules inside the package can read it without importing it.

``pyproject.toml`` reads the version from here (``[tool.setuptools.dynamic]``), so it is written once.
"""

from __future__ import annotations

__version__ = "0.2.0"
