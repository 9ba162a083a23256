"""Every path flag of every command refuses a path the operating system would refuse, in one line."""

from __future__ import annotations

import argparse

import pytest

from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.commands.common import NAME_MAX, path_argument

PATH_FLAGS = {"--store", "--out", "--rows", "--records", "--config"}


def path_flags(parser: argparse.ArgumentParser, prefix: tuple[str, ...] = ()):
    """(sub-command words, flag, action) of every path-like flag, sub-commands of sub-commands included."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from path_flags(sub, (*prefix, name))
        elif PATH_FLAGS & set(action.option_strings):
            yield prefix, action.option_strings[0], action


FLAGS = sorted((words, flag, action.type) for words, flag, action in path_flags(cli.build_parser()))


def test_every_path_flag_checks_its_path():
    assert len(FLAGS) >= 15  # store, out, rows, records, config across the commands
    unchecked = [" ".join((*words, flag)) for words, flag, kind in FLAGS if kind is not path_argument]
    assert unchecked == []


@pytest.mark.parametrize(("words", "flag"), [(w, f) for w, f, _ in FLAGS], ids=lambda v: " ".join(v) if isinstance(v, tuple) else v)
def test_a_name_too_long_for_the_file_system_is_one_line_naming_the_flag(words, flag, capsys):
    assert cli.main([*words, flag, "a" * 300]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"argument {flag}: got 'aaaa" in err[0]
    assert f"a name of 300 characters; expected names of at most {NAME_MAX}" in err[0] and len(err[0]) < 250


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("", "got '', expected a file or folder path"),
        ("  ", "got '  ', expected a file or folder path"),
        ("a\0b", "expected a path without a NUL character"),
        ("d/" + "x" * 256 + "/f", "a name of 256 characters"),
        ("/".join(["d" * 200] * 25), "expected a path of at most 4096 characters"),
    ],
)
def test_path_argument_refuses_what_the_os_would(text, expected):
    with pytest.raises(argparse.ArgumentTypeError, match=expected.replace("(", r"\(")):
        path_argument(text)


def test_path_argument_keeps_a_usable_path_as_typed():
    for text in ("results/uav-bench.sqlite", "rows/", ".", "/", "x" * NAME_MAX, "./a b/c"):
        assert path_argument(text) == text


def test_import_with_an_empty_store_names_the_flag(capsys, tmp_path):
    assert cli.main(["import", "--rows", str(tmp_path / "rows"), "--store", ""]) == 2
    assert "argument --store: got '', expected a file or folder path" in capsys.readouterr().err
