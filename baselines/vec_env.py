"""A Stable-Baselines3 ``VecEnv`` over the native numpy-batched vector env (model.md §7a).

SB3's own ``DummyVecEnv`` would step N single envs one by one, paying the per-call numpy overhead
N times (model.md §8); the native vector env steps all N UAVs as one batch. This adapter builds it
with ``gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point",
autoreset_mode="SAME_STEP")`` and speaks SB3's protocol:

- actions arrive in ``[-1, 1]`` (what SB3's squashed and clipped policies emit) and are mapped to
  the physical box ``[dv (m/s), dphi (rad), dtheta (rad)]`` with the very function
  ``gymnasium.wrappers.RescaleAction`` uses, so the adapter equals ``DummyVecEnv`` of single envs
  wrapped in ``RescaleAction(env, -1, 1)`` step for step (STYLE §7);
- ``SAME_STEP`` autoreset: a finished sub-env's returned observation is already the next
  episode's first one; its info is the info of the final transition, with
  ``terminal_observation`` and ``TimeLimit.truncated`` as SB3 expects, and the reset info goes
  to ``reset_infos``;
- seeding through ``seed(s)`` (sub-env i gets ``s + i``, SB3's and Gymnasium's convention),
  applied at the next ``reset()``.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.wrappers.utils import rescale_box
from stable_baselines3.common.vec_env.base_vec_env import (
    VecEnv,
    VecEnvIndices,
    VecEnvStepReturn,
    VecEnvWrapper,
)

import uav_penetration_env  # noqa: F401  (importing registers the env ids)
from baselines.formulation import (
    Formulation,
    learner_observation,
    learner_observation_space,
    shaping_terms,
    turn_control,
    value_potential,
)
from uav_penetration_env.model import PenetrationModel

# Attributes that differ per sub-env: read from the batched env's read-only per-env view. Every
# other attribute is the batched env's own, shared by all sub-envs.
PER_ENV_ATTRIBUTES = {"scenario": "scenarios", "state": "states", "step_index": "step_indices"}
# Keys of the native env's info that are SAME_STEP bookkeeping, not per-transition data.
_AUTORESET_KEYS = ("final_obs", "final_info")


def info_rows(info: dict[str, Any], num_envs: int) -> list[dict[str, Any]]:
    """Split a batched info (SyncVectorEnv layout: ``key`` plus ``_key`` mask) into one dict per sub-env.

    Scalars become Python numbers and array entries are copied, exactly as the single env's info
    (``uav_penetration_env.env.unbatch``), so SB3 code sees the same dicts as with ``DummyVecEnv``.
    """
    rows: list[dict[str, Any]] = [{} for _ in range(num_envs)]
    for key, value in info.items():
        if key.startswith("_") or key in _AUTORESET_KEYS:
            continue
        mask = info.get(f"_{key}")
        array = np.asarray(value)
        # tolist() converts a whole column to Python scalars at once (the same values as .item()).
        column = array.tolist() if array.ndim == 1 else [row.copy() for row in array]
        for i in range(num_envs):
            if mask is None or mask[i]:
                rows[i][key] = column[i]
    return rows


class UAVPenetrationSB3VecEnv(VecEnv):
    """SB3 ``VecEnv`` stepping ``num_envs`` UAV penetration episodes as one numpy batch.

    Args:
        env_id: a registered id (``UAVPenetration-v0``, ``UAVPenetrationPaper-v0``,
            ``UAVPenetrationRandom-v0``, ``UAVPenetrationDEM-v0``).
        num_envs: sub-envs stepped together.
        **env_kwargs: keywords of the id (``scenario``, ``profile``, ``render_mode``, ``threads``
            (default 1 here); for the Random id ``difficulty``, ``pool_size``, ``pool_seed``).

    Attributes:
        vector_env: the native Gymnasium vector env (``SAME_STEP`` autoreset, physical actions).
        physical_action_space: the env's action box in physical units (the adapter's own
            ``action_space`` is ``Box(-1, 1, (3,))``).
    """

    def __init__(self, env_id: str = "UAVPenetration-v0", num_envs: int = 1, **env_kwargs: Any) -> None:
        if "autoreset_mode" in env_kwargs:
            raise ValueError(
                f"autoreset_mode: got {env_kwargs['autoreset_mode']!r}; the SB3 adapter always uses SAME_STEP"
            )
        self.env_id = env_id
        self.env_kwargs = dict(env_kwargs)
        # DECISION (model.md §8, threads): inside a training process torch already keeps the cores
        # busy, so the batched step runs on the calling thread unless ``threads=`` says otherwise
        # (results never depend on it).
        self.vector_env = gym.make_vec(
            env_id,
            num_envs=num_envs,
            vectorization_mode="vector_entry_point",
            autoreset_mode="SAME_STEP",
            **{"threads": 1, **env_kwargs},
        )
        physical = self.vector_env.single_action_space
        if not isinstance(physical, spaces.Box):
            raise TypeError(f"{env_id}: expected a Box action space, got {physical}")
        self.physical_action_space = physical
        ones = np.ones(physical.shape, dtype=physical.dtype)
        # rescale_box's third function is the one RescaleAction(env, -1, 1) applies to every action.
        policy_space, _, self._to_physical = rescale_box(physical, -ones, ones)
        # VecEnv.__init__ reads render_mode through get_attr, so vector_env must exist before it.
        super().__init__(num_envs, self.vector_env.single_observation_space, policy_space)
        self.metadata = dict(self.vector_env.metadata)
        self._actions: np.ndarray | None = None
        self._physical = False

    # --- SB3 VecEnv API ------------------------------------------------------------------------------

    def to_physical(self, actions: np.ndarray) -> np.ndarray:
        """Map ``(num_envs, 3)`` policy actions in [-1, 1] (clipped there first) to the physical box."""
        clipped = np.clip(np.asarray(actions, dtype=self.action_space.dtype), -1.0, 1.0)
        return self._to_physical(clipped)

    def seed(self, seed: int | Sequence[int] | None = None) -> Sequence[int | None]:
        """Seeds for the next ``reset()``: an int s gives sub-env i the seed s + i; a list one seed each.

        Returns:
            The seed of each sub-env.

        Raises:
            ValueError: a list whose length is not ``num_envs``.
        """
        if seed is None or isinstance(seed, (int, np.integer)):
            return super().seed(None if seed is None else int(seed))
        seeds = [int(s) for s in seed]
        if len(seeds) != self.num_envs:
            raise ValueError(f"seed: got {len(seeds)} seeds, expected {self.num_envs} (one per sub-env)")
        self._seeds = seeds
        return seeds

    def reset(self) -> np.ndarray:
        """Reset every sub-env with the seeds set by ``seed()`` (used once) and return the observations."""
        if any(o != self._options[0] for o in self._options):
            raise ValueError("set_options: the batched env takes one options dict for all sub-envs")
        seeds = None if all(s is None for s in self._seeds) else list(self._seeds)
        options = self._options[0] or None
        obs, info = self.vector_env.reset(seed=seeds, options=options)
        self.reset_infos = info_rows(info, self.num_envs)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Store the policy actions for :meth:`step_wait`."""
        self._actions = np.asarray(actions)
        self._physical = False

    def step_async_physical(self, actions: np.ndarray) -> None:
        """Store ``(num_envs, 3)`` actions already in physical units (a training formulation's controller).

        :meth:`step_wait` passes them to the env as they are, without the [-1, 1] rescaling
        (``baselines.formulation``, docs/rl.md §6).
        """
        self._actions = np.asarray(actions, dtype=np.float64)
        self._physical = True

    def step_wait(self) -> VecEnvStepReturn:
        """Step all sub-envs; finished ones are reset at once (SAME_STEP), as ``DummyVecEnv`` does."""
        if self._actions is None:
            raise RuntimeError("step_wait() without step_async(actions)")
        physical = self._actions if self._physical else self.to_physical(self._actions)
        obs, rewards, terminated, truncated, info = self.vector_env.step(physical)
        self._actions = None
        dones = terminated | truncated
        infos = info_rows(info, self.num_envs)
        if dones.any():
            final_infos = info_rows(info["final_info"], self.num_envs)
            for i in np.flatnonzero(dones):
                # The returned obs/info of a finished sub-env belong to the next episode's start.
                self.reset_infos[i] = infos[i]
                infos[i] = final_infos[i]
                infos[i]["terminal_observation"] = info["final_obs"][i]
        for i in range(self.num_envs):
            # Gymnasium >= 0.26 splits done; SB3 bootstraps from the value of truncated episodes only.
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return obs, rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        """Close the native vector env."""
        self.vector_env.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        """One frame per sub-env (``render_mode="rgb_array"``)."""
        frames = self.vector_env.render()
        return list(frames) if frames is not None else [None] * self.num_envs

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """Per-sub-env attributes (``scenario``, ``state``, ``step_index``) or the batched env's own.

        Raises:
            AttributeError: neither the batched env nor its sub-envs have ``attr_name``.
        """
        rows = list(self._get_indices(indices))
        if attr_name in PER_ENV_ATTRIBUTES:
            values = getattr(self.vector_env, PER_ENV_ATTRIBUTES[attr_name])
            return [values[i].copy() if isinstance(values[i], np.ndarray) else values[i] for i in rows]
        value = getattr(self.vector_env, attr_name)
        return [value for _ in rows]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute of the batched env (it is shared, so only for all sub-envs at once).

        Raises:
            ValueError: ``indices`` names a subset of the sub-envs.
        """
        self._require_all(indices, f"set_attr({attr_name!r})")
        setattr(self.vector_env, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any
    ) -> list[Any]:
        """Call a method of the batched env once (it acts on every sub-env); ``render`` is split per sub-env.

        Raises:
            ValueError: ``indices`` names a subset of the sub-envs (except for ``render``).
        """
        if method_name == "render":
            frames = self.get_images()
            return [frames[i] for i in self._get_indices(indices)]
        self._require_all(indices, f"env_method({method_name!r})")
        result = getattr(self.vector_env, method_name)(*method_args, **method_kwargs)
        return [result for _ in range(self.num_envs)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        """The sub-envs are rows of one batch, never Gymnasium wrappers: always False."""
        return [False for _ in self._get_indices(indices)]

    def _require_all(self, indices: VecEnvIndices, what: str) -> None:
        if indices is not None and sorted(self._get_indices(indices)) != list(range(self.num_envs)):
            raise ValueError(
                f"{what}: the {self.num_envs} sub-envs share one batched env; got indices {indices!r}, "
                "expected None (all sub-envs)"
            )

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.env_id!r}, num_envs={self.num_envs})"


@contextlib.contextmanager
def _one_compiled_thread() -> Iterator[None]:
    """Run the value look-ups of a formulation on the calling thread (numba's count restored after).

    DECISION (model.md §8, threads): as the batched step (``threads=1`` above), the value function's
    compiled look-up runs on one thread inside a training process: a parallel region over 8 poses
    waits for a second core that torch and the other jobs keep busy (on the loaded 2-core machine
    Φ of 8 poses took 73-80 µs on one thread, 122-129 µs on two); results never depend on it.
    """
    import numba

    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(previous)


def make_formulation_vec_env(venv: Any, formulation: Formulation, gamma: float | None) -> Any:
    """``venv`` (a :class:`~baselines.vec_env.UAVPenetrationSB3VecEnv`) wrapped for ``formulation``.

    Args:
        venv: the batched SB3 adapter (one fixed scenario).
        formulation: what to apply.
        gamma: the shaping discount (the learner's γ); unused without shaping.

    Returns:
        ``venv`` itself for today's formulation, else a :class:`FormulationVecEnv`.
    """
    if formulation.is_default:
        return venv
    return FormulationVecEnv(venv, formulation, gamma)


class FormulationVecEnv(VecEnvWrapper):
    """The batched training env with a :class:`Formulation` applied (docs/rl.md §6).

    Turn actions are mapped per sub-env by :func:`turn_control` from the sub-env's exact state and
    stepped in physical units; the value inputs are appended to every observation (and to
    ``terminal_observation``); with shaping, each reward gets F of :func:`shaping_terms` (the env's
    reward is kept in ``info["reward_env"]``, F in ``info["shaping"]``; ``info["J"]`` is untouched).

    Args:
        venv: a :class:`~baselines.vec_env.UAVPenetrationSB3VecEnv` over one fixed scenario.
        formulation: what to apply.
        gamma: the shaping discount (required with ``shaping="value"``).

    Raises:
        ValueError: shaping without ``gamma`` in (0, 1].
    """

    def __init__(self, venv: Any, formulation: Formulation, gamma: float | None = None) -> None:
        formulation.check()
        if formulation.shaping == "value" and not (gamma is not None and 0.0 < gamma <= 1.0):
            raise ValueError(f"gamma: got {gamma!r}, expected a number in (0, 1] for value shaping")
        self.formulation = formulation
        self.gamma = float(gamma) if gamma is not None else 1.0
        action_space = (
            formulation.policy_action_space(venv.physical_action_space)
            if formulation.action == "turn"
            else venv.action_space
        )
        super().__init__(
            venv,
            observation_space=learner_observation_space(formulation, venv.observation_space),
            action_space=action_space,
        )
        self._phi = np.zeros(venv.num_envs)
        self._actions: np.ndarray | None = None

    @property
    def _model(self) -> PenetrationModel:
        return self.venv.vector_env.model

    def _states(self) -> np.ndarray:
        return np.array(self.venv.vector_env.states, dtype=np.float64)

    def _observe(self, obs: np.ndarray, states: np.ndarray) -> np.ndarray:
        if self.formulation.features == "none":
            return obs
        model = self._model
        return np.stack(
            [learner_observation(self.formulation, model, o, s) for o, s in zip(obs, states, strict=True)]
        )

    def reset(self) -> np.ndarray:
        """Reset every sub-env; Φ of the first states is remembered for the first step."""
        with _one_compiled_thread():
            return self._reset()

    def step_async(self, actions: np.ndarray) -> None:
        """Map turn actions to physical ones (from each sub-env's state now); pass others on."""
        with _one_compiled_thread():
            self._step_async(actions)

    def step_wait(self) -> Any:
        """Step; add F to the rewards (shaping), the value inputs to the observations (features)."""
        with _one_compiled_thread():
            return self._step_wait()

    def _reset(self) -> np.ndarray:
        obs = self.venv.reset()
        states = self._states()
        if self.formulation.shaping == "value":
            self._phi = value_potential(self._model, states)
        return self._observe(obs, states)

    def _step_async(self, actions: np.ndarray) -> None:
        if self.formulation.action != "turn":
            self.venv.step_async(actions)
            return
        model, states = self._model, self._states()
        rows = np.asarray(actions).reshape(self.num_envs, -1)
        physical = np.stack(
            [turn_control(model, s, self.formulation, a) for s, a in zip(states, rows, strict=True)]
        )
        self.venv.step_async_physical(physical)

    def _step_wait(self) -> Any:
        obs, rewards, dones, infos = self.venv.step_wait()
        model = self._model
        if self.formulation.features == "value":
            for i in np.flatnonzero(dones):
                infos[i]["terminal_observation"] = learner_observation(
                    self.formulation, model, infos[i]["terminal_observation"], infos[i]["state"]
                )
        states = self._states()  # a finished sub-env's is already its next episode's first
        if self.formulation.shaping == "value":
            final = np.stack([np.asarray(info["state"], dtype=np.float64) for info in infos])
            terminated = np.array(
                [bool(d) and not info["TimeLimit.truncated"] for d, info in zip(dones, infos, strict=True)]
            )
            terms = shaping_terms(self._phi, value_potential(model, final), terminated, self.gamma)
            for i, info in enumerate(infos):
                info["reward_env"] = float(rewards[i])
                info["shaping"] = float(terms[i])
            rewards = (rewards.astype(np.float64) + terms).astype(np.float32)
            self._phi = value_potential(model, states)
        return self._observe(obs, states), rewards, dones, infos
