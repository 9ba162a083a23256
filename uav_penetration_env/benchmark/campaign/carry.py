"""Carrying a long campaign across sessions through committed files (v3; docs/publishing.md §5.2-5.3).

``--seed-from`` starts a new store from earlier exports, ``--checkpoint`` commits the rows flown
since the last checkpoint (a new chunk) and the compute log, ``--resume`` rebuilds a missing store
and log from the checkpoint. The campaign file's ``carry`` section names the checkpoint folder and
the default seed rows.
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from uav_penetration_env.benchmark.campaign.log import command_key, read_log
from uav_penetration_env.benchmark.campaign.process import bench
from uav_penetration_env.benchmark.campaign.spec import CampaignSpec

MANIFEST = "manifest.json"
ID_COLUMNS = {"runs": "run_id", "episodes": "episode_id", "window_runs": "window_run_id"}


def merge_rows(stems: Sequence[Path], out: Path) -> dict[str, int]:
    """Join several exports into one stem ``out`` that ``uav-bench import`` reads (rows per table returned).

    DECISION (docs/publishing.md §5.3, merged rows): ``uav-bench import`` builds a new store from one
    export. Exports of one store (checkpoint chunks) have disjoint ids and keep them; an export whose
    ids collide with the rows before it (another store: the seed rows) has its run, episode and
    window-run ids moved past them, its episodes' ``run_id``, its window runs' ``run_id`` and its
    steps' ``episode_id`` with them. Scenarios and policies are keyed by hash and kept once.

    Raises:
        SystemExit: a stem without its episodes table, or an episode (policy hash, scenario hash, seed)
            in two stems (one line naming them).
    """
    import pandas as pd

    from uav_penetration_env.benchmark.rows import EXPORT_TABLES, read_table, row_path, write_table

    merged: dict[str, list[pd.DataFrame]] = {table: [] for table in EXPORT_TABLES}
    top = {column: 0 for column in ID_COLUMNS.values()}
    for stem in stems:
        frames = {table: read_table(stem, table) for table in EXPORT_TABLES}
        if frames["episodes"] is None or frames["runs"] is None:
            raise SystemExit(
                f"{stem}: no episodes or runs table; expected an export of uav-bench (--format parquet)"
            )
        shift = {}
        for table, column in ID_COLUMNS.items():
            frame = frames[table]
            ids = frame[column] if frame is not None and not frame.empty else pd.Series(dtype="int64")
            shift[column] = top[column] if len(ids) and int(ids.min()) <= top[column] else 0
            if len(ids):
                top[column] = int(ids.max()) + shift[column]
        for table, frame in frames.items():
            if frame is None or frame.empty:
                continue
            frame = frame.copy()
            for column in ("run_id", "episode_id", "window_run_id"):
                if column in frame.columns and frame[column].notna().all():
                    frame[column] = frame[column].astype("int64") + shift[column]
                elif column in frame.columns:  # a nullable reference: shift what is set
                    frame[column] = frame[column].where(frame[column].isna(), frame[column] + shift[column])
            merged[table].append(frame)
    counts = {}
    for table, frames_of in merged.items():
        if not frames_of:
            continue
        frame = pd.concat(frames_of, ignore_index=True)
        if table in ("scenarios", "policies"):
            frame = frame.drop_duplicates({"scenarios": "scenario_hash", "policies": "policy_hash"}[table])
        if table == "episodes":
            twice = frame[frame.duplicated(["policy_hash", "scenario_hash", "seed"], keep=False)]
            if not twice.empty:
                row = twice.iloc[0]
                raise SystemExit(f"episode {row.policy} on {row.scenario} seed {row.seed} is in two of "
                                 f"{', '.join(map(str, stems))}; expected each episode once")  # fmt: skip
        out.parent.mkdir(parents=True, exist_ok=True)
        write_table(frame, row_path(out, table, "parquet"), "parquet")
        counts[table] = len(frame)
    return counts


def import_rows(repo: Path, stem: Path, store: Path) -> int:
    """``uav-bench import --rows stem --store store`` in ``repo`` (its exit status)."""
    argv = ["import", "--rows", str(stem), "--store", str(store)]
    print(f"[run] {command_key(argv)}", flush=True)
    return bench(repo, argv)


def refuse_existing(*paths: Path) -> None:
    """Raise FileExistsError for the first of ``paths`` that exists (a rebuild never overwrites)."""
    for path in paths:
        if path.exists():
            raise FileExistsError(f"{path} exists; this only rebuilds a missing store and log")


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` whole or not at all (uav_penetration_env/atomic.py)."""
    from uav_penetration_env.atomic import atomic_open

    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(path) as handle:
        handle.write(text)


def read_manifest(folder: Path) -> dict[str, Any]:
    """The checkpoint's manifest: the seed stems, the chunks (name, last run id, episodes), or an empty one."""
    path = folder / MANIFEST
    return json.loads(path.read_text()) if path.is_file() else {"seeds": [], "seed_run_id": 0, "chunks": []}


def seed_from(repo: Path, spec: CampaignSpec, stems: Sequence[Path]) -> int:
    """A new store from earlier rows (``--seed-from``): the sweep then skips their episodes.

    DECISION (docs/publishing.md §5.3, seeding): the seed rows were flown with the policies the
    campaign flies (equal policy hashes: the store key) and keep their own runs and so their own
    provenance, never rewritten here. The stems are recorded in ``ROOT/seeded.json`` so that a
    checkpoint names them instead of copying their rows (they are committed already).

    Raises:
        FileExistsError: the store or its log exists (seeding is the first step, never a merge).
    """
    from uav_penetration_env.benchmark.rows import read_table

    store, log = repo / spec.layout.store, repo / spec.log
    refuse_existing(store, log)
    with tempfile.TemporaryDirectory() as folder:
        counts = merge_rows([repo / s for s in stems], Path(folder) / "seed")
        runs = read_table(Path(folder) / "seed", "runs")
        top = int(runs.run_id.max()) if runs is not None else 0  # the seed rows' last run id
        status = import_rows(repo, Path(folder) / "seed", store)
    if status == 0:
        atomic_write_text(repo / spec.root / "seeded.json", json.dumps(
            {"seeds": [Path(s).as_posix() for s in stems], "seed_run_id": top}, indent=1))  # fmt: skip
        print(f"{spec.layout.store}: seeded with {counts['episodes']} episodes of {len(stems)} exports")
    return status


def checkpoint(repo: Path, spec: CampaignSpec, folder: Path) -> Path | None:
    """Export the store's rows flown since the last checkpoint, and the compute log, into ``folder``.

    DECISION (docs/publishing.md §5.2, incremental checkpoints): each checkpoint is a new chunk
    (``chunk-NNN-*.parquet``: the runs after the last recorded run id, their episodes, steps and
    window runs, every scenario and policy), so each episode's steps are committed once and a
    session's commit stays small; the seed rows are named, not copied. The manifest is written last
    (atomically): a chunk it does not name is ignored, so a cut checkpoint leaves the last one whole.

    Returns:
        The chunk's stem (relative to ``repo``), or ``None`` when nothing was flown since (only the log is copied).

    Raises:
        FileNotFoundError: no store.
    """
    import pandas as pd

    from uav_penetration_env.benchmark.rows import EXPORT_TABLES, read_table, row_path, write_table

    store, log = repo / spec.layout.store, repo / spec.log
    if not store.is_file():
        raise FileNotFoundError(f"{store}: missing; nothing to checkpoint")
    target = repo / folder
    manifest = read_manifest(target)
    seeded = repo / spec.root / "seeded.json"
    if seeded.is_file() and not manifest["chunks"]:
        manifest.update(json.loads(seeded.read_text()))
    covered = max([manifest["seed_run_id"], *(c["run_id"] for c in manifest["chunks"])])
    target.mkdir(parents=True, exist_ok=True)
    stem = None
    with tempfile.TemporaryDirectory() as work:
        argv = ["export", "--format", "parquet", "--store", str(store), "--out", f"{work}/all"]
        if bench(repo, argv) != 0:
            raise SystemExit(f"{command_key(argv)}: failed; no checkpoint written")
        frames = {table: read_table(f"{work}/all", table) for table in EXPORT_TABLES}
        runs = frames["runs"]
        if runs is None or frames["episodes"] is None:
            raise SystemExit(f"{store}: the export holds no runs or episodes table; no checkpoint written")
        new = runs[runs.run_id > covered]
        if not new.empty:
            keep = set(new.run_id)
            episodes = frames["episodes"][frames["episodes"].run_id.isin(keep)]
            chosen = {
                "runs": new,
                "episodes": episodes,
                "scenarios": frames["scenarios"],
                "policies": frames["policies"],
            }
            steps, windows = frames["steps"], frames["window_runs"]
            chosen["steps"] = (
                steps[steps.episode_id.isin(set(episodes.episode_id))] if steps is not None else None
            )
            chosen["window_runs"] = windows[windows.run_id.isin(keep)] if windows is not None else None
            name = f"chunk-{len(manifest['chunks']) + 1:03d}"
            for table, frame in chosen.items():
                if frame is not None:
                    write_table(frame if not frame.empty else pd.DataFrame(columns=frame.columns),
                                row_path(target / name, table, "parquet"), "parquet")  # fmt: skip
            manifest["chunks"].append({"name": name, "run_id": int(new.run_id.max()), "episodes": len(episodes),
                                       "window_runs": 0 if chosen["window_runs"] is None else len(chosen["window_runs"])})  # fmt: skip
            stem = Path(folder) / name
    if log.is_file():
        atomic_write_text(target / "compute.jsonl", log.read_text())
    atomic_write_text(target / MANIFEST, json.dumps(manifest, indent=1) + "\n")
    return stem


def resume(repo: Path, spec: CampaignSpec, folder: Path) -> int:
    """Rebuild a missing store and log from the checkpoint (``--resume``): seeds and chunks, merged, imported.

    Raises:
        FileExistsError: the store or the log exists.
        FileNotFoundError: no checkpoint manifest.
    """
    store, log = repo / spec.layout.store, repo / spec.log
    refuse_existing(store, log)
    target = repo / folder
    if not (target / MANIFEST).is_file():
        raise FileNotFoundError(f"{target / MANIFEST}: missing; expected a checkpoint (--checkpoint)")
    manifest = read_manifest(target)
    stems = [repo / s for s in manifest["seeds"]] + [target / c["name"] for c in manifest["chunks"]]
    with tempfile.TemporaryDirectory() as work:
        merge_rows(stems, Path(work) / "resume")
        status = import_rows(repo, Path(work) / "resume", store)
    if status == 0:
        if manifest["seeds"]:
            atomic_write_text(repo / spec.root / "seeded.json", json.dumps(
                {"seeds": manifest["seeds"], "seed_run_id": manifest["seed_run_id"]}, indent=1))  # fmt: skip
        saved = target / "compute.jsonl"
        atomic_write_text(log, saved.read_text() if saved.is_file() else "")
        print(f"{spec.layout.store}: {len(stems)} exports; {len(read_log(log))} attempts in the log")
    return status
