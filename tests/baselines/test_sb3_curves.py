"""Learning curves from training sidecars (no torch needed)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from sb3_helpers import baselines_plugins  # noqa: F401 (a fixture)

from baselines.curves import _curve, load_curves, write_learning_curves


def write_model(folder, stem, algorithm, env_id, seed, costs, scenario="paper-2022-sec5"):
    sidecar = {"algorithm": algorithm, "env_id": env_id, "seed": seed, "env_kwargs": {"difficulty": 0.5}}
    if scenario is not None:
        sidecar["scenario"] = {"name": scenario, "hash": "abc"}
    (folder / f"{stem}.json").write_text(json.dumps(sidecar))
    steps = np.arange(1, len(costs) + 1) * 1000
    pd.DataFrame({"timesteps": steps, "mean_cost": costs, "success_rate": 1.0}).to_csv(
        folder / f"{stem}.evaluations.csv", index=False
    )


def test_mean_and_spread_over_seeds(tmp_path):
    write_model(tmp_path, "ppo-paper-s0", "ppo", "UAVPenetration-v0", 0, [30.0, 20.0, 10.0])
    write_model(tmp_path, "ppo-paper-s1", "ppo", "UAVPenetration-v0", 1, [50.0, 40.0, 30.0])
    write_model(tmp_path, "sac-random-s0", "sac", "UAVPenetrationRandom-v0", 0, [60.0, 55.0], scenario=None)
    curves = load_curves(tmp_path)
    assert sorted(curves["regime"].unique()) == [
        "UAVPenetration-v0 / paper-2022-sec5",
        "UAVPenetrationRandom-v0 (difficulty 0.5)",
    ]
    steps, mean, low, high, seeds = _curve(curves[curves["algorithm"] == "ppo"])
    assert seeds == 2
    np.testing.assert_array_equal(steps, [1000, 2000, 3000])
    np.testing.assert_array_equal(mean, [40.0, 30.0, 20.0])
    np.testing.assert_array_equal(low, [30.0, 20.0, 10.0])
    np.testing.assert_array_equal(high, [50.0, 40.0, 30.0])
    written = write_learning_curves(tmp_path, tmp_path / "out", references={"paper-2022-sec5:greedy": 17.2})
    assert [p.name for p in written] == ["learning-curves.png", "learning-curves.pdf"]
    assert all(p.stat().st_size > 1000 for p in written)


def test_seeds_evaluated_at_different_steps_are_held_between_evaluations(tmp_path):
    write_model(tmp_path, "a", "ppo", "UAVPenetration-v0", 0, [10.0, 8.0, 6.0, 4.0])  # steps 1000..4000
    frame = pd.DataFrame({"timesteps": [1500, 3500], "mean_cost": [9.0, 5.0], "success_rate": 1.0})
    write_model(tmp_path, "b", "ppo", "UAVPenetration-v0", 1, [0.0])
    frame.to_csv(tmp_path / "b.evaluations.csv", index=False)
    steps, mean, *_ = _curve(load_curves(tmp_path))
    # From 1500 on both seeds have a value: at 2000, seed a reads 8 and seed b holds 9.
    np.testing.assert_array_equal(steps, [1500, 2000, 3000, 3500, 4000])
    np.testing.assert_array_equal(mean, [9.5, 8.5, 7.5, 5.5, 4.5])


def test_empty_folder_writes_nothing(tmp_path):
    assert write_learning_curves(tmp_path, tmp_path / "out") == []


@pytest.mark.usefixtures("baselines_plugins")
def test_cli_plot_models(tmp_path, capsys):
    from uav_penetration_env.benchmark import cli

    write_model(tmp_path, "ppo-paper-s0", "ppo", "UAVPenetration-v0", 0, [3.0, 2.0])
    assert (
        cli.main(
            [
                "plot",
                "--models",
                str(tmp_path),
                "--out",
                str(tmp_path / "fig"),
                "--reference-line",
                "paper-2022-sec5:greedy=2.5",
            ]
        )
        == 0
    )
    assert (tmp_path / "fig" / "learning-curves.png").exists()
    assert cli.main(["plot", "--models", str(tmp_path / "none"), "--out", str(tmp_path / "fig")]) == 2
    assert (
        cli.main(
            ["plot", "--models", str(tmp_path), "--out", str(tmp_path / "fig"), "--reference-line", "oops"]
        )
        == 2
    )
    assert "--reference-line" in capsys.readouterr().err


@pytest.mark.parametrize("bad", ["{}", '{"algorithm": "ppo"}'])
def test_foreign_json_files_are_ignored(tmp_path, bad):
    (tmp_path / "x.json").write_text(bad)
    pd.DataFrame({"timesteps": [1], "mean_cost": [1.0]}).to_csv(tmp_path / "x.evaluations.csv", index=False)
    assert load_curves(tmp_path).empty


def test_runs_group_by_name_without_the_training_seed(tmp_path):
    write_model(tmp_path, "ppo-paper-s0", "ppo", "UAVPenetration-v0", 0, [30.0, 20.0])
    write_model(tmp_path, "ppo-paper-zoo-s0", "ppo", "UAVPenetration-v0", 0, [25.0, 15.0])
    write_model(tmp_path, "ppo-paper-zoo-s1", "ppo", "UAVPenetration-v0", 1, [35.0, 25.0])
    curves = load_curves(tmp_path)
    assert sorted(curves["group"].unique()) == ["ppo-paper", "ppo-paper-zoo"]  # two sets, not one "ppo"
    _, mean, *_ = _curve(curves[curves["group"] == "ppo-paper-zoo"])
    np.testing.assert_array_equal(mean, [30.0, 20.0])
