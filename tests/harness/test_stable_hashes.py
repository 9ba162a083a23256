"""A plug-in's policy hash is the same in every process, or the plug-in is refused saying how to fix it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from uav_penetration_env.benchmark.evaluate import policy_hash
from uav_penetration_env.benchmark.plugins import stable_parameters
from uav_penetration_env.benchmark.policies import GreedyPolicy, MPCPolicy


class PlainOptimizer:
    """Not a dataclass, no repr: its attributes describe it."""

    def __init__(self, popsize: int = 40) -> None:
        self.popsize = popsize

    def minimize(self, fun, bounds, *, rng=None, max_evals=100):  # pragma: no cover - never flown here
        raise NotImplementedError


class Opaque(PlainOptimizer):
    def __init__(self) -> None:
        super().__init__()
        self.helper = object()  # not plain data


def test_an_object_with_a_default_repr_is_described_by_its_attributes():
    described = stable_parameters(PlainOptimizer(7), "optimizer")
    assert described == {"class": f"{__name__}.PlainOptimizer", "attributes": {"popsize": 7}}
    assert stable_parameters(GreedyPolicy(), "policy")["clearance_m"] == 100.0  # a dataclass: its fields


def test_an_object_without_a_stable_description_is_refused_saying_how_to_fix_it():
    with pytest.raises(ValueError, match=r"optimizer: Opaque has no stable configuration .* make it a dataclass"):
        stable_parameters(Opaque(), "optimizer")
    with pytest.raises(ValueError, match="has no stable configuration"):
        MPCPolicy(Opaque()).config()


def test_the_hash_of_a_plain_plugin_is_the_same_in_another_process():
    here = policy_hash(MPCPolicy(PlainOptimizer(7)))
    code = (
        "import sys; sys.path.insert(0, 'tests/harness')\n"
        "from test_stable_hashes import PlainOptimizer\n"
        "from uav_penetration_env.benchmark.evaluate import policy_hash\n"
        "from uav_penetration_env.benchmark.policies import MPCPolicy\n"
        "print(policy_hash(MPCPolicy(PlainOptimizer(7))))\n"
    )
    root = Path(__file__).resolve().parents[2]
    there = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=root)
    assert there.stdout.strip() == here
