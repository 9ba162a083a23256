"""What ``uav-bench campaign`` does besides running: its compute, its install, carrying it across sessions."""

from __future__ import annotations

import sys
from pathlib import Path

from uav_penetration_env.benchmark.campaign import carry
from uav_penetration_env.benchmark.campaign import install as installing
from uav_penetration_env.benchmark.campaign.compute import compute_table, worker_seconds
from uav_penetration_env.benchmark.campaign.log import command_key, read_log, rebuild_checked
from uav_penetration_env.benchmark.campaign.plan import plan
from uav_penetration_env.benchmark.campaign.spec import CampaignSpec


def compute(repo: Path, spec: CampaignSpec) -> str:
    """The compute table (:func:`~uav_penetration_env.benchmark.campaign.compute.compute_table`).

    On a fresh clone (no log, no store) it reads what the install committed: the compute log
    beside the installed tables, and the worker time from the committed rows (the checkpoint's
    chunks, or the installed ``rows/``).
    """
    from uav_penetration_env.benchmark.rows import read_chunks, read_rows, store_tables

    log, installed = repo / spec.log, repo / spec.install.target / "compute.jsonl"
    attempts = read_log(log if log.is_file() or not installed.is_file() else installed)
    store, chunks = repo / spec.layout.store, spec.install.rows
    committed = repo / spec.install.target / "rows" / "leaderboard"
    if store.is_file():
        worker = worker_seconds(store_tables(store))
    elif chunks is not None and (repo / chunks / carry.MANIFEST).is_file():
        worker = worker_seconds(read_chunks([repo / chunks]))
    elif committed.with_name("leaderboard-runs.parquet").is_file():
        worker = worker_seconds(read_rows(committed))
    else:
        worker = {}
    sources = spec.compute
    return compute_table(
        attempts, spec.order, worker,
        rl_root=repo / sources.rl_root if sources.rl_root is not None else None,
        distill_root=repo / sources.distill_root if sources.distill_root is not None else None,
        distill_names=sources.distill_names,
    )  # fmt: skip


def install(repo: Path, spec: CampaignSpec) -> int:
    """Copy the output into the install target once the rebuild check passed (1: refused)."""
    attempts = read_log(repo / spec.log)
    checked = [part for part in plan(spec, repo, pending=list) if part.rebuild_check]
    for part in checked:
        if not rebuild_checked(attempts, part.name, [command_key(c) for c in part.commands], spec.derived):
            print(f"refused: the {part.name} part has not ended with a passed rebuild check; run it first",
                  file=sys.stderr)  # fmt: skip
            return 1
    out, target, log = repo / spec.layout.out, repo / spec.install.target, repo / spec.log
    if spec.install.mode == "folder":
        copied = installing.install_folder(out, target, log)
    else:
        copied = installing.install_replace(out, target, log)
    print(f"{len(copied)} files copied into {spec.install.target}/")
    return 0


def rebuild_from_published(repo: Path, spec: CampaignSpec) -> int:
    """``--from-published``: the store and log from the installed leaderboard."""
    return installing.from_published(repo, spec.layout.store, spec.log, spec.install.target)


def _checkpoint_folder(spec: CampaignSpec) -> Path:
    if spec.carry is None:
        raise FileNotFoundError(f"{spec.name}: no carry section; expected a checkpoint folder")
    return spec.carry.checkpoint


def seed(repo: Path, spec: CampaignSpec, stems: list[Path]) -> int:
    """``--seed-from [STEM ...]``: a new store from earlier exports (default: the file's seed rows)."""
    if spec.carry is None:
        raise FileNotFoundError(f"{spec.name}: no carry section; expected the rows to seed from")
    return carry.seed_from(repo, spec, stems or list(spec.carry.seed_rows))


def resume_from_checkpoint(repo: Path, spec: CampaignSpec) -> int:
    """``--resume``: the store and log from the committed checkpoint."""
    return carry.resume(repo, spec, _checkpoint_folder(spec))


def write_checkpoint(repo: Path, spec: CampaignSpec) -> int:
    """``--checkpoint``: the rows flown since the last checkpoint, and the log, into the checkpoint folder."""
    folder = _checkpoint_folder(spec)
    stem = carry.checkpoint(repo, spec, folder)
    print(f"{folder}: {'new rows in ' + str(stem) if stem else 'no new rows'}; the log copied; commit it")
    return 0
