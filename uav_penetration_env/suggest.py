"""Did-you-mean suggestions for unknown names: one wording and one cut-off for the whole project.

Every "unknown name" error of ``uav_penetration_env`` and ``baselines`` (scenario keys, scenario
names, policies, commands, algorithms) builds its hint here, so the suggestions read the same
everywhere. ``optimizers`` keeps its own copy of this rule because it stands alone and imports
nothing from the environment package (docs/architecture.md).
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

# DECISION: 0.6 is difflib's own default ratio: it suggests 'ihpso' for 'ihspo' and 'radars' for
# 'radar' but not unrelated short names. One cut-off for every kind of name.
CUTOFF = 0.6
MAX_SUGGESTIONS = 3


def close_matches(name: object, known: Iterable[str]) -> list[str]:
    """Up to three known names close to ``name``, best first (difflib's ratio >= 0.6)."""
    return difflib.get_close_matches(str(name), list(known), n=MAX_SUGGESTIONS, cutoff=CUTOFF)


def did_you_mean(name: object, known: Iterable[str]) -> str:
    """The hint for an unknown ``name``: ``"did you mean 'a', 'b'? "`` or ``""`` when none is close.

    Example:
        ``f"unknown policy {name!r} — {did_you_mean(name, names)}known: {', '.join(names)}"``
    """
    close = close_matches(name, known)
    return f"did you mean {', '.join(repr(c) for c in close)}? " if close else ""
