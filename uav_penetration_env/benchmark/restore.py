"""A results store rebuilt from exported rows: ``uav-bench import`` (api.md §4.9).

``uav-bench export`` writes a store as tables; this module writes them back into a new SQLite
store with every id kept, so that a published leaderboard's committed rows are not only
recomputable (``leaderboard --rows``) but also extensible: ``uav-bench run`` on the rebuilt store
skips every stored episode and adds new policies beside them, and the tables built from it equal
the published ones.

DECISION (api.md §4.9): an export written before the scenarios and policies tables were exported
(leaderboard v2's first installations) is imported too. Its scenarios are rebuilt from what the
package ships (the frozen suites' members by their recorded hash, the catalogue names, and
``random-SEED`` at the default difficulty), each accepted only if it hashes to the hash the rows
recorded, so a scenario the package now builds differently is refused rather than replaced; its
policies table stays empty, as nothing reads it but the record of configurations, and the next
``run`` registers the policies it flies.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from uav_penetration_env.benchmark.rows import EXPORT_TABLES, RowsError, read_rows, read_table


class RestoreError(ValueError):
    """Rows that cannot become a store: a scenario nothing rebuilds, or a bad target path."""


@dataclass(frozen=True)
class Restored:
    """What an import wrote.

    Attributes:
        counts: rows per table (``steps`` includes the recomputed step-0 rows).
        rebuilt_scenarios: scenarios rebuilt from the package (an export without its scenarios
            table), by name.
    """

    counts: dict[str, int]
    rebuilt_scenarios: tuple[str, ...]


def needed_scenarios(episodes: pd.DataFrame, window_runs: pd.DataFrame) -> dict[str, str]:
    """``scenario_hash -> scenario name`` of every scenario an episode or window run names.

    Raises:
        RowsError: a table without its ``scenario`` or ``scenario_hash`` column.
    """
    needed: dict[str, str] = {}
    for table, frame in (("episodes", episodes), ("window_runs", window_runs)):
        if frame.empty:
            continue
        missing = [c for c in ("scenario_hash", "scenario") if c not in frame.columns]
        if missing:
            raise RowsError(f"the {table} table has no {missing[0]} column; expected an export of uav-bench")
        needed.update(zip(frame["scenario_hash"], frame["scenario"], strict=True))
    return needed


def rebuild_scenarios(needed: Mapping[str, str]) -> dict[str, tuple[str, str]]:
    """The scenarios ``needed`` (hash -> name) as the store keeps them: ``hash -> (name, yaml)``.

    Tried in turn, cheapest first: each frozen suite's member whose fingerprint records the hash,
    each catalogue name, then ``random:SEED`` for a name ``random-SEED``; a candidate counts only
    if its own hash is the recorded one.

    Raises:
        RestoreError: a scenario none of them rebuilds (named with its hash).
    """
    from uav_penetration_env.benchmark.evaluate import scenario_yaml
    from uav_penetration_env.catalogue import NAMED_SCENARIOS, resolve_scenario
    from uav_penetration_env.suites import build_member, load_suite, suite_names

    found: dict[str, tuple[str, str]] = {}

    def offer(scenario) -> None:
        if scenario.hash in needed and scenario.hash not in found:  # the name the rows recorded
            found[scenario.hash] = (needed[scenario.hash], scenario_yaml(scenario))

    for suite_name in suite_names():
        suite = load_suite(suite_name)
        for member in suite.members:
            if member.fingerprint.scenario_hash in needed and member.fingerprint.scenario_hash not in found:
                offer(build_member(suite, member, verify=False))
    missing = set(needed) - set(found)
    for build in NAMED_SCENARIOS.values():  # a handful; built only while something is missing
        if not missing:
            break
        offer(build())
        missing = set(needed) - set(found)
    for scenario_hash in sorted(missing):
        seed = needed[scenario_hash].removeprefix("random-")
        if seed != needed[scenario_hash] and seed.isdigit():
            offer(resolve_scenario(f"random:{seed}"))
    missing = sorted(set(needed) - set(found))
    if missing:
        first = missing[0]
        raise RestoreError(
            f"scenario {needed[first]!r} (hash {first}) is not in the rows' scenarios table and no suite or "
            f"catalogue scenario of this version hashes to it ({len(missing)} such); expected an export "
            "with its scenarios table (uav-bench export of this version)"
        )
    return found


def restore_store(stem: str | Path, path: str | Path) -> Restored:
    """Write the tables exported under ``stem`` into a new results store at ``path``.

    The store is built beside ``path`` and renamed onto it when complete, so an interrupted import
    leaves no store that looks whole.

    Raises:
        RowsError: no episodes or runs table under ``stem``, or an unreadable one (:func:`read_rows`);
            an incomplete export (:func:`~.export_manifest.check_export`).
        RestoreError: ``path`` (or an SQLite journal of it, which would be replayed onto the new
            file) exists, a scenario cannot be rebuilt (:func:`rebuild_scenarios`), or the rows
            cannot form a store (:meth:`~.store.ResultsStore.load_exported`); nothing is left behind.
        StoreError: the target cannot be written.
    """
    from uav_penetration_env.atomic import atomic_path
    from uav_penetration_env.benchmark.export_manifest import check_export
    from uav_penetration_env.benchmark.store import ResultsStore

    path = Path(path)
    for leftover in (path, *(path.with_name(path.name + end) for end in ("-wal", "-shm", "-journal"))):
        if leftover.exists():
            what = "exists" if leftover == path else f"has a leftover SQLite journal {leftover.name}"
            raise RestoreError(
                f"--store {path}: {what}; expected a new file path (import does not merge into a store)"
            )
    check_export(stem)  # an export that stopped part-way is refused before anything is written
    rows = read_rows(stem)
    tables = {"episodes": rows.episodes, "runs": rows.runs, "window_runs": rows.window_runs}
    for table in EXPORT_TABLES:
        if table not in tables:
            frame = read_table(stem, table)
            tables[table] = frame if frame is not None else pd.DataFrame()
    rebuilt: tuple[str, ...] = ()
    needed = needed_scenarios(rows.episodes, rows.window_runs)
    have = set(tables["scenarios"]["scenario_hash"]) if not tables["scenarios"].empty else set()
    if set(needed) - have:
        extra = rebuild_scenarios({h: n for h, n in needed.items() if h not in have})
        frame = pd.DataFrame(
            [(h, n, y) for h, (n, y) in extra.items()], columns=["scenario_hash", "scenario", "yaml"]
        )
        tables["scenarios"] = pd.concat([tables["scenarios"], frame], ignore_index=True) if have else frame
        rebuilt = tuple(sorted(n for n, _ in extra.values()))
    with atomic_path(path) as temporary:
        temporary.unlink()  # an empty file is not an SQLite database the store would open
        with ResultsStore(temporary) as store:
            try:
                store.load_exported(tables)
            except ValueError as error:
                raise RestoreError(f"--rows {stem}: {error}") from None
            counts = {
                table: store.count(table)
                for table in ("episodes", "steps", "runs", "window_runs", "scenarios", "policies")
            }
    return Restored(counts, rebuilt)


__all__ = ["RestoreError", "Restored", "RowsError", "needed_scenarios", "rebuild_scenarios", "restore_store"]
