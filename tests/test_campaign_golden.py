"""The campaign files plan exactly the commands the retired benchmarks/publish.py planned.

``tests/fixtures/campaign/golden.json`` was written by ``make_golden.py`` from publish.py at the
commit it records, before the campaign runner replaced it: per version (v2, v3) and per state of
the RL programme (a made-up snapshot with its agents finished or still training, no agents at all,
the published snapshot), the parts in order with their wait reason and their commands.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from uav_penetration_env.benchmark.campaign.agents import agent_models
from uav_penetration_env.benchmark.campaign.log import command_key
from uav_penetration_env.benchmark.campaign.plan import plan
from uav_penetration_env.benchmark.campaign.runner import run_campaign
from uav_penetration_env.benchmark.campaign.spec import AgentSource, load_campaign_file

REPO = Path(__file__).resolve().parents[1]
FIXTURE = Path("tests/fixtures/campaign")
GOLDEN = json.loads((REPO / FIXTURE / "golden.json").read_text())
RL = FIXTURE / "rl"
# Each golden case: the agents' folder and selection record, and the programme's unfinished steps.
CASES = {
    "fixture-finished": (RL / "models", RL, []),
    "fixture-waiting": (RL / "models", RL, ["train/td3-paper-s0", "train/td3-paper-s1"]),
    "no-agents": (RL / "empty", RL / "empty", ["tune/ppo-paper"]),
    "published": (Path("leaderboards/rl/models"), Path("leaderboards/rl"), []),
}


def spec_of(version: str, models: Path, rl_root: Path):
    spec = load_campaign_file(REPO / "leaderboards" / "campaigns" / f"{version}.yaml")
    return dataclasses.replace(
        spec, agents=AgentSource(models, rl_root / "tune" / "ppo-paper" / "selection.yaml")
    )


@pytest.mark.parametrize("version", ["v2", "v3"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_the_campaign_file_plans_the_commands_publish_py_planned(version, case):
    models, rl_root, unfinished = CASES[case]
    spec = spec_of(version, models, rl_root)
    planned = [{"part": part.name, "waits": part.waits, "commands": [command_key(c) for c in part.commands]}
               for part in plan(spec, REPO, pending=lambda: list(unfinished))]  # fmt: skip
    assert planned == GOLDEN["parts"][f"{version}/{case}"]


@pytest.mark.parametrize("version", ["v2", "v3"])
def test_the_dry_run_prints_what_publish_py_printed(version, tmp_path, capsys):
    """The published snapshot's dry run, line for line, on an empty log (while its agents are those recorded)."""
    published = sorted(p.name for p in agent_models(REPO, Path("leaderboards/rl/models")))
    if published != GOLDEN["published_agents"]:
        pytest.skip(
            "leaderboards/rl/models changed since the golden dry run; the fixture cases still compare"
        )
    spec = dataclasses.replace(load_campaign_file(REPO / "leaderboards" / "campaigns" / f"{version}.yaml"),
                               root=tmp_path)  # an empty compute log  # fmt: skip
    assert run_campaign(spec, REPO, dry_run=True, pending=list) == 0
    lines = [
        line
        for line in capsys.readouterr().out.splitlines()
        if line.startswith(("[plan]", "[wait]", "[done]"))
    ]
    assert lines == GOLDEN["dry_run"][version]
