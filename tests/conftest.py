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
