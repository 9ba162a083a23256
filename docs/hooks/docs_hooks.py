"""MkDocs hooks of the documentation site (``mkdocs.yml``): links that leave ``docs/``.

The pages link to a few files beside ``docs/`` (the README, a leaderboard study); on GitHub those
links work, but the site holds only ``docs/``, so ``mkdocs build --strict`` would refuse them.

DECISION: a link whose target lies outside ``docs/`` and exists in the repository is written on
the site as its text followed by the file's repository path, in code (``README (`README.md` in the
repository)``); a target that does not exist is left alone, so the strict build still reports it
(docs/guide.md, documentation).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

LINK = re.compile(r"(?<!!)\[(?P<text>[^\]]*)\]\((?P<target>[^)\s#]+)(?P<anchor>#[^)\s]*)?\)")
FENCE = re.compile(r"^```.*?^```", re.MULTILINE | re.DOTALL)


def outside_links(markdown: str, page_dir: Path, docs_dir: Path, root: Path) -> str:
    """``markdown`` with each link to an existing file outside ``docs_dir`` replaced by its repository path.

    Args:
        markdown: The page's text.
        page_dir: The folder of the page's source file.
        docs_dir: The site's docs folder.
        root: The repository root (the folder of ``mkdocs.yml``).
    """

    def replace(match: re.Match[str]) -> str:
        target = match["target"]
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):
            return match[0]  # an absolute URL
        resolved = (page_dir / target).resolve()
        if resolved.is_relative_to(docs_dir) or not resolved.exists() or not resolved.is_relative_to(root):
            return match[0]
        return f"{match['text']} (`{resolved.relative_to(root).as_posix()}` in the repository)"

    parts, last = [], 0
    for fence in FENCE.finditer(markdown):  # code blocks are printed as they are
        parts += [LINK.sub(replace, markdown[last : fence.start()]), fence[0]]
        last = fence.end()
    parts.append(LINK.sub(replace, markdown[last:]))
    return "".join(parts)


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """MkDocs hook: rewrite the page's links that leave ``docs/`` (see the module docstring)."""
    docs_dir = Path(config["docs_dir"]).resolve()
    root = Path(config["config_file_path"]).resolve().parent
    page_dir = (docs_dir / page.file.src_uri).parent
    return outside_links(markdown, page_dir, docs_dir, root)
