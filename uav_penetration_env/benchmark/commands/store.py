"""``uav-bench store``: list the policy configurations of a results store, or drop one (api.md, harness).

``store list`` prints each configuration's table label (``name``, or ``name@hash8`` where a name
has several configurations), full hash and episode counts. ``store drop --policy LABEL`` deletes
that configuration's episodes, steps and ``policies`` row in one transaction, after a
confirmation (``--yes`` skips it; without a terminal it is required): the way to clear the
empty rows a broken plug-in left, or a configuration one no longer wants in the tables.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from uav_penetration_env.benchmark.commands.common import (
    CLIError,
    Command,
    add_store_argument,
    existing_store,
    store_error,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench store``."""
    parser.add_argument("action", choices=("list", "drop"), help="list the configurations, or drop one")
    add_store_argument(parser)
    parser.add_argument(
        "--policy", help="drop: the configuration's label as `store list` shows it (NAME or NAME@HASH8)"
    )
    parser.add_argument("--yes", action="store_true", help="drop without asking")


def configurations(store: Any) -> list[dict[str, Any]]:
    """One entry per stored configuration: label, name, hash, episodes and error episodes, by label."""
    episodes = store.episodes()
    known = store.policies()
    counts: dict[str, list[int]] = {h: [0, 0] for h in known}
    names = {h: name for h, (name, _) in known.items()}
    for policy_hash, name, error in zip(
        episodes["policy_hash"], episodes["policy"], episodes["error"], strict=True
    ):
        counts.setdefault(policy_hash, [0, 0])
        names.setdefault(policy_hash, name)
        counts[policy_hash][0] += 1
        counts[policy_hash][1] += bool(error)
    per_name: dict[str, int] = {}
    for name in names.values():
        per_name[name] = per_name.get(name, 0) + 1
    rows = [
        {
            "label": name if per_name[name] == 1 else f"{name}@{policy_hash[:8]}",
            "policy": name,
            "policy_hash": policy_hash,
            "episodes": counts[policy_hash][0],
            "errors": counts[policy_hash][1],
        }
        for policy_hash, name in names.items()
    ]
    return sorted(rows, key=lambda row: row["label"])


def find_configuration(rows: list[dict[str, Any]], label: str) -> dict[str, Any]:
    """The configuration ``label`` names: a label as listed, or NAME@PREFIX of its hash (8+ characters).

    Raises:
        CLIError: no configuration, or several, match.
    """
    matches = [row for row in rows if row["label"] == label]
    name, _, prefix = label.partition("@")
    if not matches and len(prefix) >= 8:
        matches = [row for row in rows if row["policy"] == name and row["policy_hash"].startswith(prefix)]
    if len(matches) == 1:
        return matches[0]
    if not matches:
        from uav_penetration_env.suggest import did_you_mean

        labels = [row["label"] for row in rows]
        raise CLIError(
            f"--policy {label}: no such configuration in the store; {did_you_mean(label, labels)}"
            f"expected one of {', '.join(labels) or '(none stored)'} (uav-bench store list)"
        )
    hashes = ", ".join(row["policy_hash"][:12] for row in matches)
    raise CLIError(f"--policy {label}: {len(matches)} configurations match ({hashes}); give more of the hash")


def run(args: argparse.Namespace) -> int:
    """List the configurations, or drop one after the confirmation."""
    from uav_penetration_env.benchmark.commands.run import open_store
    from uav_penetration_env.benchmark.store import ResultsStore, StoreError

    path = existing_store(args.store)
    if args.action == "list":
        try:
            with ResultsStore(path, create=False) as store:
                rows = configurations(store)
        except StoreError as error:
            raise store_error(error) from None
        width = max((len(row["policy_hash"]) for row in rows), default=16)
        print(f"{'policy':<32} {'configuration hash':<{width}}  {'episodes':>15}  {'errors':>11}")
        for row in rows:
            print(
                f"{row['label']:<32} {row['policy_hash']:<{width}}  {row['episodes']:>6} episodes  {row['errors']:>4} errors"
            )
        return 0
    if not args.policy:
        raise CLIError("--policy: required by `store drop` (a label from `uav-bench store list`)")
    store = open_store(Path(path), None)  # integrity checked, folder writable: refused before any write
    try:
        row = find_configuration(configurations(store), args.policy)
        what = (f"{row['episodes']} episodes ({row['errors']} with errors) of {row['label']} "
                f"({row['policy_hash'][:12]}) from {path}")  # fmt: skip
        if not args.yes:
            if not sys.stdin.isatty():
                raise CLIError(f"--yes: needed to drop {what} without a terminal to confirm on")
            if input(f"drop {what}? [y/N] ").strip().lower() not in ("y", "yes"):
                print("nothing dropped")
                return 0
        episodes, steps = store.drop_policy(row["policy_hash"])
    finally:
        store.close()
    print(f"dropped {episodes} episodes and {steps} steps of {row['label']} from {path}")
    return 0


COMMAND = Command(
    name="store",
    help="list a results store's policy configurations, or drop one (after a confirmation)",
    add_arguments=add_arguments,
    run=run,
)
