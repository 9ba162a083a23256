"""The documentation site builds: ``mkdocs build --strict`` over docs/ (extra ``docs``), and its link hook."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.script_modules import load_script

ROOT = Path(__file__).resolve().parent.parent


def load(name: str):
    """The site's build module ``docs/hooks/NAME.py`` (mkdocs loads it by path, not as a package)."""
    return load_script(ROOT / "docs" / "hooks" / f"{name}.py")
DOCS_EXTRA = "the docs site test needs the docs extra: pip install -e '.[docs]'"


def test_the_site_builds_strictly(tmp_path):
    """Every page of the nav renders, every link and anchor resolves, every ``:::`` block finds its object."""
    for module in ("mkdocs", "material", "mkdocstrings", "mkdocstrings_handlers.python"):
        if importlib.util.find_spec(module.split(".")[0]) is None or importlib.util.find_spec(module) is None:
            pytest.skip(DOCS_EXTRA)
    site = tmp_path / "site"
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml"), "-d", str(site)],
        cwd=ROOT, capture_output=True, text=True, timeout=120, env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert (site / "index.html").is_file() and (site / "plugins" / "index.html").is_file()
    reference = (site / "reference" / "optimizers" / "index.html").read_text(encoding="utf-8")
    assert "normalize_bounds" in reference and "register_optimizer" in reference  # docstrings rendered
    # Sphinx roles in docstrings are links where the site documents the object (docs/hooks/docs_roles.py),
    # never literal ":func:<code>x</code>" text
    for page in (site / "reference").glob("*/index.html"):
        text = page.read_text(encoding="utf-8")
        assert not re.search(r":(?:func|class|mod|data|meth|attr):<code>", text), page
    model = (site / "reference" / "model" / "index.html").read_text(encoding="utf-8")
    assert 'href="#uav_penetration_env.model.PenetrationModel.rollout_cost"><code>rollout_cost()</code></a>' in model


def test_links_that_leave_docs_become_repository_paths(tmp_path):
    hooks = load("docs_hooks")
    (tmp_path / "docs" / "envs").mkdir(parents=True)
    (tmp_path / "README.md").write_text("x")
    (tmp_path / "docs" / "model.md").write_text("x")
    markdown = (
        "See the [README](../README.md), [model](model.md#7a), [nowhere](../nowhere.md), "
        "[a site](https://example.org/x.md) and ![a figure](../README.md).\n"
        "```\n[README](../README.md)\n```\n"
    )
    out = hooks.outside_links(markdown, tmp_path / "docs", (tmp_path / "docs").resolve(), tmp_path.resolve())
    assert out.startswith("See the README (`README.md` in the repository), [model](model.md#7a), [nowhere](../nowhere.md), ")
    assert "[a site](https://example.org/x.md)" in out and "![a figure](../README.md)" in out
    assert out.endswith("```\n[README](../README.md)\n```\n")  # code blocks are printed as they are


def test_sphinx_roles_become_optional_cross_references():
    griffe = pytest.importorskip("griffe", reason=DOCS_EXTRA)
    roles = load("docs_roles")  # imports griffe itself
    module = griffe.visit("pkg.mod", filepath=Path("pkg/mod.py"), code="from pkg.other import Thing\n\ndef f():\n    pass\n")
    text = "See :class:`Thing`, :func:`~pkg.other.helper`, :meth:`Thing.run` and :mod:`.sibling`."
    out = roles.rewrite(module["f"], text)
    assert '<autoref identifier="pkg.other.Thing" optional><code>Thing</code></autoref>' in out
    assert '<autoref identifier="pkg.other.helper" optional><code>helper()</code></autoref>' in out
    assert '<autoref identifier="pkg.other.Thing.run" optional><code>Thing.run()</code></autoref>' in out
    assert '<autoref identifier="pkg.sibling" optional><code>sibling</code></autoref>' in out
    assert ":class:" not in out and ":func:" not in out
