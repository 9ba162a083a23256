"""Griffe extension of the documentation site: Sphinx cross-reference roles in docstrings (``mkdocs.yml``).

The docstrings are Google style with Sphinx's roles for cross-references (``:func:`mpc_objective```,
``:class:`~uav_penetration_env.scenario.Scenario```), which ruff's pydocstyle accepts and IDEs
link. mkdocstrings renders docstrings as Markdown, where a role is literal text
(``:func:<code>mpc_objective</code>``). This extension rewrites each role, once the package is
loaded, into an optional autorefs cross-reference: a link to the object where the site documents
it, its name in code elsewhere.

DECISION (docs/guide.md, documentation): the roles stay in the source and become optional
cross-references (``<autoref identifier=... optional>``, the form mkdocstrings itself writes for
signatures), so a reference to an object the API pages do not show is plain code rather than a
warning that fails ``mkdocs build --strict``. A name is resolved in the scope of the object whose
docstring holds it (its module's imports and members, then its parents'); ``~`` shows the last
component only, as in Sphinx; a leading ``.`` is relative to the object's package.
"""

from __future__ import annotations

import html
import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:py:)?(?P<role>func|class|mod|data|meth|attr|exc|obj|const):`(?P<target>[^`]+)`")


def identifier(obj: Any, target: str) -> str:
    """The full dotted path of ``target`` as written in ``obj``'s docstring (best effort: unresolved as written)."""
    if target.startswith("."):  # relative to the object's package, as Sphinx reads a leading dot
        module = obj if obj.is_module else obj.module
        package = module.path if module.is_package else module.path.rsplit(".", 1)[0]
        depth = len(target) - len(target.lstrip("."))
        base = package.rsplit(".", depth - 1)[0] if depth > 1 else package
        return f"{base}.{target.lstrip('.')}"
    first, _, rest = target.partition(".")
    scope = obj
    while scope is not None:
        try:
            resolved = scope.resolve(first)
        except (griffe.NameResolutionError, AttributeError, KeyError):
            scope = scope.parent
            continue
        return f"{resolved}.{rest}" if rest else resolved
    return target


def rewrite(obj: Any, text: str) -> str:
    """``text`` with every Sphinx role replaced by an optional autorefs cross-reference."""

    def replace(match: re.Match[str]) -> str:
        target = match["target"].strip()
        shown = target.lstrip("~")
        title = shown.rsplit(".", 1)[-1] if target.startswith("~") else shown.lstrip(".")
        if match["role"] in ("func", "meth"):
            title += "()"
        path = identifier(obj, shown)
        return (
            f'<autoref identifier="{html.escape(path)}" optional><code>{html.escape(title)}</code></autoref>'
        )

    return ROLE.sub(replace, text)


class SphinxRoles(griffe.Extension):
    """Rewrite the roles of every docstring of a loaded package (module docstring)."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        """Walk the package once it is loaded, so names resolve through every module's members."""
        seen: set[int] = set()

        def visit(obj: Any) -> None:
            if id(obj) in seen or obj.is_alias:
                return
            seen.add(id(obj))
            if obj.docstring is not None and ":" in obj.docstring.value:
                obj.docstring.value = rewrite(obj, obj.docstring.value)
            for member in obj.members.values():
                visit(member)

        visit(pkg)
