"""``uav-bench``: run sweeps, build leaderboards and figures, calibrate, inspect scenarios, train.

``uav-bench run`` with no flags is the main job (api.md): the paper scenario (weights
0.3/0.4/0.3), the six swarm planners plus ``pso``, ``cem`` and the ``greedy`` floor, 5 seeds, all
cores, results in ``results/uav-bench.sqlite``, then the leaderboard and figures in ``results/``.

Every input is checked before the store is opened, so a typo never damages a store; errors name
the flag, field or path and exit with status 2. Ctrl-C leaves every finished episode stored
(exit status 130); rerunning the same command resumes.
"""

from __future__ import annotations

import argparse
import difflib
import shlex
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

DEFAULT_STORE = Path("results/uav-bench.sqlite")
DEFAULT_OUT = Path("results")
MAIN_JOB_POLICIES = ("ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism", "pso", "cem", "greedy")
RUN_DEFAULTS: dict[str, Any] = {
    "policies": list(MAIN_JOB_POLICIES),
    "scenarios": ["paper"],
    "profile": None,
    "weights": None,
    "seeds": "5",
    "jobs": None,
    "backend": "loky",
    "scheduler": None,
    "store": str(DEFAULT_STORE),
    "out": str(DEFAULT_OUT),
    "max_evals": 10_000,
    "horizon": 5,
    "discount": 1.0,
    "terminal_cost": 0.06,
    "difficulty": 0.5,
    "import": [],
    "report": True,
    "progress": True,
}


class CLIError(Exception):
    """A user input problem: printed as ``uav-bench: error: ...`` with exit status 2."""


# --- parsing of the small languages of api.md ----------------------------------------------------


def parse_seeds(text: str | int) -> list[int]:
    """``20`` -> 0..19; ``5:10`` -> 5..9 (half-open, like ``range``)."""
    text = str(text).strip()
    try:
        if ":" in text:
            start, stop = (int(part) for part in text.split(":", 1))
            seeds = list(range(start, stop))
        else:
            seeds = list(range(int(text)))
    except ValueError:
        raise CLIError(
            f"--seeds: got {text!r}, expected a count N (seeds 0..N-1) or START:STOP (half-open)"
        ) from None
    if not seeds or min(seeds) < 0:
        raise CLIError(f"--seeds: got {text!r}, expected at least one seed, all >= 0")
    return seeds


def parse_weights(text: str | Sequence[float] | None) -> tuple[float, float, float] | None:
    """``0.3,0.5,0.2`` -> (0.3, 0.5, 0.2) (terrain, radar, third term)."""
    if text is None:
        return None
    try:
        values = [float(v) for v in (text.split(",") if isinstance(text, str) else text)]
    except ValueError:
        raise CLIError(
            f"--weights: got {text!r}, expected three comma-separated numbers summing to 1"
        ) from None
    if len(values) != 3:
        raise CLIError(f"--weights: got {text!r}, expected three comma-separated numbers summing to 1")
    return (values[0], values[1], values[2])


def resolve_scenarios(
    specs: Sequence[str],
    profile: str | None,
    weights: tuple[float, float, float] | None,
    difficulty: float = 0.5,
) -> list:
    """Scenario names (``paper``, ``paper-w2``, ``dem``, ``random:SEED``, ``random:A-B``) or YAML paths."""
    from uav_penetration_env import (
        ScenarioError,
        dem_scenario,
        load_scenario,
        paper_scenario,
        random_scenario,
    )

    scenarios = []
    for spec in specs:
        try:
            if spec == "paper":
                found = [paper_scenario("w1")]
            elif spec == "paper-w2":
                found = [paper_scenario("w2")]
            elif spec == "dem":
                found = [dem_scenario()]
            elif spec.startswith("random:"):
                found = [
                    random_scenario(np.random.default_rng(s), difficulty, name=f"random-{s}")
                    for s in _seed_range(spec)
                ]
            elif Path(spec).exists():
                found = [load_scenario(spec)]
            else:
                close = difflib.get_close_matches(
                    spec, ["paper", "paper-w2", "dem", "random:SEED", "random:A-B"], n=1
                )
                hint = f" — did you mean {close[0]!r}?" if close else ""
                raise CLIError(
                    f"--scenarios: unknown scenario {spec!r}{hint} expected paper, paper-w2, dem, random:SEED, random:A-B or a YAML path"
                )
            for scenario in found:
                if weights is not None:
                    scenario = scenario.updated({"cost": {"weights": list(weights)}})
                scenarios.append(scenario.with_profile(profile))
        except ScenarioError as error:
            raise CLIError(f"scenario {spec!r}: {error}") from None
    return scenarios


def _seed_range(spec: str) -> list[int]:
    body = spec.split(":", 1)[1]
    try:
        if "-" in body:
            low, high = (int(part) for part in body.split("-", 1))
            return list(range(low, high + 1))
        return [int(body)]
    except ValueError:
        raise CLIError(f"--scenarios: got {spec!r}, expected random:SEED or random:A-B (inclusive)") from None


def _split(values: Sequence[str] | None) -> list[str]:
    """Accept both ``--policies a b`` and ``--policies a,b``."""
    out: list[str] = []
    for value in values or []:
        out.extend(v for v in str(value).split(",") if v)
    return out


# --- configuration files --------------------------------------------------------------------------


def load_config(path: str | None) -> dict[str, Any]:
    """``--config FILE.yaml``: keys are the flag names with ``_``; unknown keys are errors."""
    if path is None:
        return {}
    try:
        data = yaml.safe_load(Path(path).read_text()) or {}
    except OSError as error:
        raise CLIError(f"--config: cannot read {path} ({error.strerror})") from None
    except yaml.YAMLError as error:
        raise CLIError(f"--config: {path} is not valid YAML ({error})") from None
    if not isinstance(data, dict):
        raise CLIError(f"--config: {path} must hold a mapping of flag names to values")
    allowed = [k for k in RUN_DEFAULTS if k not in ("report", "progress")]
    for key in data:
        if key not in allowed:
            close = difflib.get_close_matches(str(key), allowed, n=1)
            hint = f" — did you mean {close[0]!r}?" if close else ""
            raise CLIError(f"--config: {path}: unknown key {key!r}{hint} allowed: {', '.join(allowed)}")
    return data


def run_settings(args: argparse.Namespace) -> dict[str, Any]:
    """Flags override the config file, which overrides the defaults."""
    config = load_config(args.config)
    settings = dict(RUN_DEFAULTS)
    settings.update(config)
    for key in RUN_DEFAULTS:
        value = getattr(args, key, None)
        if value is not None and value != []:
            settings[key] = value
    settings["policies"] = _split(
        settings["policies"] if not isinstance(settings["policies"], str) else [settings["policies"]]
    )
    settings["scenarios"] = _split(
        settings["scenarios"] if not isinstance(settings["scenarios"], str) else [settings["scenarios"]]
    )
    settings["import"] = _split(
        settings["import"] if not isinstance(settings["import"], str) else [settings["import"]]
    )
    return settings


# --- commands -----------------------------------------------------------------------------------------


def _check_writable_folder(path: Path, flag: str) -> None:
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".uav-bench-write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as error:
        raise CLIError(
            f"{flag}: cannot write to {path} ({error.strerror}); expected a writable folder"
        ) from None


def command_run(args: argparse.Namespace) -> int:
    """`uav-bench run`: validate everything, evaluate into the store, then report."""
    from uav_penetration_env.benchmark.evaluate import BACKENDS, evaluate, import_plugins
    from uav_penetration_env.benchmark.policies import make_policy
    from uav_penetration_env.benchmark.store import ResultsStore, StoreError

    settings = run_settings(args)
    try:
        import_plugins(settings["import"])
    except ImportError as error:
        raise CLIError(f"--import: {error}") from None
    if settings["backend"] not in BACKENDS:
        raise CLIError(f"--backend: got {settings['backend']!r}, expected one of {', '.join(BACKENDS)}")
    seeds = parse_seeds(settings["seeds"])
    max_evals, horizon = int(settings["max_evals"]), int(settings["horizon"])
    policies = {}
    for spec in settings["policies"]:
        # An agent's table name is its file stem (sb3:ppo-paper-s0), not its whole path.
        name = f"sb3:{Path(spec[4:]).stem}" if spec.startswith("sb3:") else spec
        try:
            policies[name] = make_policy(
                spec,
                horizon=horizon,
                max_evals=max_evals,
                discount=float(settings["discount"]),
                terminal_cost=float(settings["terminal_cost"]),
            )
        except KeyError as error:
            raise CLIError(f"--policies: {error.args[0]}") from None
        except (ValueError, FileNotFoundError, ImportError) as error:
            raise CLIError(f"--policies: {spec!r}: {error}") from None
    if not policies:
        raise CLIError("--policies: expected at least one policy")
    scenarios = resolve_scenarios(
        settings["scenarios"],
        settings["profile"],
        parse_weights(settings["weights"]),
        float(settings["difficulty"]),
    )
    store_path = Path(settings["store"])
    out = Path(settings["out"])
    _check_writable_folder(store_path.parent, "--store")
    if settings["report"]:
        _check_writable_folder(out, "--out")
    try:
        store = ResultsStore(store_path)
    except StoreError as error:
        raise CLIError(f"--store: {error}") from None
    jobs = settings["jobs"]
    episodes = len(policies) * len(scenarios) * len(seeds)
    print(
        f"uav-bench run: {len(policies)} policies x {len(scenarios)} scenarios x {len(seeds)} seeds = {episodes} episodes -> {store_path}"
    )
    command = " ".join(["uav-bench", *map(shlex.quote, args.argv)])
    try:
        frame = evaluate(
            policies,
            scenarios,
            seeds,
            n_jobs=None if jobs is None else int(jobs),
            backend=settings["backend"],
            store=store,
            scheduler=settings["scheduler"],
            imports=tuple(settings["import"]),
            progress=bool(settings["progress"]),
            command=command,
        )
    except KeyboardInterrupt:
        done = len(store.done_keys())
        store.close()
        print(
            f"\ninterrupted: {done} finished episodes are stored in {store_path}; rerun the same command to resume",
            file=sys.stderr,
        )
        return 130
    store.close()
    errors = int((frame["error"] != "").sum())
    print(f"results: {store_path} ({len(frame)} episodes, {errors} errors)")
    if errors:
        first = frame.loc[frame["error"] != "", ["policy", "seed", "error"]].iloc[0]
        print(
            f"first error ({first['policy']}, seed {first['seed']}): {first['error'].splitlines()[0]}",
            file=sys.stderr,
        )
    if settings["report"]:
        _report(store_path, out, command)
    return 0


def _report(store: Path, out: Path, command: str) -> None:
    from uav_penetration_env.benchmark.figures import write_figures
    from uav_penetration_env.benchmark.leaderboard import write_leaderboards

    tables = write_leaderboards(store, out, command=command)
    figures = write_figures(store, out)
    for path in tables:
        print(f"leaderboard: {path}")
    for path in figures:
        if path.suffix == ".png":
            print(f"figure: {path}")
    markdown = [p for p in tables if p.suffix == ".md"]
    if markdown:
        print()
        print(_excerpt(markdown[0]))


def _excerpt(path: Path, rows: int = 14) -> str:
    """The table part of a generated leaderboard (for the terminal)."""
    lines = path.read_text().splitlines()
    table = [line for line in lines if line.startswith("|")]
    return "\n".join(table[: rows + 2])


def command_leaderboard(args: argparse.Namespace) -> int:
    """`uav-bench leaderboard`: Markdown + CSV tables per scenario group."""
    store = _existing_store(args.store)
    from uav_penetration_env.benchmark.leaderboard import write_leaderboards

    _check_writable_folder(Path(args.out), "--out")
    command = " ".join(["uav-bench", *map(shlex.quote, args.argv)])
    for path in write_leaderboards(
        store, Path(args.out), reference=args.reference, command=command, suite=args.suite
    ):
        print(path)
    return 0


def command_plot(args: argparse.Namespace) -> int:
    """`uav-bench plot`: the figures (PNG + PDF) per scenario group."""
    _check_writable_folder(Path(args.out), "--out")
    if args.models is not None:
        from baselines.curves import write_learning_curves

        if not Path(args.models).is_dir():
            raise CLIError(f"--models: {args.models} is not a folder of trained models")
        written = write_learning_curves(
            args.models, Path(args.out), references=dict(_reference(r) for r in args.reference_line or [])
        )
        if not written:
            raise CLIError(f"--models: no *.evaluations.csv with a .json sidecar in {args.models}")
        for path in written:
            print(path)
        return 0
    store = _existing_store(args.store)
    from uav_penetration_env.benchmark.figures import write_figures

    for path in write_figures(store, Path(args.out), suite=args.suite):
        print(path)
    return 0


def _reference(text: str) -> tuple[str, float]:
    """``SCENARIO:LABEL=VALUE`` (a dashed reference line on learning-curve panels of that scenario)."""
    try:
        key, value = text.rsplit("=", 1)
        return key, float(value)
    except ValueError:
        raise CLIError(
            f"--reference-line: got {text!r}, expected SCENARIO:LABEL=VALUE, e.g. paper-2022-sec5:greedy=17.2"
        ) from None


def _existing_store(path: str) -> Path:
    store = Path(path)
    if not store.is_file():
        raise CLIError(
            f"--store: no results store at {store}; run `uav-bench run` first or pass --store PATH"
        )
    return store


def command_export(args: argparse.Namespace) -> int:
    """`uav-bench export`: the episodes and steps tables as CSV or Parquet."""
    from uav_penetration_env.benchmark.store import ResultsStore

    store_path = _existing_store(args.store)
    out = Path(args.out) if args.out else store_path.with_suffix("")
    _check_writable_folder(out.parent, "--out")  # --out is a file stem: <stem>-episodes.csv, ...
    with ResultsStore(store_path) as store:
        tables = {"episodes": store.episodes(), "steps": store.steps()}
    written = []
    for name, frame in tables.items():
        if args.format == "csv":
            path = out.parent / f"{out.name}-{name}.csv"
            frame.to_csv(path, index=False)
        else:
            path = out.parent / f"{out.name}-{name}.parquet"
            frame.to_parquet(path, index=False)
        written.append(path)
        print(path)
    return 0


def command_calibrate(args: argparse.Namespace) -> int:
    """`uav-bench calibrate`: payoff-table constants written into a scenario file."""
    from uav_penetration_env.benchmark.calibration import payoff_table, with_payoff
    from uav_penetration_env.benchmark.evaluate import import_plugins

    import_plugins(_split(args.imports))
    from optimizers import available_optimizers

    if args.optimizer not in available_optimizers():
        close = difflib.get_close_matches(args.optimizer, available_optimizers(), n=1)
        hint = f" — did you mean {close[0]!r}?" if close else ""
        raise CLIError(f"--optimizer: unknown optimizer {args.optimizer!r}{hint}")
    (scenario,) = resolve_scenarios([args.scenario], None, None)
    out = Path(args.out)
    _check_writable_folder(out.parent, "--out")
    command = " ".join(["uav-bench", *map(shlex.quote, args.argv)])
    payoff = payoff_table(
        scenario, args.optimizer, max_evals=args.max_evals, runs=args.runs, horizon=args.horizon,
        n_jobs=args.jobs, imports=tuple(_split(args.imports)), command=command,
    )  # fmt: skip
    calibrated = with_payoff(scenario, payoff)
    calibrated.to_yaml(out)
    constants = payoff.constants
    print(
        f"terrain {constants.terrain}, radar {constants.radar}, third {constants.third}, crash penalty/step {constants.crash_penalty_per_step:.6g}"
    )
    print(f"calibrated scenario written to {out}")
    return 0


def command_scenario(args: argparse.Namespace) -> int:
    """`uav-bench scenario show|validate|generate`."""
    from uav_penetration_env import build_scenario, generate_dem_scenario

    if args.action == "generate":
        if args.name == "dem":
            scenarios = [generate_dem_scenario()]
        else:
            scenarios = resolve_scenarios([args.name], args.profile, None, args.difficulty)
        out = Path(args.out)
        if len(scenarios) == 1 and out.suffix in (".yaml", ".yml"):
            _check_writable_folder(out.parent, "--out")
            print(scenarios[0].to_yaml(out))
        else:
            _check_writable_folder(out, "--out")
            for scenario in scenarios:
                print(scenario.to_yaml(out / f"{scenario.name}.yaml"))
        return 0
    scenarios = resolve_scenarios([args.name], args.profile, None, args.difficulty)
    if args.action == "show":
        for scenario in scenarios:
            print(f"# {scenario.name}  (hash {scenario.hash})")
            print(yaml.safe_dump(scenario.to_dict(), sort_keys=False, default_flow_style=None, width=110))
        return 0
    for scenario in scenarios:  # validate: schema (already checked) and terrain-dependent rules
        from uav_penetration_env import ScenarioError

        try:
            built = build_scenario(scenario)
        except ScenarioError as error:
            raise CLIError(f"scenario {args.name!r}: {error}") from None
        print(
            f"{scenario.name}: valid (hash {scenario.hash}, {len(built.radar_xyz)} radars, grid {built.grid.nx}x{built.grid.ny})"
        )
    return 0


def command_train(args: argparse.Namespace) -> int:
    """`uav-bench train`: delegate to the RL baselines (extra ``rl``)."""
    try:
        from baselines.cli import train_command
    except ImportError as error:
        raise CLIError(f"train needs the RL extra: pip install -e '.[rl]' ({error})") from None
    return train_command(args)


# --- the parser -----------------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    """The ``uav-bench`` argument parser."""
    parser = argparse.ArgumentParser(
        prog="uav-bench",
        description="UAV penetration benchmark: run planners, build leaderboards and figures.",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = commands.add_parser(
        "run", help="evaluate planners on scenarios and seeds (resumable); no flags = the main job"
    )
    run.add_argument(
        "--policies",
        nargs="+",
        help=f"optimiser names (MPC), NAME-eq37, greedy, random, sb3:PATH.zip (default: {' '.join(MAIN_JOB_POLICIES)})",
    )
    run.add_argument(
        "--scenarios",
        nargs="+",
        help="paper, paper-w2, dem, random:SEED, random:A-B or YAML paths (default: paper)",
    )
    run.add_argument(
        "--profile", choices=["benchmark", "paper"], help="physics profile (default: each scenario's own)"
    )
    run.add_argument("--weights", help="objective weights terrain,radar,third, e.g. 0.3,0.5,0.2")
    run.add_argument("--seeds", help="N (seeds 0..N-1) or START:STOP (default: 5)")
    run.add_argument("--jobs", type=int, help="worker processes (default: all cores)")
    run.add_argument("--backend", help="loky (default), dask or sequential")
    run.add_argument("--scheduler", help="dask scheduler address (backend dask; none starts a local cluster)")
    run.add_argument("--store", help=f"results store (default: {DEFAULT_STORE})")
    run.add_argument("--out", help=f"folder for the leaderboard and figures (default: {DEFAULT_OUT})")
    run.add_argument(
        "--max-evals",
        dest="max_evals",
        type=int,
        help="objective evaluations per planning step (default: 10000)",
    )
    run.add_argument("--horizon", type=int, help="MPC horizon H (default: 5)")
    run.add_argument("--discount", type=float, help="MPC discount gamma (default: 1.0)")
    run.add_argument(
        "--terminal-cost",
        dest="terminal_cost",
        type=float,
        help="MPC cost-to-go per remaining step (default: 0.06)",
    )
    run.add_argument("--difficulty", type=float, help="difficulty of random:... scenarios (default: 0.5)")
    run.add_argument(
        "--import", dest="import", action="append", help="a plug-in module to import (repeatable)"
    )
    run.add_argument("--config", help="YAML file of settings (keys = flag names with _); flags override it")
    run.add_argument(
        "--no-report",
        dest="report",
        action="store_const",
        const=False,
        help="skip the leaderboard and figures",
    )
    run.add_argument(
        "--no-progress", dest="progress", action="store_const", const=False, help="no progress bar"
    )
    run.set_defaults(handler=command_run)

    leaderboard = commands.add_parser("leaderboard", help="Markdown + CSV leaderboards from a store")
    leaderboard.add_argument("--store", default=str(DEFAULT_STORE))
    leaderboard.add_argument("--out", default=str(DEFAULT_OUT))
    leaderboard.add_argument(
        "--reference", default="ihpso", help="policy the paired tests compare against (default: ihpso)"
    )
    leaderboard.add_argument(
        "--suite", help="one table over all the store's scenarios, named SUITE (blocks = scenario x seed)"
    )
    leaderboard.set_defaults(handler=command_leaderboard)

    plot = commands.add_parser("plot", help="figures (PNG + PDF) from a store")
    plot.add_argument("--store", default=str(DEFAULT_STORE))
    plot.add_argument("--out", default=str(DEFAULT_OUT))
    plot.add_argument("--suite", help="aggregate figures over all the store's scenarios, named SUITE")
    plot.add_argument("--models", help="instead: learning curves of the trained models in this folder")
    plot.add_argument(
        "--reference-line",
        action="append",
        help="with --models: SCENARIO:LABEL=VALUE dashed line (repeatable)",
    )
    plot.set_defaults(handler=command_plot)

    export = commands.add_parser("export", help="write the episodes and steps tables as CSV or Parquet")
    export.add_argument("--format", choices=["csv", "parquet"], required=True)
    export.add_argument("--store", default=str(DEFAULT_STORE))
    export.add_argument("--out", help="output stem (default: the store path without suffix)")
    export.set_defaults(handler=command_export)

    calibrate = commands.add_parser(
        "calibrate", help="payoff-table normalisation constants (paper §4.2) into a scenario file"
    )
    calibrate.add_argument("--scenario", default="paper", help="paper, dem, random:SEED or a YAML path")
    calibrate.add_argument("--optimizer", required=True, help="reference optimiser, e.g. ihpso")
    calibrate.add_argument("--max-evals", dest="max_evals", type=int, default=10_000)
    calibrate.add_argument("--runs", type=int, default=20)
    calibrate.add_argument("--horizon", type=int, default=10)
    calibrate.add_argument("--jobs", type=int, default=None, help="worker processes (default: all cores)")
    calibrate.add_argument(
        "--import", dest="imports", action="append", help="a plug-in module to import (repeatable)"
    )
    calibrate.add_argument("--out", required=True, help="scenario YAML to write")
    calibrate.set_defaults(handler=command_calibrate)

    scenario = commands.add_parser("scenario", help="show, validate or generate scenario files")
    scenario.add_argument("action", choices=["show", "validate", "generate"])
    scenario.add_argument("name", help="paper, paper-w2, dem, random:SEED, random:A-B or a YAML path")
    scenario.add_argument("--profile", choices=["benchmark", "paper"])
    scenario.add_argument("--difficulty", type=float, default=0.5)
    scenario.add_argument("--out", default=".", help="generate: a .yaml file or a folder")
    scenario.set_defaults(handler=command_scenario)

    train = commands.add_parser("train", help="train a Stable-Baselines3 agent (extra rl)")
    try:
        from baselines.cli import add_train_arguments

        add_train_arguments(train)
    except ImportError:
        train.add_argument("rest", nargs=argparse.REMAINDER)
    train.set_defaults(handler=command_train)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``uav-bench`` console script."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    args.argv = argv
    try:
        return int(args.handler(args) or 0)
    except CLIError as error:
        print(f"uav-bench: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
