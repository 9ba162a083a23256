"""The progress bar of long commands (run, calibrate, train): done/total, elapsed, ETA and a note.

One small class over ``rich.progress`` so every command shows the same bar, on standard error
(standard output stays the results). A disabled bar counts but draws nothing. Closing it (also
through ``with`` or a ``finally`` when Ctrl-C interrupts) stops rich's refresh thread and leaves
the last state on screen.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Hashable, Iterable
from typing import Any


class EpisodeETA:
    """The time left of a sweep, from the finished episodes' own durations per kind of work.

    A sweep mixes policies whose episodes differ by a thousand times (a floor against CMA-ES), and
    its first episodes in each worker include loading the compiled code; rich's default ETA, the
    mean rate so far, is therefore off by 10-50x early on. Here each remaining episode is priced at
    the median duration of its own policy's finished episodes (the median ignores the few slow
    first ones; a policy not seen yet gets the median over all finished episodes), and the sum is
    divided by the parallelism observed so far (finished episode-seconds per second since the earliest
    finished episode began, so the workers' start-up does not count as idle parallelism).

    Args:
        remaining: the key (policy name) of every episode still to fly.
        clock: the time source (``time.perf_counter``; tests pass their own).
    """

    def __init__(self, remaining: Iterable[Hashable], clock: Any = time.perf_counter) -> None:
        self._left: dict[Hashable, int] = {}
        for key in remaining:
            self._left[key] = self._left.get(key, 0) + 1
        self._seconds: dict[Hashable, list[float]] = {}
        self._clock = clock
        self._started = clock()
        self._first_work = math.inf  # when the earliest finished episode began (its end minus its duration)

    def finished(self, key: Hashable, seconds: float) -> None:
        """One episode of ``key`` took ``seconds`` (its own duration, in its worker)."""
        self._left[key] = max(self._left.get(key, 0) - 1, 0)
        if math.isfinite(seconds) and seconds >= 0:
            self._seconds.setdefault(key, []).append(float(seconds))
            self._first_work = min(self._first_work, self._clock() - float(seconds))

    def seconds_left(self) -> float | None:
        """The estimate, or None before the first finished episode."""
        every = [s for durations in self._seconds.values() for s in durations]
        # The parallelism is measured from when the work began, not from the command's start: the
        # seconds before the first episode (worker processes starting) would make it look lower.
        elapsed = self._clock() - max(self._started, min(self._first_work, self._clock()))
        if not every or elapsed <= 0:
            return None
        fallback = statistics.median(every)
        work = sum(
            n * statistics.median(self._seconds.get(key) or [fallback]) for key, n in self._left.items()
        )
        parallelism = max(sum(every) / elapsed, 1e-9)
        return work / parallelism


def format_eta(seconds: float | None) -> str:
    """``h:mm:ss`` of an estimate; ``-:--:--`` without one."""
    if seconds is None or not math.isfinite(seconds):
        return "-:--:--"
    whole = round(seconds)
    return f"{whole // 3600}:{whole % 3600 // 60:02d}:{whole % 60:02d}"


class ProgressBar:
    """A counted task with an ETA: ``update(n)``, ``set_postfix(key=value)``, ``close()``.

    Args:
        total: the number of units of work (episodes, environment steps).
        description: what is counted, shown before the bar.
        unit: the unit's name after the count (``ep``, ``steps``).
        enabled: draw the bar (False: count silently).
        console: a ``rich.console.Console`` to draw on (default: standard error).
        eta: an :class:`EpisodeETA` whose estimate the bar shows instead of rich's mean-rate ETA
            (updated by :meth:`finished`).
    """

    def __init__(
        self,
        total: int,
        description: str,
        *,
        unit: str = "",
        enabled: bool = True,
        console: Any = None,
        eta: EpisodeETA | None = None,
    ) -> None:
        self.n = 0
        self.total = int(total)
        self.eta = eta
        self._progress = None
        self._plain: Any = None
        if not enabled:
            return
        from rich.console import Console

        console = console if console is not None else Console(stderr=True)
        if not console.is_terminal:
            # A log file or a pipe (CI, nohup, Slurm): a live bar would draw nothing until the end.
            self._plain = PlainProgress(description, self.total, unit, console.file)
            return
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
            TimeRemainingColumn() if eta is None else TextColumn("{task.fields[eta]}"),
            TextColumn("{task.fields[note]}"),
            console=console,
            refresh_per_second=4,
        )
        self._task = self._progress.add_task(description, total=self.total, note="", eta=format_eta(None))
        self._progress.start()

    def update(self, advance: int = 1) -> None:
        """Count ``advance`` more units done."""
        self.n += int(advance)
        if self._progress is not None:
            self._progress.update(self._task, advance=int(advance))
        if self._plain is not None:
            self._plain.show(self.n, self.eta.seconds_left() if self.eta is not None else None)

    def finished(self, key: Hashable, seconds: float) -> None:
        """One unit of ``key`` is done after ``seconds`` of its own: count it and refresh the ETA."""
        if self.eta is not None:
            self.eta.finished(key, seconds)
            if self._progress is not None:
                self._progress.update(self._task, eta=format_eta(self.eta.seconds_left()))
        self.update(1)

    def set_postfix(self, **fields: Any) -> None:
        """Show ``key=value`` notes after the ETA (e.g. ``failures=2``)."""
        note = ", ".join(f"{key}={value}" for key, value in fields.items())
        if self._progress is not None:
            self._progress.update(self._task, note=note)
        if self._plain is not None:
            self._plain.note = note

    def close(self) -> None:
        """Stop drawing; the last state stays on screen. Safe to call twice."""
        if self._progress is not None:
            self._progress.stop()
            self._progress = None
        if self._plain is not None:
            self._plain.close()
            self._plain = None

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


class PlainProgress:
    """Progress as plain lines, for output that is not a terminal: one line per tenth of the work.

    ``episodes: 9/45 ep, 0:01:02 elapsed, ETA 0:04:10`` each time the count crosses a tenth of the
    total (so at most 10 lines, and the last one at the end), and once more on :meth:`close` if
    anything changed since (an interrupted run says where it stopped).
    """

    def __init__(
        self, description: str, total: int, unit: str, file: Any, clock: Any = time.perf_counter
    ) -> None:
        self.description, self.total, self.unit, self.file = description, total, unit, file
        self.note = ""
        self._clock = clock
        self._started = clock()
        self._next = 1
        self._shown: tuple[int, str] | None = None
        self._latest: tuple[int, float | None] = (0, None)

    def show(self, n: int, seconds_left: float | None, *, force: bool = False) -> None:
        """Print a line if ``n`` crossed the next tenth of the total (or ``force``)."""
        self._latest = (n, seconds_left)
        tenth = n * 10 // max(self.total, 1)
        if not force and tenth < self._next:
            return
        self._next = tenth + 1
        self._shown = (n, self.note)
        elapsed = format_eta(self._clock() - self._started)
        note = f", {self.note}" if self.note else ""
        unit = f" {self.unit}" if self.unit else ""
        print(f"{self.description}: {n}/{self.total}{unit}, {elapsed} elapsed, ETA {format_eta(seconds_left)}{note}",
              file=self.file, flush=True)  # fmt: skip

    def close(self) -> None:
        """The last state, if no line has shown it yet."""
        n, seconds_left = self._latest
        if self._shown != (n, self.note):
            self.show(n, seconds_left, force=True)
