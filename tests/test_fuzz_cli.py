"""``uav-bench`` on generated command lines: real sub-commands and flags with junk values.

Every command line ends in an exit status 0, 1 or 2, and a status-2 one in a last stderr line
``uav-bench: error: ...``: never a traceback. A command line that passes every check reaches the
command's work, which is replaced by a marker (nothing is flown, built or written outside a
temporary folder): the property is about the checks, not the work.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import importlib
import io

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from uav_penetration_env.benchmark import cli

# compile --clear would remove the compile cache; the plug-in commands (RL) train.
FUZZED = ("run", "leaderboard", "plot", "report", "export", "import", "replay", "calibrate", "scenario",
          "windows", "best-known", "suite", "store", "protocol", "timing", "campaign")  # fmt: skip
# Where each command's work starts once its inputs are checked.
WORK = (
    ("uav_penetration_env.benchmark.evaluate", "evaluate"),
    ("uav_penetration_env.benchmark.calibration", "payoff_table"),
    ("uav_penetration_env.benchmark.windows", "collect_windows"),
    ("uav_penetration_env.benchmark.windows", "run_windows"),
    ("uav_penetration_env.benchmark.bestknown.compute", "compute_record"),
    ("uav_penetration_env.benchmark.bestknown.compute", "update_from_store"),
    ("uav_penetration_env.benchmark.bestknown.record", "replay_record"),
    ("uav_penetration_env.suites", "verify_suite"),
    ("uav_penetration_env.benchmark.suite_freeze", "freeze_suite"),
    ("uav_penetration_env.build", "build_scenario"),
    ("uav_penetration_env.benchmark.replay", "animate_episode"),
    ("uav_penetration_env.benchmark.minari_export", "write_datasets"),
    ("uav_penetration_env.benchmark.timing", "time_planners"),
    ("uav_penetration_env.benchmark.protocol", "primary_answers"),
    ("uav_penetration_env.benchmark.blackbox.ioh_export", "export_window_runs"),
    ("uav_penetration_env.benchmark.campaign.runner", "run_campaign"),
    ("uav_penetration_env.benchmark.campaign.actions", "compute"),
    ("uav_penetration_env.benchmark.campaign.actions", "install"),
    ("uav_penetration_env.benchmark.campaign.actions", "seed"),
    ("uav_penetration_env.benchmark.campaign.actions", "resume_from_checkpoint"),
    ("uav_penetration_env.benchmark.campaign.actions", "write_checkpoint"),
    ("uav_penetration_env.benchmark.campaign.actions", "rebuild_from_published"),
)
JUNK = ["", " ", "-1", "0", "1", "3", "0.5", "nan", "inf", "-inf", "1e999", "x", "a" * 300, "\x00", "é",
        "1,2", "0-2", "-", "--", "none", "None", "/", ".", "paper", "random:3", "random:x", "greedy", "pso",
        "ihpso,greedy", "a=b", "{}", "[1]", "results", "results/uav-bench.sqlite", "csv", "md"]  # fmt: skip


class ReachedWork(BaseException):
    """The command line passed every check (a BaseException: no ``except Exception`` swallows it)."""


def instead_of(work):
    """A stand-in for ``work`` with its signature (``calibrate`` reads its defaults from it)."""

    @functools.wraps(work)
    def reached(*args, **kwargs):
        raise ReachedWork

    return reached


def command_parsers() -> dict[str, argparse.ArgumentParser]:
    (subparsers,) = [a for a in cli.build_parser()._actions if isinstance(a, argparse._SubParsersAction)]
    return {name: subparsers.choices[name] for name in FUZZED}


PARSERS = command_parsers()


@st.composite
def command_lines(draw) -> list[str]:
    name = draw(st.sampled_from(FUZZED))
    parser = PARSERS[name]
    values = st.one_of(st.sampled_from(JUNK), st.text(max_size=6))
    argv = [name]
    for action in parser._actions:
        if not action.option_strings and action.nargs != 0:  # a positional: one of its choices, mostly
            choices = list(action.choices or [])
            argv.append(draw(st.sampled_from(choices) if choices and draw(st.booleans()) else values))
    flags = [a for a in parser._actions if a.option_strings and "--help" not in a.option_strings]
    for action in draw(st.lists(st.sampled_from(flags), max_size=5)):
        argv.append(draw(st.sampled_from(action.option_strings)))
        if action.nargs != 0:
            argv.extend(draw(st.lists(values, min_size=1, max_size=2)))
    if draw(st.booleans()):
        argv.append(draw(values))  # a stray word
    return argv


def test_generated_command_lines_end_in_a_status_and_at_most_one_error_line(tmp_path, monkeypatch):
    fuzz_command_lines(tmp_path, monkeypatch, 300)


@pytest.mark.slow
def test_ten_thousand_generated_command_lines(tmp_path, monkeypatch):
    fuzz_command_lines(tmp_path, monkeypatch, 10_000)


def fuzz_command_lines(tmp_path, monkeypatch, examples: int) -> None:
    monkeypatch.chdir(tmp_path)  # default outputs (results/) land here
    for module, name in WORK:
        owner = importlib.import_module(module)
        monkeypatch.setattr(owner, name, instead_of(getattr(owner, name)))

    @settings(max_examples=examples, suppress_health_check=[HealthCheck.too_slow], deadline=None)
    @given(argv=command_lines())
    def check(argv: list[str]) -> None:
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                status = cli.main(argv)
            except ReachedWork:
                return
            except SystemExit as exit_:  # argparse's own exits (--help is never generated)
                status = exit_.code
        assert status in (0, 1, 2), (argv, status, err.getvalue()[-400:])
        if status == 2:
            last = err.getvalue().strip().splitlines()[-1]
            assert last.startswith("uav-bench: error: ") and "Traceback" not in err.getvalue(), (argv, last)

    check()


def test_a_control_character_in_a_value_stays_escaped_in_the_one_error_line(capsys):
    assert cli.main(["run", "\r"]) == 2  # what the fuzzing found: the message broke across lines
    err = capsys.readouterr().err
    assert err == "uav-bench: error: uav-bench run: unrecognized arguments: \\r (see uav-bench run --help)\n"


def test_the_fuzzed_commands_are_the_built_in_ones_but_compile():
    from uav_penetration_env.benchmark.commands import builtin_commands

    assert set(FUZZED) == set(builtin_commands()) - {"compile"}


@pytest.mark.parametrize(("module", "name"), WORK)
def test_every_work_entry_point_exists(module, name):
    assert callable(getattr(importlib.import_module(module), name))
