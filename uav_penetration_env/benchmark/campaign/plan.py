"""A campaign's plan: its parts with their commands filled in, from the file and the tree's state."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from uav_penetration_env.benchmark.campaign.agents import PendingSteps, agent_lists, pending_steps
from uav_penetration_env.benchmark.campaign.process import child_environment
from uav_penetration_env.benchmark.campaign.spec import CampaignSpec, fill


@dataclass(frozen=True)
class Part:
    """One part of a campaign, planned.

    Attributes:
        name: the part's name (``paper``).
        commands: ``uav-bench`` arguments, or a ``*.py`` script of the tree and its arguments.
        waits: why the rest of the campaign cannot run yet (``""``: it can).
        derived: computed from what earlier parts wrote (rerun when they add rows).
        rebuild_check: the tables part: its output is compared with the rebuild from rows.
    """

    name: str
    commands: list[list[str]]
    waits: str = ""
    derived: bool = False
    rebuild_check: bool = False


def names(spec: CampaignSpec, repo: Path) -> dict[str, str | list[str]]:
    """Every name a command may use: the paths, the lists (their paths filled in) and, with an agents section, the agent lists."""
    known: dict[str, str | list[str]] = {
        "root": str(spec.root), "store": str(spec.layout.store), "out": str(spec.layout.out),
        "rows": str(spec.layout.rows), "check": str(spec.layout.check),
    }  # fmt: skip
    if spec.agents is not None:
        known["models"] = str(spec.agents.models)
    paths = dict(known)
    for key, template in spec.lists.items():
        filled = fill(template, paths)
        known[key] = filled if filled is not None else []
    if spec.agents is not None:
        known.update(agent_lists(repo, spec.agents))
    return known


def plan(spec: CampaignSpec, repo: Path, pending: PendingSteps | None = None) -> list[Part]:
    """The campaign's parts, in order, with their commands.

    Args:
        spec: the campaign file.
        repo: the repository (the agents are read under it).
        pending: the RL programme's unfinished steps (default: the file's ``agents.pending`` command).

    DECISION (docs/publishing.md §1, incremental agents): while the programme runs, a part that
    waits for the agents flies those finished so far and then waits; the next attempt's commands
    name more agents, and ``uav-bench run`` skips the episodes the store holds, so only the new
    agents fly.
    """
    known = names(spec, repo)
    parts = []
    for part in spec.parts:
        commands = [argv for argv in (fill(t, known) for t in part.commands) if argv is not None]
        waits = ""
        if part.waits_for_agents and spec.agents is not None:
            waiting = (
                pending()
                if pending is not None
                else pending_steps(repo, spec.agents, child_environment(repo))
            )
            waits = (
                f"the RL programme has {len(waiting)} unfinished steps ({waiting[0]}, ...)" if waiting else ""
            )
        parts.append(Part(part.name, commands, waits, part.derived, part.rebuild_check))
    return parts
