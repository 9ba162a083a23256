"""UAV low-altitude penetration: a Gymnasium environment family and benchmark harness.

The model follows Luo, Liang & Li, "3D path planning for UAV penetration based on improved
holonic PSO" (J. Systems Engineering and Electronics, 2022) with the ambiguities resolved in
the project's model specification.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from uav_penetration_env._version import __version__
from uav_penetration_env.lazy import lazy_exports

# The public names, imported on first use (PEP 562): `import uav_penetration_env` registers the env
# ids without loading the compiled physics, so `uav-bench --help` and `gym.pprint_registry()` answer
# at once. The compiled modules set numba's cache folder themselves (compile_cache, model.md §8).
_EXPORTS = {
    ".build": ("BuiltScenario", "build_scenario"),
    ".catalogue": ("HELD_OUT_SEEDS", "dem_scenario", "generate_dem_scenario", "random_scenario"),
    ".model": ("PenetrationModel", "StepResult"),
    ".scenario": ("Scenario", "ScenarioError", "load_scenario", "paper_scenario"),
}


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())


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
    "register_envs",
]

# model.md §7a: four static ids, and the dynamic one of docs/dynamic.md. Each truncates itself at its scenario's K_max (time.max_steps) and
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
    # docs/dynamic.md: threats that appear, move or were never on the map; Gymnasium's own
    # synchronous/asynchronous wrappers vectorise it (each env's threats follow its own history).
    "UAVPenetrationDynamic-v0": (
        "uav_penetration_env.dynamic_env:UAVPenetrationDynamicEnv",
        None,
        {"default_scenario": "paper-dynamic", "id_profile": "benchmark"},
    ),
}


# K_max (time.max_steps) of each id's default scenario: the bundled files' value and the default
# time settings' (procedural scenarios), written here so that importing the package reads no file
# (`uav-bench --help` answers in a fraction of a second); tests/env/test_gym_conventions.py checks
# that every value equals the file's.
REGISTERED_MAX_STEPS = {"paper": 150, "dem": 150, "paper-dynamic": 150, None: 150}


def register_envs() -> None:
    """Register the four ids with Gymnasium (idempotent); importing the package calls it.

    Also the entry point of the ``gymnasium.envs`` group (pyproject.toml, under ``__root__`` so
    the ids keep no namespace), for tools that load that group. Gymnasium 1.x itself loads no
    plug-ins, so a process that has not imported this package (a ``SubprocVecEnv`` worker started
    by forkserver or spawn) finds an id through its module-qualified form,
    ``gym.make("uav_penetration_env:UAVPenetration-v0")``, which imports it (docs/guide.md).
    """
    for env_id, (entry, vector_entry, kwargs) in ENV_IDS.items():
        if env_id not in registry:
            register(
                id=env_id,
                entry_point=entry,
                vector_entry_point=vector_entry,
                kwargs=kwargs,
                max_episode_steps=REGISTERED_MAX_STEPS[kwargs.get("default_scenario")],
            )


register_envs()
