"""Shared test configuration: the hypothesis `ci` profile and a tiny, fast scenario fixture."""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

# Deterministic, deadline-free property tests: CI machines are slow and noisy, and a failing
# example must reproduce on the next run.
settings.register_profile(
    "ci",
    deadline=None,
    derandomize=True,
    max_examples=60,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile("dev", deadline=None, max_examples=300)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

# The test session's BLAS threads, as uav-bench's (model.md §8, BLAS threads): one, unless the user
# chose. Two BLAS threads beside busy processes on 2 cores stalled a 100-D CMA-ES test for minutes.
from uav_penetration_env.threads import limit_blas_threads  # noqa: E402

limit_blas_threads(1, respect_environment=True)

# The one reason every test that needs Stable-Baselines3/torch gives when the `rl` extra is absent
# (a core-only install, `pip install -e ".[dev]"`, skips them and passes the rest).
RL_EXTRA = (
    "the RL tests need the rl extra: pip install torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu "
    "&& pip install -e '.[rl]'"
)


# --- a tiny, fast scenario: a 75 km map on a 1 km grid, one mountain, two radars ----------------

import pytest  # noqa: E402

from uav_penetration_env.scenario import Scenario  # noqa: E402

TINY_SCENARIO = {
    "name": "tiny",
    "map": {"x_km": [-25, 50], "y_km": [-25, 50], "grid_m": 1000, "ceiling_m": 3000},
    "start": {"x_km": 0, "y_km": 0, "z_agl_m": 100},
    "goal": {"x_km": 25, "y_km": 25, "radius_km": 3},
    "time": {"dt_s": 300, "max_steps": 30},
    "terrain": {
        "seed": 3,
        "natural": {"method": "gaussian_field", "height_m": 150, "correlation_km": 5},
        "mountains": [{"x_km": 12, "y_km": 14, "height_m": 400}],
    },
    "radars": [
        {"name": "A", "x_km": 5, "y_km": 25, "z_m": 300},
        {"name": "B", "x_km": 25, "y_km": 5, "mast_m": 15},
    ],
    # Used only under the paper profile (eq. 39); round numbers of the right orders of magnitude.
    "normalisation": {
        "payoff": {
            "constants": {"terrain": [0, 1], "radar": [0, 50], "third": [-0.01, 0.035], "crash_penalty_per_step": 1.0},
            "provenance": {"method": "test fixture"},
        }
    },
}


def tiny_scenario(**changes: object) -> Scenario:
    """The tiny scenario, with nested ``changes`` (file units) merged in."""
    return Scenario.from_dict(TINY_SCENARIO).updated(changes)


@pytest.fixture(scope="session")
def tiny() -> Scenario:
    return tiny_scenario()


@pytest.fixture(scope="session")
def tiny_yaml(tmp_path_factory) -> str:
    """The tiny scenario cut to 20 steps, written once to a YAML file (its path)."""
    return str(
        tiny_scenario(time={"max_steps": 20}).to_yaml(tmp_path_factory.mktemp("scenario") / "tiny.yaml")
    )


def successful_episode(policy: str, seed: int, scenario: str, scenario_hash: str, cost: float) -> dict:
    """The key and cost columns of a synthetic episode row that reached the goal at total cost ``cost``.

    No penalty, so ``total_J == total_cost == cost``; the policy hash is the name padded with ``x`` to
    16 characters. Tests add the other columns they read.
    """
    return {
        "policy": policy,
        "policy_hash": f"{policy:x<16}"[:16],
        "scenario": scenario,
        "scenario_hash": scenario_hash,
        "seed": seed,
        "outcome": "success",
        "total_J": cost,
        "total_penalty": 0.0,
        "total_cost": cost,
    }


# --- `uav-bench` as the tests call it (the harness extra; imported when first called) ---------------


def run_cli(*argv: object) -> int:
    """``uav-bench ARGV`` in this process, every argument passed as its ``str``; the exit status."""
    from uav_penetration_env.benchmark import cli

    return cli.main([str(a) for a in argv])


def run_into_store(store: object, policies: list[str], scenario: object, seeds: int, *extra: object) -> int:
    """``uav-bench run`` of ``policies`` on one scenario file, seeds ``0..seeds-1``, into ``store``.

    No report and no progress bar; ``extra`` flags (``--jobs 1``, ``--max-evals 50``) are appended.
    Returns the exit status.
    """
    return run_cli("run", "--policies", *policies, "--scenarios", scenario, "--seeds", seeds, "--store", store,
                   "--no-report", "--no-progress", *extra)  # fmt: skip


def tiny_store(folder, policies: list[str], max_steps: int, seeds: int = 2) -> object:
    """A store of ``policies`` flown on the tiny scenario cut to ``max_steps``, one job (its path)."""
    scenario = tiny_scenario(time={"max_steps": max_steps}).to_yaml(folder / "tiny.yaml")
    path = folder / "run.sqlite"
    assert run_into_store(path, policies, scenario, seeds, "--jobs", 1) == 0
    return path


@pytest.fixture(scope="session")
def greedy_random_store(tmp_path_factory):
    """greedy and random, seeds 0-1, on the tiny scenario cut to 6 steps; read it, never write it."""
    return tiny_store(tmp_path_factory.mktemp("greedy-random"), ["greedy", "random"], max_steps=6)


def wait_for_episodes(store, process, at_least: int, seconds: float, poll_s: float) -> int:
    """Poll ``store``'s episode count while ``process`` runs, until it reaches ``at_least``.

    ``seconds`` bounds the wait (never an assertion on speed); a store being created or locked
    reads as 0. Returns the last count read.
    """
    import sqlite3
    import time

    stored, deadline = 0, time.monotonic() + seconds
    while time.monotonic() < deadline and process.poll() is None and stored < at_least:
        if store.exists():
            try:
                with sqlite3.connect(store, timeout=1) as connection:
                    stored = connection.execute("SELECT COUNT(*) FROM episodes").fetchone()[0]
            except sqlite3.OperationalError:
                stored = 0
        if stored < at_least:
            time.sleep(poll_s)
    return stored
