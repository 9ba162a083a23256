"""A YAML settings file reads as a mapping, or fails with one line naming the flag and the file."""

from __future__ import annotations

import pytest

from uav_penetration_env.benchmark.commands.common import CLIError
from uav_penetration_env.benchmark.commands.run import load_config
from uav_penetration_env.yaml_mapping import read_yaml_mapping


def test_a_mapping_is_read_and_an_empty_file_is_an_empty_mapping(tmp_path):
    (tmp_path / "a.yaml").write_text("seeds: 3\npolicies: [greedy]\n")
    (tmp_path / "empty.yaml").write_text("")
    assert read_yaml_mapping(tmp_path / "a.yaml", "--config", "flag names") == {"seeds": 3, "policies": ["greedy"]}
    assert read_yaml_mapping(tmp_path / "empty.yaml", "--config", "flag names") == {}


def test_each_bad_file_names_the_flag_and_the_file(tmp_path):
    missing, bad, listed = tmp_path / "missing.yaml", tmp_path / "bad.yaml", tmp_path / "list.yaml"
    bad.write_text("a: [1\n")
    listed.write_text("- 1\n- 2\n")
    with pytest.raises(FileNotFoundError, match=rf"^hyperparams: cannot read {missing} \("):
        read_yaml_mapping(missing, "hyperparams", "hyper-parameter names")
    with pytest.raises(ValueError, match=rf"^hyperparams: {bad} is not valid YAML \("):
        read_yaml_mapping(bad, "hyperparams", "hyper-parameter names")
    with pytest.raises(ValueError, match=rf"^hyperparams: {listed} must hold a mapping of hyper-parameter names to values$"):
        read_yaml_mapping(listed, "hyperparams", "hyper-parameter names")
    # The CLI's --config says the same, as a CLI error.
    with pytest.raises(CLIError, match=rf"^--config: {listed} must hold a mapping of flag names to values$"):
        load_config(str(listed))
    with pytest.raises(CLIError, match=rf"^--config: cannot read {missing} \("):
        load_config(str(missing))
