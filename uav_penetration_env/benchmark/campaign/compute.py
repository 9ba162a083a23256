"""What a campaign cost (``--compute``; docs/publishing.md §2).

Its compute log's wall and CPU time per part, its rows' worker time, and the training it publishes.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any


def rl_compute(root: Path) -> list[tuple[str, int, float]]:
    """The RL programme's compute from its committed snapshot ``root``: (what, count, wall seconds).

    Tuning: the trials' own durations (``*.trials.csv``); training: each finished model's
    ``wall_seconds`` (every resumed segment included). One torch thread per process, so wall time
    is CPU time on an idle core and more on a loaded one.
    """
    trials = [row for path in sorted(root.glob("tune/*/*.trials.csv")) for row in csv.DictReader(path.open())]
    tuning = sum(float(row.get("duration_s") or 0.0) for row in trials)
    models = [json.loads(path.read_text()) for path in sorted(root.glob("models/*.json"))]
    training = sum(float(m.get("wall_seconds") or 0.0) for m in models)
    return [(f"RL tuning ({len(trials)} trials)", len(trials), tuning),
            (f"RL training ({len(models)} runs)", len(models), training)]  # fmt: skip


def imitation_compute(distill_root: Path, names: Sequence[str] | None = None) -> tuple[str, float] | None:
    """The distilled networks' training: (what, CPU seconds), from their sidecars; ``None`` without any.

    Each ``RUN/policy.json`` records the distillation's CPU seconds (``train_cpu_seconds``) and its
    expert labels (``expert_labels``). ``names``: only these run folders (default every one).
    """
    paths = sorted(p for p in distill_root.glob("*/policy.json") if names is None or p.parent.name in names)
    sidecars = [json.loads(path.read_text()) for path in paths]
    if not sidecars:
        return None
    labels = sum(int(s.get("expert_labels") or 0) for s in sidecars)
    seconds = sum(float(s.get("train_cpu_seconds") or 0.0) for s in sidecars)
    return f"imitation training ({len(sidecars)} networks, {labels:,} expert labels)", seconds


def worker_seconds(tables: Any) -> dict[str, tuple[int, float]]:
    """Per run command: (finished episodes and window runs, the sum of their own wall seconds).

    Read from a store's (or its exported rows') ``runs``, ``episodes`` (``episode_seconds``) and
    ``window_runs`` (``seconds``) tables, keyed by the command each run's provenance records, so every
    finished item counts, including those of an attempt killed before the driver could log it.
    """
    commands = {int(r.run_id): json.loads(r.provenance).get("command", "") for r in tables.runs.itertuples()}
    totals: dict[str, list[float]] = {}
    for frame, column in ((tables.episodes, "episode_seconds"), (tables.window_runs, "seconds")):
        if frame.empty:
            continue
        for run_id, seconds in frame.groupby("run_id")[column]:
            total = totals.setdefault(commands.get(int(run_id), ""), [0, 0.0])
            total[0] += len(seconds)
            total[1] += float(seconds.sum())
    return {command: (int(n), seconds) for command, (n, seconds) in totals.items()}


def compute_table(
    attempts: list[dict],
    order: Sequence[str],
    worker: dict[str, tuple[int, float]] | None = None,
    rl_root: Path | None = None,
    distill_root: Path | None = None,
    distill_names: Sequence[str] | None = None,
) -> str:
    """Per part: attempts, logged wall and CPU time, and the worker time of its finished work; then the RL programme.

    DECISION (docs/publishing.md §2): two measures. The log's wall and CPU time cover the attempts
    that ended (a process killed with the session never writes its line); the worker time is the
    sum of every finished episode's and window run's own wall time (``worker``, from the rows), which
    counts all finished work whichever attempt did it. With as many workers as idle cores it
    approximates CPU time; on a shared machine it includes the waiting.
    """
    worker = worker or {}
    part_of = {a["command"]: a["part"] for a in attempts}
    lines = ["| part | attempts | wall [h] | CPU [h] | episodes + window runs | worker [h] |",
             "|---|---:|---:|---:|---:|---:|"]  # fmt: skip
    total_wall = total_cpu = total_worker = 0.0
    for name in order:
        rows = [a for a in attempts if a["part"] == name]
        done = [value for command, value in worker.items() if part_of.get(command) == name]
        if not rows and not done:
            continue
        wall, cpu = sum(a["wall_s"] for a in rows), sum(a["cpu_s"] for a in rows)
        items, seconds = sum(n for n, _ in done), sum(s for _, s in done)
        total_wall, total_cpu, total_worker = total_wall + wall, total_cpu + cpu, total_worker + seconds
        work = f"{items} | {seconds / 3600:.2f}" if done else "- | -"
        lines.append(f"| {name} | {len(rows)} | {wall / 3600:.2f} | {cpu / 3600:.2f} | {work} |")
    unlogged = [value for command, value in worker.items() if command not in part_of]
    if unlogged:
        items, seconds = sum(n for n, _ in unlogged), sum(s for _, s in unlogged)
        total_worker += seconds
        lines.append(f"| (runs of no logged command) | | | | {items} | {seconds / 3600:.2f} |")
    lines.append(
        f"| total | | {total_wall / 3600:.2f} | {total_cpu / 3600:.2f} | | {total_worker / 3600:.2f} |"
    )
    if rl_root is not None:
        for what, _, wall in rl_compute(rl_root):
            lines.append(f"| {what} | | {wall / 3600:.2f} | (one core each) | | |")
    imitation = imitation_compute(distill_root, distill_names) if distill_root is not None else None
    if imitation is not None:
        lines.append(f"| {imitation[0]} | | | {imitation[1] / 3600:.2f} | | |")
    return "\n".join(lines)
