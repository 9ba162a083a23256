"""Regenerate the published leaderboard v2: every command, resumable, with its compute.

```bash
python benchmarks/publish.py --dry-run              # every command and whether it is done
nice -n 10 python benchmarks/publish.py             # run what is not done (results under results/v2)
python benchmarks/publish.py --only tables          # run some parts only
python benchmarks/publish.py --compute              # wall, CPU and worker time per part
python benchmarks/publish.py --install              # replace leaderboards/'s generated files by results/v2/out's
python benchmarks/publish.py --from-published       # a new machine: results/v2 rebuilt from leaderboards/
```

The parts, in order (each a list of ``uav-bench`` commands, printed exactly as run by ``--dry-run``;
docs/publishing.md §1):

1. ``paper``: the paper scenario in both weightings, 20 paired seeds, 10 000 evaluations per
   planning step: the six paper planners, the references, the IHPSO ablations and the floors;
2. ``windows``: IHPSO, HPSO and IHPSO's variants rerun on MPC window states of the greedy episode
   (the fixed-target and fixed-budget study, with the tolerance variants);
3. ``suite``: the frozen suite ``uavpen-v1`` (its own seed rule) for the paper planners, ``cmaes``
   and the floors;
4. ``windows-suite``: IHPSO and HPSO on the window states of one procedural member per difficulty;
5. ``held-out``: the held-out set, frozen as the suite ``uavpen-heldout-v1``, for the same policies;
6. ``agents``: every finished agent of the RL programme (``leaderboards/rl/models``) on the paper
   scenario in both weightings and on the held-out suite, the Random-regime agents on
   ``uavpen-v1``, and the agent-warm-started IHPSO; while the programme's committed snapshot
   ``leaderboards/rl`` is incomplete it flies the agents finished so far, then waits (exit status 3);
7. ``best-known``: best-known records updated from the store (tracked files change: commit them);
8. ``tables``: the learning curves, the figures (per-scenario figures and 3-D views only for
   scenarios flown with at least 2 seeds: the procedural members, one seed each, are summarised by
   the suite tables), the leaderboards and the HTML report from the store into ``results/v2/out``,
   the episode, run, window-run and step rows exported as Parquet, and the tables rebuilt from the
   rows alone, which must equal the store's byte for byte apart from the date line.

DECISION (docs/publishing.md §2, clean tree): a command runs only on a clean working tree (tracked files as committed),
so every run's provenance names a clean commit; between the ``best-known`` and ``tables`` parts
the updated records must be committed. One store holds everything (``results/v2/leaderboard.sqlite``):
the suite's paper members reuse the paper part's episodes (same policy, scenario and seed), and one
report covers every table.

DECISION (docs/publishing.md §2, compute log): each attempt of a command appends a line to ``results/v2/compute.jsonl``
(part, command, wall seconds, CPU seconds of its process tree, exit status, commit); a command is
done when one attempt exited 0. ``uav-bench run`` and ``windows`` skip what the store holds, so a
cut attempt resumes. An attempt killed with its session writes no line, so ``--compute`` also sums
the worker time of every finished episode and window run from the rows (:func:`worker_seconds`).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import resource
import shlex
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from uav_penetration_env.benchmark.commands.common import OUT_SOURCE_FILE

REPO = Path(__file__).resolve().parents[1]
ROOT = Path("results/v2")
STORE = ROOT / "leaderboard.sqlite"
OUT = ROOT / "out"
ROWS = OUT / "rows" / "leaderboard"
# v2 and v3 were published under the retired fixed-target pairing; their parts keep it so they rebuild
# byte for byte (api.md §4.8, uav_penetration_env/benchmark/fixedtarget_retired.py).
RETIRED_RULE = ["--fixed-target-rule", "worse-final"]
CHECK = ROOT / "from-rows"
MODELS = Path("leaderboards/rl/models")
RL_ROOT = Path("leaderboards/rl")  # the RL programme's committed snapshot (docs/rl.md §3)
WAITING = 3  # exit status while a part waits for the RL programme (not done, not failed)

PAPER_PLANNERS = ["ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism"]
REFERENCES = ["pso", "cem", "de", "cmaes"]
IHPSO_VARIANTS = ["ihpso-noswitch", "ihpso-noreverse", "ihpso-noterm", "ihpso-random", "ihpso-scheme1",
                  "ihpso-scheme2", "ihpso-scheme3", "ihpso-2022v0", "ihpso-eq37"]  # fmt: skip
FLOORS = ["greedy", "random"]
WINDOW_OPTIMIZERS = ["ihpso", "hpso", "ihpso-noswitch", "ihpso-noreverse", "ihpso-noterm", "ihpso-2022v0",
                     "ihpso-rtol1e-6", "ihpso-rtol1e-5", "ihpso-rtol1e-3", "ihpso-rtol1e-2"]  # fmt: skip
# Every third step of the greedy episode of the paper scenario (47 steps): 15 window states.
WINDOW_STEPS = ",".join(str(step) for step in range(2, 47, 3))
COMMON = ["--store", str(STORE), "--no-report", "--no-progress"]
SUITE_WINDOW_MEMBERS = ("random-30000", "random-30100", "random-30200")  # difficulty 0.25, 0.50, 0.75
HELD_OUT = "uavpen-heldout-v1"  # the held-out set (model.md §7c) frozen as a suite: one seed per member
# The greedy floor on the paper scenario, a line in the learning curves: the suite's frozen replay
# J of uavpen-v1/paper (17.19829762, docs/suite.md), so the command does not depend on the store.
GREEDY_LINE = "paper-2022-sec5:greedy=17.198"


@dataclass(frozen=True)
class Part:
    """One part of the regeneration: its commands, or why it cannot run yet."""

    name: str
    commands: list[list[str]]
    waits: str = ""


def agent_models(models: Path = MODELS) -> list[Path]:
    """The finished agents committed by the RL programme, in name order (checkpoints left out).

    ``models`` is relative to the repository (as the commands name it); the result is too.
    """
    finished = []
    for model in sorted((REPO / models).glob("*.zip")):
        sidecar = model.with_suffix(".json")
        if sidecar.is_file() and not json.loads(sidecar.read_text()).get("interrupted"):
            finished.append(Path(models) / model.name)
    return finished


def programme_unfinished(root: Path = RL_ROOT) -> list[str]:
    """Steps of the RL programme not done yet (``[]``: finished), read from its committed snapshot."""
    from baselines.programme import training_steps, tuning_steps

    steps = tuning_steps(REPO / root) + training_steps(REPO / root, write=False)
    return [step.name for step in steps if not (step.done or step.skipped)]


def chosen_paper_ppo(agents: Sequence[str], rl_root: Path = RL_ROOT) -> list[str]:
    """The PPO paper agents of the set the confirmation chose (docs/rl.md §3.1): they warm-start IHPSO.

    Without a ``selection.yaml`` (a programme without the confirmation), every PPO paper agent.
    """
    import yaml

    record = REPO / rl_root / "tune" / "ppo-paper" / "selection.yaml"
    chosen = (yaml.safe_load(record.read_text()) or {}).get("chosen") if record.is_file() else None
    paper = [a for a in agents if "/ppo-paper-" in a]
    if chosen is None:
        return paper
    return [a for a in paper if ("/ppo-paper-zoo-s" in a) == (chosen == "zoo")]


def parts(
    models: Path = MODELS, unfinished: Callable[[], list[str]] | None = None, rl_root: Path = RL_ROOT
) -> list[Part]:
    """The regeneration's parts, in order, with their commands (``unfinished``: the RL programme's open steps)."""
    return publication_parts(Layout(STORE, OUT, ROWS, CHECK), models, unfinished, rl_root)


@dataclass(frozen=True)
class Layout:
    """Where one publication's commands write: its store, output folder, row stem and rebuild folder."""

    store: Path
    out: Path
    rows: Path
    check: Path


def publication_parts(
    layout: Layout,
    models: Path = MODELS,
    unfinished: Callable[[], list[str]] | None = None,
    rl_root: Path = RL_ROOT,
    beside: Sequence[str] = (),
) -> list[Part]:
    """The parts of a publication writing to ``layout`` (``beside``: policies added to the paper, suite and held-out parts)."""
    STORE, OUT, ROWS, CHECK = layout.store, layout.out, layout.rows, layout.check
    COMMON = ["--store", str(STORE), "--no-report", "--no-progress"]
    paper = Part("paper", [["run", "--scenarios", "paper", "paper-w2", "--policies", *PAPER_PLANNERS, *REFERENCES,
                            *IHPSO_VARIANTS, *FLOORS, *beside, "--seeds", "20", "--max-evals", "10000", *COMMON]])  # fmt: skip
    windows = Part("windows", [["windows", "--store", str(STORE), "--from-policy", "greedy", "--scenario", "paper",
                                "--steps", WINDOW_STEPS, "--optimizers", *WINDOW_OPTIMIZERS, "--seeds", "20"]])  # fmt: skip
    suite = Part(
        "suite",
        [["run", "--suite", "uavpen-v1", "--policies", *PAPER_PLANNERS, "cmaes", *FLOORS, *beside, *COMMON]],
    )
    # The same windows study on the first procedural member of each difficulty (their greedy episodes
    # fly 47 steps, as the paper scenario's): does the reverse switch act more on other landscapes?
    windows_suite = Part("windows-suite", [
        ["windows", "--store", str(STORE), "--from-policy", "greedy", "--scenario", member, "--steps", WINDOW_STEPS,
         "--optimizers", "ihpso", "hpso", "--seeds", "20"]
        for member in SUITE_WINDOW_MEMBERS
    ])  # fmt: skip
    # The held-out set: the Random-regime agents' test set (docs/suite.md), with the planners and floors to
    # pair them with; the agents join in the agents part.
    held_out = Part("held-out", [["run", "--suite", HELD_OUT, "--policies", *PAPER_PLANNERS, "cmaes", *FLOORS,
                                  *beside, *COMMON]])  # fmt: skip
    waiting = (unfinished or programme_unfinished)()
    agents = [f"sb3:{model.as_posix()}" for model in agent_models(models)]
    commands = []
    if agents:
        random_agents = [a for a in agents if "-random-" in a]
        hybrids = [f"ihpso+{agent}" for agent in chosen_paper_ppo(agents, rl_root)]
        commands.append(
            ["run", "--scenarios", "paper", "paper-w2", "--policies", *agents, "--seeds", "20", *COMMON]
        )
        if random_agents:
            commands.append(["run", "--suite", "uavpen-v1", "--policies", *random_agents, *COMMON])
        # Every agent on the held-out set: the Random-regime agents' test, the paper agents' generalisation.
        commands.append(["run", "--suite", HELD_OUT, "--policies", *agents, *COMMON])
        if hybrids:
            commands.append(["run", "--scenarios", "paper", "--policies", *hybrids, "--seeds", "20",
                             "--max-evals", "10000", *COMMON])  # fmt: skip
    # DECISION (docs/publishing.md §1, incremental agents): while the programme runs, the part flies
    # the agents finished so far and then waits; the next attempt's commands name more agents, and
    # `uav-bench run` skips the episodes the store holds, so only the new agents fly.
    waits = f"the RL programme has {len(waiting)} unfinished steps ({waiting[0]}, ...)" if waiting else ""
    agent_part = Part("agents", commands, waits)
    best_known = Part("best-known", [["best-known", "update", "--store", str(STORE), "--no-progress"]])
    tables = Part(
        "tables",
        [
            ["plot", "--models", str(models), "--out", str(OUT), "--reference-line", GREEDY_LINE],
            ["plot", "--store", str(STORE), "--out", str(OUT), "--min-seeds", "2"],
            ["report", "--store", str(STORE), "--out", str(OUT), "--min-seeds", "2",
             "--figures", str(OUT / "learning-curves.png"), *RETIRED_RULE],
            ["export", "--format", "parquet", "--store", str(STORE), "--out", str(ROWS)],
            ["leaderboard", "--rows", str(ROWS), "--out", str(CHECK), *RETIRED_RULE],
        ],
    )  # fmt: skip
    return [paper, windows, suite, windows_suite, held_out, agent_part, best_known, tables]


def command_key(argv: Sequence[str]) -> str:
    """The command as logged and printed: ``uav-bench ...``, or ``python benchmarks/....py ...`` for a script."""
    return shlex.join(["python", *argv] if argv and argv[0].endswith(".py") else ["uav-bench", *argv])


def read_log(log: Path) -> list[dict]:
    """The attempts recorded so far (an unreadable line is reported, not skipped silently)."""
    if not log.is_file():
        return []
    attempts = []
    for number, line in enumerate(log.read_text().splitlines(), 1):
        try:
            attempts.append(json.loads(line))
        except json.JSONDecodeError as error:
            raise SystemExit(
                f"{log}:{number}: not a JSON line ({error}); expected one attempt per line"
            ) from None
    return attempts


ORDER = ("paper", "windows", "suite", "windows-suite", "held-out", "agents", "best-known", "tables")
# Parts computed from what earlier parts wrote (the store, the records).
DERIVED = ("best-known", "tables")


def current(attempts: list[dict], index: int) -> bool:
    """Whether attempt ``index`` saw every earlier part's output: no attempt of an earlier part came after it.

    DECISION (docs/publishing.md §2, staleness): a derived part (best-known, tables) done before a run
    part added rows (a first publication before the agents part, say) is stale and runs again; run
    parts skip what the store holds, so they are never stale.
    """
    part = attempts[index].get("part")
    if part not in DERIVED:
        return True
    later = DERIVED[DERIVED.index(part) :]  # the derived parts are last in every publication's order
    return not any(a.get("part") not in later for a in attempts[index + 1 :])


def done_commands(attempts: list[dict]) -> set[str]:
    """The commands with a successful attempt that is :func:`current`."""
    return {a["command"] for i, a in enumerate(attempts) if a.get("status") == 0 and current(attempts, i)}


def dirty_files(repo: Path = REPO) -> list[str]:
    """Tracked files that differ from the commit (untracked files do not count, as in provenance)."""
    out = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=repo,
                         capture_output=True, text=True, check=True).stdout  # fmt: skip
    return [line[3:] for line in out.splitlines() if line.strip()]


def commit(repo: Path = REPO) -> str:
    return subprocess.run(
        ["git", "rev-parse", "HEAD"], cwd=repo, capture_output=True, text=True, check=True
    ).stdout.strip()


def uav_bench() -> list[str]:
    from baselines.programme import uav_bench_command  # the same lookup as the RL programme's

    return uav_bench_command()


def child_environment(repo: Path = REPO) -> dict[str, str]:
    """The environment of every command: this tree first on ``PYTHONPATH``.

    So the commands import the code whose commit is checked and recorded, not an editable install
    of another checkout.
    """
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(repo), env.get("PYTHONPATH", "")) if p)
    return env


def imported_from(repo: Path = REPO) -> Path:
    """Where the commands import the package from (checked against ``repo`` before anything runs)."""
    out = subprocess.run([sys.executable, "-c", "import uav_penetration_env as p; print(p.__file__)"],
                         cwd=repo, env=child_environment(repo), capture_output=True, text=True, check=True).stdout  # fmt: skip
    return Path(out.strip()).resolve().parent


def run_attempt(part: str, argv: list[str], log: Path) -> int:
    """Run one command in the repository, append its attempt (wall and CPU seconds, status) to ``log``."""
    revision = commit()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat()
    clock = time.perf_counter()
    program = (
        [sys.executable] if argv[0].endswith(".py") else uav_bench()
    )  # a script of this tree, or uav-bench
    process = subprocess.Popen([*program, *argv], cwd=REPO, env=child_environment())
    try:
        status = process.wait()
    except KeyboardInterrupt:
        status = process.wait()
    if status < 0:  # killed by a signal: report it as a shell does (130 for Ctrl-C)
        status = 128 - status
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    attempt = {"part": part, "command": command_key(argv), "started": started,
               "wall_s": round(time.perf_counter() - clock, 1), "cpu_s": round(cpu, 1), "status": status,
               "commit": revision}  # fmt: skip
    append_attempt(log, attempt)
    return status


def append_attempt(log: Path, attempt: dict) -> None:
    log.parent.mkdir(parents=True, exist_ok=True)
    with log.open("a") as handle:  # one short line per attempt: an append is atomic enough here
        handle.write(json.dumps(attempt) + "\n")


def date_free(text: str) -> str:
    """A generated file without its date line (the one line allowed to differ between rebuilds)."""
    return "\n".join(line for line in text.splitlines() if not line.startswith(("- Date:", "Date:")))


def compare_rebuild(out: Path = OUT, check: Path = CHECK) -> list[str]:
    """Tables that differ between the store's output and the rebuild from rows; ``[]``: all equal.

    Equal means byte for byte apart from the date line; a table on one side only differs.
    """

    def tables(folder: Path) -> set[str]:
        return {p.name for p in folder.iterdir() if p.suffix in (".md", ".csv")} if folder.is_dir() else set()

    written, rebuilt = tables(out), tables(check)
    if not rebuilt:
        return [f"{check}: no tables rebuilt from the rows"]
    differing = sorted(written ^ rebuilt)
    for name in sorted(written & rebuilt):
        if date_free((out / name).read_text()) != date_free((check / name).read_text()):
            differing.append(name)
    return sorted(differing)


REBUILD_CHECK = "rebuild check: tables from rows equal the store's"


def rebuild_checked(attempts: list[dict], commands: Sequence[str] = ()) -> bool:
    """Whether the last thing the tables part recorded is a passed rebuild check of current tables.

    Args:
        attempts: the compute log.
        commands: the tables part's commands (keys); each must have succeeded after the last attempt
            of an earlier part and before the check, so that the check compared tables built from
            every row (a check alone, after new rows, proves nothing about the tables it read).
    """
    tables = [i for i, a in enumerate(attempts) if a.get("part") == "tables"]
    if not tables:
        return False
    check = tables[-1]
    last = attempts[check]
    if not (last.get("command") == REBUILD_CHECK and last.get("status") == 0 and current(attempts, check)):
        return False
    since = max((i for i, a in enumerate(attempts[:check]) if a.get("part") != "tables"), default=-1)
    rebuilt = {
        a["command"]
        for a in attempts[since + 1 : check]
        if a.get("part") == "tables" and a.get("status") == 0
    }
    return all(command in rebuilt for command in commands)


def install(out: Path = OUT, target: Path = Path("leaderboards"), log: Path | None = None) -> list[Path]:
    """Replace the generated files of ``leaderboards/`` by those of ``out`` (``rl/`` is left alone).

    Removed first: v1's generated files at the top of ``leaderboards/`` (tables, figures, the page,
    its episode CSVs) and its ``models/`` and ``rows/`` folders, all replaced by v2's.
    """
    out, target = REPO / out, REPO / target
    if not (out / "index.html").is_file():
        raise SystemExit(f"{out}: no index.html; run the tables part first")
    for stale in target.iterdir():
        if stale.is_file() and stale.suffix in (".md", ".csv", ".png", ".pdf", ".html", ".parquet"):
            stale.unlink()
    for folder in ("models", "rows"):  # v1's agents and any older rows; rl/ (the programme's state) stays
        if (target / folder).is_dir():
            shutil.rmtree(target / folder)
    copied = []
    for path in sorted(p for p in out.rglob("*") if p.is_file() and p.name != OUT_SOURCE_FILE):
        destination = target / path.relative_to(out)
        destination.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(path, destination)
        copied.append(destination)
    log = REPO / ROOT / "compute.jsonl" if log is None else REPO / log
    if (
        log.is_file()
    ):  # the compute the README quotes, committed with the tables (benchmarks/headline.py reads it)
        shutil.copyfile(log, target / "compute.jsonl")
        copied.append(target / "compute.jsonl")
    return copied


def install_folder(out: Path, target: Path, log: Path | None = None) -> list[Path]:
    """Replace the folder ``target`` by ``out``'s tables, figures and report, without the exported rows.

    DECISION (docs/publishing.md §5.5, v3's install): a publication whose rows are committed
    elsewhere (v3's checkpoint chunks, which its tables part rebuilds from) installs into a folder
    of its own, so the earlier version's tables stay where they are and nothing is copied twice:
    every file under ``out`` except ``rows/`` (the store's export, the same rows as the chunks),
    then the compute log. The new folder is written beside ``target`` and renamed over it, so a cut
    install leaves the previous one whole.

    Raises:
        SystemExit: ``out`` has no ``index.html`` (the tables part has not run).
    """
    out, target = REPO / out, REPO / target
    if not (out / "index.html").is_file():
        raise SystemExit(f"{out}: no index.html; run the tables part first")
    staging = target.with_name(target.name + ".installing")
    if staging.exists():
        shutil.rmtree(staging)
    files = sorted(
        p for p in out.rglob("*")
        if p.is_file() and p.name != OUT_SOURCE_FILE and p.relative_to(out).parts[0] != "rows"
    )  # fmt: skip
    for path in files:
        destination = staging / path.relative_to(out)
        destination.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(path, destination)
    log = REPO / log if log is not None else None
    if log is not None and log.is_file():
        shutil.copyfile(log, staging / "compute.jsonl")
    previous = target.with_name(target.name + ".previous")
    if previous.exists():
        shutil.rmtree(previous)
    if target.exists():  # moved aside, not removed, until the new folder is in place
        target.rename(previous)
    staging.rename(target)
    if previous.exists():
        shutil.rmtree(previous)
    return sorted(p for p in target.rglob("*") if p.is_file())


def rl_compute(rl_root: Path = RL_ROOT) -> list[tuple[str, int, float]]:
    """The RL programme's compute from its committed snapshot: (what, count, wall seconds).

    Tuning: the trials' own durations (``*.trials.csv``); training: each finished model's
    ``wall_seconds`` (every resumed segment included). One torch thread per process, so wall time
    is CPU time on an idle core and more on a loaded one.
    """
    import csv

    root = REPO / rl_root
    trials = [row for path in sorted(root.glob("tune/*/*.trials.csv")) for row in csv.DictReader(path.open())]
    tuning = sum(float(row.get("duration_s") or 0.0) for row in trials)
    models = [json.loads(path.read_text()) for path in sorted(root.glob("models/*.json"))]
    training = sum(float(m.get("wall_seconds") or 0.0) for m in models)
    return [(f"RL tuning ({len(trials)} trials)", len(trials), tuning),
            (f"RL training ({len(models)} runs)", len(models), training)]  # fmt: skip


def imitation_compute(distill_root: Path, names: Sequence[str] | None = None) -> tuple[str, float] | None:
    """The published distilled networks' training: (what, CPU seconds), from their sidecars; ``None`` without any.

    Each ``RUN/policy.json`` records the distillation's CPU seconds (expert labelling and fits,
    ``train_cpu_seconds``) and its expert labels (``expert_labels``, each one expert decision).
    ``names``: only these run folders (a publication's own networks; default every one).
    """
    paths = sorted(p for p in (REPO / distill_root).glob("*/policy.json") if names is None or p.parent.name in names)
    sidecars = [json.loads(path.read_text()) for path in paths]
    if not sidecars:
        return None
    labels = sum(int(s.get("expert_labels") or 0) for s in sidecars)
    seconds = sum(float(s.get("train_cpu_seconds") or 0.0) for s in sidecars)
    return f"imitation training ({len(sidecars)} networks, {labels:,} expert labels)", seconds


def worker_seconds(tables: Any) -> dict[str, tuple[int, float]]:
    """Per run command: (finished episodes and window runs, the sum of their own wall seconds).

    Read from a store's (or its exported rows') ``runs``, ``episodes`` (``episode_seconds``) and
    ``window_runs`` (``seconds``) tables, keyed by the command each run's provenance records, so every
    finished item counts, including those of an attempt killed before the driver could log it.
    """
    commands = {int(r.run_id): json.loads(r.provenance).get("command", "") for r in tables.runs.itertuples()}
    totals: dict[str, list[float]] = {}
    for frame, column in ((tables.episodes, "episode_seconds"), (tables.window_runs, "seconds")):
        if frame.empty:
            continue
        for run_id, seconds in frame.groupby("run_id")[column]:
            total = totals.setdefault(commands.get(int(run_id), ""), [0, 0.0])
            total[0] += len(seconds)
            total[1] += float(seconds.sum())
    return {command: (int(n), seconds) for command, (n, seconds) in totals.items()}


def compute_table(
    attempts: list[dict],
    rl_root: Path = RL_ROOT,
    worker: dict[str, tuple[int, float]] | None = None,
    order: Sequence[str] = ORDER,
    distill_root: Path | None = None,
    distill_names: Sequence[str] | None = None,
) -> str:
    """Per part: attempts, logged wall and CPU time, and the worker time of its finished work; then the RL programme.

    DECISION (docs/publishing.md §2): two measures. The log's wall and CPU time cover the attempts
    that ended (a process killed with the session never writes its line); the worker time is the
    sum of every finished episode's and window run's own wall time (``worker``, from the rows), which
    counts all finished work whichever attempt did it. With as many workers as idle cores it
    approximates CPU time; on a shared machine it includes the waiting.
    """
    worker = worker or {}
    part_of = {a["command"]: a["part"] for a in attempts}
    lines = ["| part | attempts | wall [h] | CPU [h] | episodes + window runs | worker [h] |",
             "|---|---:|---:|---:|---:|---:|"]  # fmt: skip
    total_wall = total_cpu = total_worker = 0.0
    for name in order:
        rows = [a for a in attempts if a["part"] == name]
        done = [value for command, value in worker.items() if part_of.get(command) == name]
        if not rows and not done:
            continue
        wall, cpu = sum(a["wall_s"] for a in rows), sum(a["cpu_s"] for a in rows)
        items, seconds = sum(n for n, _ in done), sum(s for _, s in done)
        total_wall, total_cpu, total_worker = total_wall + wall, total_cpu + cpu, total_worker + seconds
        work = f"{items} | {seconds / 3600:.2f}" if done else "- | -"
        lines.append(f"| {name} | {len(rows)} | {wall / 3600:.2f} | {cpu / 3600:.2f} | {work} |")
    unlogged = [value for command, value in worker.items() if command not in part_of]
    if unlogged:
        items, seconds = sum(n for n, _ in unlogged), sum(s for _, s in unlogged)
        total_worker += seconds
        lines.append(f"| (runs of no logged command) | | | | {items} | {seconds / 3600:.2f} |")
    lines.append(
        f"| total | | {total_wall / 3600:.2f} | {total_cpu / 3600:.2f} | | {total_worker / 3600:.2f} |"
    )
    for what, _, wall in rl_compute(rl_root):
        lines.append(f"| {what} | | {wall / 3600:.2f} | (one core each) | | |")
    imitation = imitation_compute(distill_root, distill_names) if distill_root is not None else None
    if imitation is not None:
        lines.append(f"| {imitation[0]} | | | {imitation[1] / 3600:.2f} | | |")
    return "\n".join(lines)


def published_worker_seconds() -> dict[str, tuple[int, float]]:
    """:func:`worker_seconds` of the store, or of the committed rows on a clone without it ({} if neither)."""
    from uav_penetration_env.benchmark.rows import read_rows, store_tables

    if (REPO / STORE).is_file():
        return worker_seconds(store_tables(REPO / STORE))
    committed = REPO / "leaderboards" / "rows" / "leaderboard"
    if committed.with_name("leaderboard-runs.parquet").is_file():
        return worker_seconds(read_rows(committed))
    return {}


def from_published(root: Path = ROOT, published: Path = Path("leaderboards")) -> int:
    """Rebuild ``root``'s store and compute log from an installed leaderboard (``--from-published``).

    DECISION (docs/publishing.md §2, carrying on elsewhere): the store and the compute log live
    outside the tracked tree, so a new machine (or a lost folder) has neither. The installed
    leaderboard holds both in committed form: the rows (``leaderboards/rows``), which ``uav-bench
    import`` turns back into the store with every id kept, and the compute log ``--install``
    copied. With them back, every published command reads as done and a new agent, say, flies
    alone; nothing published is recomputed.

    Returns:
        The exit status of ``uav-bench import`` (the log is copied only after it succeeded).

    Raises:
        FileExistsError: the store or the log already exists (they are never overwritten).
        FileNotFoundError: no installed rows or compute log.
    """
    store, log = REPO / root / STORE.name, REPO / root / "compute.jsonl"
    for path in (store, log):
        if path.exists():
            raise FileExistsError(f"{path} exists; --from-published only rebuilds a missing store and log")
    rows, published_log = REPO / published / "rows" / "leaderboard", REPO / published / "compute.jsonl"
    for path in (rows.with_name("leaderboard-episodes.parquet"), published_log):
        if not path.is_file():
            raise FileNotFoundError(f"{path}: missing; expected an installed leaderboard (--install)")
    argv = ["import", "--rows", str(rows.relative_to(REPO)), "--store", str(store.relative_to(REPO))]
    print(f"[run] {command_key(argv)}", flush=True)
    status = subprocess.run([*uav_bench(), *argv], cwd=REPO, env=child_environment()).returncode
    if status == 0:
        from uav_penetration_env.atomic import atomic_path

        with atomic_path(log) as temporary:  # a cut copy never passes for the log
            shutil.copyfile(published_log, temporary)
        print(
            f"{log.relative_to(REPO)}: {len(read_log(log))} attempts, copied from {published_log.relative_to(REPO)}"
        )
    return status


# Leaderboard v3 (docs/publishing.md §5): the v2 parts flown with the current MPC default (the
# `value` terminal), the classical and learned planners beside them, and the terminal-cost part.
V3_ROOT = Path("results/v3")
V3 = Layout(V3_ROOT / "leaderboard.sqlite", V3_ROOT / "out", V3_ROOT / "out" / "rows" / "leaderboard",
            V3_ROOT / "from-rows")  # fmt: skip
CLASSICAL = ["lattice", "lattice-c40", "value-greedy-c40"]
DISTILLED = Path("leaderboards/distill")  # the published distilled planners (docs/rl.md §4.9)
V3_NETWORKS = ("c40-value-s1", "c40-value64-s0")  # the distilled networks v3 trained and published
LEARNED = [f"distill-shield:{DISTILLED.as_posix()}/c40-value-s1", f"distill:{DISTILLED.as_posix()}/c40-value-s1",
           f"distill-shield:{DISTILLED.as_posix()}/c40-value64-s0"]  # fmt: skip
MPC_PLANNERS = [*PAPER_PLANNERS, "cmaes"]
CTG_FORMS = ("distance", "dubins")  # the priced forms beside the default `value` (model.md §7e.4)
V3_ORDER = ("paper", "windows", "suite", "windows-suite", "held-out", "ctg-sensitivity", "agents", "best-known",
            "tables")  # fmt: skip
CTG_TABLE = "benchmarks/terminal_cost_table.py"
# The terminal-cost table's parts: (name, the scenario or frozen suite its episodes are kept within).
CTG_TABLE_PARTS = (("paper", "paper-2022-sec5"), ("suite", "uavpen-v1"), ("held-out", HELD_OUT),
                   ("paper-w2", "paper-2022-sec5-w2"))  # fmt: skip
CHECKPOINT = Path("leaderboards/v3-checkpoint")
V3_TARGET = Path("leaderboards/v3")  # v3's installed tables; v2's stay at the top of leaderboards/
MANIFEST = "manifest.json"
# Rows flown with the `value` default at clean commits, whose policy hashes equal v3's (docs/publishing.md §5.3).
SEED_ROWS = (Path("leaderboards/ctg-sensitivity/suite-value-rows/suite-value-4256938"),
             Path("leaderboards/ctg-sensitivity/suite-forms-rows/suite-forms-4256938"))  # fmt: skip


def ctg_policies() -> list[str]:
    """The seven MPC planners under each priced terminal form: ``ihpso-ctg-distance``, ``ihpso-ctg-dubins``, ..."""
    return [f"{name}-ctg-{form}" for form in CTG_FORMS for name in MPC_PLANNERS]


def parts_v3(
    models: Path = MODELS, unfinished: Callable[[], list[str]] | None = None, rl_root: Path = RL_ROOT
) -> list[Part]:
    """Leaderboard v3's parts, in :data:`V3_ORDER` (docs/publishing.md §5.1).

    The v2 parts on the v3 store with :data:`CLASSICAL` and :data:`LEARNED` beside the paper, suite and
    held-out policies; then ``ctg-sensitivity``: the seven MPC planners under the ``distance`` and
    ``dubins`` terminal forms on the paper scenario (20 seeds, 10 000 evaluations) and on the suite
    (its seed rule); its table is written in the tables part from the exported rows (the bare names
    are the ``value`` default, flown by the paper and suite parts).
    """
    v2 = publication_parts(V3, models, unfinished, rl_root, beside=[*CLASSICAL, *LEARNED])
    common = ["--store", str(V3.store), "--no-report", "--no-progress"]
    # DECISION (docs/publishing.md §5.1, every table's forms): the held-out set and the paper's second
    # weighting too, so that every claim of the results page on them is marked robust or not.
    ctg = Part("ctg-sensitivity", [
        ["run", "--scenarios", "paper", "--policies", *ctg_policies(), "--seeds", "20", "--max-evals", "10000",
         *common],
        ["run", "--suite", "uavpen-v1", "--policies", *ctg_policies(), *common],
        ["run", "--suite", HELD_OUT, "--policies", *ctg_policies(), *common],
        ["run", "--scenarios", "paper-w2", "--policies", *ctg_policies(), "--seeds", "20", "--max-evals", "10000",
         *common],
    ])  # fmt: skip
    episodes = f"{V3.rows}-episodes.parquet"
    table = [CTG_TABLE, *(argument for name, selection in CTG_TABLE_PARTS
                          for argument in ("--part", f"{name}={episodes}", "--within", f"{name}={selection}")),
             "--out", str(V3.out / "ctg-sensitivity")]  # fmt: skip
    named = {part.name: part for part in v2}
    tables = named["tables"]
    export = next(i for i, c in enumerate(tables.commands) if c[0] == "export")
    # DECISION (docs/publishing.md §5.5, the checkpoint is the published rows): the tables are rebuilt
    # from the committed chunks, not from a second export, so the rows a reader rebuilds from are the
    # ones the check read, and the install commits no copy of them.
    rebuild = ["leaderboard", "--rows", CHECKPOINT.as_posix(), "--out", str(V3.check), *RETIRED_RULE]
    named["tables"] = Part("tables", [*tables.commands[: export + 1], table, rebuild])
    named["ctg-sensitivity"] = ctg
    return [named[name] for name in V3_ORDER]


@dataclass(frozen=True)
class Publication:
    """One registered publication: its results folder, its paths, its parts' order and its plan."""

    version: str
    root: Path
    layout: Layout
    order: tuple[str, ...]
    plan: Callable[[], list[Part]]
    target: Path = Path("leaderboards")  # where --install puts the tables
    rows: Path | None = None  # the committed rows, when they are not installed with the tables (v3: the checkpoint)


def publications() -> dict[str, Publication]:
    """The registered publications by version (v2's paths read at call time, so tests can move ``ROOT``)."""
    return {
        "v2": Publication("v2", ROOT, Layout(STORE, OUT, ROWS, CHECK), ORDER, parts),
        "v3": Publication("v3", V3_ROOT, V3, V3_ORDER, parts_v3, target=V3_TARGET, rows=CHECKPOINT),
    }


ID_COLUMNS = {"runs": "run_id", "episodes": "episode_id", "window_runs": "window_run_id"}


def merge_rows(stems: Sequence[Path], out: Path) -> dict[str, int]:
    """Join several exports into one stem ``out`` that ``uav-bench import`` reads (rows per table returned).

    DECISION (docs/publishing.md §5.3, merged rows): ``uav-bench import`` builds a new store from one
    export. Exports of one store (checkpoint chunks) have disjoint ids and keep them; an export whose
    ids collide with the rows before it (another store: the seed rows) has its run, episode and
    window-run ids moved past them, its episodes' ``run_id``, its window runs' ``run_id`` and its
    steps' ``episode_id`` with them. Scenarios and policies are keyed by hash and kept once.

    Raises:
        SystemExit: a stem without its episodes table, or an episode (policy hash, scenario hash, seed)
            in two stems (one line naming them).
    """
    import pandas as pd

    from uav_penetration_env.benchmark.rows import EXPORT_TABLES, read_table, row_path, write_table

    merged: dict[str, list[pd.DataFrame]] = {table: [] for table in EXPORT_TABLES}
    top = {column: 0 for column in ID_COLUMNS.values()}
    for stem in stems:
        frames = {table: read_table(stem, table) for table in EXPORT_TABLES}
        if frames["episodes"] is None or frames["runs"] is None:
            raise SystemExit(
                f"{stem}: no episodes or runs table; expected an export of uav-bench (--format parquet)"
            )
        shift = {}
        for table, column in ID_COLUMNS.items():
            frame = frames[table]
            ids = frame[column] if frame is not None and not frame.empty else pd.Series(dtype="int64")
            shift[column] = top[column] if len(ids) and int(ids.min()) <= top[column] else 0
            if len(ids):
                top[column] = int(ids.max()) + shift[column]
        for table, frame in frames.items():
            if frame is None or frame.empty:
                continue
            frame = frame.copy()
            for column in ("run_id", "episode_id", "window_run_id"):
                if column in frame.columns and frame[column].notna().all():
                    frame[column] = frame[column].astype("int64") + shift[column]
                elif column in frame.columns:  # a nullable reference: shift what is set
                    frame[column] = frame[column].where(frame[column].isna(), frame[column] + shift[column])
            merged[table].append(frame)
    counts = {}
    for table, frames in merged.items():
        if not frames:
            continue
        frame = pd.concat(frames, ignore_index=True)
        if table in ("scenarios", "policies"):
            frame = frame.drop_duplicates({"scenarios": "scenario_hash", "policies": "policy_hash"}[table])
        if table == "episodes":
            twice = frame[frame.duplicated(["policy_hash", "scenario_hash", "seed"], keep=False)]
            if not twice.empty:
                row = twice.iloc[0]
                raise SystemExit(f"episode {row.policy} on {row.scenario} seed {row.seed} is in two of "
                                 f"{', '.join(map(str, stems))}; expected each episode once")  # fmt: skip
        out.parent.mkdir(parents=True, exist_ok=True)
        write_table(frame, row_path(out, table, "parquet"), "parquet")
        counts[table] = len(frame)
    return counts


def bench(argv: Sequence[str]) -> int:
    """One ``uav-bench`` command in this tree, as the parts' commands run (its exit status)."""
    return subprocess.run([*uav_bench(), *argv], cwd=REPO, env=child_environment()).returncode


def import_rows(stem: Path, store: Path) -> int:
    """``uav-bench import --rows stem --store store`` in this tree (its exit status)."""
    argv = ["import", "--rows", str(stem), "--store", str(store)]
    print(f"[run] {command_key(argv)}", flush=True)
    return bench(argv)


def refuse_existing(*paths: Path) -> None:
    for path in paths:
        if path.exists():
            raise FileExistsError(f"{path} exists; this only rebuilds a missing store and log")


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` whole or not at all (uav_penetration_env/atomic.py)."""
    from uav_penetration_env.atomic import atomic_open

    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(path) as handle:
        handle.write(text)


def read_manifest(folder: Path) -> dict[str, Any]:
    """The checkpoint's manifest: the seed stems, the chunks (name, last run id, episodes), or an empty one."""
    path = REPO / folder / MANIFEST
    return json.loads(path.read_text()) if path.is_file() else {"seeds": [], "seed_run_id": 0, "chunks": []}


def seed_from(stems: Sequence[Path] = SEED_ROWS, pub: Publication | None = None) -> int:
    """A new v3 store from earlier rows (``--seed-from``): the sweep then skips their episodes.

    DECISION (docs/publishing.md §5.3, seeding): the seed rows were flown with the policies v3 flies
    (equal policy hashes: the store key) from a clean checkout of 4256938, and keep their own runs
    and so their own provenance, which records the commit as ``unknown`` (a checkout without
    ``.git``): never rewritten here, so the publication names it from the rows' README. The stems are recorded in ``results/v3/seeded.json`` so that a checkpoint
    names them instead of copying their rows (they are committed already).

    Raises:
        FileExistsError: the store or its log exists (seeding is the first step, never a merge).
    """
    import tempfile

    pub = pub or publications()["v3"]
    store, log = REPO / pub.layout.store, REPO / pub.root / "compute.jsonl"
    refuse_existing(store, log)
    with tempfile.TemporaryDirectory() as folder:
        from uav_penetration_env.benchmark.rows import read_table

        counts = merge_rows([REPO / s for s in stems], Path(folder) / "seed")
        top = int(read_table(Path(folder) / "seed", "runs").run_id.max())  # the seed rows' last run id
        status = import_rows(Path(folder) / "seed", store)
    if status == 0:
        atomic_write_text(REPO / pub.root / "seeded.json", json.dumps(
            {"seeds": [s.as_posix() for s in stems], "seed_run_id": top}, indent=1))  # fmt: skip
        print(f"{store.relative_to(REPO)}: seeded with {counts['episodes']} episodes of {len(stems)} exports")
    return status


def checkpoint(pub: Publication | None = None, folder: Path = CHECKPOINT) -> Path | None:
    """Export the store's rows flown since the last checkpoint, and the compute log, into ``folder``.

    DECISION (docs/publishing.md §5.2, incremental checkpoints): each checkpoint is a new chunk
    (``chunk-NNN-*.parquet``: the runs after the last recorded run id, their episodes, steps and
    window runs, every scenario and policy), so each episode's steps are committed once and a
    session's commit stays small; the seed rows are named, not copied. The manifest is written last
    (atomically): a chunk it does not name is ignored, so a cut checkpoint leaves the last one whole.

    Returns:
        The chunk's stem, or ``None`` when nothing was flown since (only the log is copied).
    """
    import tempfile

    import pandas as pd

    from uav_penetration_env.benchmark.rows import EXPORT_TABLES, read_table, row_path, write_table

    pub = pub or publications()["v3"]
    store, log = REPO / pub.layout.store, REPO / pub.root / "compute.jsonl"
    if not store.is_file():
        raise FileNotFoundError(f"{store}: missing; nothing to checkpoint")
    manifest = read_manifest(folder)
    seeded = REPO / pub.root / "seeded.json"
    if seeded.is_file() and not manifest["chunks"]:
        manifest.update(json.loads(seeded.read_text()))
    covered = max([manifest["seed_run_id"], *(c["run_id"] for c in manifest["chunks"])])
    target = REPO / folder
    target.mkdir(parents=True, exist_ok=True)
    stem = None
    with tempfile.TemporaryDirectory() as work:
        argv = ["export", "--format", "parquet", "--store", str(store), "--out", f"{work}/all"]
        if bench(argv) != 0:
            raise SystemExit(f"{command_key(argv)}: failed; no checkpoint written")
        frames = {table: read_table(f"{work}/all", table) for table in EXPORT_TABLES}
        runs = frames["runs"]
        new = runs[runs.run_id > covered]
        if not new.empty:
            keep = set(new.run_id)
            episodes = frames["episodes"][frames["episodes"].run_id.isin(keep)]
            chosen = {
                "runs": new,
                "episodes": episodes,
                "scenarios": frames["scenarios"],
                "policies": frames["policies"],
            }
            steps, windows = frames["steps"], frames["window_runs"]
            chosen["steps"] = (
                steps[steps.episode_id.isin(set(episodes.episode_id))] if steps is not None else None
            )
            chosen["window_runs"] = windows[windows.run_id.isin(keep)] if windows is not None else None
            name = f"chunk-{len(manifest['chunks']) + 1:03d}"
            for table, frame in chosen.items():
                if frame is not None:
                    write_table(frame if not frame.empty else pd.DataFrame(columns=frame.columns),
                                row_path(target / name, table, "parquet"), "parquet")  # fmt: skip
            manifest["chunks"].append({"name": name, "run_id": int(new.run_id.max()), "episodes": len(episodes),
                                       "window_runs": 0 if chosen["window_runs"] is None else len(chosen["window_runs"])})  # fmt: skip
            stem = Path(folder) / name
    if log.is_file():
        atomic_write_text(target / "compute.jsonl", log.read_text())
    atomic_write_text(target / MANIFEST, json.dumps(manifest, indent=1) + "\n")
    return stem


def resume(pub: Publication | None = None, folder: Path = CHECKPOINT) -> int:
    """Rebuild a missing v3 store and log from the checkpoint (``--resume``): seeds and chunks, merged, imported.

    Raises:
        FileExistsError: the store or the log exists.
        FileNotFoundError: no checkpoint manifest.
    """
    import tempfile

    pub = pub or publications()["v3"]
    store, log = REPO / pub.layout.store, REPO / pub.root / "compute.jsonl"
    refuse_existing(store, log)
    if not (REPO / folder / MANIFEST).is_file():
        raise FileNotFoundError(f"{REPO / folder / MANIFEST}: missing; expected a checkpoint (--checkpoint)")
    manifest = read_manifest(folder)
    stems = [REPO / s for s in manifest["seeds"]] + [REPO / folder / c["name"] for c in manifest["chunks"]]
    with tempfile.TemporaryDirectory() as work:
        merge_rows(stems, Path(work) / "resume")
        status = import_rows(Path(work) / "resume", store)
    if status == 0:
        if manifest["seeds"]:
            atomic_write_text(REPO / pub.root / "seeded.json", json.dumps(
                {"seeds": manifest["seeds"], "seed_run_id": manifest["seed_run_id"]}, indent=1))  # fmt: skip
        saved = REPO / folder / "compute.jsonl"
        atomic_write_text(log, saved.read_text() if saved.is_file() else "")
        print(f"{store.relative_to(REPO)}: {len(stems)} exports; {len(read_log(log))} attempts in the log")
    return status


WINDOW_EVIDENCE = Path(
    "leaderboards/rows/leaderboard"
)  # v2's rows: the episodes' and window runs' own seconds


def scenario_group(scenario: str) -> str:
    """The estimate's scenario groups: ``paper`` (both weightings), ``dem``, ``procedural``."""
    return "paper" if scenario.startswith("paper") else "dem" if scenario.startswith("dem") else "procedural"


def evidence_name(policy: str) -> str:
    """A command's policy name as the rows record it (``sb3:DIR/ppo-paper-s0.zip`` -> ``sb3:ppo-paper-s0``)."""
    head, sep, path = policy.rpartition("sb3:")
    return f"{head}sb3:{Path(path).stem}" if sep else policy


def flag_values(argv: Sequence[str], flag: str) -> list[str]:
    if flag not in argv:
        return []
    values = []
    for item in argv[argv.index(flag) + 1 :]:
        if item.startswith("--"):
            break
        values.append(item)
    return values


SCENARIO_NAMES = {"paper": "paper-2022-sec5", "paper-w2": "paper-2022-sec5-w2"}


def planned_items(argv: Sequence[str]) -> list[tuple[str, str, int]]:
    """(policy or optimizer, scenario, seed) of every episode or window run a command plans.

    A run's episodes: every ``--scenarios`` name by ``--seeds``, or a suite's members by its rule
    (docs/suite.md §4; the classical and learned planners and the agents taken as deterministic);
    a windows command's runs: its steps by optimizers by seeds, named by the optimizer.
    """
    from uav_penetration_env.suites import FIXED_MEMBER_SEEDS, load_suite
    from uav_penetration_env.suites.schema import FIXED_GROUP

    if not argv or argv[0] not in ("run", "windows"):
        return []
    seeds = list(range(int(flag_values(argv, "--seeds")[0]))) if "--seeds" in argv else None
    if argv[0] == "windows":
        scenario = SCENARIO_NAMES.get(flag_values(argv, "--scenario")[0], flag_values(argv, "--scenario")[0])
        steps = flag_values(argv, "--steps")[0].split(",")
        return [
            (o, scenario, s) for o in flag_values(argv, "--optimizers") for _ in steps for s in seeds or [0]
        ]
    items = []
    for policy in flag_values(argv, "--policies"):
        deterministic = policy in CLASSICAL or policy.startswith(("distill", "sb3:"))
        if "--suite" in argv:
            for member in load_suite(flag_values(argv, "--suite")[0]).members:
                fixed = member.group == FIXED_GROUP
                rule = range(1 if deterministic or not fixed else FIXED_MEMBER_SEEDS)
                items += [(policy, member.scenario, seed) for seed in rule]
        else:
            for name in flag_values(argv, "--scenarios"):
                items += [(policy, SCENARIO_NAMES.get(name, name), seed) for seed in seeds or [0]]
    return items


def evidence() -> tuple[
    dict[tuple[str, str], float], dict[tuple[str, str], float], set[tuple[str, str, int]], float
]:
    """Mean seconds per (policy, group) of episodes and per (optimizer, group) of window runs, the seed rows' keys, and v2's speed ratio.

    DECISION (docs/publishing.md §5.4, the estimate): the seed rows (flown at 4256938, the code v3
    runs) speak first for a name they hold. v2's rows speak for the rest, scaled by the speed
    ratio ``r``: the seed rows' seconds over v2's on the same episodes, v2's MPC planners (the
    ``distance`` default then) against ``NAME-ctg-distance`` in each scenario group, which fly
    the same steps (ihpso on dem-topobathy: 117.8 steps in both), so ``r`` measures the code and
    the machine, not the work. A name with no evidence counts 0 s and is listed (a lower bound).
    """
    from uav_penetration_env.benchmark.rows import read_table

    seconds: dict[tuple[str, str], float] = {}
    counts: dict[tuple[str, str], int] = {}
    seeded: set[tuple[str, str, int]] = set()
    for stem in SEED_ROWS:
        e = read_table(REPO / stem, "episodes")
        seeded |= set(zip(e.policy, e.scenario, e.seed.astype(int), strict=True))
        grouped = e.groupby([e.policy, e.scenario.map(scenario_group)]).episode_seconds
        for key, mean in grouped.mean().items():
            seconds.setdefault(key, float(mean))
        counts.update(grouped.size().items())
    v2 = read_table(REPO / WINDOW_EVIDENCE, "episodes")
    v2_seconds = {
        key: float(m)
        for key, m in v2.groupby([v2.policy, v2.scenario.map(scenario_group)]).episode_seconds.mean().items()
    }
    mpc = {*PAPER_PLANNERS, *REFERENCES, *IHPSO_VARIANTS}
    matched = [
        ((f"{p}-ctg-distance", g), (p, g))
        for p, g in v2_seconds
        if p in mpc and (f"{p}-ctg-distance", g) in seconds
    ]
    ratio = sum(counts[k] * seconds[k] for k, _ in matched) / sum(
        counts[k] * v2_seconds[o] for k, o in matched
    )
    for (policy, group), mean in v2_seconds.items():
        seconds.setdefault((policy, group), ratio * mean)
        if policy in mpc:
            seconds.setdefault((f"{policy}-ctg-distance", group), ratio * mean)
    w = read_table(REPO / WINDOW_EVIDENCE, "window_runs")
    windows = {
        key: ratio * float(v)
        for key, v in w.groupby([w.optimizer, w.scenario.map(scenario_group)]).seconds.mean().items()
    }
    return seconds, windows, seeded, ratio


def estimate(plan: Sequence[Part]) -> str:
    """Per part: planned episodes and window runs, their worker hours, and what the seed rows cover (a Markdown table).

    Worker hours are the sum of the items' own wall seconds (:func:`compute_table`'s measure): CPU
    hours where each worker has an idle core, so about half of it in wall time on 2 idle cores.
    """
    seconds, windows, seeded, ratio = evidence()
    missing: set[str] = set()

    def cost(kind: str, name: str, scenario: str) -> float:
        group = scenario_group(scenario)
        table = windows if kind == "windows" else seconds
        for key in ((name, group), *((n, g) for (n, g) in table if n == name)):
            if key in table:
                return table[key]
        missing.add(name)
        return 0.0

    lines = ["| part | episodes + window runs | worker [h] | in the seed rows | worker left after seeding [h] |",
             "|---|---:|---:|---:|---:|"]  # fmt: skip
    total = left_total = 0.0
    for part in plan:
        n = hours = covered = left = 0.0
        for command in part.commands:
            for name, scenario, seed in planned_items(command):
                c = cost(command[0], evidence_name(name), scenario) / 3600
                n, hours = n + 1, hours + c
                if command[0] == "run" and (name, scenario, seed) in seeded:
                    covered += 1
                else:
                    left += c
        if not n:
            continue
        total, left_total = total + hours, left_total + left
        lines.append(f"| {part.name} | {int(n)} | {hours:.2f} | {int(covered)} | {left:.2f} |")
    lines.append(f"| total | | {total:.2f} | | {left_total:.2f} |")
    lines.append(
        f"\nv2's seconds scaled by r = {ratio:.3f} (the seed rows' seconds over v2's on the same episodes)"
    )
    if missing:
        lines.append(f"\nno timing evidence (taken as 0 s, a lower bound): {', '.join(sorted(missing))}")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python benchmarks/publish.py", description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", default=(), metavar="PART", help="run only these parts")
    parser.add_argument(
        "--dry-run", action="store_true", help="print every command and its state; run nothing"
    )
    parser.add_argument(
        "--compute", action="store_true", help="print the compute table (wall, CPU, worker time); run nothing"
    )
    parser.add_argument(
        "--from-published",
        action="store_true",
        help="rebuild a missing results/v2 store and compute log from the installed leaderboard; run nothing else",
    )
    parser.add_argument(
        "--install",
        action="store_true",
        help="replace leaderboards/'s generated files by results/VERSION/out's (after a passed rebuild check)",
    )
    parser.add_argument("--version", choices=sorted(publications()), default="v2",
                        help="the publication (default v2; v3: docs/publishing.md §5)")  # fmt: skip
    parser.add_argument("--estimate", action="store_true",
                        help="print the compute estimate per part from earlier rows; run nothing")  # fmt: skip
    v3 = parser.add_argument_group("carrying v3 across sessions (docs/publishing.md §5.2-5.3)")
    v3.add_argument("--checkpoint", action="store_true",
                    help=f"export the rows flown since the last checkpoint and the log into {CHECKPOINT}/")  # fmt: skip
    v3.add_argument("--resume", action="store_true",
                    help="rebuild a missing results/v3 store and log from the checkpoint")  # fmt: skip
    v3.add_argument("--seed-from", nargs="*", type=Path, metavar="STEM",
                    help="start a new results/v3 store from earlier exports (default: the terminal-cost "
                         "study's suite rows, whose policy hashes are v3's)")  # fmt: skip
    args = parser.parse_args(argv)
    pub = publications()[args.version]
    carry = [
        flag for flag in ("checkpoint", "resume", "seed_from") if getattr(args, flag) not in (False, None)
    ]
    if carry and args.version != "v3":
        parser.error(
            f"--{carry[0].replace('_', '-')}: only with --version v3 (v2 carries on with --from-published)"
        )
    try:
        if args.seed_from is not None:
            return seed_from(args.seed_from or SEED_ROWS, pub)
        if args.resume:
            return resume(pub)
        if args.checkpoint:
            stem = checkpoint(pub)
            print(
                f"{CHECKPOINT}: {'new rows in ' + str(stem) if stem else 'no new rows'}; the log copied; commit it"
            )
            return 0
    except (FileExistsError, FileNotFoundError) as error:
        print(f"refused: {error}", file=sys.stderr)
        return 1
    if args.from_published:
        if args.version != "v2":
            parser.error("--from-published: v2 only; v3 carries on with --resume")
        try:
            return from_published()
        except (FileExistsError, FileNotFoundError) as error:
            print(f"refused: {error}", file=sys.stderr)
            return 1
    log = REPO / pub.root / "compute.jsonl"
    attempts = read_log(log)
    if args.estimate:
        print(estimate(pub.plan()))
        return 0
    if args.compute:
        published = REPO / "leaderboards" / "compute.jsonl"
        if (
            args.version == "v2" and not log.is_file() and published.is_file()
        ):  # a fresh clone: the log --install committed
            attempts = read_log(published)
        if args.version == "v2":
            worker = published_worker_seconds()
        else:
            from uav_penetration_env.benchmark.rows import read_chunks, store_tables

            store, committed = REPO / pub.layout.store, REPO / pub.target / "compute.jsonl"
            if not log.is_file() and committed.is_file():  # a fresh clone: the installed log
                attempts = read_log(committed)
            if store.is_file():
                worker = worker_seconds(store_tables(store))
            elif pub.rows is not None and (REPO / pub.rows / MANIFEST).is_file():
                worker = worker_seconds(read_chunks([REPO / pub.rows]))  # a fresh clone: the committed chunks
            else:
                worker = {}
        # v3 publishes the distilled planners (docs/publishing.md §5.1), so their training is its compute.
        distill_root = DISTILLED if args.version == "v3" else None
        print(compute_table(attempts, worker=worker, order=pub.order, distill_root=distill_root, distill_names=V3_NETWORKS))
        return 0
    if args.install:
        tables = next(part for part in pub.plan() if part.name == "tables")
        if not rebuild_checked(attempts, [command_key(c) for c in tables.commands]):
            print("refused: the tables part has not ended with a passed rebuild check; run it first",
                  file=sys.stderr)  # fmt: skip
            return 1
        if pub.rows is not None:
            copied = install_folder(pub.layout.out, pub.target, log=pub.root / "compute.jsonl")
        else:
            copied = install(pub.layout.out, pub.target, log=pub.root / "compute.jsonl")
        print(f"{len(copied)} files copied into {pub.target}/")
        return 0
    plan = pub.plan()
    names = [p.name for p in plan]
    unknown = [name for name in args.only if name not in names]
    if unknown:
        parser.error(f"--only {' '.join(unknown)}: unknown part; expected some of {', '.join(names)}")
    checked_imports = False
    for part in plan:
        if args.only and part.name not in args.only:
            continue
        # Read again before each part: a run part that just added rows makes the derived parts
        # after it stale in this very invocation (current()).
        done = done_commands(read_log(log))
        for index, command in enumerate(part.commands):
            key = command_key(command)
            if key in done:
                print(f"[done] {part.name}: {key}", flush=True)
                continue
            print(f"[{'plan' if args.dry_run else 'run'}] {part.name}: {key}", flush=True)
            if args.dry_run:
                continue
            dirty = dirty_files()
            if dirty:
                print(f"refused: tracked files differ from the commit ({', '.join(dirty[:5])}); commit them first, "
                      "so the provenance names a clean commit", file=sys.stderr)  # fmt: skip
                return 1
            if not checked_imports:
                package = imported_from()
                if not package.is_relative_to(REPO.resolve()):
                    print(
                        f"refused: the commands would import {package}, not this tree ({REPO})",
                        file=sys.stderr,
                    )
                    return 1
                checked_imports = True
            if part.name == "tables":  # no stale file may take part in the comparison
                for folder, first in (
                    (pub.layout.out, index == 0),
                    (pub.layout.check, command[0] == "leaderboard"),
                ):
                    if first and (REPO / folder).is_dir():
                        shutil.rmtree(REPO / folder)
            status = run_attempt(part.name, command, log)
            if status != 0:
                print(
                    f"stopped at {part.name} (exit status {status}); run again to continue", file=sys.stderr
                )
                return status
        if part.waits:  # its commands so far are done; the rest, and the later parts, wait
            print(f"[wait] {part.name}: {part.waits}", flush=True)
            if not args.dry_run:
                return WAITING
            continue
        if part.name == "tables" and not args.dry_run:
            differing = compare_rebuild(REPO / pub.layout.out, REPO / pub.layout.check)
            append_attempt(log, {"part": "tables", "command": REBUILD_CHECK, "wall_s": 0.0, "cpu_s": 0.0,
                                 "status": 1 if differing else 0, "commit": commit()})  # fmt: skip
            if differing:
                print(f"the tables rebuilt from rows differ: {', '.join(differing)}", file=sys.stderr)
                if pub.rows is not None:  # v3 rebuilds from the committed checkpoint (docs/publishing.md §5.5)
                    print(f"(the rows are {pub.rows}: if the store holds rows the checkpoint lacks, run --checkpoint "
                          "and commit it before the tables part)", file=sys.stderr)  # fmt: skip
                return 1
            print("tables rebuilt from the rows equal the store's (apart from the date line)")
    if args.dry_run and args.version == "v3":
        print(
            "\nestimate (worker hours from earlier rows' own episode and window-run seconds; docs/publishing.md §5.4):"
        )
        print(estimate(plan))
    return 0


if __name__ == "__main__":
    sys.exit(main())
