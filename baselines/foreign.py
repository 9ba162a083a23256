"""A model trained outside the project (no ``.json`` sidecar): what its files say (docs/rl.md §5.2).

A ``.zip`` saved by Stable-Baselines3 itself (``model.save``), by rl-baselines3-zoo or by any
other tool has no sidecar, so :func:`baselines.policy.load_policy` reads what can be read from
the files: the algorithm, the observation and action spaces and the timesteps trained come from
the ``data`` JSON inside the ``.zip`` (:func:`read_model_header`); the observation statistics
from the ``?vecnormalize=`` option or the places the project and the zoo save them
(:func:`find_statistics`); the env id from the zoo's log layout. No torch here: the evaluator's
parent process reads headers without it, and never unpickles anything (the spaces are rebuilt from
the JSON SB3 writes beside their pickles, :func:`_space`). Loading the model itself (SB3's
``load``) unpickles parts of the ``.zip``, so a model without a sidecar is loaded only when the
user opts in (:data:`TRUST_VARIABLE`, :func:`check_trusted`).
"""

from __future__ import annotations

import json
import math
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from baselines.artifacts import ModelFiles
from baselines.policy_params import NO_STATISTICS, STATISTICS_OPTION
from uav_penetration_env import ENV_IDS

MAX_DATA_BYTES = 64 * 2**20  # SB3's 'data' JSON takes kilobytes
# DECISION (docs/rl.md §5.2): the opt-in to load a model without a sidecar, whose .zip SB3 unpickles.
TRUST_VARIABLE = "UAV_PENETRATION_TRUST_MODELS"
ZOO_STATISTICS = (
    "vecnormalize.pkl"  # rl_zoo3: LOG/ALGO/ENV_1/ENV/vecnormalize.pkl beside LOG/ALGO/ENV_1/ENV.zip
)
# The Stable-Baselines3 modules of the policy classes, and the family of algorithms sharing them.
_POLICY_MODULES = {
    "stable_baselines3.common.policies": "ppo/a2c",
    "stable_baselines3.ppo.policies": "ppo/a2c",
    "stable_baselines3.a2c.policies": "ppo/a2c",
    "stable_baselines3.sac.policies": "sac",
    "stable_baselines3.td3.policies": "td3/ddpg",
    "stable_baselines3.ddpg.policies": "td3/ddpg",
}


@dataclass(frozen=True)
class ModelHeader:
    """What a Stable-Baselines3 ``.zip`` records about itself (its ``data`` JSON).

    Attributes:
        algorithm: ``ppo``, ``a2c``, ``sac``, ``td3`` or ``ddpg`` (keys of
            :data:`baselines.hyperparameters.KNOWN_ALGORITHMS`).
        observation_space: the space the policy was trained on.
        action_space: the space the policy acts in.
        num_timesteps: environment steps trained.
    """

    algorithm: str
    observation_space: spaces.Space[Any]
    action_space: spaces.Space[Any]
    num_timesteps: int


def read_model_header(path: Path) -> ModelHeader:
    """The algorithm, spaces and timesteps recorded in a Stable-Baselines3 ``.zip`` (no torch).

    PPO and A2C share their policy class; PPO's data has ``clip_range``. TD3 and DDPG share theirs;
    DDPG is TD3 with ``policy_delay`` 1 and ``target_noise_clip`` 0 (no target-policy smoothing).

    Raises:
        ValueError: not a Stable-Baselines3 zip, or a policy of an algorithm outside
            ``stable_baselines3`` (e.g. ``sb3_contrib``), naming the file.
    """
    try:
        with zipfile.ZipFile(path) as archive:
            if archive.getinfo("data").file_size > MAX_DATA_BYTES:
                raise ValueError(f"a 'data' entry of {archive.getinfo('data').file_size} bytes")
            data = json.loads(archive.read("data"))
        policy = data["policy_class"]
        module = str(policy["__module__"])
        observation_space = _space(data["observation_space"])
        action_space = _space(data["action_space"])
    except (zipfile.BadZipFile, KeyError, TypeError, ValueError, AttributeError) as error:
        raise ValueError(
            f"{path}: not a Stable-Baselines3 model (its 'data' entry with the policy class and spaces "
            f"could not be read: {type(error).__name__}: {error})"
        ) from None
    family = _POLICY_MODULES.get(module)
    if family is None:
        raise ValueError(
            f"{path}: its policy class comes from {module!r}; sb3: scores models of "
            f"stable_baselines3's PPO, A2C, SAC, TD3 and DDPG"
        )
    if family == "ppo/a2c":
        algorithm = "ppo" if "clip_range" in data else "a2c"
    elif family == "td3/ddpg":
        ddpg = data.get("policy_delay") == 1 and data.get("target_noise_clip") == 0
        algorithm = "ddpg" if ddpg else "td3"
    else:
        algorithm = family
    return ModelHeader(algorithm, observation_space, action_space, int(data.get("num_timesteps", 0)))


BOX_TYPE = "<class 'gymnasium.spaces.box.Box'>"
SPACE_DTYPES = ("float32", "float64")
MAX_SPACE_SIZE = 100_000  # far above the env's 67 observations and 3 actions


def _space(entry: Any) -> spaces.Box:
    """A ``Box`` from the plain JSON SB3 writes beside a space's pickle; the pickle itself is never read.

    DECISION (docs/rl.md §5.2): SB3 stores each space as a base64 pickle (``:serialized:``) plus its
    attributes as JSON (``dtype``, ``_shape``, and ``low``/``high`` as NumPy prints them). Unpickling
    a file from outside the project runs whatever code it names, so the header is read from the JSON
    attributes alone: a ``Box`` of a float dtype whose printed bounds list every entry. Any other
    space cannot be the env's, and is refused as such.

    Raises:
        ValueError: naming what the entry holds instead.
    """
    if not isinstance(entry, dict) or entry.get(":type:") != BOX_TYPE:
        kind = entry.get(":type:") if isinstance(entry, dict) else type(entry).__name__
        raise ValueError(f"a space of type {kind!r}, expected {BOX_TYPE} (read without unpickling)")
    shape, dtype = entry.get("_shape"), entry.get("dtype")
    if not (isinstance(shape, list) and all(isinstance(n, int) and n >= 0 for n in shape)):
        raise ValueError(f"a Box of shape {shape!r}, expected a list of sizes")
    if dtype not in SPACE_DTYPES or math.prod(shape) > MAX_SPACE_SIZE:
        raise ValueError(f"a Box of dtype {dtype!r} and shape {shape}, expected {' or '.join(SPACE_DTYPES)}")
    low, high = (_printed_array(entry.get(name), shape).astype(dtype) for name in ("low", "high"))
    return spaces.Box(low, high, tuple(shape), dtype=np.dtype(dtype))


def _printed_array(text: Any, shape: list[int]) -> np.ndarray:
    """An array from NumPy's ``str`` of it (every entry printed, none summarised as ``...``).

    NumPy prints each float in its shortest form that reads back to the same value in its own
    dtype, so the bounds come back exactly once cast to the space's dtype.
    """
    if not isinstance(text, str) or "..." in text:
        raise ValueError(f"Box bounds {str(text)[:80]!r}, expected every entry printed")
    words = text.replace("[", " ").replace("]", " ").split()
    if len(words) != math.prod(shape):
        raise ValueError(f"Box bounds of {len(words)} entries, expected {math.prod(shape)}")
    return np.array([float(word) for word in words], dtype=np.float64).reshape(shape)


def check_trusted(path: Path) -> None:
    """Refuse to load a model without a sidecar unless :data:`TRUST_VARIABLE` is ``1``.

    DECISION (docs/rl.md §5.2): SB3's ``load`` unpickles parts of a ``.zip`` (the spaces, the
    schedules, the policy's arguments), and unpickling runs whatever code a file names. A model
    without the project's sidecar comes from outside the project, so it is loaded only after the
    user says they trust it, as ``huggingface_sb3`` gates pickles behind ``TRUST_REMOTE_CODE``.
    Its header is read before (no pickle), so a model that could not be scored anyway is refused
    for that reason first.

    Raises:
        ValueError: one line naming the model and the variable to set.
    """
    if os.environ.get(TRUST_VARIABLE) != "1":
        raise ValueError(
            f"{path}: a model without a sidecar comes from outside this project, and loading it unpickles "
            f"parts of it (which can run code); expected {TRUST_VARIABLE}=1 in the environment to load a "
            "model whose source you trust (docs/rl.md §5.2)"
        )


def check_spaces(path: Path, header: ModelHeader, observation: spaces.Box) -> None:
    """Refuse, in one line, a model whose spaces are not the env's observation box and ``Box(-1, 1, (3,))``.

    Args:
        path: the model (named in the message).
        header: what its zip records.
        observation: the env's observation box (:func:`uav_penetration_env.env.observation_space`).

    Raises:
        ValueError: naming each space that differs and the expected one.
    """
    problems = []
    trained = header.observation_space
    if not (
        isinstance(trained, spaces.Box)
        and trained.shape == observation.shape
        and np.array_equal(trained.low, observation.low)
        and np.array_equal(trained.high, observation.high)
    ):
        problems.append(f"observation space {trained} (the env's is {observation})")
    acts = header.action_space
    if not (
        isinstance(acts, spaces.Box)
        and acts.shape == (3,)
        and np.array_equal(acts.low, -np.ones(3))
        and np.array_equal(acts.high, np.ones(3))
    ):
        problems.append(
            f"action space {acts} (expected Box(-1.0, 1.0, (3,)), the physical box normalised by "
            "baselines.zoo.NormalisedActions or RescaleAction(env, -1, 1))"
        )
    if problems:
        raise ValueError(
            f"sb3 model {path} does not fit this env: it was trained with " + "; ".join(problems)
        )


def zoo_env_id(files: ModelFiles) -> str | None:
    """The env id of an rl-baselines3-zoo log folder holding the model, else ``None``.

    The zoo saves ``ENV_1/ENV.zip`` (and ``ENV_1/best_model.zip``) with ``ENV_1/ENV/`` beside it;
    the id is the registered UAV id whose folder is there (or the model's stem, if it is one).
    """
    if files.model.stem in ENV_IDS:
        return files.model.stem
    found = [env_id for env_id in ENV_IDS if (files.model.parent / env_id / ZOO_STATISTICS).is_file()]
    return found[0] if len(found) == 1 else None


def find_statistics(files: ModelFiles, option: str | None) -> Path | None:
    """The observation statistics of a model without a sidecar.

    DECISION (docs/rl.md §5.2, statistics of a foreign model): ``?vecnormalize=PATH`` names the file,
    ``?vecnormalize=none`` says the model saw raw observations; without the option the project's
    name ``DIR/NAME.vecnormalize.pkl`` and then the zoo's ``DIR/ENV/vecnormalize.pkl`` (ENV a
    registered UAV id) are tried, and finding neither is an error rather than a guess: a model
    trained on normalised observations, fed raw ones, flies but scores as a different agent.

    Returns:
        The statistics file, or ``None`` for ``?vecnormalize=none``.

    Raises:
        FileNotFoundError: the named file does not exist, or none is found (naming where it looked
            and how to give one).
    """
    if option == NO_STATISTICS:
        return None
    if option is not None:
        named = Path(option)
        if not named.is_file():
            raise FileNotFoundError(f"{named}: no such observation statistics file (?{STATISTICS_OPTION}=)")
        return named
    tried = [files.vecnormalize]
    env_id = zoo_env_id(files)
    if env_id is not None:
        tried.append(files.model.parent / env_id / ZOO_STATISTICS)
    for candidate in tried:
        if candidate.is_file():
            return candidate
    raise FileNotFoundError(
        f"{files.model}: no sidecar {files.sidecar.name} and no observation statistics at "
        f"{' or '.join(str(p) for p in tried)}; give them as sb3:{files.model}?{STATISTICS_OPTION}=PATH.pkl "
        f"(rl_zoo3 writes LOG/ALGO/ENV_1/ENV/vecnormalize.pkl), or ?{STATISTICS_OPTION}={NO_STATISTICS} "
        "for a model trained without VecNormalize"
    )
