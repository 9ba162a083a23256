"""``uav-bench scenario show|validate|generate``: inspect, check and write scenario files."""

from __future__ import annotations

import argparse
from pathlib import Path

import yaml

from uav_penetration_env.benchmark.commands.common import (
    CLIError,
    Command,
    check_writable_folder,
    path_argument,
    resolve_scenarios,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments of ``uav-bench scenario``."""
    from uav_penetration_env.catalogue import SCENARIO_HELP

    parser.add_argument("action", choices=["show", "validate", "generate"])
    parser.add_argument("name", help=SCENARIO_HELP)
    parser.add_argument("--profile", choices=["benchmark", "paper"])
    parser.add_argument("--difficulty", type=float, default=0.5, help="of random:... (default: 0.5)")
    parser.add_argument("--out", type=path_argument, default=".", help="generate: a .yaml file or a folder")


def run(args: argparse.Namespace) -> int:
    """Show the scenarios as YAML, validate them against their terrain, or write them to files."""
    if args.action == "generate" and args.name == "dem":
        from uav_penetration_env.catalogue import generate_dem_scenario

        scenarios = [generate_dem_scenario()]  # rebuilt from the raw DEM, not the shipped file
    else:
        scenarios = resolve_scenarios(
            [args.name], args.profile, None, args.difficulty, flag=f"scenario {args.action}"
        )
    if args.action == "generate":
        out = Path(args.out)
        if len(scenarios) == 1 and out.suffix in (".yaml", ".yml"):
            check_writable_folder(out.parent, "--out")
            print(scenarios[0].to_yaml(out))
        else:
            # The scenario's name may come from an untrusted file: its file name is the
            # leaderboard's sanitised stem, so `../x` or `/abs/x` cannot leave --out.
            from uav_penetration_env.benchmark.leaderboard.groups import sanitize

            check_writable_folder(out, "--out")
            for scenario in scenarios:
                print(scenario.to_yaml(out / f"{sanitize(scenario.name)}.yaml"))
        return 0
    if args.action == "show":
        for scenario in scenarios:
            print(f"# {scenario.name}  (hash {scenario.hash})")
            print(yaml.safe_dump(scenario.to_dict(), sort_keys=False, default_flow_style=None, width=110))
        return 0
    from uav_penetration_env.build import build_scenario
    from uav_penetration_env.scenario import ScenarioError

    for scenario in scenarios:  # validate: the schema is checked already; now the terrain-dependent rules
        try:
            built = build_scenario(scenario)
        except ScenarioError as error:
            raise CLIError(f"scenario {args.name!r}: {error}") from None
        print(
            f"{scenario.name}: valid (hash {scenario.hash}, {len(built.radar_xyz)} radars, grid {built.grid.nx}x{built.grid.ny})"
        )
    return 0


COMMAND = Command(
    name="scenario",
    help="show, validate or generate scenario files",
    add_arguments=add_arguments,
    run=run,
)
