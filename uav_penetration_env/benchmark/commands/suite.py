"""``uav-bench suite list|show|verify|freeze``: the frozen benchmark suites (docs/suite.md).

``verify`` rebuilds members and compares each with its frozen fingerprint (every member is
checked; exit status 1 when one differs). ``freeze`` writes a new suite version from a recipe
file or from an existing suite's members, and never overwrites one.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import yaml

from uav_penetration_env.benchmark.commands.common import CLIError, Command, path_argument


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments of ``uav-bench suite``."""
    from uav_penetration_env.suites import SUITE_FOLDER

    parser.add_argument("action", choices=["list", "show", "verify", "freeze"])
    parser.add_argument("name", nargs="?", help="suite name (show, verify, freeze) or a suite .yaml file")
    parser.add_argument(
        "--members",
        nargs="+",
        help="show/verify: only members matching these shell patterns (uavpen-v1/d0.25/*)",
    )
    parser.add_argument(
        "--rebuild",
        action="store_true",
        help="verify: rebuild terrain and floors in an empty cache rather than load them from the build cache",
    )
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--recipe", help="freeze: a recipe file (suite, description, members)")
    source.add_argument("--like", help="freeze: take the members' recipes from this existing suite")
    parser.add_argument(
        "--description", help="freeze --like: the new suite's description (default: the old one)"
    )
    parser.add_argument(
        "--out",
        type=path_argument,
        default=str(SUITE_FOLDER),
        help=f"freeze: the folder of the new file (default: {SUITE_FOLDER})",
    )


def run(args: argparse.Namespace) -> int:
    """Dispatch to the action; suite problems become one-line errors."""
    from uav_penetration_env.suites import SuiteError

    if args.action == "list" and args.name is not None:
        raise CLIError(
            f"suite list {args.name}: list takes no suite name; use `uav-bench suite show {args.name}`"
        )
    try:
        return ACTIONS[args.action](args)
    except SuiteError as error:
        raise CLIError(str(error)) from None


def _list(args: argparse.Namespace) -> int:
    from uav_penetration_env.suites import load_suite, suite_names

    for name in suite_names():
        suite = load_suite(name)
        groups = ", ".join(
            f"{group} {sum(m.group == group for m in suite.members)}" for group in suite.groups
        )
        print(f"{name}: {len(suite.members)} members ({groups}) — {suite.description.splitlines()[0]}")
    return 0


def _needs_name(args: argparse.Namespace) -> str:
    if not args.name:
        raise CLIError(
            f"suite {args.action}: expected a suite name, e.g. `uav-bench suite {args.action} uavpen-v1`"
        )
    return args.name


def _show(args: argparse.Namespace) -> int:
    from uav_penetration_env.benchmark.leaderboard.formatting import markdown_table
    from uav_penetration_env.suites import load_suite

    suite = load_suite(_needs_name(args))
    print(f"# {suite.name} ({suite.path})\n\n{suite.description}\n")
    frozen = suite.frozen
    print(
        f"frozen {frozen.get('date', '?')} at commit {frozen.get('commit', '?')}, package {frozen.get('package_version', '?')}"
    )
    rules = suite.fingerprint
    print(
        f"fingerprint: heights and floors rounded to {rules.get('quantum_m')} m; replay: {rules.get('replay')}\n"
    )
    rows = [
        [
            m.name,
            m.group,
            m.scenario,
            m.fingerprint.scenario_hash,
            m.fingerprint.terrain_hash,
            m.fingerprint.floors_hash,
            f"{m.fingerprint.replay_total_j:.10g}",
        ]
        for m in suite.select(args.members)
    ]
    header = ["member", "group", "scenario", "scenario hash", "terrain hash", "floors hash", "replay total J"]
    print(markdown_table(header, rows, ["l", "l", "l", "l", "l", "l", "r"]))
    return 0


def _verify(args: argparse.Namespace) -> int:
    import os
    import tempfile

    from uav_penetration_env import cache
    from uav_penetration_env.benchmark.progress import ProgressBar
    from uav_penetration_env.suites import load_suite, verify_suite

    suite = load_suite(_needs_name(args))
    members = suite.select(args.members)
    started = time.perf_counter()
    failures = []
    with tempfile.TemporaryDirectory(prefix="uav-suite-verify-") as empty:
        saved = os.environ.get(cache.ENV_VAR)
        if args.rebuild:
            # Terrain and floors computed afresh: a warm cache keyed by inputs and the package
            # version would hide a change to the terrain synthesis made without a version bump.
            os.environ[cache.ENV_VAR] = empty
            cache.clear_memory()
        try:
            with ProgressBar(len(members), f"verify {suite.name}", unit="member") as bar:
                for check in verify_suite(suite, args.members):
                    if check.error is not None:
                        failures.append(check.error)
                        print(f"MISMATCH {check.error}", file=sys.stderr)
                    bar.update(1)
        finally:
            if args.rebuild:
                if saved is None:
                    os.environ.pop(cache.ENV_VAR, None)
                else:
                    os.environ[cache.ENV_VAR] = saved
                cache.clear_memory()
    seconds = time.perf_counter() - started
    verdict = (
        f"{len(failures)} of {len(members)} members DIFFER"
        if failures
        else f"all {len(members)} members reproduce"
    )
    print(f"suite {suite.name}: {verdict} ({seconds:.1f} s{', rebuilt' if args.rebuild else ''})")
    return 1 if failures else 0


def _freeze(args: argparse.Namespace) -> int:
    from uav_penetration_env.benchmark.progress import ProgressBar
    from uav_penetration_env.benchmark.suite_freeze import freeze_suite
    from uav_penetration_env.suites import load_suite, recipes_from_dict

    name = _needs_name(args)
    if args.recipe:
        try:
            data = yaml.safe_load(Path(args.recipe).read_text())
        except OSError as error:
            raise CLIError(f"--recipe {args.recipe}: cannot read it ({error.strerror})") from None
        except yaml.YAMLError as error:
            raise CLIError(f"--recipe {args.recipe}: not valid YAML ({error})") from None
        recipe_name, description, recipes = recipes_from_dict(data, f"--recipe {args.recipe}")
        if recipe_name != name:
            raise CLIError(f"--recipe {args.recipe}: names the suite {recipe_name!r}, expected {name!r}")
    elif args.like:
        old = load_suite(args.like)
        description, recipes = args.description or old.description, [m.recipe for m in old.members]
    else:
        raise CLIError("suite freeze: expected --recipe FILE or --like SUITE")
    with ProgressBar(len(recipes), f"freeze {name}", unit="member") as bar:
        path = freeze_suite(name, description, recipes, args.out, progress=lambda _: bar.update(1))
    print(f"suite {name}: {len(recipes)} members frozen -> {path}")
    return 0


ACTIONS = {"list": _list, "show": _show, "verify": _verify, "freeze": _freeze}

COMMAND = Command(
    name="suite",
    help="frozen benchmark suites: list, show, verify the fingerprints, freeze a new version",
    add_arguments=add_arguments,
    run=run,
)
