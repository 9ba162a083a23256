"""The source distribution carries the tests, the docs and the examples (docs/guide.md, Installing)."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.slow
def test_the_sdist_carries_tests_docs_and_examples_but_not_the_leaderboards(tmp_path):
    pytest.importorskip("build", reason="python -m build needs the build package: pip install build")
    # A clean copy: setuptools adds the files an existing *.egg-info/SOURCES.txt lists (an editable
    # install writes one), which would hide a missing MANIFEST.in line.
    source = tmp_path / "source"
    ignore = shutil.ignore_patterns(
        ".git", ".venv*", "*.egg-info", "leaderboards", "site", "results", "__pycache__"
    )
    shutil.copytree(ROOT, source, ignore=ignore)
    (source / "leaderboards").mkdir()
    (source / "leaderboards" / "README.md").write_text("published outputs\n")  # to be left out
    subprocess.run(
        [sys.executable, "-m", "build", "--sdist", "--outdir", str(tmp_path), str(source)],
        check=True,
        capture_output=True,
    )
    (tarball,) = tmp_path.glob("uav_penetration-*.tar.gz")
    with tarfile.open(tarball) as archive:
        names = {name.split("/", 1)[1] for name in archive.getnames() if "/" in name}
    for member in ("tests/conftest.py", "tests/harness/test_blackbox.py", "docs/blackbox.md", "docs/index.md",
                   "mkdocs.yml", "examples/random_search.py", "examples/nevergrad_de.py",
                   "docs/hooks/docs_hooks.py", "uav_penetration_env/benchmark/blackbox/problems.py"):  # fmt: skip
        assert member in names, member
    assert not any(name.startswith("leaderboards/") for name in names)
    assert not any("__pycache__" in name or name.endswith(".pyc") for name in names)
