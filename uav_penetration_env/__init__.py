"""UAV low-altitude penetration: a Gymnasium environment family and benchmark harness.

The model follows Luo, Liang & Li, "3D path planning for UAV penetration based on improved
holonic PSO" (J. Systems Engineering and Electronics, 2022) with the ambiguities resolved in
the project's model specification.
"""

from __future__ import annotations

# First: numba's cache folder must be set before any compiled module is imported.
from uav_penetration_env import compile_cache  # noqa: F401  isort: skip

from gymnasium.envs.registration import register, registry

from uav_penetration_env._version import __version__
from uav_penetration_env.build import BuiltScenario, build_scenario
from uav_penetration_env.catalogue import (
    HELD_OUT_SEEDS,
    default_max_steps,
    dem_scenario,
    generate_dem_scenario,
    random_scenario,
)
from uav_penetration_env.model import PenetrationModel, StepResult
from uav_penetration_env.scenario import Scenario, ScenarioError, load_scenario, paper_scenario

__all__ = [
    "ENV_IDS",
    "HELD_OUT_SEEDS",
    "BuiltScenario",
    "PenetrationModel",
    "Scenario",
    "ScenarioError",
    "StepResult",
    "__version__",
    "build_scenario",
    "dem_scenario",
    "generate_dem_scenario",
    "load_scenario",
    "paper_scenario",
    "random_scenario",
]

# model.md §7a: four ids. Each truncates itself at its scenario's K_max (time.max_steps) and
# registers that K_max as max_episode_steps, so gym.make's TimeLimit truncates at the same step.
_ENV = "uav_penetration_env.env:UAVPenetrationEnv"
_VECTOR = "uav_penetration_env.vector_env:UAVPenetrationVectorEnv"
ENV_IDS = {
    "UAVPenetration-v0": (_ENV, _VECTOR, {"default_scenario": "paper", "id_profile": "benchmark"}),
    "UAVPenetrationPaper-v0": (_ENV, _VECTOR, {"default_scenario": "paper", "id_profile": "paper"}),
    "UAVPenetrationRandom-v0": (
        "uav_penetration_env.env:UAVPenetrationRandomEnv",
        "uav_penetration_env.vector_env:UAVPenetrationRandomVectorEnv",
        {"id_profile": "benchmark"},
    ),
    "UAVPenetrationDEM-v0": (_ENV, _VECTOR, {"default_scenario": "dem", "id_profile": "benchmark"}),
}
for _id, (_entry, _vector_entry, _kwargs) in ENV_IDS.items():
    if _id not in registry:
        register(
            id=_id,
            entry_point=_entry,
            vector_entry_point=_vector_entry,
            kwargs=_kwargs,
            max_episode_steps=default_max_steps(_kwargs.get("default_scenario")),
        )
