"""The frozen suite uavpen-v1: its file, its fingerprints and the guard that refuses a changed member."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from uav_penetration_env import cache, catalogue
from uav_penetration_env.benchmark.suite_freeze import freeze_suite
from uav_penetration_env.catalogue import HELD_OUT_SEEDS, resolve_scenario
from uav_penetration_env.suites import (
    QUANTUM_M,
    Recipe,
    SuiteError,
    SuiteMismatchError,
    array_hash,
    build_member,
    decode_actions,
    encode_actions,
    load_suite,
    suite_names,
    suite_path,
    suite_text,
    verify_suite,
)

GOLDEN_HASHES = json.loads((Path(__file__).parents[1] / "golden" / "scenario_hashes.json").read_text())
# A few members of every kind: fingerprinting them builds three scenarios (about 2 s each, cold).
SMOKE_MEMBERS = ("uavpen-v1/paper", "uavpen-v1/d0.25/30000", "uavpen-v1/d0.75/30219")


@pytest.fixture(scope="module")
def v1():
    return load_suite("uavpen-v1")


@pytest.fixture
def empty_cache(tmp_path, monkeypatch):
    """An empty build cache, so terrain and floors are computed by the code under test."""
    monkeypatch.setenv(cache.ENV_VAR, str(tmp_path / "cache"))
    cache.clear_memory()
    yield
    cache.clear_memory()


def test_v1_members_are_the_reserved_seeds_in_three_difficulties(v1):
    assert "uavpen-v1" in suite_names()
    assert len(v1.members) == 63 and v1.groups == ["fixed", "d0.25", "d0.50", "d0.75"]
    assert [m.name for m in v1.members[:3]] == ["uavpen-v1/paper", "uavpen-v1/paper-w2", "uavpen-v1/dem"]
    ranges = {"d0.25": range(30_000, 30_020), "d0.50": range(30_100, 30_120), "d0.75": range(30_200, 30_220)}
    for group, seeds in ranges.items():
        members = [m for m in v1.members if m.group == group]
        assert [m.recipe.seed for m in members] == list(seeds)
        assert {m.recipe.difficulty for m in members} == {float(group[1:])}
        assert [m.name for m in members] == [f"uavpen-v1/{group}/{s}" for s in seeds]
        assert [m.scenario for m in members] == [f"random-{s}" for s in seeds]
    procedural = {m.recipe.seed for m in v1.members if m.recipe.seed is not None}
    # Disjoint from the held-out set, the learning-curve seeds (20000+ below 30000 here), the RL
    # tuning validation seeds and the Random id's training pool (HELPERS: reserved ranges).
    assert not procedural & set(HELD_OUT_SEEDS)
    assert not procedural & set(range(40_000, 40_050))
    assert max(procedural) < 2**32
    assert len({m.fingerprint.scenario_hash for m in v1.members}) == 63


def test_fixed_members_keep_their_pinned_hashes(v1):
    """The suite re-identifies nothing: its paper members are the paper scenario, hash for hash."""
    assert v1.member("uavpen-v1/paper").fingerprint.scenario_hash == GOLDEN_HASHES["paper-w1"]
    assert v1.member("uavpen-v1/paper-w2").fingerprint.scenario_hash == GOLDEN_HASHES["paper-w2"]
    assert v1.member("uavpen-v1/dem").fingerprint.scenario_hash == resolve_scenario("dem").hash


def test_procedural_member_is_the_catalogue_scenario(v1):
    member = v1.member("uavpen-v1/d0.50/30107")
    scenario = member.recipe.build()
    assert scenario == resolve_scenario("random:30107", difficulty=0.5)
    assert scenario.hash == member.fingerprint.scenario_hash


@pytest.mark.parametrize("name", SMOKE_MEMBERS)
def test_smoke_members_reproduce_their_fingerprints(v1, name):
    scenario = build_member(v1, name)  # raises on any difference
    assert scenario.hash == v1.member(name).fingerprint.scenario_hash


@pytest.mark.slow
def test_every_member_reproduces(v1):
    failures = [str(check.error) for check in verify_suite(v1) if check.error is not None]
    assert failures == []


def test_a_changed_generator_constant_is_refused_naming_member_and_hashes(v1, monkeypatch):
    member = v1.member("uavpen-v1/d0.25/30003")
    monkeypatch.setattr(catalogue, "RANDOM_SQUARE_KM", (0.0, 99.0))
    changed = member.recipe.build().hash
    with pytest.raises(SuiteMismatchError) as caught:
        build_member(v1, member.name)
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"suite uavpen-v1 member uavpen-v1/d0.25/30003: scenario hash '{changed}'")
    assert f"!= frozen '{member.fingerprint.scenario_hash}'" in message
    assert "freeze a new suite version" in message
    assert (caught.value.field, caught.value.frozen) == ("scenario_hash", member.fingerprint.scenario_hash)


def test_a_changed_terrain_synthesis_is_refused(v1, monkeypatch, empty_cache):
    """Same scenario, same hash, other heights: only the built-terrain fingerprint can see it."""
    from uav_penetration_env import build

    original = build.mountain_heights  # mountains 0.01 % higher: at most 9 cm on a 900 m peak
    monkeypatch.setattr(build, "mountain_heights", lambda *a, **k: 1.0001 * original(*a, **k))
    with pytest.raises(
        SuiteMismatchError, match=r"member uavpen-v1/d0.25/30000: terrain hash '[0-9a-f]{16}' != frozen"
    ):
        build_member(v1, "uavpen-v1/d0.25/30000")


def test_the_replayed_total_j_is_compared_to_a_relative_tolerance(v1, monkeypatch):
    from uav_penetration_env.env import UAVPenetrationEnv

    member = v1.member("uavpen-v1/paper")
    step = UAVPenetrationEnv.step
    for factor, refused in ((1.0 + 1e-12, False), (1.0 + 1e-7, True)):

        def scaled(self, action, factor=factor):
            observation, reward, terminated, truncated, info = step(self, action)
            return observation, reward, terminated, truncated, {**info, "J": info["J"] * factor}

        monkeypatch.setattr(UAVPenetrationEnv, "step", scaled)
        if refused:
            with pytest.raises(SuiteMismatchError, match=r"replayed total J .* != \(rtol 1e-09\) frozen"):
                build_member(v1, member)
        else:
            build_member(v1, member)


def test_the_check_replays_the_stored_controls_not_the_greedy_floor(v1, monkeypatch):
    """Changing the harness's greedy floor changes no frozen member's check (issue 41)."""
    from uav_penetration_env.benchmark import policies

    def refuse(*args, **kwargs):
        raise AssertionError("the fingerprint check flew the greedy floor")

    monkeypatch.setattr(policies, "greedy_action", refuse)
    monkeypatch.setattr(policies.GreedyPolicy, "act", refuse)
    scenario = build_member(v1, "uavpen-v1/d0.25/30000")  # raises on any difference
    assert scenario.name == "random-30000"


def _with_controls(member, actions):
    return dataclasses.replace(member, fingerprint=dataclasses.replace(member.fingerprint, replay_actions=actions))


def test_changed_replay_controls_are_refused(v1):
    member = v1.member("uavpen-v1/paper")
    actions = member.fingerprint.replay_actions
    steps = len(actions)
    nudged = list(actions)
    dv, dphi, dtheta = nudged[steps // 2]
    nudged[steps // 2] = (dv, dphi, dtheta + 1e-4)  # a pitch change of 0.006 degrees, once
    with pytest.raises(SuiteMismatchError, match=r"replayed total J .* != \(rtol 1e-09\) frozen") as caught:
        build_member(v1, _with_controls(member, tuple(nudged)))
    assert caught.value.field == "replay_total_j"
    # Too few controls: the episode has not ended when they run out; too many: it ends before.
    with pytest.raises(
        SuiteMismatchError, match=rf"replay episode length 'more than {steps - 1}' != frozen {steps - 1} "
    ):
        build_member(v1, _with_controls(member, actions[:-1]))
    with pytest.raises(SuiteMismatchError, match=rf"replay episode length {steps} != frozen {steps + 1} "):
        build_member(v1, _with_controls(member, (*actions, actions[-1])))


def test_replay_controls_are_stored_exactly_and_compactly():
    rng = np.random.default_rng(0)
    actions = tuple(tuple(float(v) for v in row) for row in rng.normal(size=(150, 3)) / 7.0)
    text = encode_actions(actions)
    assert decode_actions(text, 150, "m") == actions  # bit for bit: float64 survives
    assert max(len(line) for line in text.splitlines()) <= 96
    for name in suite_names():
        suite = load_suite(name)
        # Each file is exactly what the writer makes of its content: nothing hand-edited.
        assert suite_text(suite) == suite_path(name).read_text()
        # The pitch column's 8 bytes per step dominate: about 11 base64 characters per step.
        for member in suite.members:
            encoded = encode_actions(member.fingerprint.replay_actions)
            assert len(encoded) <= 40 + 12 * len(member.fingerprint.replay_actions), member.name


def test_array_hash_rounds_last_digits_away_but_sees_a_centimetre():
    rng = np.random.default_rng(0)
    # Values a third of a quantum from the nearest rounding boundary, as almost all values are.
    heights = (np.round(rng.uniform(0, 900, (40, 30)) / QUANTUM_M) + 0.2) * QUANTUM_M
    reference = array_hash(heights)
    assert array_hash(heights * (1 + 4e-16)) == reference  # a last-digit difference
    assert array_hash(heights + 1e-9) == reference
    moved = heights.copy()
    moved[7, 3] += QUANTUM_M
    assert array_hash(moved) != reference
    assert array_hash(heights.reshape(30, 40)) != reference  # the shape is hashed too
    assert array_hash(np.array([0.0])) == array_hash(np.array([-0.0]))
    with pytest.raises(ValueError, match="non-finite"):
        array_hash(np.array([1.0, np.nan]))


def test_unknown_names_get_a_did_you_mean(v1):
    with pytest.raises(
        SuiteError,
        match=r"unknown suite 'uavpen-v2' — did you mean 'uavpen-v1', 'uavpen-heldout-v2', 'uavpen-heldout-v1'\? "
        r"known suites: uavpen-dynamic-heldout-v1, uavpen-dynamic-v1, uavpen-heldout-v1, uavpen-heldout-v2, uavpen-v1$",
    ):
        load_suite("uavpen-v2")
    with pytest.raises(SuiteError, match=r"unknown member 'uavpen-v1/papr' — did you mean 'uavpen-v1/paper'"):
        v1.member("uavpen-v1/papr")
    with pytest.raises(SuiteError, match=r"no member matches 'uavpen-v1/d0.3/\*'"):
        v1.select(["uavpen-v1/d0.3/*"])
    assert [m.name for m in v1.select(["uavpen-v1/d0.75/3021?"])] == [
        f"uavpen-v1/d0.75/{s}" for s in range(30210, 30220)
    ]


def test_a_malformed_suite_file_names_the_field(v1, tmp_path):
    data = v1.to_dict()
    data["members"][4]["terain_hash"] = data["members"][4].pop("terrain_hash")
    path = tmp_path / "broken-v1.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    with pytest.raises(
        SuiteError, match=r"members\[4\]: unknown key 'terain_hash' — did you mean 'terrain_hash'"
    ):
        load_suite(path)
    data = v1.to_dict()
    data["members"][1]["build"] = {"catalogue": "papr"}
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    with pytest.raises(SuiteError, match=r"members\[1\].build.catalogue: got 'papr' — did you mean 'paper'"):
        load_suite(path)
    for key, value, message in (
        ("replay_actions", "not base64!", r"members\[2\].replay_actions: got undecodable text, expected 22 steps"),
        ("replay_steps", 46, r"members\[2\].replay_actions: got 66 numbers, expected 138 \(46 steps"),
        ("replay_steps", 0, r"members\[2\].replay_steps: got 0, expected an integer >= 1"),
    ):
        data = v1.to_dict()
        data["members"][2][key] = value
        path.write_text(yaml.safe_dump(data, sort_keys=False))
        with pytest.raises(SuiteError, match=message):
            load_suite(path)
    data = v1.to_dict()
    data["fingerprint"]["scheme"] = 1
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    with pytest.raises(SuiteError, match=r"fingerprint.scheme: got 1, expected 2"):
        load_suite(path)


def test_freeze_writes_a_new_version_and_never_overwrites(tmp_path, v1):
    with pytest.raises(SuiteError, match="suite uavpen-v1 already exists"):
        freeze_suite("uavpen-v1", "again", [Recipe(catalogue="paper")], tmp_path)
    path = freeze_suite(
        "tiny-v1", "one member", [Recipe(catalogue="paper"), Recipe(difficulty=0.25, seed=30000)], tmp_path
    )
    frozen = load_suite(path)
    assert [m.name for m in frozen.members] == ["tiny-v1/paper", "tiny-v1/d0.25/30000"]
    # The same recipe under another suite name: the same scenarios, the same fingerprints.
    assert [m.fingerprint for m in frozen.members] == [
        v1.member("uavpen-v1/paper").fingerprint,
        v1.member("uavpen-v1/d0.25/30000").fingerprint,
    ]
    before = path.read_bytes()
    with pytest.raises(SuiteError, match="already exists; a frozen suite is never overwritten"):
        freeze_suite("tiny-v1", "other", [Recipe(catalogue="dem")], tmp_path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["tiny-v1.yaml"]  # no temporary file left behind
    with pytest.raises(SuiteError, match="expected a versioned name"):
        freeze_suite("tiny", "unversioned", [Recipe(catalogue="paper")], tmp_path)


def test_the_suite_command(tmp_path, capsys):
    from uav_penetration_env.benchmark import cli

    assert cli.main(["suite", "list"]) == 0
    listed = {line.split(":")[0]: line for line in capsys.readouterr().out.splitlines()}
    assert listed["uavpen-heldout-v1"].startswith("uavpen-heldout-v1: 50 members (d0.50 50)")
    assert listed["uavpen-heldout-v2"].startswith("uavpen-heldout-v2: 50 members (d0.50 50)")
    assert listed["uavpen-v1"].startswith("uavpen-v1: 63 members (fixed 3, d0.25 20, d0.50 20, d0.75 20)")
    assert listed["uavpen-dynamic-v1"].startswith(
        "uavpen-dynamic-v1: 24 members (d0.50-u0.25-l0.00-m0-e2 8, d0.50-u0.50-l0.50-m1-e3 8, d0.50-u0.75-l0.75-m2-e5 8)"
    )
    assert cli.main(["suite", "show", "uavpen-v1", "--members", "uavpen-v1/paper*"]) == 0
    out = capsys.readouterr().out
    assert "| uavpen-v1/paper-w2 | fixed | paper-2022-sec5-w2 | d2cada97cea659ca |" in out
    assert "uavpen-v1/dem" not in out
    assert cli.main(["suite", "verify", "uavpen-v1", "--members", "uavpen-v1/paper"]) == 0
    assert "suite uavpen-v1: all 1 members reproduce" in capsys.readouterr().out
    recipe = tmp_path / "recipe.yaml"
    recipe.write_text(
        "suite: mini-v1\ndescription: one member\nmembers:\n  - {difficulty: 0.25, seeds: 30000-30000}\n"
    )
    out_dir = tmp_path / "suites"
    assert cli.main(["suite", "freeze", "mini-v1", "--recipe", str(recipe), "--out", str(out_dir)]) == 0
    assert [m.name for m in load_suite(out_dir / "mini-v1.yaml").members] == ["mini-v1/d0.25/30000"]
    capsys.readouterr()
    assert cli.main(["suite", "freeze", "mini-v1", "--recipe", str(recipe), "--out", str(out_dir)]) == 2
    assert "already exists; a frozen suite is never overwritten" in capsys.readouterr().err
    assert cli.main(["suite", "freeze", "mini-v2", "--recipe", str(recipe), "--out", str(out_dir)]) == 2
    assert "names the suite 'mini-v1', expected 'mini-v2'" in capsys.readouterr().err


def test_verify_reports_every_changed_member_and_fails(monkeypatch, capsys):
    from uav_penetration_env.benchmark import cli

    monkeypatch.setattr(catalogue, "RANDOM_SQUARE_KM", (0.0, 99.0))
    status = cli.main(
        ["suite", "verify", "uavpen-v1", "--members", "uavpen-v1/paper", "uavpen-v1/d0.25/3000[12]"]
    )
    captured = capsys.readouterr()
    assert status == 1
    assert "suite uavpen-v1: 2 of 3 members DIFFER" in captured.out
    assert captured.err.count("MISMATCH suite uavpen-v1 member uavpen-v1/d0.25/3000") == 2


@pytest.mark.slow
def test_the_whole_suite_runs_with_greedy(tmp_path):
    """The issue's check: ``uav-bench run --suite uavpen-v1 --policies greedy --seeds 1``."""
    import sqlite3

    from uav_penetration_env.benchmark import cli

    store = tmp_path / "suite.sqlite"
    argv = ["run", "--suite", "uavpen-v1", "--policies", "greedy", "--seeds", "1", "--store", str(store)]
    assert cli.main([*argv, "--out", str(tmp_path / "out"), "--no-progress"]) == 0
    suite = load_suite("uavpen-v1")
    with sqlite3.connect(store) as connection:
        totals = dict(connection.execute("SELECT scenario_hash, total_cost FROM episodes").fetchall())
    assert len(totals) == 63
    for member in suite.members:  # each greedy episode is its member's frozen replay
        assert totals[member.fingerprint.scenario_hash] == pytest.approx(
            member.fingerprint.replay_total_j, rel=1e-9
        )
    assert (tmp_path / "out" / "uavpen-v1.md").is_file() and (
        tmp_path / "out" / "uavpen-v1-d0.75.csv"
    ).is_file()


def test_the_held_out_suite_is_the_held_out_set_unchanged(v1):
    held_out = load_suite("uavpen-heldout-v1")
    assert [m.name for m in held_out.members] == [f"uavpen-heldout-v1/d0.50/{s}" for s in HELD_OUT_SEEDS]
    for member, seed in zip(held_out.members, HELD_OUT_SEEDS, strict=True):
        # the same scenario `random:10000-10049` has named since version 0.1 (and its stored episodes)
        assert member.fingerprint.scenario_hash == resolve_scenario(f"random:{seed}", difficulty=0.5).hash
    assert not {m.fingerprint.scenario_hash for m in held_out.members} & {m.fingerprint.scenario_hash for m in v1.members}
    scenario = build_member(held_out, "uavpen-heldout-v1/d0.50/10049")  # fingerprints reproduce (raises otherwise)
    assert scenario.name == "random-10049"


def test_the_fresh_held_out_suite_is_apart_from_every_other_published_map(v1):
    """uavpen-heldout-v2 (docs/suite.md §8): seeds 70000-70049, no map shared with another suite."""
    from uav_penetration_env.suites.published import published_maps

    fresh = load_suite("uavpen-heldout-v2")
    assert [m.name for m in fresh.members] == [f"uavpen-heldout-v2/d0.50/{s}" for s in range(70000, 70050)]
    scenarios = [resolve_scenario(f"random:{s}", difficulty=0.5) for s in range(70000, 70050)]
    assert [m.fingerprint.scenario_hash for m in fresh.members] == [s.hash for s in scenarios]
    others = {h for h, member in published_maps().items() if not member.startswith("uavpen-heldout-v2/")}
    assert not {s.map_hash for s in scenarios} & others
    assert build_member(fresh, "uavpen-heldout-v2/d0.50/70049").name == "random-70049"  # reproduces (raises otherwise)


@pytest.mark.slow
def test_every_fresh_held_out_member_reproduces():
    failures = [str(c.error) for c in verify_suite(load_suite("uavpen-heldout-v2")) if c.error is not None]
    assert failures == []


@pytest.mark.slow
def test_every_held_out_member_reproduces():
    failures = [str(c.error) for c in verify_suite(load_suite("uavpen-heldout-v1")) if c.error is not None]
    assert failures == []


DYNAMIC_SUITES = {
    "uavpen-dynamic-v1": range(80000, 80024),
    "uavpen-dynamic-heldout-v1": range(81000, 81030),
}


@pytest.mark.parametrize("name", list(DYNAMIC_SUITES))
def test_the_dynamic_suites_are_their_recipes_apart_from_every_other_map(name):
    """docs/dynamic.md §5: dynamic members, their declared seeds, no map shared with another suite; one replays."""
    from uav_penetration_env.suites.published import published_maps

    suite = load_suite(name)
    assert [m.recipe.seed for m in suite.members] == list(DYNAMIC_SUITES[name])
    assert all(m.recipe.dynamic is not None for m in suite.members)
    others = {h for h, member in published_maps().items() if not member.startswith(f"{name}/")}
    first = suite.members[0]
    scenario = build_member(suite, first.name)  # replays the greedy floor in the dynamic env (raises otherwise)
    assert scenario.is_dynamic and scenario.hash == first.fingerprint.scenario_hash
    assert scenario.map_hash not in others


@pytest.mark.slow
@pytest.mark.parametrize("name", list(DYNAMIC_SUITES))
def test_every_dynamic_member_reproduces(name):
    failures = [str(c.error) for c in verify_suite(load_suite(name)) if c.error is not None]
    assert failures == []
