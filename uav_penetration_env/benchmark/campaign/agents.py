"""The RL programme's finished agents, as a campaign flies them (docs/publishing.md §1, docs/rl.md §3).

Read from the programme's committed snapshot: the finished agents (a sidecar that does not say
``interrupted``), the Random-regime ones among them, and the PPO paper agents of the set the
full-budget confirmation chose, which warm-start IHPSO. Whether the programme has unfinished steps
is asked of the programme itself, through the command the campaign names (``agents.pending``), so
the harness imports nothing from ``baselines``.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

from uav_penetration_env.benchmark.campaign.spec import AgentSource

PendingSteps = Callable[[], list[str]]


def agent_models(repo: Path, models: Path) -> list[Path]:
    """The finished agents in ``models``, in name order (checkpoints left out).

    ``models`` is relative to ``repo`` (as the commands name it); the result is too.
    """
    finished = []
    for model in sorted((repo / models).glob("*.zip")):
        sidecar = model.with_suffix(".json")
        if sidecar.is_file() and not json.loads(sidecar.read_text()).get("interrupted"):
            finished.append(Path(models) / model.name)
    return finished


def chosen_paper_ppo(agents: list[str], selection: Path | None) -> list[str]:
    """The PPO paper agents of the set the confirmation chose (docs/rl.md §3.1): they warm-start IHPSO.

    Without a selection record (a programme without the confirmation), every PPO paper agent.
    """
    import yaml

    record = (
        (yaml.safe_load(selection.read_text()) or {}) if selection is not None and selection.is_file() else {}
    )
    chosen = record.get("chosen")
    paper = [a for a in agents if "/ppo-paper-" in a]
    if chosen is None:
        return paper
    return [a for a in paper if ("/ppo-paper-zoo-s" in a) == (chosen == "zoo")]


def agent_lists(repo: Path, source: AgentSource) -> dict[str, list[str]]:
    """The lists a campaign's commands splice: ``agents`` (``sb3:PATH``), ``random_agents``, ``warm_started`` (``ihpso+sb3:PATH``)."""
    agents = [f"sb3:{model.as_posix()}" for model in agent_models(repo, source.models)]
    selection = repo / source.selection if source.selection is not None else None
    return {
        "agents": agents,
        "random_agents": [a for a in agents if "-random-" in a],
        "warm_started": [f"ihpso+{a}" for a in chosen_paper_ppo(agents, selection)],
    }


def pending_steps(repo: Path, source: AgentSource, env: dict[str, str]) -> list[str]:
    """The programme's unfinished steps, as its ``pending`` command prints them (one per line).

    Raises:
        SystemExit: the command failed (its message names it).
    """
    if not source.pending:
        return []
    argv = [sys.executable if source.pending[0] == "python" else source.pending[0], *source.pending[1:]]
    done = subprocess.run(argv, cwd=repo, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        raise SystemExit(f"agents.pending: {' '.join(source.pending)} exited {done.returncode} ({last})")
    return [line.strip() for line in done.stdout.splitlines() if line.strip()]
