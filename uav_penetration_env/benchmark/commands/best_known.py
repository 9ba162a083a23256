"""``uav-bench best-known compute|verify|update``: best-known records (docs/best-known.md).

* ``compute``: run the offline reference planner on scenarios and keep a record when it beats the
  existing one.
* ``verify``: replay records through the env; exit 1 with one line per record whose replayed
  total differs from the recorded J* by more than 1e-12 relative.
* ``update``: replace records with cheaper stored episodes (any policy) or, with ``--seconds``,
  the result of a new offline search; prints the improvement in absolute terms and in %.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from uav_penetration_env.benchmark.commands.common import (
    CLIError,
    Command,
    existing_store,
    path_argument,
    resolve_scenarios,
    split_list,
)

ACTIONS = ("compute", "verify", "update")
NAMED_SECONDS = 600.0  # the named members (paper, paper-w2, DEM) head the tables, so they get a longer search
PROCEDURAL_SECONDS = 90.0
NAMED = ("paper", "paper-w2", "dem")


def positive_seconds(text: str) -> float:
    """An argparse ``type=``: a number of seconds > 0."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"got {text!r}, expected a number of seconds > 0")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench best-known``."""
    from uav_penetration_env.benchmark.commands.common import int_at_least
    from uav_penetration_env.catalogue import SCENARIO_HELP

    parser.add_argument("action", choices=ACTIONS, help="compute | verify | update")
    parser.add_argument(
        "--scenarios",
        nargs="+",
        default=None,
        help=f"{SCENARIO_HELP} (compute: required; verify/update: default every record / every stored scenario)",
    )
    parser.add_argument(
        "--difficulty", type=float, default=0.5, help="difficulty of random: scenarios (default 0.5)"
    )
    parser.add_argument(
        "--store",
        type=path_argument,
        default=None,
        help="results store: stored tracks seed the search; update reads it",
    )
    parser.add_argument(
        "--seconds",
        type=positive_seconds,
        default=None,
        help=f"wall seconds per search (default: {PROCEDURAL_SECONDS:g} for procedural scenarios, "
        f"{NAMED_SECONDS:g} for {', '.join(NAMED)}); update: run a new search too",
    )
    parser.add_argument("--evals", type=int_at_least(1), default=None, help="evaluation budget per search")
    parser.add_argument("--seed", type=int_at_least(0), default=0, help="search seed (default 0)")
    parser.add_argument(
        "--no-track-seeds",
        dest="track_seeds",
        action="store_false",
        help="search from the greedy episode and random starts only (no stored track, no record)",
    )
    parser.add_argument(
        "--work", default=None, help="checkpoint folder; rerunning continues an interrupted search"
    )
    parser.add_argument(
        "--records", type=path_argument, default=None, help="records folder (default: the package's)"
    )
    parser.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")


def _budget(args: argparse.Namespace, spec: str) -> tuple[float | None, int | None]:
    if args.seconds is None and args.evals is not None:
        return None, args.evals
    if args.seconds is not None:
        return args.seconds, args.evals
    return (NAMED_SECONDS if spec in NAMED else PROCEDURAL_SECONDS), args.evals


def _scenarios(args: argparse.Namespace) -> list[tuple[str, Any]]:
    pairs = []
    for spec in split_list(args.scenarios):
        pairs += [(spec, s) for s in resolve_scenarios([spec], difficulty=args.difficulty)]
    return pairs


def _progress(enabled: bool, total_seconds: float | None):
    from uav_penetration_env.benchmark.progress import ProgressBar

    bar = ProgressBar(1000, "search", unit="‰", enabled=enabled)

    def report(mode: str, state: Any, share: float) -> None:
        target = int(1000 * share)
        if target > bar.n:
            bar.update(target - bar.n)
        bar.set_postfix(mode=mode, best=f"{state.best_f:.6g}", evals=state.evals, run=state.run_label)

    return bar, report


def _search(args: argparse.Namespace, spec: str, scenario: Any, store: Path | None) -> Any:
    """One offline search of ``scenario`` under the flags' budget, with its progress bar."""
    from uav_penetration_env.benchmark.bestknown.compute import compute_record
    from uav_penetration_env.benchmark.bestknown.planner import SearchSettings

    seconds, evals = _budget(args, spec)
    settings = SearchSettings(seconds=seconds, max_evals=evals, seed=args.seed)
    bar, report = _progress(args.progress, seconds)
    try:
        return compute_record(
            scenario,
            settings,
            store=store,
            track_seeds=args.track_seeds,
            work=args.work,
            folder=args.records,
            progress=report,
        )
    finally:
        bar.close()


def _compute(args: argparse.Namespace, scenarios: list[tuple[str, Any]]) -> int:
    from uav_penetration_env.scenario import ScenarioError

    store = None if args.store is None else existing_store(args.store)
    for spec, scenario in scenarios:
        try:
            outcome = _search(args, spec, scenario, store)
        except ScenarioError as error:
            raise CLIError(f"--scenarios {spec}: {error}") from None
        except ValueError as error:
            raise CLIError(str(error)) from None
        print(outcome.message(scenario.name))
        record = outcome.record
        if record is not None and record.unseeded_total is not None:
            print(
                f"{scenario.name}: unseeded search (greedy + random starts only): {record.unseeded_total:.10g}"
            )
    return 0


def _verify(args: argparse.Namespace) -> int:
    from uav_penetration_env.benchmark.bestknown.record import (
        REPLAY_TOLERANCE,
        RecordError,
        load_record,
        records,
        relative_difference,
        replay_record,
    )

    try:
        if args.scenarios is None:
            chosen = records(args.records)
        else:
            chosen = []
            for spec, scenario in _scenarios(args):
                record = load_record(scenario.hash, args.records)
                if record is None:
                    raise CLIError(f"--scenarios {spec}: no record for scenario hash {scenario.hash}")
                chosen.append(record)
    except RecordError as error:
        raise CLIError(str(error)) from None
    failures = 0
    for record in chosen:
        try:
            replay = replay_record(record)
        except (RecordError, RuntimeError) as error:
            print(f"{record.scenario_name} ({record.scenario_hash}): {error}")
            failures += 1
            continue
        difference = relative_difference(replay.total_cost, record.total_cost)
        if difference > REPLAY_TOLERANCE or replay.steps != record.steps:
            print(
                f"{record.scenario_name} ({record.scenario_hash}): total_cost: replay gives {replay.total_cost!r} "
                f"in {replay.steps} steps, expected {record.total_cost!r} in {record.steps} steps "
                f"(relative difference {difference:.3g} > {REPLAY_TOLERANCE:g})"
            )
            failures += 1
        else:
            print(f"{record.scenario_name} ({record.scenario_hash}): ok, J* = {record.total_cost:.10g}")
    if not chosen:
        print("no records")
    return 1 if failures else 0


def _update(args: argparse.Namespace) -> int:
    from uav_penetration_env.benchmark.bestknown.compute import update_from_store
    from uav_penetration_env.benchmark.store import ResultsStore
    from uav_penetration_env.scenario import ScenarioError, load_scenario

    if args.store is None:
        raise CLIError("--store: missing, expected the results store whose episodes may beat the records")
    store = existing_store(args.store)
    if args.scenarios is None:
        import yaml

        with ResultsStore(store, create=False) as results:
            known = results.scenarios()
        scenarios = [
            (name, load_scenario(yaml.safe_load(text))) for _, (name, text) in sorted(known.items()) if text
        ]
    else:
        scenarios = _scenarios(args)
    for spec, scenario in scenarios:
        try:
            outcome = update_from_store(scenario, store, folder=args.records)
            print(outcome.message(scenario.name))
            if args.seconds is not None or args.evals is not None:
                outcome = _search(args, spec, scenario, store)
                print(outcome.message(scenario.name))
        except ScenarioError as error:
            print(f"{scenario.name}: skipped: {error}")
    return 0


def run(args: argparse.Namespace) -> int:
    """Dispatch to compute, verify or update."""
    if args.records is not None and args.action == "verify" and not Path(args.records).is_dir():
        raise CLIError(f"--records {args.records}: not found; expected a folder of best-known records")
    if args.records is not None:
        folder = Path(args.records)
        if folder.exists() and not folder.is_dir():
            raise CLIError(f"--records {args.records}: is a file; expected a folder of best-known records")
        try:
            folder.mkdir(parents=True, exist_ok=True)  # compute and update write there
        except OSError as error:
            raise CLIError(
                f"--records {args.records}: cannot create it ({error.strerror}); expected a writable folder"
            ) from None
    if args.action == "compute":
        if not args.scenarios:
            raise CLIError("--scenarios: missing, expected the scenarios to compute records for (e.g. paper)")
        return _compute(args, _scenarios(args))
    if args.action == "verify":
        return _verify(args)
    return _update(args)


COMMAND = Command(
    name="best-known",
    help="best-known records: compute (offline search), verify (replay), update (from a store)",
    add_arguments=add_arguments,
    run=run,
)
