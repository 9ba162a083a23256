"""The policy hashes of the results stores, pinned: the MPC settings' path from the CLI keeps every key.

The hashes were computed before the MPC settings became one ``MPCSettings`` object built from the
command line; a store written then must still resume and group with one written now. A failure
here means a store key changed: intended only with a new optimiser default or lattice version,
never with a refactoring.
"""

from __future__ import annotations

import pytest

from optimizers import get_optimizer
from uav_penetration_env.benchmark import cli
from uav_penetration_env.benchmark.commands import run as run_command
from uav_penetration_env.benchmark.commands import windows as windows_command
from uav_penetration_env.benchmark.evaluate import policy_hash
from uav_penetration_env.benchmark.policies import MPCPolicy
from uav_penetration_env.mpc import MPCSettings, Terminal

GREEDY = "a8b41c8703ab00ac"
RUN_HASHES = {
    (): {
        "ihpso": "60d4db0d56da9926",
        "hpso": "6a4a5d89f267caad",
        "lpso": "03d060dac21da37a",
        "ps2o": "62e1d662cabe2a4e",
        "mcpso": "c3cea0dc93eb4ecc",
        "ccpso-ism": "0463d8c1721012fd",
        "pso": "8e4b45110c0abcc1",
        "cem": "8cca2e84dd8b9ed6",
        "greedy": GREEDY,
    },
    ("--horizon", "7", "--terminal", "dubins"): {
        "ihpso": "511861a49a87f708",
        "hpso": "a387c2c56d96073d",
        "lpso": "2a0052a70c67126e",
        "ps2o": "98bee95936a8f16a",
        "mcpso": "5184369250a41535",
        "ccpso-ism": "7e215369f68e0a36",
        "pso": "539fdfd7696d569c",
        "cem": "540926b7c04bbcf1",
        "greedy": GREEDY,
    },
    # Under the default value form, a c_T reaches only the suffixes whose form reads one.
    ("--policies", "hpso-ctg-distance", "hpso-ctg-dubins", "hpso-ctg-value", "ihpso-eq37", "--terminal-cost", "0.3"): {
        "hpso-ctg-distance": "40d550778333f718",
        "hpso-ctg-dubins": "eda628d3cf129204",
        "hpso-ctg-value": "6a4a5d89f267caad",
        "ihpso-eq37": "f0a32957f7a2ccb6",
    },
    ("--policies", "ihpso", "cem", "--discount", "0.9", "--max-evals", "300", "--terminal", "distance",
     "--terminal-cost", "0.1"): {"ihpso": "0bce6339dd9b2be1", "cem": "7deae7f30cc945e0"},
    ("--policies", "pso", "--terminal", "none", "--horizon", "3"): {"pso": "290c5781833f78ac"},
}  # fmt: skip


def run_hashes(argv: list[str]) -> dict[str, str]:
    """``uav-bench run ARGV``'s policies by table name -> their store hashes (nothing is run)."""
    args = cli.build_parser().parse_args(["run", *argv])
    args.argv = ["run", *argv]
    settings = run_command.run_settings(args)
    return {name: policy_hash(policy) for name, policy in run_command.make_policies(settings.policies, settings.mpc).items()}


@pytest.mark.parametrize("argv", list(RUN_HASHES), ids=lambda argv: " ".join(argv) or "no flags")
def test_run_flags_give_the_pinned_policy_hashes(argv):
    assert run_hashes(list(argv)) == RUN_HASHES[argv]


def test_a_config_file_gives_the_flags_hashes(tmp_path):
    # YAML values reach the settings unconverted (an int discount, a float budget, an int c_T):
    # they are converted as the flags are, so the keys match.
    config = tmp_path / "run.yaml"
    config.write_text(
        "discount: 1\nmax_evals: 300.0\nterminal: distance\nterminal_cost: 0\nhorizon: 4\npolicies: [ihpso, greedy]\n"
    )
    assert run_hashes(["--config", str(config)]) == {"ihpso": "800b9a7a47046215", "greedy": GREEDY}


def test_window_runs_keep_their_optimizer_hashes():
    args = cli.build_parser().parse_args(["windows", "--steps", "3", "--horizon", "3", "--max-evals", "400"])
    settings = windows_command.window_settings(args)
    assert policy_hash(MPCPolicy(get_optimizer("ihpso"), settings)) == "404569f4838a0f14"
    distance = MPCSettings(discount=0.95, terminal=Terminal("distance", 0.2))
    assert policy_hash(MPCPolicy(get_optimizer("hpso"), distance)) == "d7ae78c243285a94"
