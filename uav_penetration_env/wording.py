"""How messages, tables and headlines write counts: ``1 seed``, ``2 seeds`` (a leaf module, no imports)."""

from __future__ import annotations


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``1 scenario``, ``2 scenarios``: a count with its noun in the right number.

    Args:
        n: the count.
        noun: the singular noun.
        plural: the plural where it is not ``noun + "s"`` (``policies``).
    """
    return f"{n} {noun if n == 1 else (plural or noun + 's')}"
