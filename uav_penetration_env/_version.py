"""The package version: a leaf module, so modules inside the package can read it without importing it.

``pyproject.toml`` reads the version from here (``[tool.setuptools.dynamic]``), so it is written once.
"""

from __future__ import annotations

__version__ = "0.2.0"


def installed_versions(names: tuple[str, ...]) -> dict[str, str]:
    """Python's version and each named distribution's (``"not installed"`` when absent), in that order.

    What a recorded result's numbers depend on (best-known records, suite fingerprints).
    """
    import platform
    from importlib import metadata

    versions = {"python": platform.python_version()}
    for name in names:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions
