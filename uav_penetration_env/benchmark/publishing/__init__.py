"""The publishing helpers: the results page, the headline numbers, the terminal-cost table.

Each module has a ``main(argv)``; the thin scripts ``benchmarks/results_page.py``,
``benchmarks/headline.py`` and ``benchmarks/terminal_cost_table.py`` call it (the commands
docs/publishing.md and the campaign files name). The env pages' generator reads the RL extra's
action wrapper, so it is a docs build script (``docs/hooks/env_pages.py``), not part of the harness.
"""

from __future__ import annotations

from pathlib import Path


def repository() -> Path:
    """The checkout whose files the helpers read and write by default (``leaderboards/``, ``docs/``, ``README.md``).

    DECISION (docs/publishing.md §4, default folders): the source checkout this package was imported
    from when it is one (an editable install, or ``PYTHONPATH`` at a checkout), so the scripts work
    from any folder as before; else the current folder.
    """
    here = Path(__file__).resolve().parents[3]
    return here if (here / "pyproject.toml").is_file() and (here / "leaderboards").is_dir() else Path.cwd()
