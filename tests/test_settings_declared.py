"""Every declared setting of ``run``, ``train`` and ``distill`` is a flag, a config key and a check.

The settings classes declare each setting once (:mod:`uav_penetration_env.settings_fields`); these
tests walk their fields, so a field that is not reachable as a flag, as a config key or through
the check fails here, and a flag that reaches no field (parsed, then dropped) fails too.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import pytest

from baselines.cli import add_train_arguments
from baselines.distill.cli import add_distill_arguments
from baselines.distill.config import DistillConfig
from baselines.plan import TrainConfig
from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.commands import run as run_command
from uav_penetration_env.benchmark.commands.common import CLIError
from uav_penetration_env.benchmark.commands.run_settings import RunSettings
from uav_penetration_env.mpc import SETTING_FIELDS
from uav_penetration_env.settings_fields import (
    Setting,
    SettingError,
    check_fields,
    config_keys,
    declared,
    flag_of,
    given_values,
    key_of,
    parse_values,
)

# Values for the settings whose default is None (nothing to write back), as a flag's text.
SAMPLES = {"profile": "paper", "weights": "0.3,0.4,0.3", "jobs": "2", "threads": "2", "reference": "pso",
           "scheduler": "tcp://host:8786", "suite": "uavpen-v1", "scenario": "paper", "out": "x/model.zip",
           "hyperparams": "hp.yaml", "difficulty": "0.25", "init_from": "runs/d", "critic_warmup_steps": "64"}  # fmt: skip


def parser_of(add: object) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(exit_on_error=False)
    add(parser)  # type: ignore[operator]
    return parser


COMMANDS = {
    RunSettings: lambda: cli.build_parser()._subparsers._group_actions[0].choices["run"],  # type: ignore[union-attr]
    TrainConfig: lambda: parser_of(add_train_arguments),
    DistillConfig: lambda: parser_of(add_distill_arguments),
}
# What each command reads besides its settings class: the MPC settings and --config of run.
OTHER_DESTS = {RunSettings: {*SETTING_FIELDS, "config", "help"}, TrainConfig: {"help"}, DistillConfig: {"help"}}
REQUIRED = {DistillConfig: ["--out", "run/folder"]}


def flag_argv(field: dataclasses.Field, spec: Setting) -> list[str]:
    """A command line that sets ``field``: its flag and a value (the default, or a sample)."""
    flag = flag_of(field, spec)
    if spec.switch is not None:
        return [flag]
    if field.name in SAMPLES:
        return [flag, SAMPLES[field.name]]
    if spec.many:
        items = [str(item) for item in field.default] or ["position"]
        return [flag, *items] if spec.many != "append" else [flag, items[0]]
    return [flag, str(field.default)]


@pytest.mark.parametrize("cls", list(COMMANDS), ids=lambda cls: cls.__name__)
def test_every_declared_field_is_a_flag_that_reaches_it(cls):
    parser = COMMANDS[cls]()
    fields = declared(cls)
    assert len(fields) >= 15
    for field, spec in fields:
        argv = flag_argv(field, spec)
        extra = [] if argv[0] in REQUIRED.get(cls, []) else REQUIRED.get(cls, [])
        given = given_values(parser.parse_args([*argv, *extra]), cls)
        assert field.name in given, f"{argv[0]} does not reach {cls.__name__}.{field.name}"
        value = getattr(parse_values(cls, given), field.name)
        if spec.switch is not None:
            assert value == spec.switch
        elif field.name not in SAMPLES and not spec.many:
            assert value == field.default, f"{argv} -> {value!r}, not the default {field.default!r}"


@pytest.mark.parametrize("cls", list(COMMANDS), ids=lambda cls: cls.__name__)
def test_no_flag_is_parsed_and_then_dropped(cls):
    # Every destination of the command's parser is a declared field (or what the command reads
    # besides its settings): a flag added to the parser alone would fail here.
    dests = {action.dest for action in COMMANDS[cls]()._actions}
    assert dests - OTHER_DESTS[cls] == {field.name for field, _ in declared(cls) if flag_of(field, _)}


def bad_value(spec: Setting) -> object:
    """A value outside a setting's kind or domain (None: the setting is checked elsewhere)."""
    if spec.kind is object:
        return None
    if spec.kind in (int, float):
        return "lots"
    if spec.kind is bool:
        return "maybe"
    if isinstance(spec.kind, tuple):  # a config file's scalar: a mapping is none
        return {"a": 1}
    return "no-such-choice" if not spec.allowed("no-such-choice") else None


@pytest.mark.parametrize("cls", [*COMMANDS], ids=lambda cls: cls.__name__)
@pytest.mark.parametrize("label", ["flag", "field"])
def test_a_bad_value_is_refused_in_one_line_naming_the_setting(cls, label):
    check_fields(cls())  # the defaults lie in their domains
    checked = 0
    for field, spec in declared(cls):
        value = bad_value(spec)
        if value is None:
            continue
        name = flag_of(field, spec) if label == "flag" else field.name
        with pytest.raises(SettingError) as caught:
            parse_values(cls, {field.name: [value] if spec.many else value}, label=label)
        shown = [value] if spec.many and not spec.each else value
        assert str(caught.value) == f"{name}: got {shown!r}, expected {spec.expected}"
        assert "\n" not in str(caught.value) and spec.expected
        # The same check guards an instance built from Python (values as they are).
        with pytest.raises(SettingError, match=f"^{field.name}: got "):
            check_fields(dataclasses.replace(cls(), **{field.name: (value,) if spec.many else value}))
        checked += 1
    assert checked >= 8


def test_run_config_keys_reach_every_field(tmp_path):
    # Each config key of run sets its field and counts as given, as the flag does.
    keys = {key_of(field, spec): field for field, spec in declared(RunSettings) if key_of(field, spec)}
    assert set(keys) == set(config_keys(RunSettings)) and set(keys) <= set(run_command.CONFIG_KEYS)
    assert {"report", "progress"}.isdisjoint(keys)  # switches of the command line only
    config = tmp_path / "run.yaml"
    for key, field in keys.items():
        spec: Setting = field.metadata["setting"]
        value = SAMPLES.get(field.name, field.default)
        value = [*value] if isinstance(value, tuple) else (True if spec.kind is bool else value)
        config.write_text(f"{key}: {value!r}\n".replace("'", '"'))
        args = cli.build_parser().parse_args(["run", "--config", str(config)])
        settings = run_command.run_settings(args)
        assert field.name in settings.explicit, key
        got = getattr(settings, field.name)
        assert (list(got) if isinstance(got, tuple) else got) == value or str(got) == str(value), key


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("difficulty: hard", "--difficulty: got 'hard', expected a number in [0, 1]"),
        ("threads: 0", "--threads: got 0, expected an integer >= 1"),
        ("jobs: 1.5", "--jobs: got 1.5, expected an integer (0: all cores, -N: all but N-1)"),
        ("seeds: [1, 2]", "--seeds: got [1, 2], expected a single value"),
        ("policies: 3", "--policies: got 3, expected one or more names"),
    ],
)
def test_run_config_values_are_checked_as_the_flags_are(text, message, tmp_path):
    config = tmp_path / "bad.yaml"
    config.write_text(text)
    args = cli.build_parser().parse_args(["run", "--config", str(config)])
    with pytest.raises(CLIError) as caught:
        run_command.run_settings(args)
    assert str(caught.value) == message


def test_run_list_settings_split_commas(tmp_path):
    config = tmp_path / "lists.yaml"
    # A comma list from a flag or a file is split, as before (--policies a,b is a b).
    config.write_text("policies: pso,cem\nimport: []\n")
    args = cli.build_parser().parse_args(["run", "--config", str(config), "--members", "a,b", "c"])
    settings = run_command.run_settings(args)
    assert (settings.policies, settings.members, settings.imports) == (("pso", "cem"), ("a", "b", "c"), ())


def test_train_and_distill_fields_are_their_config_keys():
    # train_agent(**keys) and run_distill(**keys) read the field names: the config keys.
    for cls in (TrainConfig, DistillConfig):
        assert config_keys(cls) == [field.name for field, _ in declared(cls)]
        defaults = {field.name: field.default for field, _ in declared(cls)}
        assert parse_values(cls, given_values(defaults, cls, by="key")) == cls()
    undeclared = {f.name for f in dataclasses.fields(TrainConfig)} - set(config_keys(TrainConfig))
    assert undeclared == {"env_kwargs", "eval_seeds", "on_evaluation", "device"}  # Python only


def test_the_train_command_keeps_its_defaults():
    from baselines.cli import CLI_DEFAULTS, _train_config

    args = parser_of(add_train_arguments).parse_args(["--out", "m.zip"])
    config = _train_config(args)
    assert config == dataclasses.replace(CLI_DEFAULTS, out=Path("m.zip"))
    assert config.progress_bar and not TrainConfig().progress_bar  # the CLI shows a bar; Python none
    args = parser_of(add_train_arguments).parse_args(["--out", "m.zip", "--no-progress", "--timesteps", "64"])
    assert (_train_config(args).progress_bar, _train_config(args).total_timesteps) == (False, 64)
