"""The campaign runner (uav-bench campaign): its plan, the clean-tree guard, the compute log, the
rebuild check, install, compute and carrying a campaign across sessions (docs/publishing.md)."""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path

import pytest

from uav_penetration_env.benchmark.campaign import actions, carry, process, runner
from uav_penetration_env.benchmark.campaign.agents import chosen_paper_ppo
from uav_penetration_env.benchmark.campaign.compute import (
    compute_table,
    imitation_compute,
    rl_compute,
    worker_seconds,
)
from uav_penetration_env.benchmark.campaign.install import compare_rebuild, install_folder, install_replace
from uav_penetration_env.benchmark.campaign.log import (
    REBUILD_CHECK,
    append_attempt,
    command_key,
    done_commands,
    read_log,
)
from uav_penetration_env.benchmark.campaign.log import rebuild_checked as checked
from uav_penetration_env.benchmark.campaign.plan import plan
from uav_penetration_env.benchmark.campaign.spec import (
    AgentSource,
    CampaignFileError,
    campaign_from_mapping,
    load_campaign_file,
)
from uav_penetration_env.benchmark.commands.common import OUT_SOURCE_FILE

REPO = Path(__file__).resolve().parents[1]
DERIVED = ("best-known", "tables")


def campaign(version, models=Path("models"), rl_root=Path("rl")):
    """The published campaign file, its agents read from ``models`` (relative to the test's repo)."""
    spec = load_campaign_file(REPO / "leaderboards" / "campaigns" / f"{version}.yaml")
    return dataclasses.replace(
        spec, agents=AgentSource(models, rl_root / "tune" / "ppo-paper" / "selection.yaml")
    )


def fake_agent(folder, name, interrupted=False):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.zip").write_bytes(b"zip")
    (folder / f"{name}.json").write_text(json.dumps({"interrupted": interrupted}))


def attempt(part, command, status=0):
    return {"part": part, "command": command, "status": status, "wall_s": 1.0, "cpu_s": 1.0}


def rebuild_checked(attempts, commands=()):
    return checked(attempts, "tables", commands, DERIVED)


def write_files(folder: Path, files: dict[str, str]) -> None:
    """Write each file of ``files`` (path under ``folder`` -> text), its folders made as needed."""
    for name, text in files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def compute_log(folder: Path) -> Path:
    """``folder/compute.jsonl`` holding one logged attempt of the paper part (its path)."""
    log = folder / "compute.jsonl"
    write_files(folder, {"compute.jsonl": '{"part": "paper", "wall_s": 1.0, "cpu_s": 2.0}\n'})
    return log


def test_agents_wait_for_the_rl_programme(tmp_path):
    parts = plan(campaign("v2"), tmp_path, pending=lambda: ["train/sac-paper-s2"])
    assert [p.name for p in parts] == ["paper", "windows", "suite", "windows-suite", "held-out", "agents",
                                       "best-known", "tables"]  # fmt: skip
    held_out = parts[4].commands[0]
    assert held_out[:3] == ["run", "--suite", "uavpen-heldout-v1"] and "greedy" in held_out
    agents = parts[5]
    assert agents.commands == [] and "1 unfinished steps (train/sac-paper-s2" in agents.waits


def test_agents_finished_so_far_fly_while_the_programme_runs(tmp_path):
    """Incremental: the waiting part names the finished agents; a later plan names more of them."""
    fake_agent(tmp_path / "models", "ppo-paper-zoo-s0")
    fake_agent(tmp_path / "models", "sac-paper-s0", interrupted=True)  # still training: not flown
    early = plan(campaign("v2"), tmp_path, pending=lambda: ["train/sac-paper-s0"])[5]
    assert early.waits and [c[:2] for c in early.commands] == [["run", "--scenarios"], ["run", "--suite"],
                                                                ["run", "--scenarios"]]  # fmt: skip
    assert "sb3:models/ppo-paper-zoo-s0.zip" in early.commands[0]
    assert not any("sac-paper-s0" in " ".join(c) for c in early.commands)
    fake_agent(tmp_path / "models", "sac-paper-s0")
    late = plan(campaign("v2"), tmp_path, pending=list)[5]
    assert not late.waits and any("sac-paper-s0" in " ".join(c) for c in late.commands)
    assert command_key(late.commands[0]) != command_key(early.commands[0])


def test_the_warm_started_agents_are_the_set_the_confirmation_chose(tmp_path):
    agents = [
        f"sb3:m/{n}.zip" for n in ("ppo-paper-s0", "ppo-paper-zoo-s0", "ppo-paper-zoo-s1", "sac-paper-s0")
    ]
    record = tmp_path / "selection.yaml"
    assert chosen_paper_ppo(agents, record) == agents[:3]  # no record: every PPO paper agent
    record.write_text("chosen: study\n")
    assert chosen_paper_ppo(agents, record) == agents[:1]
    record.write_text("chosen: zoo\n")
    assert chosen_paper_ppo(agents, record) == agents[1:3]


def test_commands_import_this_tree_and_a_wait_is_not_success(tmp_path, monkeypatch, capsys):
    env = process.child_environment(tmp_path)
    assert env["PYTHONPATH"].split(os.pathsep)[0] == str(tmp_path)
    spec = campaign("v2")  # no finished agent under tmp_path: nothing flies first
    assert (
        runner.run_campaign(spec, tmp_path, only=["agents"], pending=lambda: ["tune/ppo-random"])
        == runner.WAITING
        == 3
    )
    assert "[wait] agents: the RL programme has 1 unfinished steps" in capsys.readouterr().out


def test_the_pending_command_is_asked_for_the_unfinished_steps(tmp_path):
    """``agents.pending`` prints one step per line; a failing command is named, not read as finished."""
    from uav_penetration_env.benchmark.campaign.agents import pending_steps

    source = AgentSource(
        Path("models"), pending=("python", "-c", "print('tune/ppo-paper'); print('train/x')")
    )
    assert pending_steps(tmp_path, source, dict(os.environ)) == ["tune/ppo-paper", "train/x"]
    failing = AgentSource(Path("models"), pending=("python", "-c", "raise SystemExit('no programme')"))
    with pytest.raises(SystemExit, match=r"agents.pending: python -c .* exited 1 \(no programme\)"):
        pending_steps(tmp_path, failing, dict(os.environ))


def test_install_needs_a_passed_rebuild_check(tmp_path, capsys):
    key = {"part": "tables", "wall_s": 1.0, "cpu_s": 1.0}
    assert not rebuild_checked([{**key, "command": "uav-bench report", "status": 0}])
    assert not rebuild_checked([{**key, "command": REBUILD_CHECK, "status": 1}])
    assert rebuild_checked([{**key, "command": REBUILD_CHECK, "status": 0}])
    assert actions.install(tmp_path, campaign("v2")) == 1
    assert "refused: the tables part has not ended with a passed rebuild check" in capsys.readouterr().err


def test_derived_parts_done_before_new_rows_run_again():
    """A first publication before the agents part: its best-known and tables go stale when agents run."""
    first = [attempt("held-out", "run held"), attempt("best-known", "bk"), attempt("tables", "plot"),
             attempt("tables", REBUILD_CHECK)]  # fmt: skip
    assert done_commands(first, DERIVED) == {"run held", "bk", "plot", REBUILD_CHECK}
    assert rebuild_checked(first)
    # The agents part's attempt, even a failed one, may have written rows: both derived parts rerun.
    later = [*first, attempt("agents", "run agents", status=1)]
    assert done_commands(later, DERIVED) == {"run held"}
    assert not rebuild_checked(later)
    # best-known again makes the tables stale but not the run parts; the tables again are current.
    again = [*later, attempt("agents", "run agents"), attempt("best-known", "bk")]
    assert done_commands(again, DERIVED) == {"run held", "run agents", "bk"}
    assert rebuild_checked([*again, attempt("tables", "plot"), attempt("tables", REBUILD_CHECK)])


def test_agent_commands_cover_every_finished_agent(tmp_path):
    for name in (
        "ppo-paper-s0",
        "ppo-paper-zoo-s0",
        "ppo-paper-zoo-s1",
        "ppo-random-zoo-s0",
        "sac-random-s0",
    ):
        fake_agent(tmp_path / "models", name)
    fake_agent(tmp_path / "models", "td3-paper-s0", interrupted=True)  # a run cut short is not published
    record = tmp_path / "rl" / "tune" / "ppo-paper" / "selection.yaml"
    record.parent.mkdir(parents=True)
    record.write_text("chosen: zoo\n")
    parts = {part.name: part for part in plan(campaign("v2"), tmp_path, pending=list)}
    paper, random_suite, held_out, hybrid = parts["agents"].commands
    agents = [f"sb3:models/{n}.zip" for n in
              ("ppo-paper-s0", "ppo-paper-zoo-s0", "ppo-paper-zoo-s1", "ppo-random-zoo-s0", "sac-random-s0")]  # fmt: skip
    assert paper[paper.index("--policies") + 1 : paper.index("--seeds")] == agents
    assert random_suite[:3] == ["run", "--suite", "uavpen-v1"] and random_suite[4:6] == agents[3:]
    assert held_out[:3] == ["run", "--suite", "uavpen-heldout-v1"]
    assert held_out[held_out.index("--policies") + 1 : held_out.index("--store")] == agents
    assert hybrid[hybrid.index("--policies") + 1 : hybrid.index("--seeds")] == [
        f"ihpso+{a}" for a in agents[1:3]
    ]


@pytest.mark.parametrize("version", ["v2", "v3"])
def test_every_command_parses_with_the_real_cli_or_its_script(tmp_path, version):
    from uav_penetration_env.benchmark.cli import build_parser
    from uav_penetration_env.benchmark.publishing.terminal_cost_table import build_parser as table_parser

    fake_agent(tmp_path / "models", "ppo-paper-zoo-s0")
    parser, table = build_parser(), table_parser()
    parser.exit_on_error = table.exit_on_error = False
    for part in plan(campaign(version), tmp_path, pending=list):
        for command in part.commands:
            if command[0].endswith(".py"):
                assert command_key(command).startswith("python benchmarks/terminal_cost_table.py --part")
                table.parse_args(command[1:])
            else:
                parser.parse_args(command)


def test_the_rebuild_check_ignores_only_the_date_line(tmp_path):
    out, check = tmp_path / "out", tmp_path / "check"
    out.mkdir(), check.mkdir()
    table = "# Leaderboard\n\n- Commits: `abc`\n- Date: {}\n\n| a |\n| 1 |\n"
    (out / "paper.md").write_text(table.format("2026-11-29T19:00:00+00:00"))
    (check / "paper.md").write_text(table.format("2026-11-30T08:00:00+00:00"))
    (out / "paper.csv").write_text("a\n1\n")
    (check / "paper.csv").write_text("a\n1\n")
    assert compare_rebuild(out, check) == []
    (check / "paper.csv").write_text("a\n2\n")
    assert compare_rebuild(out, check) == ["paper.csv"]
    (check / "suite.md").write_text("only rebuilt\n")
    assert compare_rebuild(out, check) == ["paper.csv", "suite.md"]
    (out / "rl.md").write_text("only written from the store\n")  # a table the rows lost is a difference
    assert compare_rebuild(out, check) == ["paper.csv", "rl.md", "suite.md"]


@pytest.mark.parametrize(
    ("dirty", "package", "refused"),
    [
        (["optimizers/ihpso.py"], "uav_penetration_env", "tracked files differ from the commit (optimizers/ihpso.py)"),
        ([], "/elsewhere/uav_penetration_env", "the commands would import /elsewhere/uav_penetration_env"),
    ],
    ids=["dirty tree", "package of another tree"],
)
def test_nothing_runs_on_a_dirty_tree_or_with_the_package_of_another_tree(
    dirty, package, refused, tmp_path, monkeypatch, capsys
):
    monkeypatch.setattr(process, "dirty_files", lambda repo: dirty)
    # A relative package lies inside the campaign's tree (tmp_path); the absolute one elsewhere.
    monkeypatch.setattr(process, "imported_from", lambda repo: tmp_path / package)
    ran = []
    monkeypatch.setattr(process, "run_attempt", lambda *args: ran.append(args) or 0)
    assert runner.run_campaign(campaign("v2"), tmp_path, only=["paper"], pending=list) == 1
    assert ran == [] and f"refused: {refused}" in capsys.readouterr().err


def test_done_commands_are_skipped_and_compute_sums_every_attempt(tmp_path, monkeypatch, capsys):
    spec = campaign("v2")
    paper = command_key(plan(spec, tmp_path, pending=list)[0].commands[0])
    attempts = [
        {"part": "paper", "command": paper, "wall_s": 3600.0, "cpu_s": 5400.0, "status": 130},
        {"part": "paper", "command": paper, "wall_s": 1800.0, "cpu_s": 3600.0, "status": 0},
    ]
    (tmp_path / spec.root).mkdir(parents=True)
    (tmp_path / spec.log).write_text("".join(json.dumps(a) + "\n" for a in attempts))
    assert runner.run_campaign(spec, tmp_path, only=["paper"], dry_run=True, pending=list) == 0
    assert capsys.readouterr().out.startswith("[done] paper: uav-bench run --scenarios paper paper-w2")
    table = actions.compute(tmp_path, spec)
    assert "| paper | 2 | 1.50 | 2.50 |" in table and "| total | | 1.50 | 2.50 |" in table


def test_a_damaged_compute_log_is_named(tmp_path):
    log = tmp_path / "compute.jsonl"
    log.write_text('{"part": "paper"}\nnot json\n')
    with pytest.raises(SystemExit, match=r"compute\.jsonl:2: not a JSON line"):
        read_log(log)


def test_rl_compute_sums_trial_durations_and_training_wall_time(tmp_path):
    study = tmp_path / "tune" / "ppo-paper"
    study.mkdir(parents=True)
    (study / "ppo-paper.trials.csv").write_text("number,state,duration_s\n0,COMPLETE,600\n1,PRUNED,300\n")
    models = tmp_path / "models"
    models.mkdir()
    for name, seconds in (("ppo-paper-s0", 1800.0), ("ppo-paper-zoo-s0", 5400.0)):
        (models / f"{name}.json").write_text(json.dumps({"wall_seconds": seconds}))
    assert rl_compute(tmp_path) == [("RL tuning (2 trials)", 2, 900.0), ("RL training (2 runs)", 2, 7200.0)]
    table = compute_table([], DERIVED, rl_root=tmp_path)
    assert "| RL tuning (2 trials) | | 0.25 |" in table and "| RL training (2 runs) | | 2.00 |" in table
    assert "imitation" not in table


def test_the_imitation_row_sums_the_distilled_networks_sidecars(tmp_path):
    for name, labels, seconds in (("a", 1000, 1800.0), ("b", 234, 5400.0)):
        (tmp_path / name).mkdir()
        (tmp_path / name / "policy.json").write_text(
            json.dumps({"expert_labels": labels, "train_cpu_seconds": seconds})
        )
    assert imitation_compute(tmp_path) == ("imitation training (2 networks, 1,234 expert labels)", 7200.0)
    table = compute_table([], DERIVED, distill_root=tmp_path)
    assert "| imitation training (2 networks, 1,234 expert labels) | | | 2.00 | | |" in table
    assert imitation_compute(tmp_path / "none") is None


def test_install_replaces_the_generated_files_and_commits_the_compute_log(tmp_path):
    out, target = tmp_path / "results/v2/out", tmp_path / "leaderboards"
    write_files(out, {"index.html": "<html></html>", "paper-2022-sec5.md": "v2", "rows/leaderboard-episodes.parquet": "rows"})
    write_files(target, {
        "held-out-random-d0.5.md": "v1",  # a v1 table v2 no longer writes
        "models/ppo-paper-s0.zip": "v1 agent",
        "rl/state.json": "{}",
    })  # fmt: skip
    log = compute_log(tmp_path / "results/v2")
    copied = install_replace(out, target, log)
    assert sorted(p.relative_to(target).as_posix() for p in copied) == [
        "compute.jsonl", "index.html", "paper-2022-sec5.md", "rows/leaderboard-episodes.parquet"
    ]  # fmt: skip
    assert not (target / "held-out-random-d0.5.md").exists() and not (target / "models").exists()
    assert (target / "rl" / "state.json").is_file()  # the RL programme's snapshot stays
    assert (target / "compute.jsonl").read_text() == log.read_text()


def test_v3_installs_into_its_own_folder_without_the_exported_rows(tmp_path):
    """v2's tables stay; v3's folder is replaced whole, its rows are the committed chunks (publishing.md §5.5)."""
    out, target = tmp_path / "results/v3/out", tmp_path / "leaderboards/v3"
    write_files(out, {
        "index.html": "<html></html>",
        "uavpen-v1.csv": "v3",
        "ctg-sensitivity/sensitivity.md": "forms",
        "rows/leaderboard-steps.parquet": "rows",
        OUT_SOURCE_FILE: "results/v3/leaderboard.sqlite",
    })  # fmt: skip
    write_files(target, {"stale.md": "an earlier v3 table no longer written"})
    write_files(tmp_path / "leaderboards", {"paper-2022-sec5.md": "v2"})
    log = compute_log(tmp_path / "results/v3")
    copied = install_folder(out, target, log)
    assert sorted(p.relative_to(target).as_posix() for p in copied) == [
        "compute.jsonl", "ctg-sensitivity/sensitivity.md", "index.html", "uavpen-v1.csv"
    ]  # fmt: skip
    assert (tmp_path / "leaderboards" / "paper-2022-sec5.md").read_text() == "v2"
    assert not (tmp_path / "leaderboards" / "v3.installing").exists()
    assert not (tmp_path / "leaderboards" / "v3.previous").exists()
    assert (target / "compute.jsonl").read_text() == log.read_text()
    assert (
        campaign("v3").install.target == Path("leaderboards/v3") and campaign("v3").install.mode == "folder"
    )


def test_worker_time_counts_finished_work_of_every_attempt_logged_or_not():
    from types import SimpleNamespace

    import pandas as pd

    paper = "uav-bench run --scenarios paper --policies ihpso"
    runs = pd.DataFrame({"run_id": [1, 2, 3], "provenance": [json.dumps({"command": c}) for c in
                                                              (paper, paper, "uav-bench windows --x")]})  # fmt: skip
    # Run 1 was killed with its session (no log line); run 2, the same command resumed, was logged.
    episodes = pd.DataFrame({"run_id": [1, 1, 2], "episode_seconds": [1800.0, 1800.0, 3600.0]})
    windows = pd.DataFrame({"run_id": [3, 3], "seconds": [360.0, 360.0]})
    worker = worker_seconds(SimpleNamespace(runs=runs, episodes=episodes, window_runs=windows))
    assert worker == {paper: (3, 7200.0), "uav-bench windows --x": (2, 720.0)}
    attempts = [{"part": "paper", "command": paper, "wall_s": 1800.0, "cpu_s": 3600.0, "status": 0}]
    table = compute_table(attempts, ("paper",), worker=worker)
    assert "| paper | 1 | 0.50 | 1.00 | 3 | 2.00 |" in table
    assert "| (runs of no logged command) | | | | 2 | 0.20 |" in table
    assert "| total | | 0.50 | 1.00 | | 2.20 |" in table


def tiny_store(tmp_path, store, seeds):
    from tests.conftest import tiny_scenario
    from uav_penetration_env.benchmark import cli

    scenario = tmp_path / "tiny.yaml"
    if not scenario.is_file():
        tiny_scenario(time={"max_steps": 6}).to_yaml(scenario)
    assert cli.main(["run", "--policies", "greedy", "--scenarios", str(scenario), "--seeds", seeds, "--store",
                     str(store), "--jobs", "1", "--no-report", "--no-progress"]) == 0  # fmt: skip


def in_process(monkeypatch):
    """``uav-bench`` commands in this process (no interpreter start per command), from ``repo``."""
    from uav_penetration_env.benchmark import cli

    def bench(repo, argv):
        here = Path.cwd()
        os.chdir(repo)
        try:
            return cli.main(list(argv))
        finally:
            os.chdir(here)

    for module in (carry, process):
        monkeypatch.setattr(module, "bench", bench)


def test_from_published_rebuilds_a_missing_store_and_log_once(tmp_path, monkeypatch, capsys):
    from uav_penetration_env.benchmark import cli
    from uav_penetration_env.benchmark.rows import store_tables

    in_process(monkeypatch)
    original = tmp_path / "original.sqlite"
    tiny_store(tmp_path, original, "2")
    rows = tmp_path / "leaderboards" / "rows" / "leaderboard"
    assert cli.main(["export", "--format", "parquet", "--store", str(original), "--out", str(rows)]) == 0
    (tmp_path / "leaderboards" / "compute.jsonl").write_text(
        '{"part": "paper", "command": "c", "status": 0}\n'
    )
    spec = campaign("v2")
    assert actions.rebuild_from_published(tmp_path, spec) == 0
    assert store_tables(tmp_path / spec.layout.store).episodes.equals(store_tables(original).episodes)
    assert read_log(tmp_path / spec.log) == [{"part": "paper", "command": "c", "status": 0}]
    with pytest.raises(FileExistsError, match="exists; --from-published only rebuilds a missing store"):
        actions.rebuild_from_published(tmp_path, spec)


def test_a_check_alone_after_new_rows_does_not_pass_for_rebuilt_tables():
    """The check must follow every tables command rerun after the last rows, not only be the last line."""
    tables = ["plot", "report"]
    published = [
        attempt("agents", "run a"),
        *(attempt("tables", c) for c in tables),
        attempt("tables", REBUILD_CHECK),
    ]
    assert rebuild_checked(published, tables)
    # new agents flew, best-known ran, and a check was logged without the tables being rebuilt
    stale = [
        *published,
        attempt("agents", "run b"),
        attempt("best-known", "bk"),
        attempt("tables", REBUILD_CHECK),
    ]
    assert not rebuild_checked(stale, tables)
    assert rebuild_checked(stale)  # what the check alone would have said
    rebuilt = [*stale, *(attempt("tables", c) for c in tables), attempt("tables", REBUILD_CHECK)]
    assert rebuild_checked(rebuilt, tables)


def test_derived_parts_rerun_in_the_same_invocation_after_new_rows(tmp_path, monkeypatch):
    monkeypatch.setattr(process, "dirty_files", lambda repo: [])
    monkeypatch.setattr(process, "imported_from", lambda repo: repo)
    monkeypatch.setattr(runner, "compare_rebuild", lambda *args: [])
    fake_agent(tmp_path / "models", "ppo-paper-s0")
    spec = campaign("v2")
    parts = plan(spec, tmp_path, pending=list)
    log = tmp_path / spec.log
    log.parent.mkdir(parents=True)
    # everything published once; then a new agent makes the agents part's commands new
    logged = [attempt(part.name, command_key(c)) for part in parts for c in part.commands]
    logged = [a for a in logged if a["part"] != "agents"] + [attempt("tables", REBUILD_CHECK)]
    log.write_text("".join(json.dumps(a) + "\n" for a in logged))
    ran = []

    def run_attempt(repo, part, argv, path):
        ran.append(part)
        append_attempt(path, attempt(part, command_key(argv)))
        return 0

    monkeypatch.setattr(process, "run_attempt", run_attempt)
    assert runner.run_campaign(spec, tmp_path, pending=list) == 0
    tables = next(p for p in parts if p.name == "tables")
    assert ran == ["agents"] * len(parts[5].commands) + ["best-known"] + ["tables"] * len(tables.commands)
    assert rebuild_checked(read_log(log), [command_key(c) for c in tables.commands])


def test_v3_seed_checkpoint_and_resume_round_trip(tmp_path, monkeypatch, capsys):
    """Seeded from two stores (colliding ids), checkpointed twice (only new runs), resumed: the same episodes."""
    from uav_penetration_env.benchmark import cli
    from uav_penetration_env.benchmark.rows import read_table, store_tables

    in_process(monkeypatch)
    spec = campaign("v3")
    stems = []
    for name, seeds in (("a", "2"), ("b", "2:3")):  # two stores: both start their ids at 1
        tiny_store(tmp_path, tmp_path / f"{name}.sqlite", seeds)
        stems.append(Path(f"seed/{name}"))
        assert cli.main(["export", "--format", "parquet", "--store", str(tmp_path / f"{name}.sqlite"),
                         "--out", str(tmp_path / stems[-1])]) == 0  # fmt: skip
    assert actions.seed(tmp_path, spec, stems) == 0
    store = tmp_path / spec.layout.store
    held = store_tables(store).episodes
    assert sorted(held.seed) == [0, 1, 2] and held.episode_id.is_unique and held.run_id.nunique() == 2
    with pytest.raises(FileExistsError, match="exists; this only rebuilds a missing store"):
        actions.seed(tmp_path, spec, stems)
    log = tmp_path / spec.log
    log.write_text('{"part": "paper", "command": "c", "status": 0}\n')
    folder = Path("leaderboards/v3-checkpoint")
    assert carry.checkpoint(tmp_path, spec, folder) is None  # only seed rows: named, not copied
    assert carry.read_manifest(tmp_path / folder)["seeds"] == [s.as_posix() for s in stems]
    tiny_store(tmp_path, store, "4")  # seed 3 is new: one more run, one more episode
    first = carry.checkpoint(tmp_path, spec, folder)
    assert first == folder / "chunk-001" and read_table(tmp_path / first, "episodes").seed.tolist() == [3]
    steps = read_table(tmp_path / first, "steps")
    assert set(steps.episode_id) == set(read_table(tmp_path / first, "episodes").episode_id)
    assert carry.checkpoint(tmp_path, spec, folder) is None  # nothing new since
    expected = store_tables(store).episodes
    for path in (store, log, tmp_path / spec.root / "seeded.json"):
        path.unlink()
    assert actions.resume_from_checkpoint(tmp_path, spec) == 0
    rebuilt = store_tables(store).episodes
    assert rebuilt.drop(columns="finished").equals(expected.drop(columns="finished"))
    assert read_log(log) == [{"part": "paper", "command": "c", "status": 0}]
    with pytest.raises(FileExistsError):
        actions.resume_from_checkpoint(tmp_path, spec)


def test_the_carry_flags_need_a_carry_section(capsys):
    from uav_penetration_env.benchmark import cli

    assert cli.main(["campaign", str(REPO / "leaderboards/campaigns/v2.yaml"), "--checkpoint"]) == 2
    err = capsys.readouterr().err
    assert "--checkpoint: " in err and "v2.yaml has no carry section" in err


def test_merged_rows_refuse_an_episode_twice(tmp_path):
    from uav_penetration_env.benchmark import cli

    tiny_store(tmp_path, tmp_path / "a.sqlite", "1")
    assert (
        cli.main(
            [
                "export",
                "--format",
                "parquet",
                "--store",
                str(tmp_path / "a.sqlite"),
                "--out",
                str(tmp_path / "a"),
            ]
        )
        == 0
    )
    with pytest.raises(SystemExit, match=r"^episode greedy on .* seed 0 is in two of"):
        carry.merge_rows([tmp_path / "a", tmp_path / "a"], tmp_path / "merged")


MINIMAL = {"name": "t", "root": "results/t", "parts": [{"name": "a", "commands": [["run", "--store", "$store"]]}],
           "install": {"target": "out"}}  # fmt: skip


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"colour": 1}, r"t\.colour: got 1, expected no such key"),
        ({"parts": []}, r"t\.parts: got \[\], expected a non-empty list of parts"),
        ({"parts": [{"name": "a", "commands": [["run", "$nope"]]}]}, r"t\.parts\.a: got '\$nope', expected a known name"),
        ({"parts": [{"name": "a", "commands": [["x"]]}, {"name": "a", "commands": [["y"]]}]}, r"expected each part name once"),
        ({"parts": [{"name": "d", "derived": True, "commands": [["x"]]}, {"name": "r", "commands": [["y"]]}]},
         r"expected the derived parts last"),
        ({"install": {"target": "out", "mode": "copy"}}, r"t\.install\.mode: got 'copy', expected one of replace, folder"),
        ({"lists": {"l": ["a"]}, "parts": [{"name": "a", "commands": [["x", "--y=${l}"]]}]}, r"\$\{NAME\} of a path"),
        ({"parts": [{"name": "a", "waits_for_agents": True, "commands": [["x"]]}]}, r"t\.agents: got None, expected an agents section"),
        ({"lists": ["a"]}, r"t\.lists: got \['a'\], expected a mapping of names to lists of strings"),
        ({"layout": {"out": 3}}, r"t\.layout\.out: got 3, expected a non-empty string"),
        ({"parts": [{"name": "a", "commands": [["x", {"k": 1}]]}]}, r"t\.parts\[0\]\.commands\[0\]: got .*, expected a list of strings"),
    ],
)  # fmt: skip
def test_a_bad_campaign_file_is_one_line_naming_the_field(change, message):
    with pytest.raises(CampaignFileError, match=message):
        campaign_from_mapping({**MINIMAL, **change}, source="t")


def test_names_fill_whole_items_and_paths_inside_strings_and_an_empty_list_drops_its_command(tmp_path):
    data = {**MINIMAL, "lists": {"common": ["--store", "$store"], "none": []},
            "parts": [{"name": "a", "commands": [["run", "$common", "--figures", "${out}/x.png"], ["run", "$none"]]}]}  # fmt: skip
    (part,) = plan(campaign_from_mapping(data, source="t"), tmp_path)
    assert part.commands == [
        ["run", "--store", "results/t/leaderboard.sqlite", "--figures", "results/t/out/x.png"]
    ]


def test_an_attempt_is_logged_with_its_status_and_times(tmp_path):
    """A script of the tree runs under this Python in ``repo``; its attempt is one log line, whatever its status."""
    (tmp_path / "step.py").write_text(
        "import pathlib, sys\npathlib.Path('ran').write_text('yes')\nsys.exit(4)\n"
    )
    log = tmp_path / "results" / "compute.jsonl"
    assert process.run_attempt(tmp_path, "paper", ["step.py", "--flag"], log) == 4
    assert (tmp_path / "ran").read_text() == "yes"  # it ran in the repository
    (line,) = read_log(log)
    assert {k: line[k] for k in ("part", "command", "status", "commit")} == {
        "part": "paper", "command": "python step.py --flag", "status": 4, "commit": "unknown"
    }  # fmt: skip
    assert line["wall_s"] >= 0.0 and line["cpu_s"] >= 0.0
    assert done_commands(read_log(log)) == set()  # a failed attempt is not done


def test_a_bad_campaign_file_is_one_error_line_from_the_command(tmp_path, capsys):
    from uav_penetration_env.benchmark import cli

    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nroot: r\nparts: [{name: a, commands: [[run, $nope]]}]\ninstall: {target: t}\n")
    assert cli.main(["campaign", str(bad), "--dry-run"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "uav-bench: error: bad.yaml.parts.a: got '$nope', expected a known name (known: check, out, root, rows, store)"
    ]
    assert cli.main(["campaign", str(REPO / "leaderboards/campaigns/v3.yaml"), "--only", "nope"]) == 2
    assert "--only nope: unknown part; expected some of paper, windows" in capsys.readouterr().err
