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
