"""The RL programme driver: the steps it runs, what it skips, and that a stopped programme resumes."""

from __future__ import annotations

import argparse
import contextlib
import io
import json
from pathlib import Path

import pytest
import yaml

from baselines.campaign import default_campaign
from baselines.programme import (
    main,
    off_policy_timesteps,
    run_programme,
    study_yaml,
)

STUDIES = default_campaign().studies  # the packaged campaign's, baselines/campaigns/rl.yaml

# A best trial that took 240 CPU-s for its 50 000 steps: 4.8 ms per step, so 20 CPU-min is 250 000 steps.
PROVENANCE = {"trials_complete": 12, "trials_pruned": 3, "best_trial_cpu_seconds": 240.0,
              "budget_steps_per_trial": 50_000}  # fmt: skip


def finish_study(root, algo, regime, **changes):
    path = study_yaml(root, algo, regime)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump({"provenance": {**PROVENANCE, **changes}, "gamma": 0.99}))


class FakeUavBench:
    """Records each command and leaves behind what the real one would (a study's YAML, a model's sidecar)."""

    def __init__(self, root, fail_at=None, zoo_cost=17.0, study_cost=20.0):
        self.root, self.fail_at, self.calls = root, fail_at, []
        self.zoo_cost, self.study_cost = zoo_cost, study_cost

    def __call__(self, argv):
        self.calls.append(list(argv))
        flags = dict(zip(argv[1::2], argv[2::2], strict=False))
        if self.fail_at is not None and len(self.calls) == self.fail_at:
            return 130  # Ctrl-C in the child
        if argv[0] == "tune":
            trials = int(flags["--trials"])
            finish_study(
                self.root, flags["--algo"], flags["--regime"], trials_complete=trials, trials_pruned=0
            )
        else:
            model = self.root / "models" / flags["--out"].rpartition("/")[2]
            model.parent.mkdir(parents=True, exist_ok=True)
            model.write_bytes(b"zip")
            cost = self.zoo_cost if "-zoo-" in model.name else self.study_cost
            sidecar = {"timesteps_done": int(flags["--timesteps"]), "interrupted": False,
                       "final_evaluation": {"mean_cost": cost}}  # fmt: skip
            model.with_suffix(".json").write_text(json.dumps(sidecar))
        return 0


def run_names(calls):
    return [c[c.index("--out") + 1].rpartition("/")[2][: -len(".zip")] for c in calls if c[0] == "train"]


def test_the_programme_runs_every_step_once_and_a_second_run_skips_them(tmp_path, capsys):
    fake = FakeUavBench(tmp_path)
    assert run_programme(tmp_path, runner=fake) == 0
    names = [f"{c[0]} {c[2]} {c[4]}" for c in fake.calls]
    assert names[:5] == [f"tune {a} {r}" for a, r, _ in STUDIES]
    # PPO per regime: seed 0 of both sets (the confirmation), then seeds 1-4 of the chosen (zoo) set
    ppo_paper = ["ppo-paper-s0", "ppo-paper-zoo-s0"] + [f"ppo-paper-zoo-s{seed}" for seed in range(1, 5)]
    assert run_names(fake.calls)[:6] == ppo_paper
    # + the corridor experiments (2 x 5 seeds) and the formulations of docs/rl.md §6 (4 x 3 seeds)
    assert len(fake.calls) == 5 + 6 + 6 + 3 + 3 + 3 + 10 + 12
    assert run_names(fake.calls)[-22:] == [
        *(f"ppo-paper-{name}-s{seed}" for name in ("ent", "gamma") for seed in range(5)),
        *(f"ppo-paper-{name}-s{seed}" for name in ("turn", "turn-value", "shaped", "turn-value-warm") for seed in range(3)),
    ]
    ent = fake.calls[-22]
    assert ent[ent.index("--hyperparams") + 1] == "baselines/hyperparams/experiments/ppo-ent.yaml"
    printed = capsys.readouterr().out
    assert (
        "[run] tune/ppo-paper (0/30 trials): uav-bench tune --algo ppo --regime paper --trials 30" in printed
    )

    ppo, zoo = fake.calls[5], fake.calls[6]
    assert ppo[:4] == ["train", "--algo", "ppo", "--scenario"] and "--resume" in ppo
    flags = dict(zip(ppo[1::2], ppo[2::2], strict=False))
    assert flags["--timesteps"] == "2000000" and flags["--seed"] == "0"
    assert flags["--hyperparams"] == str(study_yaml(tmp_path, "ppo", "paper"))
    assert "--hyperparams" not in zoo  # the untuned set, baselines/hyperparams/ppo.yaml
    selection = yaml.safe_load((tmp_path / "tune" / "ppo-paper" / "selection.yaml").read_text())
    assert selection["chosen"] == "zoo" and selection["final_cost"] == {"study": 20.0, "zoo": 17.0}
    sac_random = next(
        c for c in fake.calls if c[:3] == ["train", "--algo", "sac"] and "UAVPenetrationRandom-v0" in c
    )
    assert dict(zip(sac_random[1::2], sac_random[2::2], strict=False))["--timesteps"] == "250000"

    again = FakeUavBench(tmp_path)
    assert run_programme(tmp_path, runner=again) == 0
    assert again.calls == []
    printed = capsys.readouterr().out
    assert printed.count("[done]") == 5 + 31 + 12 and printed.count("[skip]") == 8
    assert "[skip] train/ppo-random-s4: not chosen" in printed


def test_the_study_set_trains_the_remaining_seeds_when_it_wins_the_confirmation(tmp_path):
    fake = FakeUavBench(tmp_path, zoo_cost=21.0, study_cost=16.0)
    assert run_programme(tmp_path, runner=fake, only=["tune/ppo-paper", "train/ppo-paper-*"]) == 0
    assert run_names(fake.calls)[:6] == ["ppo-paper-s0", "ppo-paper-zoo-s0"] + [
        f"ppo-paper-s{s}" for s in range(1, 5)
    ]
    trained = [c for c in fake.calls if c[0] == "train"]
    assert [("--hyperparams" in c) for c in trained][:6] == [True, False, True, True, True, True]


def test_a_stopped_programme_continues_where_it_stopped(tmp_path, capsys):
    first = FakeUavBench(tmp_path, fail_at=8)  # interrupted in the third training run (zoo seed 1)
    assert run_programme(tmp_path, runner=first) == 130
    assert "programme stopped at train/ppo-paper-zoo-s1 (exit status 130)" in capsys.readouterr().out
    rest = FakeUavBench(tmp_path)
    assert run_programme(tmp_path, runner=rest) == 0
    assert run_names(rest.calls)[0] == "ppo-paper-zoo-s1"  # the cut run first, nothing before it
    assert len(rest.calls) == 48 - 7


def test_a_step_another_process_runs_is_skipped_and_left_to_it(tmp_path, capsys):
    """Two programme processes share the steps: a held lock makes the other one pass the step by."""
    import fcntl

    from baselines.programme import step_lock

    for algo, regime, _ in STUDIES:
        finish_study(tmp_path, algo, regime, trials_complete=100, trials_pruned=0)
    with step_lock(tmp_path, "train/ppo-paper-s0") as free:
        assert free
        # flock locks belong to open files: a second open of the path (as another process makes) is refused.
        with (
            (tmp_path / "locks" / "train_ppo-paper-s0.lock").open("a") as other,
            pytest.raises(BlockingIOError),
        ):
            fcntl.flock(other, fcntl.LOCK_EX | fcntl.LOCK_NB)
        fake = FakeUavBench(tmp_path)
        assert run_programme(tmp_path, runner=fake, only=["train/ppo-paper-*"]) == 0
    assert "ppo-paper-s0" not in run_names(fake.calls)
    assert run_names(fake.calls)[0] == "ppo-paper-zoo-s0"
    assert "[busy] train/ppo-paper-s0: another programme process runs it" in capsys.readouterr().out
    with step_lock(tmp_path, "train/ppo-paper-s0") as free:  # released: free again
        assert free


def test_an_unfinished_study_runs_again_and_holds_back_its_training(tmp_path, capsys):
    for algo, regime, trials in STUDIES:
        finish_study(tmp_path, algo, regime, trials_complete=trials, trials_pruned=0)
    finish_study(tmp_path, "sac", "random", trials_complete=4, trials_pruned=2)  # 6 of 15
    assert run_programme(tmp_path, dry_run=True, only=["tune/*", "train/sac-random-*"]) == 0
    printed = capsys.readouterr().out
    assert (
        "[plan] tune/sac-random (6/15 trials)" in printed
        and "[done] tune/ppo-paper (30/30 trials)" in printed
    )
    assert "[wait] train/sac-random-s0: waits for tune/sac-random" in printed
    assert "train/ppo" not in printed  # not selected


def test_off_policy_budget_is_twenty_cpu_minutes_of_the_best_trial():
    assert off_policy_timesteps(PROVENANCE) == 250_000
    assert off_policy_timesteps({**PROVENANCE, "best_trial_cpu_seconds": 6000.0}) == 100_000  # floor
    assert off_policy_timesteps({**PROVENANCE, "best_trial_cpu_seconds": 10.0}) == 2_000_000  # ceiling
    with pytest.raises(ValueError, match="pass --off-policy-steps"):
        off_policy_timesteps({"trials_complete": 15})


def test_the_commands_parse_with_the_real_flags(tmp_path):
    pytest.importorskip("optuna")
    from baselines.cli import add_train_arguments
    from baselines.tune import add_tune_arguments

    fake = FakeUavBench(tmp_path)
    run_programme(tmp_path, runner=fake)
    parsers = {
        "tune": argparse.ArgumentParser(exit_on_error=False),
        "train": argparse.ArgumentParser(exit_on_error=False),
    }
    add_tune_arguments(parsers["tune"])
    add_train_arguments(parsers["train"])
    for argv in fake.calls:
        args = parsers[argv[0]].parse_args(argv[1:])
        assert args.out.startswith(str(tmp_path))


def test_main_dry_run(tmp_path, capsys):
    assert main(["--root", str(tmp_path), "--dry-run", "--only", "tune/td3-*"]) == 0
    assert capsys.readouterr().out.strip().splitlines() == [
        f"[plan] tune/td3-paper (0/15 trials): uav-bench tune --algo td3 --regime paper --trials 15 "
        f"--out {tmp_path}/tune/td3-paper"
    ]
    assert not any(tmp_path.iterdir())


def test_snapshot_keeps_what_resuming_needs_and_restore_never_overwrites(tmp_path):
    import sqlite3

    from baselines.programme import restore, snapshot

    root, saved = tmp_path / "rl", tmp_path / "saved"
    study = root / "tune" / "ppo-paper"
    (study / "trials").mkdir(parents=True)
    with sqlite3.connect(study / "study.sqlite") as db:
        db.execute("CREATE TABLE trials (number INTEGER, value REAL)")
        db.executemany("INSERT INTO trials VALUES (?, ?)", [(0, 21.5), (1, 19.25)])
    for name in ("ppo-paper.yaml", "ppo-paper.trials.csv", "ppo-paper.summary.md", "trials/trial-0000.zip"):
        (study / name).write_text(name)
    models = root / "models"
    (models / "ppo-paper-s1.checkpoints").mkdir(parents=True)
    for suffix in (".zip", ".json", ".vecnormalize.pkl", ".evaluations.csv"):
        (models / f"ppo-paper-s0{suffix}").write_text(suffix)  # a finished model
    checkpoint = models / "ppo-paper-s1.checkpoints"
    for name in ("s1-300steps.zip", "s1-300steps.json", "s1-300steps.vecnormalize.pkl", "s1-300steps.replay.npz",
                 "s1-200steps.zip"):  # fmt: skip
        (checkpoint / name).write_text(name)
    (checkpoint / "resume.json").write_text(
        json.dumps({"finished": False, "model": "s1-300steps.zip", "replay_buffer": "s1-300steps.replay.npz"})
    )

    written = {p.relative_to(saved).as_posix() for p in snapshot(root, saved)}
    assert "tune/ppo-paper/study.sqlite" in written and "tune/ppo-paper/ppo-paper.yaml" in written
    assert not any("trials/" in p for p in written)  # trial models are evidence, not resume state
    assert {
        f"models/ppo-paper-s0{s}" for s in (".zip", ".json", ".vecnormalize.pkl", ".evaluations.csv")
    } <= written
    # An off-policy checkpoint cannot resume without its replay buffer (tens of MB): left out.
    assert not any("s1-" in p or "ppo-paper-s1.checkpoints" in p for p in written)
    with_buffers = {
        p.relative_to(tmp_path / "b").as_posix() for p in snapshot(root, tmp_path / "b", replay_buffers=True)
    }
    assert "models/ppo-paper-s1.checkpoints/resume.json" in with_buffers
    assert "models/ppo-paper-s1.checkpoints/s1-300steps.replay.npz" in with_buffers
    assert "models/ppo-paper-s1.checkpoints/s1-300steps.vecnormalize.pkl" in with_buffers
    assert "models/ppo-paper-s1.checkpoints/s1-200steps.zip" not in with_buffers  # only the last checkpoint
    # A later snapshot replaces the earlier checkpoint instead of piling checkpoints up.
    (checkpoint / "s1-400steps.zip").write_text("s1-400steps.zip")
    (checkpoint / "resume.json").write_text(
        json.dumps({"finished": False, "model": "s1-400steps.zip", "replay_buffer": "s1-300steps.replay.npz"})
    )
    snapshot(root, tmp_path / "b", replay_buffers=True)
    kept = sorted(p.name for p in (tmp_path / "b" / "models" / "ppo-paper-s1.checkpoints").iterdir())
    assert kept == ["resume.json", "s1-300steps.replay.npz", "s1-400steps.zip"]
    with sqlite3.connect(saved / "tune" / "ppo-paper" / "study.sqlite") as db:
        assert db.execute("SELECT number, value FROM trials ORDER BY number").fetchall() == [
            (0, 21.5),
            (1, 19.25),
        ]

    fresh = tmp_path / "fresh"
    (fresh / "tune" / "ppo-paper").mkdir(parents=True)
    (fresh / "tune" / "ppo-paper" / "ppo-paper.yaml").write_text("newer")
    copied = {p.relative_to(fresh).as_posix() for p in restore(saved, fresh)}
    assert copied == written - {"tune/ppo-paper/ppo-paper.yaml"}
    assert (fresh / "tune" / "ppo-paper" / "ppo-paper.yaml").read_text() == "newer"
    assert main(["--root", str(fresh), "--restore", str(saved)]) == 0  # nothing left to copy, still fine


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["--only", "nomatch/*", "--dry-run"], "matches no step"),
        (["--restore", "missing-folder"], "not found"),
        (["--off-policy-steps", "0", "--dry-run"], "expected an integer >= 1"),
        (["--snapshot", "a", "--restore", "b"], "not allowed with"),
    ],
)
def test_bad_programme_flags_are_refused_in_one_line(tmp_path, capsys, argv, expected):
    with pytest.raises(SystemExit) as exit_info:
        main(["--root", str(tmp_path), *argv])
    assert exit_info.value.code == 2 and expected in capsys.readouterr().err


def test_the_confirmation_is_read_back_never_written_by_a_dry_run_and_never_crashes(tmp_path, capsys):
    finish_study(tmp_path, "ppo", "paper", trials_complete=30, trials_pruned=0)
    models = tmp_path / "models"
    models.mkdir()
    for label, cost in (("ppo-paper-s0", 20.0), ("ppo-paper-zoo-s0", None)):
        (models / f"{label}.zip").write_bytes(b"zip")
        final = {} if cost is None else {"final_evaluation": {"mean_cost": cost}}
        (models / f"{label}.json").write_text(json.dumps({"timesteps_done": 2_000_000, **final}))
    assert run_programme(tmp_path, dry_run=True, only=["train/ppo-paper-*"]) == 0
    assert "[wait] train/ppo-paper-s1: the confirmation cannot choose: " in capsys.readouterr().out
    (models / "ppo-paper-zoo-s0.json").write_text(
        json.dumps({"timesteps_done": 2_000_000, "final_evaluation": {"mean_cost": 17.0}})
    )
    assert run_programme(tmp_path, dry_run=True, only=["train/ppo-paper-*"]) == 0
    assert not (tmp_path / "tune" / "ppo-paper" / "selection.yaml").exists()  # a dry run writes nothing
    assert "[plan] train/ppo-paper-zoo-s1" in capsys.readouterr().out
    # A recorded choice stands, whatever the sidecars say now.
    (tmp_path / "tune" / "ppo-paper" / "selection.yaml").write_text(yaml.safe_dump({"chosen": "study"}))
    assert run_programme(tmp_path, dry_run=True, only=["train/ppo-paper-*"]) == 0
    printed = capsys.readouterr().out
    assert "[plan] train/ppo-paper-s1" in printed and "[skip] train/ppo-paper-zoo-s1" in printed


GOLDEN = Path(__file__).parent / "data" / "programme_steps.json"


def programme_transcript(root) -> dict:
    """Every step name, the commands of a whole run either way the PPO confirmation goes, and a dry run.

    The folder is written ``ROOT`` so the transcript does not depend on where the test runs.
    """
    from baselines.programme import step_names

    transcript: dict = {"step_names": step_names()}
    with contextlib.redirect_stdout(io.StringIO()) as printed:
        run_programme(root / "empty", dry_run=True)
    lines = printed.getvalue().splitlines()
    transcript["dry_run_empty"] = [line.replace(str(root / "empty"), "ROOT") for line in lines]
    for chosen, costs in (("zoo", {"zoo_cost": 17.0, "study_cost": 20.0}),
                          ("study", {"zoo_cost": 21.0, "study_cost": 16.0})):  # fmt: skip
        folder = root / chosen
        fake = FakeUavBench(folder, **costs)
        with contextlib.redirect_stdout(io.StringIO()):
            run_programme(folder, runner=fake)
        transcript[f"commands_{chosen}_chosen"] = [
            [arg.replace(str(folder), "ROOT") for arg in argv] for argv in fake.calls
        ]
    return transcript


def test_the_programme_is_the_pinned_one(tmp_path):
    """The campaign's steps and commands, in order, are those pinned in tests/baselines/data."""
    assert programme_transcript(tmp_path) == json.loads(GOLDEN.read_text())


def test_unfinished_lists_every_step_of_a_new_programme_and_writes_nothing(tmp_path, capsys):
    """A new root: no study has its trials, so every tuning step and every run is unfinished."""
    from baselines.programme import main, step_names

    assert main(["--root", str(tmp_path), "--unfinished"]) == 0
    assert sorted(capsys.readouterr().out.split()) == sorted(step_names())
    assert list(tmp_path.iterdir()) == []
