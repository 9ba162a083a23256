"""Smoke tests: the env and harness benchmark scripts run end to end with their quick settings."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pandas as pd
import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def load(name: str):
    spec = importlib.util.spec_from_file_location(name, BENCHMARKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
    finally:
        sys.modules.pop(spec.name, None)
    return module


def test_bench_env_quick_run_reports_every_figure(capsys):
    results = load("bench_env").main(["--quick"])
    out = capsys.readouterr().out
    for header in ("build times", "single env", "native vector env", "rollout_cost"):
        assert header in out
    assert results["single_env_steps_per_s"] > 0 and results["rollout_vs_env"] > 1
    assert {"vector_1", "vector_16", "vector_256", "vector_1024"} <= set(results)


def test_bench_contention_measures_each_figure_idle_and_loaded(capsys):
    results = load("bench_contention").main(["--seconds", "0.05", "--load", "1"])
    assert list(results) == ["idle, OMP_WAIT_POLICY=PASSIVE", "with 1 busy processes, OMP_WAIT_POLICY=PASSIVE"]
    for ratios in results.values():
        assert {"rollout 100 x 5", "rollout 10000 x 5", "vector env 256", "single env"} <= set(ratios)
        assert all(ratio > 0 for ratio in ratios.values())
    assert "x" in capsys.readouterr().out


def test_bench_vector_breakdown_prints_each_component_and_the_ratio(capsys):
    rows = load("bench_vector_breakdown").main(["--envs", "16", "--repeats", "1", "--steps", "5"])
    out = capsys.readouterr().out
    for part in ("kinematics", "radars (", "terrain patch", "fused step + observe", "reset draws", "ratio x"):
        assert part in out
    assert all(value > 0 for value in rows.values())
    # The whole step costs more than the compiled pass it makes.
    assert rows["vector env step, whole"] > rows["fused step + observe kernel (the vector env's)"]


@pytest.mark.slow
def test_bench_vector_breakdown_compares_two_trees_idle_and_loaded(capsys):
    root = str(BENCHMARKS.parent)
    quick = ["--rounds", "1", "--envs", "16", "--repeats", "1", "--steps", "5", "--load", "1"]
    results = load("bench_vector_breakdown").main(["--compare", root, *quick])
    assert {"idle, speed-up", "with 1 busy processes, speed-up"} <= set(results)
    assert all(value > 0 for value in results.values())
    assert "faster after" in capsys.readouterr().out


@pytest.mark.slow
def test_bench_harness_full_settings_run():
    results = load("bench_harness").main(["--steps", "3", "--max-evals", "2000", "--sweep-max-evals", "1000"])
    assert 0.0 < results["pso_share"] <= 1.0


def test_bench_harness_quick_run(capsys):
    results = load("bench_harness").main(["--quick"])
    out = capsys.readouterr().out
    assert "planning per MPC step" in out and "8-episode sweep" in out
    assert all(0.0 < results[f"{name}_share"] <= 1.0 for name in ("ihpso", "pso", "cem", "cmaes"))
    assert results["speedup"] > 0


def test_bench_checks_quick_run_reports_every_entry_point(capsys):
    results = load("bench_checks").main(["--quick"])
    out = capsys.readouterr().out
    for name in ("step, 1 row", "observe, 1 row", "rollout_cost", "height"):
        assert name in out
    assert len(results) == 5 and all(value > 0 for value in results.values())


def test_bench_rl_quick_run_reports_every_case(capsys):
    from conftest import RL_EXTRA

    pytest.importorskip("stable_baselines3", reason=RL_EXTRA)
    bench = load("bench_rl")
    results = bench.main(["--quick"])
    out = capsys.readouterr().out
    assert set(results) == set(bench.CASES) and all(value > 0 for value in results.values())
    assert out.count("steps per CPU-s") == len(bench.CASES)


def test_reproduce_published_counts_exact_rounding_and_differing_episodes():
    import pandas as pd

    module = load("reproduce_published")
    published = pd.DataFrame(
        {
            "policy": ["pso", "pso", "pso", "cem"],
            "scenario": ["paper", "paper", "paper", "paper"],
            "seed": [0, 1, 2, 0],
            "outcome": ["success", "success", "success", "collision"],
            "total_J": [14.5, 16.0, 15.0, 20.0],
            "steps": [50, 55, 52, 30],
        }
    )
    rerun = pd.DataFrame(
        {
            "policy": ["pso", "pso", "pso", "cem", "cem"],
            "scenario": ["paper"] * 5,
            "seed": [0, 1, 2, 0, 7],  # cem seed 7 has no published row
            "outcome": ["success", "success", "success", "success", "success"],
            "total_J": [14.5, 16.0 * (1 + 4e-16), 15.3, 19.0, 18.0],
            "steps": [50, 55, 53, 40, 41],
            "error": ["", "", "", "", ""],
        }
    )
    compared = module.compare(rerun, published)
    assert compared["exact"].tolist() == [False, False, True, False, False]  # sorted: cem 0, cem 7, pso 0-2
    assert compared["published_found"].tolist() == [True, False, True, True, True]
    table = module.summary(compared, published).set_index("policy")
    assert table.loc["pso", ["rerun", "exact", "within_1e-12", "same_outcome", "differing"]].tolist() == [
        3,
        1,
        2,
        3,
        2,
    ]
    assert table.loc["pso", "max_|dJ|/J"] == pytest.approx(0.02)  # (15.3 - 15) / 15
    assert table.loc["cem", ["exact", "same_outcome", "differing"]].tolist() == [0, 0, 1]
    assert table.loc["cem", "mean_dJ/J"] == pytest.approx(-0.05)


def test_reproduce_published_reads_a_row_export_or_a_csv(tmp_path):
    import pandas as pd

    from uav_penetration_env.benchmark.rows import row_path, write_table

    module = load("reproduce_published")
    episodes = pd.DataFrame({"policy": ["pso"], "scenario": ["paper"], "scenario_hash": ["ab"], "seed": [0], "outcome": ["success"],
                             "total_J": [14.5], "steps": [50]})  # fmt: skip
    stem = tmp_path / "rows" / "leaderboard"
    stem.parent.mkdir()
    write_table(episodes, row_path(stem, "episodes", "csv"), "csv")
    write_table(pd.DataFrame({"policy": ["pso"]}), row_path(stem, "runs", "csv"), "csv")
    assert module.read_published(stem)[["policy", "total_J", "steps"]].values.tolist() == [["pso", 14.5, 50]]
    episodes.to_csv(tmp_path / "v1.csv", index=False)
    assert module.read_published(tmp_path / "v1.csv")["total_J"].tolist() == [14.5]
    with pytest.raises(SystemExit, match=r"^--published .*missing: --rows .*no episodes table"):
        module.read_published(tmp_path / "missing")
    with pytest.raises(SystemExit, match=r"^--published .*gone.csv: no such file; expected an episode CSV"):
        module.read_published(tmp_path / "gone.csv")


def test_reproduce_published_compares_with_the_current_publication_and_reads_a_checkpoint(tmp_path):
    """The default is leaderboard v3's checkpoint folder (leaderboards/README.md); a checkpoint folder
    stands for its chunks (it was refused: the script read one export stem only)."""
    import json

    import pandas as pd

    from uav_penetration_env.benchmark.rows import row_path, write_table

    module = load("reproduce_published")
    assert module.PUBLISHED == module.ROOT / "leaderboards" / "v3-checkpoint"
    folder = tmp_path / "checkpoint"
    folder.mkdir()
    for chunk, (episode_id, seed, total) in {"chunk-001": (1, 0, 14.5), "chunk-002": (2, 1, 15.5)}.items():
        episodes = pd.DataFrame({"episode_id": [episode_id], "run_id": [episode_id], "policy": ["pso"], "scenario": ["paper"],
                                 "scenario_hash": ["ab"], "seed": [seed], "outcome": ["success"], "total_J": [total],
                                 "steps": [50]})  # fmt: skip
        write_table(episodes, row_path(folder / chunk, "episodes", "parquet"), "parquet")
        write_table(pd.DataFrame({"run_id": [episode_id]}), row_path(folder / chunk, "runs", "parquet"), "parquet")
    (folder / "manifest.json").write_text(json.dumps({"seeds": [], "chunks": [{"name": "chunk-001"}, {"name": "chunk-002"}]}))
    published = module.read_published(folder)
    assert published.sort_values("seed")[["seed", "total_J"]].values.tolist() == [[0, 14.5], [1, 15.5]]


def test_mechanism_share_row_reads_the_traces():
    module = load("ihpso_mechanism_shares")

    def trace(reverse, stopped_by, switch, tests):
        return {
            "reverse_switch_iterations": reverse,
            "stopped_by": stopped_by,
            "switch_iterations": switch,
            "termination_tests": [(0, False)] * tests,
        }

    traces = [
        trace([10, 30], "termination", [3], 3),  # reverse at 10 / 49, stopped at 40 / 49
        trace([], "termination", [3], 1),  # stopped at 20 / 49
        trace([], "max_evals", [5], 0),
        trace([], "max_evals", [], 0),
    ]
    row = module.share_row(5_000, traces, nits=[40, 20, 49, 49], nfevs=[4_100, 2_100, 5_000, 5_000])
    assert row["T"] == "49" and row["runs"] == "4"
    assert row["reverse switch"] == "1/4 (25%)" and row["first reverse / T"] == "0.20 [0.20, 0.20]"
    assert row["termination"] == "2/4 (50%)"
    assert (
        row["stop / T"] == f"{30 / 49:.2f} [{25 / 49:.2f}, {35 / 49:.2f}]"
    )  # median of 20 and 40, quartiles
    assert row["eq. 33 tests/run"] == "1.00" and row["evals used"] == "81%"
    assert module.quartiles([]) == "-"


def test_bench_suite_quick_run_reports_every_figure(capsys):
    results = load("bench_suite").main(["--quick"])
    out = capsys.readouterr().out
    assert "suite uavpen-v1, 3 members" in out and "run --suite --policies greedy --seeds 1" in out
    assert set(results) == {"verify_warm_s", "verify_cold_s", "run_greedy_s"}
    assert all(value > 0 for value in results.values())


def test_rl_corridor_reads_altitudes_from_the_stored_steps(tmp_path):
    from conftest import tiny_scenario

    from uav_penetration_env.benchmark.evaluate import evaluate
    from uav_penetration_env.benchmark.policies import make_policy
    from uav_penetration_env.benchmark.store import ResultsStore

    store = tmp_path / "run.sqlite"
    evaluate({"greedy": make_policy("greedy")}, [tiny_scenario(time={"max_steps": 6})], range(1), store=store,
             progress=False)  # fmt: skip
    table = load("rl_corridor").corridor_table(store, scenario="tiny", seed=0)
    with ResultsStore(store, create=False) as opened:
        steps = opened.steps(opened.episodes()["episode_id"].astype(int).tolist())
    row = table.iloc[0]
    assert row["policy"] == "greedy" and row["steps"] == len(steps)
    assert row["AGL median [m]"] == pytest.approx(float(steps["altitude_agl"].median()))
    assert row["detected steps"] == f"{int(steps['detected'].sum())}/{len(steps)}"
    with pytest.raises(
        ValueError, match="--scenario paper --seed 0: no finished episode; stored scenarios: tiny"
    ):
        load("rl_corridor").corridor_table(store, scenario="paper", seed=0)


def test_goal_misses_measures_the_closest_approach_and_the_end_at_the_edge(tmp_path, capsys):
    import yaml
    from conftest import tiny_scenario

    from uav_penetration_env.benchmark.store import ResultsStore

    module = load("goal_misses")
    tiny = tiny_scenario()  # map -25..50 km square, goal at (25, 25)
    store = tmp_path / "m.sqlite"
    tracks = {  # (policy, seed): (outcome, [(x, y, distance to goal)])
        ("hpso", 0): ("success", [(10.0, 10.0, 21.2), (24.0, 24.0, 1.4)]),
        ("hpso", 1): ("collided", [(20.0, 28.0, 5.8), (40.0, 40.0, 21.2), (48.0, 30.0, 23.5)]),  # ends 2 km from x=50
        ("greedy", 0): ("success", [(25.0, 25.0, 0.0)]),  # a floor: not an MPC planner, left out
    }
    with ResultsStore(store) as s:
        s.register({}, {tiny.hash: ("tiny", yaml.safe_dump(tiny.to_dict(), sort_keys=False))})
        for (policy, seed), (outcome, points) in tracks.items():
            steps = [{"step": k, "x_km": x, "y_km": y, "distance_to_goal": d, "J": 0.1, "penalty": 0.0}
                     for k, (x, y, d) in enumerate(points, start=1)]  # fmt: skip
            s.write_episode({"policy": policy, "policy_hash": f"{policy:0<16}", "scenario": "tiny",
                             "scenario_hash": tiny.hash, "seed": seed, "outcome": outcome, "total_J": 1.0,
                             "total_penalty": 0.0, "total_cost": 1.0, "steps": len(points), "error": ""}, steps)  # fmt: skip
    table = module.summary(module.approaches(store)).set_index("policy")
    assert list(table.index) == ["hpso"]
    row = table.loc["hpso"]
    assert (row["episodes"], row["failed"], row["collided"]) == (2, 1, 1)
    assert row["closest_km_failed"] == 5.8 and row["closest_km_success"] == 1.4
    assert row["failed_at_edge"] == 1
    assert module.main([str(store)]) == 0
    assert "1 failed of 2 MPC episodes; 1 failures ended within 5 km of the map edge" in capsys.readouterr().out
    assert module.scenario_group("random-30006") == "uavpen-v1 d0.25"
    assert module.scenario_group("random-10049") == "uavpen-heldout-v1"


def _terminal_store(path, rows, scenario):
    """A store of hand-made episodes: rows of (policy, seed, outcome, total_cost, closest distance [km])."""
    import yaml

    from uav_penetration_env.benchmark.store import ResultsStore

    with ResultsStore(path) as s:
        s.register({}, {scenario.hash: (scenario.name, yaml.safe_dump(scenario.to_dict(), sort_keys=False))})
        for policy, seed, outcome, cost, closest in rows:
            steps = [{"step": 1, "x_km": 0.0, "y_km": 0.0, "distance_to_goal": closest, "J": cost, "penalty": 0.0}]
            s.write_episode({"policy": policy, "policy_hash": f"{policy:0<16}"[:16], "scenario": scenario.name,
                             "scenario_hash": scenario.hash, "seed": seed, "outcome": outcome, "total_J": cost,
                             "total_penalty": 0.0, "total_cost": cost, "steps": 1, "error": ""}, steps)  # fmt: skip


def test_terminal_cost_sensitivity_pairs_ihpso_with_hpso_per_form(tmp_path, capsys):
    from conftest import tiny_scenario

    module = load("terminal_cost_sensitivity")
    rows = [(f"{p}-ctg-{f}", seed, "success", base + seed, 1.0)
            for f, offset in (("value", 0.0), ("distance", 5.0))
            for p, base in (("ihpso", 10.0 + offset), ("hpso", 11.0 + offset)) for seed in range(4)]  # fmt: skip
    _terminal_store(tmp_path / "s.sqlite", rows, tiny_scenario())
    assert module.main(["--store", str(tmp_path / "s.sqlite"), "--summary-only"]) == 0
    out = capsys.readouterr().out
    # IHPSO is exactly 1.0 cheaper on every seed under both forms.
    assert "value    n= 4: mean -1.000 [-1.000, -1.000]" in out and "IHPSO cheaper on 4" in out
    assert "distance n= 4: mean -1.000" in out
    assert module.iqm([1.0, 2.0, 3.0, 100.0]) == 2.5


def test_terminal_cost_selection_counts_failures_and_pairs_forms(tmp_path, capsys):
    from conftest import tiny_scenario

    module = load("terminal_cost_selection")
    rows = [("hpso-ctg-value", 0, "success", 10.0, 2.0), ("hpso-ctg-distance", 0, "collided", 90.0, 7.5),
            ("hpso-ctg-dubins", 0, "success", 11.0, 2.5), ("greedy", 0, "success", 15.0, 1.0)]  # fmt: skip
    _terminal_store(tmp_path / "select-d0.5.sqlite", rows, tiny_scenario())
    table = module.episodes(tmp_path)
    assert dict(zip(table.policy, table.form, strict=True))["hpso-ctg-value"] == "value"
    assert set(table.planner) == {"hpso", "greedy"}
    module.summary(table)
    out = capsys.readouterr().out
    assert "failures (1):" in out and "value - distance: mean -80.000" in out


def test_terminal_cost_table_pairs_per_scenario_and_checks_each_conclusion_per_form(tmp_path):
    module = load("terminal_cost_table")
    # Two scenarios x three seeds. Under `value` (the bare names) IHPSO is exactly 1.0 cheaper than
    # HPSO in every pair; under `distance` exactly 1.0 dearer, and one HPSO episode fails.
    rows = []
    for scenario, base in (("a", 10.0), ("b", 20.0)):
        for seed in range(3):
            rows += [("ihpso", scenario, seed, "success", base + seed), ("hpso", scenario, seed, "success", base + seed + 1),
                     ("ihpso-ctg-distance", scenario, seed, "success", base + seed + 2),
                     ("hpso-ctg-distance", scenario, seed, "collided" if (scenario, seed) == ("a", 0) else "success",
                      base + seed + 1), ("greedy", scenario, seed, "success", 99.0)]  # fmt: skip
    path = tmp_path / "episodes.csv"
    pd.DataFrame(rows, columns=["policy", "scenario", "seed", "outcome", "total_cost"]).to_csv(path, index=False)
    assert module.main(["--part", f"suite={path}", "--out", str(tmp_path / "out")]) == 0
    e = module.read_part([path], "value")
    assert set(e[e.planner == "greedy"].form) == {"-"} and set(e[e.planner == "ihpso"].form) == {"value", "distance"}
    value = module.paired(e, "value")
    assert (value["unit"], value["n"], value["mean"], value["low"], value["high"]) == ("scenario", 2, -1.0, -1.0, -1.0)
    assert module.paired(e, "distance")["mean"] == 1.0
    table = module.planner_table(e)
    ihpso = table[(table.planner == "ihpso") & (table.form == "value")].iloc[0]
    assert (ihpso.episodes, ihpso.success, ihpso.mean_rank) == (6, 1.0, 1.0)
    assert table[(table.planner == "hpso") & (table.form == "distance")].success.iloc[0] == 5 / 6
    text = (tmp_path / "out" / "sensitivity.md").read_text()
    # 5 of 6 is below the 99 % bar under distance only; the cheapest planner flips with the form.
    assert "| every MPC planner reaches the goal in at least 99% of episodes | yes | – | no | depends on the form |" in text
    assert "| ihpso has the lowest mean total cost | yes | – | no | depends on the form |" in text
    csv = pd.read_csv(tmp_path / "out" / "sensitivity.csv")
    assert set(csv.part) == {"suite"} and len(csv) == 5


def test_terminal_cost_table_refuses_a_malformed_part(tmp_path, capsys):
    module = load("terminal_cost_table")
    with pytest.raises(SystemExit):
        module.main(["--part", "no-equals-sign", "--out", str(tmp_path)])
    assert "expected NAME=PATH" in capsys.readouterr().err


def test_rl_noise_corridor_without_noise_is_the_greedy_floor(capsys):
    from conftest import tiny_scenario

    from uav_penetration_env.benchmark.policies import GreedyPolicy
    from uav_penetration_env.env import UAVPenetrationEnv

    module = load("rl_noise_corridor")
    env = UAVPenetrationEnv(tiny_scenario())
    cost, crashed = module.noisy_episode(env, 100.0, 0.0, None)
    policy = GreedyPolicy()
    observation, info = env.reset(seed=0)
    policy.reset(env.model, 0)
    total, done = 0.0, False
    while not done:  # the floor flown directly: the same episode, the same cost
        observation, reward, terminated, truncated, info = env.step(policy.act(observation, info))
        total -= reward
        done = terminated or truncated
    assert cost == total and not crashed
    module.main(["--scenario", "paper", "--stds", "0.37", "--clearances", "100", "--episodes", "2"])
    assert "0.37" in capsys.readouterr().out


def test_terminal_cost_table_within_keeps_a_suite_by_its_seed_rule_or_one_scenario():
    """One export holds every scenario (leaderboard v3): ``--within`` keeps what ``run --suite`` flies."""
    import pandas as pd

    module = load("terminal_cost_table")
    # the suite rule (docs/suite.md §4): seeds 0-4 on a fixed member, seed 0 on a procedural one
    rows = [("paper-2022-sec5", s) for s in range(7)] + [
        ("random-30000", 0),
        ("random-30000", 1),
        ("random-10000", 0),
    ]
    e = pd.DataFrame(rows, columns=["scenario", "seed"]).assign(policy="ihpso")
    suite = module.within(e, "uavpen-v1")
    assert list(zip(suite.scenario, suite.seed, strict=True)) == [
        ("paper-2022-sec5", s) for s in range(5)
    ] + [("random-30000", 0)]
    assert module.within(e, "random-30000").seed.tolist() == [0, 1]
    with pytest.raises(SystemExit, match=r"^--within: 'nowhere' is neither a suite nor a scenario"):
        module.within(e, "nowhere")


def test_rl_formulations_groups_agents_by_name_and_counts_maps_cheaper_than_greedy():
    script = load("rl_formulations")

    def row(policy, scenario, cost, outcome="success"):
        return {"policy": policy, "scenario": scenario, "total_cost": cost, "outcome": outcome, "error": ""}

    agent = "sb3:ppo-paper-turn-s{}"  # the store's label
    episodes = pd.DataFrame(
        [row(agent.format(0), "paper-2022-sec5", 13.0), row(agent.format(1), "paper-2022-sec5", 15.0),
         row(agent.format(0), "random-50500", 9.0), row(agent.format(1), "random-50500", 11.0),
         row(agent.format(0), "random-50501", 90.0, "collided"), row(agent.format(1), "random-50501", 12.0),
         row("greedy", "paper-2022-sec5", 17.2), row("greedy", "random-50500", 10.5), row("greedy", "random-50501", 12.0)]
    )  # fmt: skip
    table = script.formulation_table(episodes).set_index("formulation")
    turn = table.loc["ppo-turn"]
    assert turn["seeds"] == 2 and turn["paper J per seed"] == "13.00 / 15.00" and turn["paper J mean"] == 14.0
    assert 13.0 <= turn["paper CI low"] <= turn["paper CI high"] <= 15.0
    # Map 50500: mean over seeds 10.0 < greedy 10.5; map 50501: 51.0 > 12.0.
    assert turn["maps cheaper than greedy"] == 1 and turn["validation success"] == 0.75
    assert table.index.tolist() == ["ppo-turn", "greedy"]  # the references last
    assert "| ppo-turn | 2 | 13.00 / 15.00 | 14.00 [" in script.markdown(table.reset_index())


def test_the_quick_start_check_runs_the_readmes_own_commands(tmp_path):
    """.ci/quickstart_under_load.py reads the README's quick start, so it runs what a newcomer types."""
    import importlib.util

    path = Path(__file__).resolve().parents[1] / ".ci" / "quickstart_under_load.py"
    spec = importlib.util.spec_from_file_location("quickstart_under_load", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    readme = (path.parents[1] / "README.md").read_text(encoding="utf-8")
    assert module.quick_start_commands(readme) == ['pip install -e ".[dev]"', "uav-bench run && pytest"]
    with pytest.raises(ValueError, match="no ```bash block under '## Set up and run'"):
        module.quick_start_commands("# README\n\n## Set up and run\n\nno block\n\n## Next\n")
    contributing = (path.parents[1] / "CONTRIBUTING.md").read_text(encoding="utf-8")
    assert "python3 .ci/quickstart_under_load.py" in contributing


def test_bench_value_quick_run_times_each_part_and_matches_the_reference(capsys):
    results = load("bench_value").main(["--quick"])
    out = capsys.readouterr().out
    assert list(results) == ["0 busy processes beside it", "1 busy processes beside it"]
    for builds, changes in results.values():
        assert [(row["map"], row["threads"]) for row in builds] == [("random-50000", 1), ("random-50000", 2)]
        assert all(row["difference"] <= 1e-9 for row in builds)
        assert all(row[f"{method}_{part}"] > 0 for row in builds for method in ("reference", "sweeps") for part in ("moves", "costs", "sweeps", "route"))
        assert [row["change"] for row in changes] == ["added", "moved", "removed"]
        assert all(row["difference"] <= 1e-9 and 0 < row["changed_moves"] < row["moves"] for row in changes)
    assert "radar added" in out and "max rel diff" in out
