"""Scenario groups of a results store and the policy labels inside them (api.md, harness).

A scenario group is every episode with one ``scenario_hash`` (the hash covers the geometry, the
weights, the profile and the normalisation, so costs inside a group are comparable and costs
across groups are not); a suite group pools several scenarios, pairing policies on (scenario,
seed) blocks.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from uav_penetration_env.benchmark.columns import EPISODE, numeric_columns

NUMERIC_EPISODE_COLUMNS = numeric_columns(EPISODE)  # coerced to float: an all-NULL column reads as object


@dataclass(frozen=True)
class ScenarioGroup:
    """The episodes of one scenario hash, with the file stem its outputs use.

    Attributes:
        stem: sanitized scenario name (plus a hash prefix when two hashes share a name).
        scenario_hash: the group's scenario hash.
        name: the scenario's name.
        episodes: its episode rows (error rows included), with a ``label`` column per policy.
    """

    stem: str
    scenario_hash: str
    name: str
    episodes: pd.DataFrame
    scenarios: tuple[str, ...] = ()  # a suite's scenario names; empty for one scenario


def sanitize(name: str) -> str:
    """A file-name-safe version of ``name``: runs of other characters become ``-``."""
    cleaned = re.sub(r"[^A-Za-z0-9._-]+", "-", name).strip("-.")
    return cleaned or "scenario"


def policy_labels(episodes: pd.DataFrame) -> pd.Series:
    """The display name of each row's policy: its name, or ``name@hash8`` if the name has two configurations."""
    hashes_per_name = episodes.groupby("policy")["policy_hash"].nunique()
    ambiguous = set(hashes_per_name[hashes_per_name > 1].index)
    return pd.Series(
        [
            f"{name}@{str(h)[:8]}" if name in ambiguous else str(name)
            for name, h in zip(episodes["policy"], episodes["policy_hash"], strict=True)
        ],
        index=episodes.index,
        dtype=object,
    )


def prepare_episodes(episodes: pd.DataFrame) -> pd.DataFrame:
    """Episode rows with numeric columns coerced, ``error`` as text, an ``is_error`` flag and a ``label``."""
    frame = episodes.copy()
    for column in NUMERIC_EPISODE_COLUMNS:
        if column in frame:
            # An all-NULL SQLite column arrives as object dtype; make it a float column.
            frame[column] = pd.to_numeric(frame[column], errors="coerce").astype(np.float64)
    frame["error"] = frame["error"].fillna("").astype(str) if "error" in frame else ""
    frame["is_error"] = (frame["error"] != "") | (frame["outcome"].astype(str) == "error")
    if "label" not in frame:
        frame["label"] = policy_labels(frame)
    return frame


def scenario_groups(episodes: pd.DataFrame) -> list[ScenarioGroup]:
    """Split episodes by scenario hash, sorted by (name, hash); stems are unique.

    Args:
        episodes: rows of the ``episodes`` table.

    Returns:
        One :class:`ScenarioGroup` per scenario hash.
    """
    if episodes.empty:
        return []
    keys = sorted(
        {(str(n), str(h)) for n, h in zip(episodes["scenario"], episodes["scenario_hash"], strict=True)}
    )
    stems = [sanitize(name) for name, _ in keys]
    groups = []
    for (name, scenario_hash), stem in zip(keys, stems, strict=True):
        if stems.count(stem) > 1:
            stem = f"{stem}-{scenario_hash[:8]}"
        rows = episodes[episodes["scenario_hash"].astype(str) == scenario_hash]
        groups.append(ScenarioGroup(stem, scenario_hash, name, prepare_episodes(rows)))
    return groups


def suite_group(episodes: pd.DataFrame, name: str) -> ScenarioGroup:
    """All episodes as one suite (e.g. the held-out random scenarios): each (scenario, seed) is a block.

    Paired statistics need blocks in which every policy flew the same episode; in a suite that is
    the pair (scenario, seed), so the ``seed`` column becomes a block index (the episode seed stays
    in ``episode_seed``) and the tables, tests and figures work unchanged.
    """
    frame = episodes.copy()
    pairs = list(zip(frame["scenario_hash"].astype(str), frame["seed"].astype(int), strict=True))
    blocks = {pair: i for i, pair in enumerate(sorted(set(pairs)))}
    frame["episode_seed"] = frame["seed"]
    frame["seed"] = [blocks[pair] for pair in pairs]
    hashes = sorted(set(frame["scenario_hash"].astype(str)))
    suite_hash = hashlib.sha256(",".join(hashes).encode()).hexdigest()[:16]
    names = tuple(sorted(set(frame["scenario"].astype(str))))
    frame["episode_scenario_hash"] = frame["scenario_hash"]
    frame["scenario_hash"] = suite_hash
    return ScenarioGroup(sanitize(name), suite_hash, name, prepare_episodes(frame), names)


def cost_table(episodes: pd.DataFrame, column: str = "total_cost") -> pd.DataFrame:
    """Seeds x policies table of one episode column, from finished (non-error) episodes only.

    Args:
        episodes: one scenario group's rows (``prepare_episodes`` is applied if needed).
        column: the value to tabulate.

    Returns:
        Rows = sorted seeds, columns = sorted policy labels, NaN where a policy has no finished episode.
    """
    frame = episodes if "is_error" in episodes else prepare_episodes(episodes)
    valid = frame[~frame["is_error"]]
    labels = sorted(frame["label"].unique())
    table = valid.groupby(["seed", "label"])[column].mean().unstack("label")
    table = table.reindex(columns=labels).sort_index()
    table.index = table.index.astype(int)
    return table


DEFAULT_REFERENCE = "ihpso"
FALLBACK_REFERENCE = "greedy"


def resolve_reference(labels: Sequence[str], episodes: pd.DataFrame, reference: str) -> str | None:
    """The label that stands for ``reference``: itself, else the configuration of that name with most episodes.

    DECISION (api.md §4.5, the default reference): when the default reference (``ihpso``) is not
    in the group, the table compares against the greedy floor if it is there, else against the
    policy with the most finished seeds (ties: the first label): every table a run, the
    leaderboard command and the report write from the same store then has the same reference and
    a filled Δ column. An explicitly named reference is never replaced (the command line refuses
    one that names nothing stored); it gives None when absent from this group.
    """
    found = _named(labels, episodes, reference)
    if found is not None or reference != DEFAULT_REFERENCE:
        return found
    found = _named(labels, episodes, FALLBACK_REFERENCE)
    if found is not None:
        return found
    finished = episodes[~episodes["is_error"]]
    if finished.empty:
        return None
    counts = finished.groupby("label")["seed"].nunique()
    return str(sorted(counts.index, key=lambda label: (-counts[label], str(label)))[0])


def _named(labels: Sequence[str], episodes: pd.DataFrame, reference: str) -> str | None:
    if reference in labels:
        return reference
    named = episodes[(episodes["policy"] == reference) & ~episodes["is_error"]]
    if named.empty:
        return None
    counts = named.groupby("label").size()
    return str(sorted(counts.index, key=lambda label: (-counts[label], label))[0])
