"""Installing a campaign's output into the tracked tree, checking it first, and the way back.

``--install`` copies the tables, figures and report once the tables part ended with a passed
rebuild check; ``--from-published`` rebuilds a missing store and compute log from an installed
leaderboard.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from uav_penetration_env.benchmark.campaign import process
from uav_penetration_env.benchmark.campaign.log import command_key, read_log
from uav_penetration_env.benchmark.commands.common import OUT_SOURCE_FILE

INSTALLED_SUFFIXES = (".md", ".csv", ".png", ".pdf", ".html", ".parquet")


def date_free(text: str) -> str:
    """A generated file without its date line (the one line allowed to differ between rebuilds)."""
    return "\n".join(line for line in text.splitlines() if not line.startswith(("- Date:", "Date:")))


def compare_rebuild(out: Path, check: Path) -> list[str]:
    """Tables that differ between the store's output and the rebuild from rows; ``[]``: all equal.

    Equal means byte for byte apart from the date line; a table on one side only differs.
    """

    def tables(folder: Path) -> set[str]:
        return {p.name for p in folder.iterdir() if p.suffix in (".md", ".csv")} if folder.is_dir() else set()

    written, rebuilt = tables(out), tables(check)
    if not rebuilt:
        return [f"{check}: no tables rebuilt from the rows"]
    differing = sorted(written ^ rebuilt)
    for name in sorted(written & rebuilt):
        if date_free((out / name).read_text()) != date_free((check / name).read_text()):
            differing.append(name)
    return sorted(differing)


def _require_report(out: Path) -> None:
    if not (out / "index.html").is_file():
        raise SystemExit(f"{out}: no index.html; run the tables part first")


def install_replace(out: Path, target: Path, log: Path | None = None) -> list[Path]:
    """Replace the generated files of ``target`` by those of ``out`` (install mode ``replace``; paths absolute).

    Removed first: the generated files at the top of ``target`` (tables, figures, the page, its
    episode CSVs) and its ``models/`` and ``rows/`` folders; ``rl/`` (the RL programme's state)
    and other folders stay. The compute log is copied last (the README's compute reads it).

    Raises:
        SystemExit: ``out`` has no ``index.html`` (the tables part has not run).
    """
    _require_report(out)
    for stale in target.iterdir():
        if stale.is_file() and stale.suffix in INSTALLED_SUFFIXES:
            stale.unlink()
    for folder in ("models", "rows"):
        if (target / folder).is_dir():
            shutil.rmtree(target / folder)
    copied = []
    for path in sorted(p for p in out.rglob("*") if p.is_file() and p.name != OUT_SOURCE_FILE):
        destination = target / path.relative_to(out)
        destination.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(path, destination)
        copied.append(destination)
    if log is not None and log.is_file():
        shutil.copyfile(log, target / "compute.jsonl")
        copied.append(target / "compute.jsonl")
    return copied


def install_folder(out: Path, target: Path, log: Path | None = None) -> list[Path]:
    """Replace the folder ``target`` by ``out``'s tables, figures and report, without the exported rows.

    DECISION (docs/publishing.md §5.5, v3's install): a publication whose rows are committed
    elsewhere (v3's checkpoint chunks, which its tables part rebuilds from) installs into a folder
    of its own (install mode ``folder``), so the earlier version's tables stay where they are and
    nothing is copied twice: every file under ``out`` except ``rows/``, then the compute log. The
    new folder is written beside ``target`` and renamed over it, so a cut install leaves the
    previous one whole.

    Raises:
        SystemExit: ``out`` has no ``index.html`` (the tables part has not run).
    """
    _require_report(out)
    staging = target.with_name(target.name + ".installing")
    if staging.exists():
        shutil.rmtree(staging)
    files = sorted(
        p for p in out.rglob("*")
        if p.is_file() and p.name != OUT_SOURCE_FILE and p.relative_to(out).parts[0] != "rows"
    )  # fmt: skip
    for path in files:
        destination = staging / path.relative_to(out)
        destination.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(path, destination)
    if log is not None and log.is_file():
        staging.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(log, staging / "compute.jsonl")
    previous = target.with_name(target.name + ".previous")
    if previous.exists():
        shutil.rmtree(previous)
    if target.exists():  # moved aside, not removed, until the new folder is in place
        target.rename(previous)
    staging.rename(target)
    if previous.exists():
        shutil.rmtree(previous)
    return sorted(p for p in target.rglob("*") if p.is_file())


def from_published(repo: Path, store: Path, log: Path, published: Path) -> int:
    """Rebuild a missing store and compute log from an installed leaderboard (``--from-published``).

    DECISION (docs/publishing.md §2, carrying on elsewhere): the store and the compute log live
    outside the tracked tree, so a new machine has neither. The installed leaderboard holds both
    in committed form: the rows (``PUBLISHED/rows/leaderboard``), which ``uav-bench import`` turns
    back into the store with every id kept, and the compute log ``--install`` copied. With them
    back, every published command reads as done; nothing published is recomputed.

    Args:
        repo: the repository; the other paths are relative to it.
        store: the store to rebuild.
        log: the compute log to rebuild.
        published: the install target holding ``rows/leaderboard`` and ``compute.jsonl``.

    Returns:
        The exit status of ``uav-bench import`` (the log is copied only after it succeeded).

    Raises:
        FileExistsError: the store or the log already exists (they are never overwritten).
        FileNotFoundError: no installed rows or compute log.
    """
    from uav_penetration_env.atomic import atomic_path

    for path in (repo / store, repo / log):
        if path.exists():
            raise FileExistsError(f"{path} exists; --from-published only rebuilds a missing store and log")
    rows, published_log = published / "rows" / "leaderboard", repo / published / "compute.jsonl"
    for path in (repo / rows.with_name("leaderboard-episodes.parquet"), published_log):
        if not path.is_file():
            raise FileNotFoundError(f"{path}: missing; expected an installed leaderboard (--install)")
    argv = ["import", "--rows", str(rows), "--store", str(store)]
    print(f"[run] {command_key(argv)}", flush=True)
    status = process.bench(repo, argv)
    if status == 0:
        with atomic_path(repo / log) as temporary:  # a cut copy never passes for the log
            shutil.copyfile(published_log, temporary)
        print(f"{log}: {len(read_log(repo / log))} attempts, copied from {published / 'compute.jsonl'}")
    return status
