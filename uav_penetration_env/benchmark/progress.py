"""The progress bar of long commands (run, calibrate, train): done/total, elapsed, ETA and a note.

One small class over ``rich.progress`` so every command shows the same bar, on standard error
(standard output stays the results). A disabled bar counts but draws nothing. Closing it (also
through ``with`` or a ``finally`` when Ctrl-C interrupts) stops rich's refresh thread and leaves
the last state on screen.
"""

from __future__ import annotations

from typing import Any


class ProgressBar:
    """A counted task with an ETA: ``update(n)``, ``set_postfix(key=value)``, ``close()``.

    Args:
        total: the number of units of work (episodes, environment steps).
        description: what is counted, shown before the bar.
        unit: the unit's name after the count (``ep``, ``steps``).
        enabled: draw the bar (False: count silently).
        console: a ``rich.console.Console`` to draw on (default: standard error).
    """

    def __init__(
        self, total: int, description: str, *, unit: str = "", enabled: bool = True, console: Any = None
    ) -> None:
        self.n = 0
        self.total = int(total)
        self._progress = None
        if not enabled:
            return
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self._progress = Progress(
            TextColumn("{task.description}"),
            BarColumn(bar_width=30),
            MofNCompleteColumn(),
            TextColumn(unit),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            TextColumn("{task.fields[note]}"),
            console=console if console is not None else Console(stderr=True),
            refresh_per_second=4,
        )
        self._task = self._progress.add_task(description, total=self.total, note="")
        self._progress.start()

    def update(self, advance: int = 1) -> None:
        """Count ``advance`` more units done."""
        self.n += int(advance)
        if self._progress is not None:
            self._progress.update(self._task, advance=int(advance))

    def set_postfix(self, **fields: Any) -> None:
        """Show ``key=value`` notes after the ETA (e.g. ``failures=2``)."""
        if self._progress is not None:
            note = ", ".join(f"{key}={value}" for key, value in fields.items())
            self._progress.update(self._task, note=note)

    def close(self) -> None:
        """Stop drawing; the last state stays on screen. Safe to call twice."""
        if self._progress is not None:
            self._progress.stop()
            self._progress = None

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
