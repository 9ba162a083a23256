"""The publication driver (benchmarks/publish.py): its commands, the clean-tree guard, the rebuild check."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from tests.test_benchmark_scripts import load
from uav_penetration_env.benchmark.commands.common import OUT_SOURCE_FILE

publish = load("publish")


def fake_agent(folder, name, interrupted=False):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.zip").write_bytes(b"zip")
    (folder / f"{name}.json").write_text(json.dumps({"interrupted": interrupted}))


def test_agents_wait_for_the_rl_programme(tmp_path):
    plan = publish.parts(tmp_path, unfinished=lambda: ["train/sac-paper-s2"])
    assert [p.name for p in plan] == list(publish.ORDER) == [
        "paper",
        "windows",
        "suite",
        "windows-suite",
        "held-out",
        "agents",
        "best-known",
        "tables",
    ]
    held_out = plan[4].commands[0]
    assert held_out[:3] == ["run", "--suite", "uavpen-heldout-v1"] and "greedy" in held_out
    agents = plan[5]
    assert agents.commands == [] and "1 unfinished steps (train/sac-paper-s2" in agents.waits


def test_agents_finished_so_far_fly_while_the_programme_runs(tmp_path):
    """Incremental: the waiting part names the finished agents; a later plan names more of them."""
    fake_agent(tmp_path, "ppo-paper-zoo-s0")
    fake_agent(tmp_path, "sac-paper-s0", interrupted=True)  # still training: not flown
    early = publish.parts(tmp_path, unfinished=lambda: ["train/sac-paper-s0"])[5]
    assert early.waits and [c[:2] for c in early.commands] == [["run", "--scenarios"], ["run", "--suite"],
                                                                ["run", "--scenarios"]]  # fmt: skip
    assert f"sb3:{tmp_path.as_posix()}/ppo-paper-zoo-s0.zip" in early.commands[0]
    assert not any("sac-paper-s0" in " ".join(c) for c in early.commands)
    fake_agent(tmp_path, "sac-paper-s0")
    late = publish.parts(tmp_path, unfinished=lambda: [])[5]
    assert not late.waits and any("sac-paper-s0" in " ".join(c) for c in late.commands)
    assert publish.command_key(late.commands[0]) != publish.command_key(early.commands[0])


def test_the_hybrids_use_the_set_the_confirmation_chose(tmp_path):
    agents = [
        f"sb3:m/{n}.zip" for n in ("ppo-paper-s0", "ppo-paper-zoo-s0", "ppo-paper-zoo-s1", "sac-paper-s0")
    ]
    assert publish.chosen_paper_ppo(agents, tmp_path) == agents[:3]  # no record: every PPO paper agent
    record = tmp_path / "tune" / "ppo-paper" / "selection.yaml"
    record.parent.mkdir(parents=True)
    record.write_text("chosen: study\n")
    assert publish.chosen_paper_ppo(agents, tmp_path) == agents[:1]
    record.write_text("chosen: zoo\n")
    assert publish.chosen_paper_ppo(agents, tmp_path) == agents[1:3]


def test_commands_import_this_tree_and_a_wait_is_not_success(tmp_path, monkeypatch, capsys):
    env = publish.child_environment(tmp_path)
    assert env["PYTHONPATH"].split(os.pathsep)[0] == str(tmp_path)
    monkeypatch.setattr(publish, "ROOT", tmp_path)
    monkeypatch.setattr(publish, "programme_unfinished", lambda: ["tune/ppo-random"])
    monkeypatch.setattr(publish, "agent_models", lambda models: [])  # no finished agent: nothing flies first
    assert publish.main(["--only", "agents"]) == publish.WAITING == 3
    assert "[wait] agents: the RL programme has 1 unfinished steps" in capsys.readouterr().out


def test_install_needs_a_passed_rebuild_check(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(publish, "ROOT", tmp_path)
    key = {"part": "tables", "wall_s": 1.0, "cpu_s": 1.0}
    assert not publish.rebuild_checked([{**key, "command": "uav-bench report", "status": 0}])
    assert not publish.rebuild_checked([{**key, "command": publish.REBUILD_CHECK, "status": 1}])
    assert publish.rebuild_checked([{**key, "command": publish.REBUILD_CHECK, "status": 0}])
    assert publish.main(["--install"]) == 1
    assert "refused: the tables part has not ended with a passed rebuild check" in capsys.readouterr().err


def attempt(part, command, status=0):
    return {"part": part, "command": command, "status": status, "wall_s": 1.0, "cpu_s": 1.0}


def test_derived_parts_done_before_new_rows_run_again():
    """A first publication before the agents part: its best-known and tables go stale when agents run."""
    first = [attempt("held-out", "run held"), attempt("best-known", "bk"), attempt("tables", "plot"),
             attempt("tables", publish.REBUILD_CHECK)]  # fmt: skip
    assert publish.done_commands(first) == {"run held", "bk", "plot", publish.REBUILD_CHECK}
    assert publish.rebuild_checked(first)
    # The agents part's attempt, even a failed one, may have written rows: both derived parts rerun.
    later = [*first, attempt("agents", "run agents", status=1)]
    assert publish.done_commands(later) == {"run held"}
    assert not publish.rebuild_checked(later)
    # best-known again makes the tables stale but not the run parts; the tables again are current.
    again = [*later, attempt("agents", "run agents"), attempt("best-known", "bk")]
    assert publish.done_commands(again) == {"run held", "run agents", "bk"}
    assert publish.rebuild_checked([*again, attempt("tables", "plot"), attempt("tables", publish.REBUILD_CHECK)])


def test_agent_commands_cover_every_finished_agent(tmp_path):
    for name in (
        "ppo-paper-s0",
        "ppo-paper-zoo-s0",
        "ppo-paper-zoo-s1",
        "ppo-random-zoo-s0",
        "sac-random-s0",
    ):
        fake_agent(tmp_path, name)
    fake_agent(tmp_path, "td3-paper-s0", interrupted=True)  # a run cut short is not published
    record = tmp_path / "rl" / "tune" / "ppo-paper" / "selection.yaml"
    record.parent.mkdir(parents=True)
    record.write_text("chosen: zoo\n")
    plan = {part.name: part for part in publish.parts(tmp_path, unfinished=list, rl_root=tmp_path / "rl")}
    paper, random_suite, held_out, hybrid = plan["agents"].commands
    agents = [f"sb3:{(tmp_path / n).as_posix()}.zip" for n in
              ("ppo-paper-s0", "ppo-paper-zoo-s0", "ppo-paper-zoo-s1", "ppo-random-zoo-s0", "sac-random-s0")]  # fmt: skip
    assert paper[paper.index("--policies") + 1 : paper.index("--seeds")] == agents
    assert random_suite[:3] == ["run", "--suite", "uavpen-v1"] and random_suite[4:6] == agents[3:]
    # every agent on the held-out set: the Random-regime agents' test, the paper agents' generalisation
    assert held_out[:3] == ["run", "--suite", "uavpen-heldout-v1"]
    assert held_out[held_out.index("--policies") + 1 : held_out.index("--store")] == agents
    # the chosen (zoo) PPO paper agents warm-start IHPSO
    assert hybrid[hybrid.index("--policies") + 1 : hybrid.index("--seeds")] == [
        f"ihpso+{a}" for a in agents[1:3]
    ]


def test_every_command_parses_with_the_real_cli(tmp_path):
    from uav_penetration_env.benchmark.cli import build_parser

    fake_agent(tmp_path, "ppo-paper-zoo-s0")
    parser = build_parser()
    parser.exit_on_error = False
    for part in publish.parts(tmp_path, unfinished=list):
        for command in part.commands:
            parser.parse_args(command)


def test_the_rebuild_check_ignores_only_the_date_line(tmp_path):
    out, check = tmp_path / "out", tmp_path / "check"
    out.mkdir(), check.mkdir()
    table = "# Leaderboard\n\n- Commits: `abc`\n- Date: {}\n\n| a |\n| 1 |\n"
    (out / "paper.md").write_text(table.format("2026-11-29T19:00:00+00:00"))
    (check / "paper.md").write_text(table.format("2026-11-30T08:00:00+00:00"))
    (out / "paper.csv").write_text("a\n1\n")
    (check / "paper.csv").write_text("a\n1\n")
    assert publish.compare_rebuild(out, check) == []
    (check / "paper.csv").write_text("a\n2\n")
    assert publish.compare_rebuild(out, check) == ["paper.csv"]
    (check / "suite.md").write_text("only rebuilt\n")
    assert publish.compare_rebuild(out, check) == ["paper.csv", "suite.md"]
    (out / "rl.md").write_text("only written from the store\n")  # a table the rows lost is a difference
    assert publish.compare_rebuild(out, check) == ["paper.csv", "rl.md", "suite.md"]


def test_nothing_runs_on_a_dirty_tree(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(publish, "ROOT", tmp_path)
    monkeypatch.setattr(publish, "dirty_files", lambda: ["optimizers/ihpso.py"])
    monkeypatch.setattr(publish, "programme_unfinished", lambda: ["tune/ppo-random"])
    ran = []
    monkeypatch.setattr(publish, "run_attempt", lambda *args: ran.append(args) or 0)
    assert publish.main(["--only", "paper"]) == 1
    assert (
        ran == []
        and "refused: tracked files differ from the commit (optimizers/ihpso.py)" in capsys.readouterr().err
    )


def test_done_commands_are_skipped_and_compute_sums_every_attempt(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(publish, "ROOT", tmp_path)
    monkeypatch.setattr(publish, "programme_unfinished", lambda: ["tune/ppo-random"])
    paper = publish.command_key(publish.parts(unfinished=list)[0].commands[0])
    attempts = [
        {"part": "paper", "command": paper, "wall_s": 3600.0, "cpu_s": 5400.0, "status": 130},
        {"part": "paper", "command": paper, "wall_s": 1800.0, "cpu_s": 3600.0, "status": 0},
    ]
    (tmp_path / "compute.jsonl").write_text("".join(json.dumps(a) + "\n" for a in attempts))
    assert publish.main(["--dry-run", "--only", "paper"]) == 0
    assert capsys.readouterr().out.startswith("[done] paper: uav-bench run --scenarios paper paper-w2")
    assert publish.main(["--compute"]) == 0
    table = capsys.readouterr().out
    assert "| paper | 2 | 1.50 | 2.50 |" in table and "| total | | 1.50 | 2.50 |" in table


def test_a_damaged_compute_log_is_named(tmp_path):
    log = tmp_path / "compute.jsonl"
    log.write_text('{"part": "paper"}\nnot json\n')
    with pytest.raises(SystemExit, match=r"compute\.jsonl:2: not a JSON line"):
        publish.read_log(log)


def test_rl_compute_sums_trial_durations_and_training_wall_time(tmp_path):
    study = tmp_path / "tune" / "ppo-paper"
    study.mkdir(parents=True)
    (study / "ppo-paper.trials.csv").write_text("number,state,duration_s\n0,COMPLETE,600\n1,PRUNED,300\n")
    models = tmp_path / "models"
    models.mkdir()
    for name, seconds in (("ppo-paper-s0", 1800.0), ("ppo-paper-zoo-s0", 5400.0)):
        (models / f"{name}.json").write_text(json.dumps({"wall_seconds": seconds}))
    assert publish.rl_compute(tmp_path) == [
        ("RL tuning (2 trials)", 2, 900.0),
        ("RL training (2 runs)", 2, 7200.0),
    ]
    table = publish.compute_table([], rl_root=tmp_path)
    assert "| RL tuning (2 trials) | | 0.25 |" in table and "| RL training (2 runs) | | 2.00 |" in table
    assert "imitation" not in table  # v2's table: no distilled planners published


def test_the_imitation_row_sums_the_distilled_networks_sidecars(tmp_path):
    for name, labels, seconds in (("a", 1000, 1800.0), ("b", 234, 5400.0)):
        (tmp_path / name).mkdir()
        (tmp_path / name / "policy.json").write_text(json.dumps({"expert_labels": labels, "train_cpu_seconds": seconds}))
    assert publish.imitation_compute(tmp_path) == ("imitation training (2 networks, 1,234 expert labels)", 7200.0)
    table = publish.compute_table([], rl_root=tmp_path / "none", distill_root=tmp_path)
    assert "| imitation training (2 networks, 1,234 expert labels) | | | 2.00 | | |" in table
    assert publish.imitation_compute(tmp_path / "none") is None


def test_install_replaces_the_generated_files_and_commits_the_compute_log(tmp_path, monkeypatch):
    monkeypatch.setattr(publish, "REPO", tmp_path)
    out, target = tmp_path / publish.OUT, tmp_path / "leaderboards"
    (out / "rows").mkdir(parents=True)
    (out / "index.html").write_text("<html></html>")
    (out / "paper-2022-sec5.md").write_text("v2")
    (out / "rows" / "leaderboard-episodes.parquet").write_bytes(b"rows")
    (target / "models").mkdir(parents=True)
    (target / "rl").mkdir()
    (target / "held-out-random-d0.5.md").write_text("v1")  # a v1 table v2 no longer writes
    (target / "models" / "ppo-paper-s0.zip").write_bytes(b"v1 agent")
    (target / "rl" / "state.json").write_text("{}")
    log = tmp_path / publish.ROOT / "compute.jsonl"
    log.write_text('{"part": "paper", "wall_s": 1.0, "cpu_s": 2.0}\n')
    copied = publish.install()
    assert sorted(p.relative_to(target).as_posix() for p in copied) == [
        "compute.jsonl", "index.html", "paper-2022-sec5.md", "rows/leaderboard-episodes.parquet"
    ]  # fmt: skip
    assert not (target / "held-out-random-d0.5.md").exists() and not (target / "models").exists()
    assert (target / "rl" / "state.json").is_file()  # the RL programme's snapshot stays
    assert (target / "compute.jsonl").read_text() == log.read_text()


def test_v3_installs_into_its_own_folder_without_the_exported_rows(tmp_path, monkeypatch):
    """v2's tables stay; v3's folder is replaced whole, its rows are the committed chunks (publishing.md §5.5)."""
    monkeypatch.setattr(publish, "REPO", tmp_path)
    out, target = tmp_path / "results/v3/out", tmp_path / "leaderboards/v3"
    (out / "rows").mkdir(parents=True)
    (out / "ctg-sensitivity").mkdir()
    (out / "index.html").write_text("<html></html>")
    (out / "uavpen-v1.csv").write_text("v3")
    (out / "ctg-sensitivity" / "sensitivity.md").write_text("forms")
    (out / "rows" / "leaderboard-steps.parquet").write_bytes(b"rows")
    (out / OUT_SOURCE_FILE).write_text("results/v3/leaderboard.sqlite")
    target.mkdir(parents=True)
    (target / "stale.md").write_text("an earlier v3 table no longer written")
    (tmp_path / "leaderboards" / "paper-2022-sec5.md").write_text("v2")
    log = tmp_path / "results/v3/compute.jsonl"
    log.write_text('{"part": "paper", "wall_s": 1.0, "cpu_s": 2.0}\n')
    copied = publish.install_folder(Path("results/v3/out"), Path("leaderboards/v3"), Path("results/v3/compute.jsonl"))
    assert sorted(p.relative_to(target).as_posix() for p in copied) == [
        "compute.jsonl", "ctg-sensitivity/sensitivity.md", "index.html", "uavpen-v1.csv"
    ]  # fmt: skip
    assert (tmp_path / "leaderboards" / "paper-2022-sec5.md").read_text() == "v2"
    assert not (tmp_path / "leaderboards" / "v3.installing").exists() and not (tmp_path / "leaderboards" / "v3.previous").exists()
    assert (target / "compute.jsonl").read_text() == log.read_text()
    assert publish.publications()["v3"].target == Path("leaderboards/v3")


def test_worker_time_counts_finished_work_of_every_attempt_logged_or_not():
    from types import SimpleNamespace

    import pandas as pd

    paper = "uav-bench run --scenarios paper --policies ihpso"
    runs = pd.DataFrame({"run_id": [1, 2, 3], "provenance": [json.dumps({"command": c}) for c in
                                                              (paper, paper, "uav-bench windows --x")]})  # fmt: skip
    # Run 1 was killed with its session (no log line); run 2, the same command resumed, was logged.
    episodes = pd.DataFrame({"run_id": [1, 1, 2], "episode_seconds": [1800.0, 1800.0, 3600.0]})
    windows = pd.DataFrame({"run_id": [3, 3], "seconds": [360.0, 360.0]})
    worker = publish.worker_seconds(SimpleNamespace(runs=runs, episodes=episodes, window_runs=windows))
    assert worker == {paper: (3, 7200.0), "uav-bench windows --x": (2, 720.0)}
    attempts = [{"part": "paper", "command": paper, "wall_s": 1800.0, "cpu_s": 3600.0, "status": 0}]
    table = publish.compute_table(attempts, rl_root=Path("/nonexistent"), worker=worker)
    assert "| paper | 1 | 0.50 | 1.00 | 3 | 2.00 |" in table
    assert "| (runs of no logged command) | | | | 2 | 0.20 |" in table
    assert "| total | | 0.50 | 1.00 | | 2.20 |" in table


def test_from_published_rebuilds_a_missing_store_and_log_once(tmp_path, monkeypatch, capsys):
    from tests.conftest import tiny_scenario
    from uav_penetration_env.benchmark import cli
    from uav_penetration_env.benchmark.rows import store_tables

    monkeypatch.setattr(publish, "REPO", tmp_path)
    original = tmp_path / "original.sqlite"
    scenario = str(tiny_scenario(time={"max_steps": 6}).to_yaml(tmp_path / "tiny.yaml"))
    assert cli.main(["run", "--policies", "greedy", "--scenarios", scenario, "--seeds", "2", "--store", str(original),
                     "--jobs", "1", "--no-report", "--no-progress"]) == 0  # fmt: skip
    rows = tmp_path / "leaderboards" / "rows" / "leaderboard"
    assert cli.main(["export", "--format", "parquet", "--store", str(original), "--out", str(rows)]) == 0
    (tmp_path / "leaderboards" / "compute.jsonl").write_text(
        '{"part": "paper", "command": "c", "status": 0}\n'
    )
    assert publish.main(["--from-published"]) == 0
    store = tmp_path / publish.STORE
    assert store_tables(store).episodes.equals(store_tables(original).episodes)
    assert publish.read_log(tmp_path / publish.ROOT / "compute.jsonl") == [
        {"part": "paper", "command": "c", "status": 0}
    ]
    capsys.readouterr()
    assert publish.main(["--from-published"]) == 1  # never over an existing store
    assert "exists; --from-published only rebuilds a missing store" in capsys.readouterr().err


def test_a_check_alone_after_new_rows_does_not_pass_for_rebuilt_tables():
    """The check must follow every tables command rerun after the last rows, not only be the last line."""
    tables = ["plot", "report"]
    published = [attempt("agents", "run a"), *(attempt("tables", c) for c in tables),
                 attempt("tables", publish.REBUILD_CHECK)]  # fmt: skip
    assert publish.rebuild_checked(published, tables)
    # new agents flew, best-known ran, and a check was logged without the tables being rebuilt
    stale = [
        *published,
        attempt("agents", "run b"),
        attempt("best-known", "bk"),
        attempt("tables", publish.REBUILD_CHECK),
    ]
    assert not publish.rebuild_checked(stale, tables)
    assert publish.rebuild_checked(stale)  # what the check alone would have said
    rebuilt = [*stale, *(attempt("tables", c) for c in tables), attempt("tables", publish.REBUILD_CHECK)]
    assert publish.rebuild_checked(rebuilt, tables)


def test_derived_parts_rerun_in_the_same_invocation_after_new_rows(tmp_path, monkeypatch):
    monkeypatch.setattr(publish, "ROOT", tmp_path)
    monkeypatch.setattr(publish, "programme_unfinished", lambda: [])
    monkeypatch.setattr(publish, "dirty_files", lambda: [])
    monkeypatch.setattr(publish, "imported_from", lambda: publish.REPO)
    monkeypatch.setattr(publish, "compare_rebuild", lambda *args: [])
    plan = publish.parts()
    log = tmp_path / "compute.jsonl"
    # everything published once; then a new agent makes the agents part's commands new
    logged = [attempt(part.name, publish.command_key(c)) for part in plan for c in part.commands]
    logged = [a for a in logged if a["part"] != "agents"] + [attempt("tables", publish.REBUILD_CHECK)]
    log.write_text("".join(json.dumps(a) + "\n" for a in logged))
    ran = []

    def run_attempt(part, argv, path):
        ran.append(part)
        publish.append_attempt(path, attempt(part, publish.command_key(argv)))
        return 0

    monkeypatch.setattr(publish, "run_attempt", run_attempt)
    assert publish.main([]) == 0
    tables = next(p for p in plan if p.name == "tables")
    assert ran == ["agents"] * len(plan[5].commands) + ["best-known"] + ["tables"] * len(tables.commands)
    assert publish.rebuild_checked(publish.read_log(log), [publish.command_key(c) for c in tables.commands])


def test_v3_flies_the_new_planners_beside_the_v2_parts(tmp_path):
    v2 = {part.name: part for part in publish.parts(tmp_path, unfinished=list)}
    v3 = {part.name: part for part in publish.parts_v3(tmp_path, unfinished=list)}
    assert list(v3) == list(publish.V3_ORDER) and "ctg-sensitivity" not in v2
    new = ["lattice", "lattice-c40", "value-greedy-c40", "distill-shield:leaderboards/distill/c40-value-s1",
           "distill:leaderboards/distill/c40-value-s1", "distill-shield:leaderboards/distill/c40-value64-s0"]  # fmt: skip
    for name in ("paper", "suite", "held-out"):
        (command,) = v3[name].commands
        policies = command[command.index("--policies") + 1 :]
        assert (
            policies[: policies.index(new[0])]
            == v2[name].commands[0][v2[name].commands[0].index("--policies") + 1 :][: policies.index(new[0])]
        )  # the v2 policies first, in their order
        assert all(p in policies for p in new) and not any(p in v2[name].commands[0] for p in new)
        assert command[command.index("--store") + 1] == "results/v3/leaderboard.sqlite"
    paper, suite, held_out, w2 = v3["ctg-sensitivity"].commands
    forms = [f"{n}-ctg-{f}" for f in ("distance", "dubins") for n in ("ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism", "cmaes")]  # fmt: skip
    for command, scenario in ((paper, "paper"), (w2, "paper-w2")):
        assert command[:3] == ["run", "--scenarios", scenario]
        assert command[command.index("--policies") + 1 : command.index("--seeds")] == forms and "20" in command
    for command, suite_name in ((suite, "uavpen-v1"), (held_out, "uavpen-heldout-v1")):
        assert command[:3] == ["run", "--suite", suite_name] and command[4:18] == forms
    table = next(c for c in v3["tables"].commands if c[0] == "benchmarks/terminal_cost_table.py")
    within = [table[i + 1] for i, a in enumerate(table) if a == "--within"]
    assert within == ["paper=paper-2022-sec5", "suite=uavpen-v1", "held-out=uavpen-heldout-v1",
                      "paper-w2=paper-2022-sec5-w2"]  # fmt: skip
    tables = [c[0] for c in v3["tables"].commands]
    assert tables.index("benchmarks/terminal_cost_table.py") == tables.index("export") + 1
    # v3's tables are rebuilt from the committed checkpoint, not from a second export (publishing.md §5.5)
    assert v3["tables"].commands[-1][:3] == ["leaderboard", "--rows", "leaderboards/v3-checkpoint"]
    # the v2 plan writes to results/v2 only
    assert all("results/v3" not in " ".join(c) for part in v2.values() for c in part.commands)


def test_every_v3_command_parses_with_the_real_cli_or_its_script(tmp_path):
    from uav_penetration_env.benchmark.cli import build_parser

    table = load("terminal_cost_table").build_parser()
    parser = build_parser()
    parser.exit_on_error = table.exit_on_error = False
    for part in publish.parts_v3(tmp_path, unfinished=list):
        for command in part.commands:
            if command[0].endswith(".py"):
                assert publish.command_key(command).startswith(
                    "python benchmarks/terminal_cost_table.py --part"
                )
                table.parse_args(command[1:])
            else:
                parser.parse_args(command)


def tiny_store(tmp_path, store, seeds):
    from tests.conftest import tiny_scenario
    from uav_penetration_env.benchmark import cli

    scenario = tmp_path / "tiny.yaml"
    if not scenario.is_file():
        tiny_scenario(time={"max_steps": 6}).to_yaml(scenario)
    assert cli.main(["run", "--policies", "greedy", "--scenarios", str(scenario), "--seeds", seeds, "--store",
                     str(store), "--jobs", "1", "--no-report", "--no-progress"]) == 0  # fmt: skip


def test_v3_seed_checkpoint_and_resume_round_trip(tmp_path, monkeypatch, capsys):
    """Seeded from two stores (colliding ids), checkpointed twice (only new runs), resumed: the same episodes."""
    from uav_penetration_env.benchmark import cli
    from uav_penetration_env.benchmark.rows import read_table, store_tables

    monkeypatch.setattr(publish, "REPO", tmp_path)
    monkeypatch.setattr(publish, "bench", cli.main)  # in-process: no interpreter start per command
    pub = publish.publications()["v3"]
    stems = []
    for name, seeds in (("a", "2"), ("b", "2:3")):  # two stores: both start their ids at 1
        tiny_store(tmp_path, tmp_path / f"{name}.sqlite", seeds)
        stems.append(Path(f"seed/{name}"))
        assert cli.main(["export", "--format", "parquet", "--store", str(tmp_path / f"{name}.sqlite"),
                         "--out", str(tmp_path / stems[-1])]) == 0  # fmt: skip
    assert publish.seed_from(stems, pub) == 0
    store = tmp_path / pub.layout.store
    held = store_tables(store).episodes
    assert sorted(held.seed) == [0, 1, 2] and held.episode_id.is_unique and held.run_id.nunique() == 2
    with pytest.raises(FileExistsError, match="exists; this only rebuilds a missing store"):
        publish.seed_from(stems, pub)
    log = tmp_path / pub.root / "compute.jsonl"
    log.write_text('{"part": "paper", "command": "c", "status": 0}\n')
    folder = Path("leaderboards/v3-checkpoint")
    assert publish.checkpoint(pub, folder) is None  # only seed rows: named, not copied
    assert publish.read_manifest(folder)["seeds"] == [s.as_posix() for s in stems]
    tiny_store(tmp_path, store, "4")  # seed 3 is new: one more run, one more episode
    first = publish.checkpoint(pub, folder)
    assert first == folder / "chunk-001" and read_table(tmp_path / first, "episodes").seed.tolist() == [3]
    steps = read_table(tmp_path / first, "steps")
    assert set(steps.episode_id) == set(read_table(tmp_path / first, "episodes").episode_id)
    assert publish.checkpoint(pub, folder) is None  # nothing new since
    expected = store_tables(store).episodes
    for path in (store, log, tmp_path / pub.root / "seeded.json"):
        path.unlink()
    capsys.readouterr()
    assert publish.resume(pub, folder) == 0
    rebuilt = store_tables(store).episodes
    assert rebuilt.drop(columns="finished").equals(expected.drop(columns="finished"))
    assert publish.read_log(log) == [{"part": "paper", "command": "c", "status": 0}]
    with pytest.raises(FileExistsError):
        publish.resume(pub, folder)


def test_v3_only_flags_refuse_v2(capsys):
    with pytest.raises(SystemExit):
        publish.main(["--checkpoint"])
    assert "--checkpoint: only with --version v3" in capsys.readouterr().err


def test_the_estimate_counts_each_command_by_its_seed_rule():
    """Counted by hand: uavpen-v1 has 3 fixed members (5 seeds, 1 for a deterministic planner) and 60 procedural (1)."""
    suite = publish.planned_items(["run", "--suite", "uavpen-v1", "--policies", "ihpso", "lattice"])
    assert sum(p == "ihpso" for p, _, _ in suite) == 3 * 5 + 60 and sum(p == "lattice" for p, _, _ in suite) == 63
    paper = publish.planned_items(["run", "--scenarios", "paper", "paper-w2", "--policies", "greedy", "--seeds", "20"])
    assert len(paper) == 40 and {s for _, s, _ in paper} == {"paper-2022-sec5", "paper-2022-sec5-w2"}
    windows = next(p for p in publish.parts_v3(unfinished=list) if p.name == "windows").commands[0]
    assert len(publish.planned_items(windows)) == 15 * 10 * 20  # steps x optimizers x seeds
    assert publish.evidence_name("ihpso+sb3:leaderboards/rl/models/ppo-paper-s0.zip") == "ihpso+sb3:ppo-paper-s0"


def test_merged_rows_refuse_an_episode_twice(tmp_path):
    from uav_penetration_env.benchmark import cli

    tiny_store(tmp_path, tmp_path / "a.sqlite", "1")
    assert cli.main(["export", "--format", "parquet", "--store", str(tmp_path / "a.sqlite"), "--out", str(tmp_path / "a")]) == 0
    with pytest.raises(SystemExit, match=r"^episode greedy on .* seed 0 is in two of"):
        publish.merge_rows([tmp_path / "a", tmp_path / "a"], tmp_path / "merged")
