"""Learned planners out of sample (docs/publishing.md §6): map hashes, the published maps, the distillation's checks."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from uav_penetration_env.catalogue import resolve_scenario, resolve_scenarios
from uav_penetration_env.suites.published import check_unpublished, published_maps, published_overlap

ROOT = Path(__file__).resolve().parents[1]


def test_the_map_hash_ignores_name_and_weights_and_sees_the_radars():
    paper, w2 = resolve_scenario("paper"), resolve_scenario("paper-w2")
    assert paper.hash != w2.hash and paper.map_hash == w2.map_hash  # the second weighting: the same map
    assert paper.updated({"name": "elsewhere"}).map_hash == paper.map_hash
    moved = paper.to_dict()["radars"]
    moved[0] = {**moved[0], "x_km": moved[0]["x_km"] + 1.0}
    assert paper.updated({"radars": moved}).map_hash != paper.map_hash


def test_every_published_member_is_a_published_map_and_fresh_seeds_are_not():
    maps = published_maps()
    assert len(set(maps.values())) == len(maps) >= 100  # one entry per distinct map (paper and w2 share one)
    assert published_overlap([resolve_scenario("paper-w2"), *resolve_scenarios("random:10003", 0.5)]) == [
        ("paper-2022-sec5-w2", "uavpen-v1/paper"),
        ("random-10003", "uavpen-heldout-v1/d0.50/10003"),
    ]
    assert published_overlap(resolve_scenarios("random:50000-50002", 0.5)) == []
    with pytest.raises(ValueError, match=r"^--scenarios: 'paper-2022-sec5' is the map of the published uavpen-v1/paper"):
        check_unpublished([resolve_scenario("paper")], "--scenarios")


def test_the_distillation_trains_and_selects_on_unpublished_maps_only():
    pytest.importorskip("torch")
    from baselines.distill.config import DistillConfig, checked

    config = checked(DistillConfig(expert="greedy"))
    training, validation = config._scenario_objects, config._validation_objects
    assert len(training) == 40 and len(validation) == 20
    assert published_overlap([*training, *validation]) == []
    assert not {s.map_hash for s in training} & {s.map_hash for s in validation}
    with pytest.raises(ValueError, match=r"^--scenarios: 'paper-2022-sec5' is the map of the published"):
        checked(DistillConfig(expert="greedy", scenarios=("paper", "random:50000-50001")))
    with pytest.raises(ValueError, match=r"^--validation: 'random-50001' is also a training map"):
        checked(DistillConfig(expert="greedy", scenarios=("random:50000-50001",), validation=("random:50001",)))
    with pytest.raises(ValueError, match=r"^--validation: got 'random:70010'.*uavpen-heldout-v2"):
        checked(DistillConfig(expert="greedy", scenarios=("random:50000",), validation=("random:70010",)))
    # Reproducing a v3 network (trained on the paper map) needs the explicit flag.
    checked(DistillConfig(expert="greedy", scenarios=("paper",), validation=(), allow_published_maps=True))


@pytest.mark.parametrize("folder", sorted((ROOT / "leaderboards" / "distill").glob("oos-*")), ids=lambda p: p.name)
def test_the_published_out_of_sample_networks_never_saw_a_published_map(folder):
    """The sidecar's own record of its training and validation maps, rebuilt and compared by map hash."""
    key = json.loads((folder / "config.json").read_text())
    training = [s for spec in key["scenarios"] for s in resolve_scenarios(spec, key["difficulty"])]
    validation = [s for spec in key["validation"] for s in resolve_scenarios(spec, key["difficulty"])]
    assert [s.hash for s in training] == key["scenario_hashes"]
    assert [s.hash for s in validation] == key["validation_hashes"]
    assert published_overlap([*training, *validation]) == []


@pytest.mark.parametrize("sidecar", sorted((ROOT / "leaderboards" / "rl" / "oos").glob("*.json")), ids=lambda p: p.stem)
def test_the_out_of_sample_agents_trained_on_an_unpublished_map_from_an_out_of_sample_network(sidecar):
    """An agent's sidecar names its training scenario (by hash) and the network it started from."""
    side = json.loads(sidecar.read_text())
    scenario = resolve_scenario(f"random:{side['scenario']['name'].removeprefix('random-')}", 0.5)
    assert scenario.hash == side["scenario"]["hash"]  # the map it trained on, rebuilt
    assert published_overlap([scenario]) == []
    assert Path(side["warm_start"]["folder"]).name.startswith("oos-")
