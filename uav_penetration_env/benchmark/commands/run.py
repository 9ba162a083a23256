"""``uav-bench run``: evaluate policies on scenarios and seeds into a results store, then report.

With no flags it is the main job (api.md): the paper scenario (weights 0.3/0.4/0.3), the six
swarm planners plus ``pso``, ``cem`` and the ``greedy`` floor, 5 seeds, all cores, results in
``results/uav-bench.sqlite``, then the leaderboards, figures and HTML report (``index.html``) in
``results/``, and a compact summary in the terminal.

Every input (flags, ``--config`` file, policy names and the extras they need, scenarios, the
store's folder) is checked before the store is opened, so a typo never damages a store. Ctrl-C
leaves every finished episode stored (exit status 130); rerunning the same command resumes.
"""

from __future__ import annotations

import argparse
import dataclasses
import signal
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from uav_penetration_env.benchmark.commands.common import (
    CLIError,
    Command,
    check_out_folder,
    check_writable_folder,
    command_line,
    parse_seeds,
    parse_weights,
    path_argument,
    record_out_folder,
    resolve_scenarios,
    store_error,
)
from uav_penetration_env.benchmark.commands.mpc_flags import SETTING_FIELDS, add_mpc_arguments, mpc_settings
from uav_penetration_env.benchmark.commands.run_settings import (
    SUITE_CONFLICTS,
    RunSettings,
)
from uav_penetration_env.benchmark.plugins import PluginUnavailable, plugin_policy_forms
from uav_penetration_env.settings_fields import (
    SettingError,
    add_flags,
    config_keys,
    given_values,
    parse_values,
)
from uav_penetration_env.suggest import did_you_mean
from uav_penetration_env.wording import counted
from uav_penetration_env.yaml_mapping import read_yaml_mapping

if TYPE_CHECKING:  # the MPC settings module is imported where a planner is built
    from uav_penetration_env.mpc import MPCSettings

# The MPC settings are config keys too, their defaults the dataclass's (mpc_flags).
CONFIG_KEYS = [*config_keys(RunSettings), *SETTING_FIELDS]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench run``: one per :class:`RunSettings` and ``MPCSettings`` field, and ``--config``."""
    from uav_penetration_env.catalogue import SCENARIO_HELP

    plugin_forms = "".join(f", {form}" for form in plugin_policy_forms())
    add_flags(parser, RunSettings, fill={"plugin_forms": plugin_forms, "scenario_help": SCENARIO_HELP})
    add_mpc_arguments(parser)
    parser.add_argument(
        "--config",
        type=path_argument,
        help="YAML file of settings (keys = flag names with _); flags override it",
    )


def load_config(path: str | None) -> dict[str, Any]:
    """``--config FILE.yaml``: keys are the flag names with ``_``; unknown keys are errors.

    Raises:
        CLIError: an unreadable file, invalid YAML, not a mapping, or an unknown key.
    """
    if path is None:
        return {}
    try:
        data = read_yaml_mapping(Path(path), "--config", "flag names")
    except (OSError, ValueError) as error:
        raise CLIError(str(error)) from None
    for key in data:
        if key not in CONFIG_KEYS:
            raise CLIError(
                f"--config: {path}: unknown key {key!r} — {did_you_mean(key, CONFIG_KEYS)}"
                f"allowed: {', '.join(CONFIG_KEYS)}"
            )
    return data


def run_settings(args: argparse.Namespace) -> RunSettings:
    """Flags override the config file, which overrides :class:`RunSettings`' defaults (``MPC_DEFAULTS`` for MPC).

    Every value is converted to its kind and checked against its domain here, the config file's
    as the flags' (``difficulty: hard`` is refused, not a traceback). ``settings.mpc`` is the one
    :class:`~uav_penetration_env.mpc.MPCSettings` of every planner; ``settings.explicit`` holds the
    keys set by a flag or the config file.

    Raises:
        CLIError: a bad ``--config`` file, or a setting outside its domain (``--horizon: ...``,
            ``--difficulty: got 'hard', expected a number in [0, 1]``).
    """
    config = load_config(args.config)
    mpc_given = {key: config[key] for key in SETTING_FIELDS if key in config}
    mpc_given.update({key: getattr(args, key) for key in SETTING_FIELDS if getattr(args, key, None) is not None})
    mpc = mpc_settings(mpc_given)
    values = given_values(config, RunSettings, by="key")
    flags = given_values(args, RunSettings)
    values.update(flags)
    explicit = set(values) | set(mpc_given)
    try:
        settings = parse_values(RunSettings, values, label="flag")
    except SettingError as error:
        raise CLIError(str(error)) from None
    return dataclasses.replace(settings, mpc=mpc, explicit=frozenset(explicit))


def make_policies(names: Sequence[str], mpc: MPCSettings) -> dict[str, Any]:
    """The policies ``names`` (``--policies``) by table name, MPC planners with ``mpc``; plug-in kinds checked for their extras.

    Raises:
        CLIError: an unknown name, a plug-in whose extra is missing, a bad agent file.
    """
    from uav_penetration_env.benchmark.policies import make_policy, parse_policy

    policies = {}
    for spec in names:
        try:
            parsed = parse_policy(spec)  # read once: its label is the table name, its spec builds the policy
            policies[parsed.label] = make_policy(parsed, mpc)
        except KeyError as error:
            raise CLIError(f"--policies: {error.args[0]}") from None
        except PluginUnavailable as error:  # it names the policy and what to install
            raise CLIError(f"--policies: {error}") from None
        except (ValueError, FileNotFoundError, ImportError) as error:
            raise CLIError(f"--policies: {spec!r}: {error}") from None
    if not policies:
        raise CLIError("--policies: expected at least one policy")
    return policies


def suite_plan(settings: RunSettings, policies: dict[str, Any]) -> tuple[list[Any], list[int], Any]:
    """The members of ``--suite`` (each verified against its fingerprint), the seeds and the seed rule.

    Without ``--seeds`` each (policy, member) flies :func:`~uav_penetration_env.suites.default_seeds`
    (5 seeds for a stochastic policy on a fixed member, else 1); an explicit ``--seeds`` applies to
    every member and policy.

    Returns:
        The scenarios, the union of the seeds, and the ``include`` rule for :func:`evaluate`.

    Raises:
        CLIError: a flag that would change the members, an unknown suite or member pattern, or a
            member whose fingerprint differs (naming the member, the field and both values).
    """
    from uav_penetration_env.benchmark.policies import is_deterministic
    from uav_penetration_env.benchmark.progress import ProgressBar
    from uav_penetration_env.suites import SuiteError, build_member, default_seeds, load_suite

    for key in SUITE_CONFLICTS:
        if key in settings.explicit:
            raise CLIError(
                f"--{key}: not with --suite (a frozen suite's members are fixed; use --members to select some)"
            )
    try:
        suite = load_suite(str(settings.suite))
        members = suite.select(settings.members)
        scenarios = []
        with ProgressBar(
            len(members), f"verify {suite.name}", unit="member", enabled=bool(settings.progress)
        ) as bar:
            for member in members:
                scenarios.append(build_member(suite, member))
                bar.update(1)
    except SuiteError as error:
        raise CLIError(f"--suite: {error}") from None
    if "seeds" in settings.explicit:
        return scenarios, parse_seeds(settings.seeds), lambda name, policy, scenario, seed: True
    member_of = {member.fingerprint.scenario_hash: member for member in members}
    deterministic = {name: is_deterministic(policy) for name, policy in policies.items()}

    def include(name: str, policy: Any, scenario: Any, seed: int) -> bool:
        return seed in default_seeds(member_of[scenario.hash], scenario, deterministic[name])

    from uav_penetration_env.suites import FIXED_MEMBER_SEEDS

    return scenarios, list(range(FIXED_MEMBER_SEEDS)), include


def run(args: argparse.Namespace) -> int:
    """Validate everything, evaluate into the store, then write the leaderboards, figures and report."""
    from uav_penetration_env.benchmark.plugins import import_plugins
    from uav_penetration_env.benchmark.policy_names import unknown_policy
    from uav_penetration_env.benchmark.workers import BACKENDS, ClusterError

    # DECISION (api.md §4.7, fast refusals): what can be checked without the physics is checked
    # first (flags, --config, --import, policy names, scenario files), so a typo answers in about
    # the time of --help, not after the compiled model's imports.
    settings = run_settings(args)
    try:
        import_plugins(settings.imports)
    except ImportError as error:
        raise CLIError(f"--import: {error}") from None
    if settings.backend not in BACKENDS:
        raise CLIError(f"--backend: got {settings.backend!r}, expected one of {', '.join(BACKENDS)}")
    seeds = parse_seeds(settings.seeds)
    for spec in settings.policies:
        problem = unknown_policy(spec)
        if problem is not None:
            raise CLIError(f"--policies: {problem}")
    # The scenarios of --scenarios need no policy; a suite's seed rule does (after make_policies).
    plan = episode_plan(settings, {}, seeds) if settings.suite is None else None

    from uav_penetration_env.benchmark.evaluate import evaluate  # the physics and the compiled code

    policies = make_policies(settings.policies, settings.mpc)
    reference = run_reference(settings.reference, list(policies))
    scenarios, seeds, include, suite_settings = plan or episode_plan(settings, policies, seeds)
    store_path = Path(settings.store)
    # The report goes next to the store it reads unless --out says where: a run on another store
    # never replaces the main job's report in ./results.
    out = Path(settings.out) if "out" in settings.explicit else store_path.parent
    if settings.report:  # refused before the store is opened: the report would land among another's files
        check_out_folder(out, store_path, replace=bool(settings.replace_out))
    store = open_store(store_path, out if settings.report else None)
    announce(settings, policies, scenarios, seeds, include, store_path)
    command = command_line(args)
    jobs = settings.jobs
    previous = _catch_sigterm()
    try:
        frame = evaluate(
            policies,
            scenarios,
            seeds,
            n_jobs=None if jobs is None else int(jobs),
            backend=settings.backend,
            store=store,
            scheduler=settings.scheduler,
            imports=tuple(settings.imports),
            progress=bool(settings.progress),
            command=command,
            include=include,
            run_settings=suite_settings,
            threads=settings.threads,
        )
    except ClusterError as error:  # refused before any episode: the scheduler or a plug-in (one line)
        store.close()
        raise CLIError(str(error)) from None
    except KeyboardInterrupt as error:
        # joblib aborts its loky workers when the interruption reaches its generator (tested).
        done = len(store.done_keys())
        store.close()
        what = f"terminated (signal {error.signum})" if isinstance(error, Terminated) else "interrupted"
        print(
            f"\n{what}: {done} finished episodes are stored in {store_path}; rerun the same command to resume",
            file=sys.stderr,
        )
        return 128 + error.signum if isinstance(error, Terminated) else 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    store.close()
    errors = print_outcome(frame, store_path)
    if settings.report and settings.suite is not None:
        suite_report(store_path, out, command, settings.suite, reference)
    elif settings.report:
        report(store_path, out, command, reference)
    return 1 if errors else 0  # some work failed: say so in the exit status too (cli.EXIT_STATUS)


class Terminated(KeyboardInterrupt):
    """SIGTERM (what Slurm, Kubernetes and systemd send), taken as Ctrl-C is: finished episodes are kept."""

    def __init__(self, signum: int) -> None:
        super().__init__(f"signal {signum}")
        self.signum = signum


def _raise_terminated(signum: int, frame: Any) -> None:
    raise Terminated(signum)


def _catch_sigterm() -> Any:
    """Route SIGTERM to :class:`Terminated` for the run; returns the previous handler (None off the main thread)."""
    if threading.current_thread() is not threading.main_thread():
        return None  # signal handlers can only be set there (a run started from a thread keeps the default)
    return signal.signal(signal.SIGTERM, _raise_terminated)


def episode_plan(
    settings: RunSettings, policies: dict[str, Any], seeds: list[int]
) -> tuple[list[Any], list[int], Any, dict[str, Any]]:
    """The scenarios, seeds, episode filter and extra run settings of ``--suite`` or ``--scenarios``.

    Raises:
        CLIError: ``--members`` without ``--suite``, or no scenario.
    """
    include = None
    suite_settings: dict[str, Any] = {}
    if settings.suite is not None:
        scenarios, seeds, include = suite_plan(settings, policies)
        suite_settings = {"suite": settings.suite, "members": list(settings.members)}
    else:
        if settings.members:
            raise CLIError("--members: only with --suite (it selects suite members)")
        scenarios = resolve_scenarios(
            settings.scenarios,
            settings.profile,
            parse_weights(settings.weights),
            float(settings.difficulty),
        )
    if not scenarios:
        raise CLIError(f"--scenarios: got {list(settings.scenarios)!r}, expected at least one scenario")
    return scenarios, seeds, include, suite_settings


def open_store(store_path: Path, out: Path | None) -> Any:
    """The results store, opened after every check that could refuse it (a bad store is left as it is).

    Raises:
        CLIError: the store is damaged or not a results store, or its folder (or ``out``) is not writable.
    """
    from uav_penetration_env.benchmark.store import (
        ResultsStore,
        StoreError,
        check_integrity,
        inspect_store_file,
    )

    try:
        inspect_store_file(store_path)  # before anything is written
        check_integrity(
            store_path
        )  # pages damaged inside a file of the right size, which run would write into
    except StoreError as error:
        raise store_error(error) from None
    check_writable_folder(store_path.parent, "--store", store_path)
    if out is not None:
        check_writable_folder(out, "--out")
    try:
        return ResultsStore(store_path)
    except StoreError as error:
        raise store_error(error) from None


def announce(
    settings: RunSettings,
    policies: dict[str, Any],
    scenarios: list[Any],
    seeds: list[int],
    include: Any,
    store_path: Path,
) -> None:
    """Print the run's size: policies x scenarios x seeds, or the suite's members under its seed rule."""
    if include is None:
        episodes = len(policies) * len(scenarios) * len(seeds)
        print(
            f"uav-bench run: {counted(len(policies), 'policy', 'policies')} x {counted(len(scenarios), 'scenario')} "
            f"x {counted(len(seeds), 'seed')} = {counted(episodes, 'episode')} -> {store_path}"
        )
        return
    episodes = sum(
        include(name, policy, scenario, seed)
        for name, policy in policies.items()
        for scenario in scenarios
        for seed in seeds
    )
    rule = "--seeds " + str(settings.seeds) if "seeds" in settings.explicit else "the suite's seed rule"
    print(
        f"uav-bench run: suite {settings.suite}: {counted(len(policies), 'policy', 'policies')} x "
        f"{counted(len(scenarios), 'member')} ({rule}) = {counted(episodes, 'episode')} -> {store_path}"
    )


def print_outcome(frame: Any, store_path: Path) -> int:
    """Print the episode and error counts (and the first error on stderr); returns the error count."""
    errors = int((frame["error"] != "").sum())
    failed = f"; {errors} of {len(frame)} episodes FAILED, exit status 1" if errors else ""
    print(f"results: {store_path} ({len(frame)} episodes, {errors} errors{failed})")
    if errors:
        first = frame.loc[frame["error"] != "", ["policy", "seed", "error"]].iloc[0]
        print(
            f"first error ({first['policy']}, seed {first['seed']}): {first['error'].splitlines()[0]}",
            file=sys.stderr,
        )
    return errors


def run_reference(reference: str | None, policies: list[str]) -> str:
    """The reference the run's tables are asked for: ``--reference``, else the default name ``ihpso``.

    The tables resolve the default by the one rule of api.md §4.5 (ihpso where flown, else greedy,
    else the policy on the most seeds;
    :func:`~uav_penetration_env.benchmark.leaderboard.groups.resolve_reference`), so the report a
    run writes and the one ``uav-bench report`` rebuilds from the same store agree; the terminal
    summary shows what each table chose (:func:`~uav_penetration_env.benchmark.summary.table_reference`).

    Raises:
        CLIError: ``--reference`` names no policy of ``--policies``.
    """
    if reference is None:
        from uav_penetration_env.benchmark.leaderboard.groups import DEFAULT_REFERENCE

        return DEFAULT_REFERENCE
    if reference not in policies:
        raise CLIError(
            f"--reference {reference}: {did_you_mean(reference, policies)}"
            f"expected one of --policies ({', '.join(policies)})"
        )
    return str(reference)


def report(store: Path, out: Path, command: str, reference: str = "ihpso") -> None:
    """Write the leaderboards, figures (PNG + PDF) and HTML report of ``store`` into ``out``; summarise."""
    from uav_penetration_env.benchmark.commands.report import print_written, write_results

    written = write_results(store, out, command=command, reference=reference, formats=("png", "pdf"))
    record_out_folder(out, store)
    print()
    print_written(written, out, reference)


def suite_report(store: Path, out: Path, command: str, suite: str, reference: str = "ihpso") -> None:
    """After ``run --suite``: write the leaderboards and summarise the suite's own tables.

    DECISION (docs/suite.md §5): a suite run writes the tables only. The figures and the HTML page
    draw every scenario's terrain (63 members: many minutes and a page of some 200 MB); ``uav-bench
    report`` writes them when wanted.
    """
    from uav_penetration_env.benchmark.leaderboard import write_leaderboards
    from uav_penetration_env.benchmark.summary import print_summary
    from uav_penetration_env.suites import load_suite

    name = load_suite(suite).name
    tables = write_leaderboards(store, out, reference=reference, command=command)
    record_out_folder(out, store)
    own = [path for path in tables if path.stem == name or path.stem.startswith(f"{name}-")]
    print()
    print_summary(own)
    print(
        f"per-scenario tables: {len(tables) - len(own)} files in {out}; figures and the HTML report: "
        f"uav-bench report --store {store} --out {out}"
    )


COMMAND = Command(
    name="run",
    help="evaluate planners on scenarios and seeds (resumable); no flags = the main job",
    add_arguments=add_arguments,
    run=run,
)
