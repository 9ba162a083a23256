"""rl-baselines3-zoo interop: the action wrapper its hyper-parameter files name (docs/rl.md §5).

``baselines/hyperparams/zoo/ppo.yml``, ``sac.yml`` and ``td3.yml`` are hyper-parameter files in
rl-baselines3-zoo's format, keyed by the four env ids, with the settings of the project's own
``ppo.yaml``, ``sac.yaml`` and ``td3.yaml``. They name :class:`NormalisedActions` as ``env_wrapper``, so
``python -m rl_zoo3.train --algo ppo --env UAVPenetration-v0 --gym-packages uav_penetration_env
--conf-file baselines/hyperparams/zoo/ppo.yml --num-threads 1`` trains in the action space the project's agents
use. The zoo saves the model as ``LOG/ALGO/ENV_1/ENV.zip`` and the observation statistics as
``LOG/ALGO/ENV_1/ENV/vecnormalize.pkl``; ``uav-bench run --policies sb3:LOG/ALGO/ENV_1/ENV.zip``
finds them there (:func:`baselines.policy.load_policy`).

Only gymnasium and numpy are imported: the wrapper also serves plain Gymnasium users.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.wrappers.utils import rescale_box

ZOO_HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams" / "zoo"


class NormalisedActions(gym.ActionWrapper, gym.utils.RecordConstructorArgs):
    """The env's action box ``[dv (m/s), dphi (rad), dtheta (rad)]`` seen as ``Box(-1, 1, (3,))``.

    An action is clipped to [-1, 1] and mapped affinely onto the physical box by the function
    ``gymnasium.wrappers.RescaleAction(env, -1, 1)`` applies, so a single env wrapped here steps
    exactly as one sub-env of :class:`baselines.vec_env.UAVPenetrationSB3VecEnv` (the adapter the
    project's agents train on) and as :class:`baselines.policy.SB3Policy` acts. Unlike
    ``RescaleAction`` with the YAML floats ``-1.0, 1.0`` the bounds are built in the box's own
    dtype (float32), which keeps Gymnasium from warning about lowered precision in every sub-env.

    DECISION (docs/rl.md §5.1, the zoo's action wrapper): the zoo files name this class rather than
    ``gymnasium.wrappers.RescaleAction`` with keyword arguments, because it also clips, as the
    training adapter and :class:`~baselines.policy.SB3Policy` do: SB3 clips PPO's and A2C's
    actions itself, but an ``EvalCallback`` of another library or a hand-written loop may not, and
    an unclipped action outside [-1, 1] would map outside the physical box (the env clips it again,
    so only the logged action would differ).

    Args:
        env: an env with a ``Box`` action space (any of the ``UAVPenetration*-v0`` ids).

    Raises:
        TypeError: the action space is not a ``Box``.
    """

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        box = env.action_space
        if not isinstance(box, spaces.Box):
            raise TypeError(f"NormalisedActions: expected a Box action space, got {box}")
        gym.utils.RecordConstructorArgs.__init__(self)
        gym.ActionWrapper.__init__(self, env)
        ones = np.ones(box.shape, dtype=box.dtype)
        policy_space, _, self._to_physical = rescale_box(box, -ones, ones)
        self.action_space = policy_space
        self._dtype = box.dtype

    def action(self, action: Any) -> np.ndarray:
        """Map a ``(3,)`` action in [-1, 1] (clipped there first) to the physical box."""
        clipped = np.clip(np.asarray(action, dtype=self._dtype), -1.0, 1.0)
        return np.asarray(self._to_physical(clipped))
