"""A spy on one function of an optimiser's module: every call goes through, and what a test reads of it is kept."""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType
from typing import Any


def record_calls(monkeypatch, module: ModuleType, name: str, note: Callable[..., Any]) -> list[Any]:
    """Replace ``module.name`` for the test by a wrapper that calls it unchanged.

    Before each call the wrapper appends ``note(*args, **kwargs)`` (what the test checks of the
    call, e.g. one keyword's value) to the list it returns; the list fills as the optimiser runs.
    """
    notes: list[Any] = []
    real = getattr(module, name)

    def spy(*args: Any, **kwargs: Any) -> Any:
        notes.append(note(*args, **kwargs))
        return real(*args, **kwargs)

    monkeypatch.setattr(module, name, spy)
    return notes
