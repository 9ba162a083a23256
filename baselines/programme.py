"""Run a campaign of RL tuning studies, then long training runs, resumably (docs/rl.md §3).

```bash
nice -n 10 python -m baselines.programme --root results/rl            # run (or continue) it all
python -m baselines.programme --root results/rl --dry-run             # what is done, what would run
nice -n 10 python -m baselines.programme --root results/rl --only 'train/sac-*'
python -m baselines.programme --campaign my-campaign.yaml --dry-run   # another campaign
```

This module is the generic runner; what it runs is data, a campaign file read by
:mod:`baselines.campaign` (default: the packaged ``baselines/campaigns/rl.yaml``). Steps, in
order (each one a ``uav-bench`` command, printed before it runs):

1. the campaign's tuning studies (``uav-bench tune``), into ``ROOT/tune/ALGO-REGIME/``; the
   packaged one: PPO paper and random (30 trials each), SAC paper and random and TD3 paper (15
   trials each);
2. its training runs (``uav-bench train --resume`` with the study's YAML), into ``ROOT/models/``;
   the packaged one: PPO 2 M steps x training seeds 0-4 in both regimes, SAC (both regimes) and
   TD3 (paper) x seeds 0-2, each about 20 CPU-minutes (:func:`off_policy_timesteps`);
3. its experiments (the untuned set with overrides), after the runs.

Every step is idempotent: a study with its trials, or a model whose sidecar says it trained its
steps, is skipped; anything else is (re)started with the command that resumes it (a study from its
SQLite storage, a model from its last checkpoint), so a programme stopped anywhere (Ctrl-C, a lost
session, a reboot) continues where it stopped when run again. Training waits for its study: the
hyper-parameters of a run must not change under it.
"""

from __future__ import annotations

import argparse
import contextlib
import fnmatch
import json
import shlex
import shutil
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from baselines.campaign import DEFAULT_CAMPAIGN, Campaign, CampaignError, default_campaign, load_campaign
from uav_penetration_env.benchmark.campaign.process import run_attempt, uav_bench_command

__all__ = ["restore", "run_programme", "snapshot", "uav_bench_command", "unfinished_steps"]

DEFAULT_ROOT = Path("results/rl")
ZOO = "zoo"  # the label part of runs trained with the untuned set, baselines/hyperparams/ALGO.yaml


@dataclass(frozen=True)
class Step:
    """One command of the programme.

    Attributes:
        name: ``tune/ALGO-REGIME`` or ``train/ALGO-REGIME-sSEED``.
        argv: the ``uav-bench`` arguments (``None``: cannot be built yet; ``why`` says why).
        done: whether the step's result is already there.
        why: what the state is (done, waiting for a study, ...).
        skipped: a run of the set the full-budget confirmation did not choose (never runs).
    """

    name: str
    argv: list[str] | None
    done: bool
    why: str = ""
    skipped: bool = False


def study_dir(root: Path, algo: str, regime: str) -> Path:
    """Where ``uav-bench tune`` writes the study of ``algo`` on ``regime``."""
    return root / "tune" / f"{algo}-{regime}"


def study_yaml(root: Path, algo: str, regime: str) -> Path:
    """The best-hyper-parameter file of that study."""
    return study_dir(root, algo, regime) / f"{algo}-{regime}.yaml"


def study_progress(path: Path) -> tuple[int, dict[str, Any]] | None:
    """Finished trials (COMPLETE + PRUNED) and the provenance recorded in a study's YAML (``None``: no file yet)."""
    if not path.is_file():
        return None
    provenance = (yaml.safe_load(path.read_text()) or {}).get("provenance") or {}
    return int(provenance.get("trials_complete", 0)) + int(provenance.get("trials_pruned", 0)), provenance


def off_policy_timesteps(provenance: dict[str, Any], minutes: float | None = None) -> int:
    """Environment steps that take about ``minutes`` of one core with a study's best hyper-parameters.

    ``minutes`` ``None``: the packaged campaign's ``off_policy_cpu_minutes``.

    DECISION (docs/rl.md §3): SAC and TD3 runs are budgeted in CPU time (about 20 minutes each in
    the packaged campaign), converted once into steps from the best trial's own measured CPU seconds for its steps
    (``best_trial_cpu_seconds`` / ``budget_steps_per_trial`` in the study's provenance), rounded
    to 10 000 and kept within 100 000-2 000 000. A step budget, not a clock, so a run is
    reproducible and resumes to the same end; it is fixed once the study is, because the study's
    file no longer changes.

    Raises:
        ValueError: a provenance without the trial's CPU time or budget.
    """
    cpu = provenance.get("best_trial_cpu_seconds")
    steps = provenance.get("budget_steps_per_trial")
    if not cpu or not steps:
        raise ValueError(
            "provenance: no best_trial_cpu_seconds / budget_steps_per_trial (a study written before "
            "they were recorded); pass --off-policy-steps"
        )
    if minutes is None:
        minutes = default_campaign().off_policy_cpu_minutes
    per_step = float(cpu) / float(steps)
    total = round(minutes * 60.0 / per_step / 10_000) * 10_000
    return int(min(2_000_000, max(100_000, total)))


def model_done(model: Path, timesteps: int) -> bool:
    """Whether ``model``'s sidecar says it trained ``timesteps`` steps to the end (not interrupted)."""
    sidecar = model.with_suffix(".json")
    if not model.is_file() or not sidecar.is_file():
        return False
    try:
        data = json.loads(sidecar.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError):
        return False
    return not data.get("interrupted") and int(data.get("timesteps_done", 0)) >= timesteps


def step_names(campaign: Campaign | None = None) -> list[str]:
    """The name of every step of the campaign (default: the packaged one), in order (they do not depend on its state)."""
    campaign = campaign or default_campaign()
    names = [f"tune/{a}-{r}" for a, r, _ in campaign.studies]
    for algo, regime, seeds, _ in campaign.runs:
        names += [f"train/{algo}-{regime}-s{seed}" for seed in seeds]
        if algo in campaign.confirmed:
            names += [f"train/{algo}-{regime}-{ZOO}-s{seed}" for seed in seeds]
    names += [f"train/{e.algo}-{e.regime}-{e.name}-s{seed}" for e in campaign.experiments for seed in e.seeds]
    return names


def tuning_steps(root: Path, campaign: Campaign | None = None) -> list[Step]:
    """The campaign's tuning studies (default: the packaged campaign), each done when its YAML records its trials."""
    steps = []
    for algo, regime, trials in (campaign or default_campaign()).studies:
        progress = study_progress(study_yaml(root, algo, regime))
        finished = progress is not None and progress[0] >= trials
        argv = ["tune", "--algo", algo, "--regime", regime, "--trials", str(trials),
                "--out", str(study_dir(root, algo, regime))]  # fmt: skip
        why = f"{progress[0] if progress else 0}/{trials} trials"
        steps.append(Step(f"tune/{algo}-{regime}", argv, finished, why))
    return steps


def final_cost(model: Path) -> float:
    """The final evaluation's mean cost (total J + failure penalty) recorded in a finished run's sidecar.

    Raises:
        ValueError: a sidecar without ``final_evaluation.mean_cost``.
    """
    sidecar = model.with_suffix(".json")
    final = (json.loads(sidecar.read_text()).get("final_evaluation") or {}).get("mean_cost")
    if final is None:
        raise ValueError(f"{sidecar}: no final_evaluation.mean_cost; expected the sidecar of a finished run")
    return float(final)


def selection_file(root: Path, algo: str, regime: str) -> Path:
    """Where the full-budget confirmation of ``algo`` on ``regime`` records its choice."""
    return study_dir(root, algo, regime) / "selection.yaml"


def confirm_selection(
    root: Path, algo: str, regime: str, timesteps: int, *, write: bool = True
) -> str | None:
    """Which set trains the remaining seeds: ``"study"``, ``ZOO``, or ``None`` while a candidate runs.

    DECISION (docs/rl.md §3.1): a short-budget study ranks settings by how fast they learn, not
    where they end (on the paper scenario its best set plateaued at J ~ 20.6 and then collapsed,
    where the untuned set kept improving to ~17). So seed 0 of both sets, the study's best and the
    untuned zoo-derived set, trains the full budget, and the set with the lower final cost (ties:
    the study's) trains seeds 1-4. Both seed-0 runs stay in the results under their own labels
    (``ppo-R-s0``, ``ppo-R-zoo-s0``). The choice is written once to ``selection.yaml`` beside the
    study, with both costs, and read back from it from then on (``write=False``: never written,
    for a dry run or a reader of a committed snapshot).

    Raises:
        ValueError: both runs finished but a sidecar lacks its final evaluation (names the file),
            or a ``selection.yaml`` whose ``chosen`` is neither ``study`` nor ``zoo``.
    """
    record = selection_file(root, algo, regime)
    if record.is_file():
        chosen = (yaml.safe_load(record.read_text()) or {}).get("chosen")
        if chosen not in ("study", ZOO):
            raise ValueError(f"{record}: chosen is {chosen!r}; expected 'study' or '{ZOO}'")
        return str(chosen)
    study_run = root / "models" / f"{algo}-{regime}-s0.zip"
    zoo_run = root / "models" / f"{algo}-{regime}-{ZOO}-s0.zip"
    if not (model_done(study_run, timesteps) and model_done(zoo_run, timesteps)):
        return None
    costs = {"study": final_cost(study_run), ZOO: final_cost(zoo_run)}
    chosen = "study" if costs["study"] <= costs[ZOO] else ZOO
    if write:
        from uav_penetration_env.atomic import write_text_atomic

        body = {
            "rule": "seed 0 of both sets trained the full budget; the lower final cost (total J + "
            "failure penalty of the final evaluation) trains the remaining seeds; ties: the study's set",
            "timesteps": timesteps,
            "final_cost": {"study": costs["study"], ZOO: costs[ZOO]},
            "runs": {"study": str(study_run), ZOO: str(zoo_run)},
            "chosen": chosen,
            "hyperparams": str(study_yaml(root, algo, regime))
            if chosen == "study"
            else f"baselines/hyperparams/{algo}.yaml",
        }
        write_text_atomic(record, yaml.safe_dump(body, sort_keys=False))
    return chosen


def train_step(
    name: str,
    algo: str,
    regime: str,
    seed: int,
    total: int,
    hyperparams: str | Path | None,
    model: Path,
    campaign: Campaign | None = None,
    flags: Sequence[str] = (),
) -> Step:
    """One resumable ``uav-bench train`` run (``hyperparams`` None: the untuned set), done when its sidecar says so.

    The regime's flags and the evaluation and checkpoint cadence come from ``campaign`` (default:
    the packaged one); ``flags`` are an experiment's formulation flags (docs/rl.md §6).
    """
    c = campaign or default_campaign()
    argv = ["train", "--algo", algo, *c.regime_flags[regime], "--timesteps", str(total), "--seed", str(seed),
            *(["--hyperparams", str(hyperparams)] if hyperparams else []), "--out", str(model),
            "--eval-freq", str(c.eval_freq[algo]), "--eval-episodes", str(c.eval_episodes[regime]),
            "--checkpoint-freq", str(c.checkpoint_freq[algo]), *flags, "--resume", "--no-progress"]  # fmt: skip
    done = model_done(model, total)
    return Step(name, argv, done, f"{total} steps" + (", done" if done else ""))


def training_steps(
    root: Path, off_policy_steps: int | None = None, *, write: bool = True, campaign: Campaign | None = None
) -> list[Step]:
    """The training runs; a run whose study (or, for a confirmed algorithm, whose confirmation) has not finished has no command yet.

    ``write=False`` never writes the confirmation's ``selection.yaml`` (:func:`confirm_selection`).
    ``campaign``: the runs and experiments to list (default: the packaged campaign).
    """
    campaign = campaign or default_campaign()
    trials_wanted = {(a, r): n for a, r, n in campaign.studies}
    steps = []
    for algo, regime, seeds, timesteps in campaign.runs:
        hyperparams = study_yaml(root, algo, regime)
        progress = study_progress(hyperparams)
        ready = progress is not None and progress[0] >= trials_wanted[(algo, regime)]
        total = timesteps
        if total is None and ready:
            total = (
                off_policy_steps
                if off_policy_steps is not None
                else off_policy_timesteps(progress[1], campaign.off_policy_cpu_minutes)
            )
        confirmed = algo in campaign.confirmed and total is not None
        blocked = ""
        try:
            chosen = confirm_selection(root, algo, regime, total, write=write) if confirmed else None
        except ValueError as error:  # a finished run without its final evaluation: say so, do not crash
            chosen, blocked = None, str(error)
        sets = [("", hyperparams, ready)] + ([(f"-{ZOO}", None, True)] if algo in campaign.confirmed else [])
        for seed in seeds:
            for part, params, params_ready in sets:
                label = f"{algo}-{regime}{part}-s{seed}"
                name = f"train/{label}"
                model = root / "models" / f"{label}.zip"
                if not params_ready or total is None:
                    steps.append(Step(name, None, False, f"waits for tune/{algo}-{regime}"))
                    continue
                if algo in campaign.confirmed and seed != min(seeds):
                    if chosen is None:
                        why = (
                            f"the confirmation cannot choose: {blocked}"
                            if blocked
                            else f"waits for the confirmation (train/{algo}-{regime}-s0 and train/{algo}-{regime}-{ZOO}-s0)"
                        )
                        steps.append(Step(name, None, False, why))  # fmt: skip
                        continue
                    if (chosen == ZOO) != (part == f"-{ZOO}"):
                        steps.append(Step(name, None, False, f"not chosen ({selection_file(root, algo, regime)})",
                                          skipped=True))  # fmt: skip
                        continue
                steps.append(train_step(name, algo, regime, seed, total, params, model, campaign))
    for algo, regime, experiment, overrides, seeds, total, flags in campaign.experiments:
        for seed in seeds:
            label = f"{algo}-{regime}-{experiment}-s{seed}"
            model = root / "models" / f"{label}.zip"
            steps.append(train_step(f"train/{label}", algo, regime, seed, total, overrides, model, campaign, flags))
    return steps


def unfinished_steps(root: Path, campaign: Campaign | None = None) -> list[str]:
    """Steps of the programme not done yet (``[]``: finished), read from ``root`` without writing anything.

    What ``--unfinished`` prints, one per line: a publication campaign's agents part waits while
    there are any (``agents.pending`` in leaderboards/campaigns/v2.yaml; docs/publishing.md §1).
    """
    steps = tuning_steps(root, campaign) + training_steps(root, write=False, campaign=campaign)
    return [step.name for step in steps if not (step.done or step.skipped)]


def run_logged(root: Path, name: str, argv: Sequence[str]) -> int:
    """Run ``uav-bench ARGV`` for step ``name`` in a fresh process, its attempt logged in ``ROOT/compute.jsonl``.

    DECISION (docs/rl.md §3, one runner's machinery): the programme's steps run and are logged by
    the publication campaigns' code, not a copy of it; what is done is still read from each step's
    results, because a step's command depends on the studies' results.

    The campaign runner's own machinery (:func:`uav_penetration_env.benchmark.campaign.process.run_attempt`):
    the same log line (step, command, wall and CPU seconds, exit status, commit) as a publication's,
    and on Ctrl-C the child, in the same process group, saves its state (exit status 130) while
    this waits for it.
    """
    return run_attempt(Path.cwd(), name, argv, Path(root) / "compute.jsonl")


@contextlib.contextmanager
def step_lock(root: Path, name: str) -> Iterator[bool]:
    """Hold ``ROOT/locks/NAME.lock`` while a step runs; yields False when another process holds it.

    DECISION (docs/rl.md §3, parallel programme processes): two processes may work through one
    programme (one per core); an advisory ``flock`` makes each skip a step the other is running, so
    no run is trained twice into the same files. The lock dies with its process, so a killed
    process leaves nothing to clean up. Without ``fcntl`` (Windows) every step counts as free.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not on the platforms CI runs
        yield True
        return
    path = root / "locks" / (name.replace("/", "_") + ".lock")
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            yield False
            return
        try:
            yield True
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def run_programme(
    root: Path = DEFAULT_ROOT,
    *,
    only: Sequence[str] = (),
    dry_run: bool = False,
    off_policy_steps: int | None = None,
    runner: Callable[[Sequence[str]], int] | None = None,
    campaign: Campaign | None = None,
) -> int:
    """Run every step not done yet, in order, printing each command; stop at the first failure.

    Args:
        root: the programme's folder (studies in ``tune/``, models in ``models/``).
        only: ``fnmatch`` patterns of step names to run (empty: all).
        dry_run: print the steps and their state, run nothing.
        off_policy_steps: steps of the SAC/TD3 runs instead of the CPU-time budget.
        runner: runs ``uav-bench ARGV`` and returns its exit status (default: :func:`run_logged`).
        campaign: what to run (default: the packaged campaign, ``baselines/campaigns/rl.yaml``).

    Returns:
        0 when every selected step is done or run by another programme process (:func:`step_lock`),
        else the failing step's exit status (130: interrupted).
    """
    root = Path(root)
    campaign = campaign or default_campaign()

    def selected(step: Step) -> bool:
        return not only or any(fnmatch.fnmatchcase(step.name, pattern) for pattern in only)

    for phase in (
        lambda: tuning_steps(root, campaign),
        lambda: training_steps(root, off_policy_steps, write=not dry_run, campaign=campaign),
    ):
        # The steps are listed again after every run: a finished run can make a waiting one ready
        # (the PPO confirmation chooses the set of the remaining seeds).
        reported: set[str] = set()
        waiting: set[str] = set()
        ran = True
        while ran:
            ran = False
            for step in filter(selected, phase()):
                if step.name in reported:
                    continue
                command = "uav-bench " + shlex.join(step.argv) if step.argv else "-"
                if step.done or step.skipped:
                    state = (
                        f"[done] {step.name} ({step.why})" if step.done else f"[skip] {step.name}: {step.why}"
                    )
                    print(state, flush=True)
                    reported.add(step.name)
                    continue
                if step.argv is None:
                    if step.name not in waiting:
                        print(f"[wait] {step.name}: {step.why}", flush=True)
                        waiting.add(step.name)
                    continue
                reported.add(step.name)
                if dry_run:
                    print(f"[plan] {step.name} ({step.why}): {command}", flush=True)
                    continue
                with step_lock(root, step.name) as free:
                    if not free:
                        print(f"[busy] {step.name}: another programme process runs it", flush=True)
                        continue
                    print(f"[run] {step.name} ({step.why}): {command}", flush=True)
                    status = runner(step.argv) if runner is not None else run_logged(root, step.name, step.argv)
                if status != 0:
                    print(
                        f"programme stopped at {step.name} (exit status {status}); run it again to continue"
                    )
                    return status
                ran = True
                break
    return 0


STUDY_FILES = ("*.yaml", "*.trials.csv", "*.summary.md")  # beside each study's SQLite storage
MODEL_SUFFIXES = (".zip", ".json", ".vecnormalize.pkl", ".evaluations.csv")


def _copy_sqlite(source: Path, target: Path) -> None:
    """A consistent copy of an SQLite file that may be written meanwhile (SQLite's online backup)."""
    import sqlite3

    from uav_penetration_env.atomic import atomic_path

    target.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(target) as temporary:
        src, dst = sqlite3.connect(source), sqlite3.connect(temporary)
        try:
            src.backup(dst)
        finally:
            dst.close()
            src.close()


def _copy_file(source: Path, target: Path) -> None:
    from uav_penetration_env.atomic import atomic_path

    target.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(target) as temporary:
        shutil.copyfile(source, temporary)


def snapshot(root: Path, destination: Path, *, replay_buffers: bool = False) -> list[Path]:
    """Copy what resuming the programme needs from ``root`` to ``destination`` (to be committed).

    Per study: its SQLite storage (a consistent online backup, so a running study may be
    snapshotted), best YAML, trial table and summary; the trials' models are left out (evidence,
    not needed to resume). Per model: a finished model's files; an unfinished one's last
    checkpoint (``resume.json`` and the files it names); an unfinished SAC/TD3 run only with
    ``replay_buffers`` (its buffer is tens of MB and it cannot resume without it, so without the
    flag such a run starts over).

    DECISION (docs/rl.md §3): the programme's state travels between sessions as committed files,
    because a session can end at any time and only what is committed survives it.

    Returns:
        The files written.
    """
    root, destination = Path(root), Path(destination)
    written: list[Path] = []
    for study in sorted((root / "tune").glob("*/study.sqlite")):
        relative = study.parent.relative_to(root)
        _copy_sqlite(study, destination / relative / study.name)
        written.append(destination / relative / study.name)
        for pattern in STUDY_FILES:
            for path in sorted(study.parent.glob(pattern)):
                _copy_file(path, destination / relative / path.name)
                written.append(destination / relative / path.name)
    for model in sorted((root / "models").glob("*.zip")):
        relative = model.parent.relative_to(root)
        stem = model.name[: -len(".zip")]
        for suffix in MODEL_SUFFIXES:
            path = model.parent / f"{stem}{suffix}"
            if path.is_file():
                _copy_file(path, destination / relative / path.name)
                written.append(destination / relative / path.name)
    for state in sorted((root / "models").glob("*.checkpoints/resume.json")):
        data = json.loads(state.read_text())
        if data.get("finished") or (data.get("replay_buffer") and not replay_buffers):
            continue  # an off-policy checkpoint without its buffer cannot resume: the run starts over
        names = [state.name, data["model"]]
        model_stem = data["model"][: -len(".zip")]
        names += [f"{model_stem}{suffix}" for suffix in MODEL_SUFFIXES[1:]]
        if replay_buffers and data.get("replay_buffer"):
            names.append(data["replay_buffer"])
        relative = state.parent.relative_to(root)
        target_folder = destination / relative
        if target_folder.is_dir():  # an older snapshot's checkpoint is superseded by this one
            for stale in target_folder.iterdir():
                if stale.is_file() and stale.name not in names:
                    stale.unlink()
        for name in names:
            path = state.parent / name
            if path.is_file():
                _copy_file(path, destination / relative / name)
                written.append(destination / relative / name)
    return written


def restore(source: Path, root: Path) -> list[Path]:
    """Copy a :func:`snapshot` back under ``root``, never over a file that is already there.

    Returns:
        The files copied.
    """
    source, root = Path(source), Path(root)
    copied = []
    for path in sorted(p for p in source.rglob("*") if p.is_file()):
        target = root / path.relative_to(source)
        if not target.exists():
            _copy_file(path, target)
            copied.append(target)
    return copied


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m baselines.programme``: run (or continue) the programme."""
    parser = argparse.ArgumentParser(
        prog="python -m baselines.programme", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--root", default=str(DEFAULT_ROOT), help=f"output folder (default: {DEFAULT_ROOT})")
    parser.add_argument(
        "--campaign",
        default=str(DEFAULT_CAMPAIGN),
        metavar="PATH",
        help="the campaign's YAML file: its studies and runs (default: the packaged baselines/campaigns/rl.yaml)",
    )
    parser.add_argument(
        "--only", nargs="+", default=(), metavar="PATTERN", help="run only steps matching (e.g. 'tune/*')"
    )
    parser.add_argument("--dry-run", action="store_true", help="print the steps and their state; run nothing")
    parser.add_argument("--unfinished", action="store_true",
                        help="print the steps not done yet, one per line (none: finished); run nothing")  # fmt: skip
    parser.add_argument(
        "--off-policy-steps",
        type=int,
        help="steps of each run without timesteps in the campaign (default: its off_policy_cpu_minutes "
        f"of one core, from the study; {default_campaign().off_policy_cpu_minutes:g} in the packaged one)",
    )
    carry = parser.add_mutually_exclusive_group()
    carry.add_argument(
        "--snapshot",
        metavar="DEST",
        help="copy the studies and models (no replay buffers) to DEST, to commit them; run nothing",
    )
    carry.add_argument(
        "--restore", metavar="SRC", help="copy a snapshot back under --root (missing files only); run nothing"
    )
    args = parser.parse_args(argv)
    if args.off_policy_steps is not None and args.off_policy_steps < 1:
        parser.error(f"--off-policy-steps: got {args.off_policy_steps}, expected an integer >= 1")
    if args.restore and not Path(args.restore).is_dir():
        parser.error(f"--restore {args.restore}: not found; expected a folder written by --snapshot")
    try:
        campaign = load_campaign(args.campaign)
    except CampaignError as error:
        parser.error(f"--campaign {error}")
    names = step_names(campaign)
    unmatched = [p for p in args.only if not any(fnmatch.fnmatchcase(name, p) for name in names)]
    if unmatched:
        parser.error(f"--only {' '.join(unmatched)}: matches no step; expected patterns such as 'tune/ppo-*'")
    if args.unfinished:
        print("\n".join(unfinished_steps(Path(args.root), campaign)))
        return 0
    if args.snapshot or args.restore:
        copied = (
            snapshot(Path(args.root), Path(args.snapshot))
            if args.snapshot
            else restore(Path(args.restore), Path(args.root))
        )
        print(f"{len(copied)} files copied to {args.snapshot or args.root}")
        return 0
    try:
        return run_programme(
            Path(args.root),
            only=args.only,
            dry_run=args.dry_run,
            off_policy_steps=args.off_policy_steps,
            campaign=campaign,
        )
    except KeyboardInterrupt:
        print("\ninterrupted; run the same command again to continue", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
