"""Native numpy-batched vector env: the same ``PenetrationModel`` on ``(num_envs, 6)`` (model.md §7a).

Supports Gymnasium's ``NEXT_STEP`` (default), ``SAME_STEP`` and ``DISABLED`` autoreset modes and
returns infos in ``SyncVectorEnv``'s layout (every key batched, with a ``_key`` mask), so it can
replace ``gym.make_vec(..., vectorization_mode="sync")``: sub-env i equals a single env reset with
seed ``s + i`` (or ``seeds[i]``), step for step, ``max_episode_steps`` (which ``make_vec`` passes
from the spec) truncates as Gymnasium's ``TimeLimit`` does in sync mode, ``np_random_seed`` is the
tuple of the sub-envs' seeds, and wrong inputs raise the exception types sync mode raises.

The Random id (model.md §7a, "Vector env"): by default (``pool="shared"``) every sub-env draws
its *seedless* resets from one pool of ``pool_size`` scenarios, seeded by the first reset's seed
for sub-env 0. Sync mode instead gives sub-env i its own pool, seeded by ``s + i``, so after the
first seedless autoreset of sub-envs 1..n the two differ. ``pool="per_env"`` reproduces sync mode
exactly. DECISION (model.md §7a): the shared pool is the default because the model holds every
scenario in use in one padded pool: per-env pools make that up to ``num_envs x pool_size``
scenarios to build and hold (each a terrain grid and up to 8 masking floors) instead of
``pool_size``, for the same training distribution in expectation.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from uav_penetration_env import kernels
from uav_penetration_env.env import (
    BuiltCache,
    FixedScenarioSource,
    RandomScenarioSource,
    ScenarioLike,
    action_space,
    batched_info,
    observation_space,
    resolve_scenario,
    validate_action,
)
from uav_penetration_env.kinematics import UAVLimits
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.scenario import Scenario


def _autoreset_mode(value: AutoresetMode | str) -> AutoresetMode:
    if isinstance(value, AutoresetMode):
        return value
    names = {mode.name.lower(): mode for mode in AutoresetMode} | {
        mode.value.lower(): mode for mode in AutoresetMode
    }
    key = str(value).lower().replace("-", "_")
    if key not in names:
        raise ValueError(f"autoreset_mode: got {value!r}, expected one of {[m.name for m in AutoresetMode]}")
    return names[key]


def _reset_mask(value: Any, num_envs: int) -> np.ndarray:
    """``options["reset_mask"]`` checked with the exception types of Gymnasium's sync vector env."""
    if not isinstance(value, np.ndarray):
        raise TypeError(f"options['reset_mask']: got {type(value).__name__}, expected a numpy bool array")
    if value.dtype != np.bool_:
        raise TypeError(f"options['reset_mask']: got dtype {value.dtype}, expected bool")
    if value.shape != (num_envs,):
        raise ValueError(f"options['reset_mask']: got shape {value.shape}, expected ({num_envs},)")
    if not value.any():
        raise ValueError("options['reset_mask']: got no True value, expected at least one sub-env to reset")
    return value


def _vector_info(
    info: dict[str, np.ndarray], rows: np.ndarray | None = None, num_envs: int | None = None
) -> dict[str, Any]:
    """Batched info in SyncVectorEnv's layout: each key plus a ``_key`` mask.

    With ``rows``, ``info`` holds only those rows and is scattered into ``num_envs``-sized arrays.
    """
    if rows is not None and num_envs is None:
        raise TypeError("_vector_info: rows given without num_envs")
    out: dict[str, Any] = {}
    if rows is None or num_envs is None:
        # The masks as rows of one block: each its own writable array, allocated in one call.
        size = len(next(iter(info.values()))) if info else 0
        for mask, (key, value) in zip(np.ones((len(info), size), dtype=bool), info.items(), strict=True):
            out[key] = value
            out[f"_{key}"] = mask
        return out
    for key, value in info.items():
        full = np.zeros((num_envs, *value.shape[1:]), dtype=value.dtype)
        full[rows] = value
        mask = np.zeros(num_envs, dtype=bool)
        mask[rows] = True
        out[key], out[f"_{key}"] = full, mask
    return out


class UAVPenetrationVectorEnv(VectorEnv):
    """``num_envs`` penetration episodes stepped as one numpy batch.

    Args:
        num_envs: number of sub-envs.
        scenario: a YAML path, mapping or :class:`Scenario` (``None``: the id's default).
        profile: ``"benchmark"`` or ``"paper"`` (overrides the id's and the file's profile).
        render_mode: ``"rgb_array"`` (a tuple of frames, one per sub-env) or ``None``.
        autoreset_mode: ``NEXT_STEP`` (default), ``SAME_STEP`` or ``DISABLED``.
        max_episode_steps: truncate each episode after this many steps, as Gymnasium's
            ``TimeLimit`` does in sync mode (``None``: only the scenario's K_max); ``make_vec``
            passes the id's registered value.
        default_scenario: the id's scenario (set at registration).
        id_profile: the id's profile (set at registration).
        threads: compiled threads of the batched step (:class:`PenetrationModel`'s ``threads``):
            1 beside a training process's own threads, None for numba's count in force.
    """

    def __init__(
        self,
        num_envs: int = 1,
        scenario: ScenarioLike = None,
        profile: str | None = None,
        render_mode: str | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        max_episode_steps: int | None = None,
        *,
        default_scenario: str = "paper",
        id_profile: str | None = None,
        threads: int | None = None,
    ) -> None:
        source = FixedScenarioSource(resolve_scenario(scenario, default_scenario, profile, id_profile))
        self._setup(num_envs, [source], render_mode, autoreset_mode, max_episode_steps, threads)

    def _setup(
        self,
        num_envs: int,
        sources: Sequence[FixedScenarioSource | RandomScenarioSource],
        render_mode: str | None,
        autoreset_mode: AutoresetMode | str,
        max_episode_steps: int | None,
        threads: int | None = None,
    ) -> None:
        self._threads = kernels.check_threads(threads)
        if not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs: got {num_envs!r}, expected an integer >= 1")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode: got {render_mode!r}, expected 'rgb_array' or None")
        if max_episode_steps is not None and (
            not isinstance(max_episode_steps, (int, np.integer)) or max_episode_steps < 1
        ):
            raise ValueError(
                f"max_episode_steps: got {max_episode_steps!r}, expected an integer >= 1 or None"
            )
        self.max_episode_steps = None if max_episode_steps is None else int(max_episode_steps)
        self.num_envs = int(num_envs)
        self.render_mode = render_mode
        self.autoreset_mode = _autoreset_mode(autoreset_mode)
        self.metadata = {"render_modes": ["rgb_array"], "autoreset_mode": self.autoreset_mode}
        # One scenario source for every sub-env, or one per sub-env (the Random id's per-env pools).
        self._sources = list(sources) if len(sources) > 1 else [sources[0]] * int(num_envs)
        self.source = self._sources[0]
        self._built = BuiltCache()
        self._model: PenetrationModel | None = None
        self._model_keys: list[str] = []
        n = self.num_envs
        self._rngs: list[np.random.Generator | None] = [None] * n
        self._sub_seeds: list[int | None] = [None] * n
        self._scenarios: list[Scenario | None] = [None] * n
        self._states = np.zeros((n, 6))
        self._steps = np.zeros(n, dtype=np.int64)
        self._index = np.zeros(n, dtype=np.intp)
        self._autoreset = np.zeros(n, dtype=bool)
        self._started = False
        self._tracks: list[list[np.ndarray]] = [[] for _ in range(n)]
        if isinstance(self.source, FixedScenarioSource):
            self._load([self.source.scenario])
            limits = self.model.limits
        else:
            limits = UAVLimits.from_scenario(Scenario())
        self.single_observation_space = observation_space()
        self.single_action_space = action_space(limits)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._high = limits.action_high

    # --- the scenario pool held by the model ---------------------------------------------------------

    @property
    def model(self) -> PenetrationModel:
        """The batched model currently serving the sub-envs."""
        if self._model is None:
            raise RuntimeError("no scenario loaded yet: call reset() first")
        return self._model

    # --- read-only public view of the sub-envs (for adapters such as baselines' SB3 VecEnv) ------------

    @property
    def scenarios(self) -> tuple[Scenario | None, ...]:
        """The scenario each sub-env is flying (``None`` before its first reset)."""
        return tuple(self._scenarios)

    @property
    def states(self) -> np.ndarray:
        """(num_envs, 6) current states [x, y, z (m), v (m/s), phi, theta (rad)]: a read-only view.

        The view follows the env as it steps; copy it to keep a snapshot.
        """
        view = self._states.view()
        view.flags.writeable = False
        return view

    @property
    def step_indices(self) -> np.ndarray:
        """(num_envs,) steps taken in each sub-env's current episode: a read-only view."""
        view = self._steps.view()
        view.flags.writeable = False
        return view

    def describe_scenarios(self) -> dict[str, Any]:
        """Where the sub-envs' scenarios come from, as JSON-able data (e.g. for a training sidecar).

        Returns:
            For a fixed scenario: ``kind="fixed"``, ``name``, ``hash``, ``profile``. For the Random id:
            ``kind="random"``, ``difficulty``, ``pool_size``, ``pool_seed`` (``None`` until the first
            reset draws it) and ``profile``.
        """
        source = self.source
        if isinstance(source, FixedScenarioSource):
            scenario = source.scenario
            return {
                "kind": "fixed",
                "name": scenario.name,
                "hash": scenario.hash,
                "profile": scenario.profile,
            }
        return {
            "kind": "random",
            "difficulty": source.difficulty,
            "pool_size": source.pool_size,
            "pool_seed": source.pool_seed,
            "profile": source.profile,
        }

    def _load(self, needed: Sequence[Scenario]) -> None:
        """Make sure the model's pool holds ``needed``, rebuilding it only when something is missing.

        The pool keeps every scenario loaded so far while it stays under ``num_envs + pool_size``
        entries (so the Random id stops rebuilding once its pool is loaded), else only those in use.
        """
        if all(s.hash in self._model_keys for s in needed):
            return
        loaded = [b.scenario for b in self._model.built] if self._model is not None else []
        in_use = [s for s in self._scenarios if s is not None]
        cap = self.num_envs + getattr(self.source, "pool_size", 1) * len(set(map(id, self._sources)))
        candidates = [*loaded, *needed] if len(loaded) + len(needed) <= cap else [*in_use, *needed]
        pool = list({s.hash: s for s in candidates}.values())
        self._model = PenetrationModel(
            [self._built.get(s) for s in pool], radar_slots=self.source.radar_slots, threads=self._threads
        )
        self._model_keys = [s.hash for s in pool]
        position = {k: i for i, k in enumerate(self._model_keys)}
        for i, scenario in enumerate(self._scenarios):
            if scenario is not None and scenario.hash in position:
                self._index[i] = position[scenario.hash]

    def _rows_index(self, rows: np.ndarray) -> np.ndarray | None:
        return None if self.model.pool_size == 1 else self._index[rows]

    # --- Gymnasium API ---------------------------------------------------------------------------------

    def reset(
        self, *, seed: int | Sequence[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset all sub-envs (or those in ``options["reset_mask"]``); int seed s gives sub-env i seed s + i."""
        n = self.num_envs
        if seed is None:
            seeds: list[int | None] = [None] * n
        elif isinstance(seed, (int, np.integer)):
            seeds = [int(seed) + i for i in range(n)]
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise ValueError(f"seed: got {len(seeds)} seeds, expected {n} (one per sub-env)")
        mask = np.ones(n, dtype=bool)
        if options is not None and "reset_mask" in options:
            mask = _reset_mask(options["reset_mask"], n)
        rows = np.flatnonzero(mask)
        self._reset_rows(rows, [seeds[i] for i in rows])
        self._started = True
        # Gymnasium's VectorEnv annotates an int; its own vector envs keep one seed per sub-env too.
        self._np_random_seed = tuple(self._sub_seeds)  # type: ignore[assignment]
        result = self.model.reset_result(self._states[rows], self._rows_index(rows))
        # observe() without a result re-evaluates the radars at each state: the same numbers a step
        # into that state reported, so rows that were not reset keep their observation.
        obs = self.model.observe(
            self._states, self._steps, None, None if self.model.pool_size == 1 else self._index
        )
        info = batched_info(result)
        if len(rows) == n:
            return obs, _vector_info(info)
        return obs, _vector_info(info, rows, n)

    def _reset_rows(self, rows: np.ndarray, seeds: Sequence[int | None]) -> None:
        rows_list = np.asarray(rows).tolist()  # Python ints: the loops below index lists with them
        chosen = []
        for i, s in zip(rows_list, seeds, strict=True):
            if s is not None or self._rngs[i] is None:
                self._rngs[i], self._sub_seeds[i] = seeding.np_random(s)
            chosen.append(self._sources[i].choose(s, self._rngs[i]))
        self._load(chosen)
        position = {k: j for j, k in enumerate(self._model_keys)}
        for i, scenario in zip(rows_list, chosen, strict=True):
            self._scenarios[i] = scenario
        self._index[rows] = [position[scenario.hash] for scenario in chosen]
        self._states[rows] = self.model.initial_states([self._rngs[i] for i in rows_list], self._index[rows])
        self._steps[rows] = 0
        self._autoreset[rows] = False
        if self.render_mode is not None:
            for i in rows:
                self._tracks[i] = [self._states[i].copy()]

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every sub-env; finished ones reset as ``autoreset_mode`` prescribes."""
        if not self._started:
            raise RuntimeError("step() called before reset()")
        n = self.num_envs
        if np.ndim(actions) == 0:  # as sync mode: a scalar cannot be split into sub-env actions
            raise TypeError(f"actions: got the scalar {actions!r}, expected an array of shape ({n}, 3)")
        controls = validate_action(actions, self._high, shape=(n, 3))
        rewards = np.zeros(n)
        terminated = np.zeros(n, dtype=bool)
        truncated = np.zeros(n, dtype=bool)

        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            resetting = np.flatnonzero(self._autoreset)
            stepping = np.flatnonzero(~self._autoreset)
        else:
            if self.autoreset_mode == AutoresetMode.DISABLED and self._autoreset.any():
                raise RuntimeError(
                    "sub-envs finished: reset them with options={'reset_mask': ...} (autoreset DISABLED)"
                )
            resetting = np.zeros(0, dtype=np.intp)
            stepping = np.arange(n)

        if len(resetting):
            self._reset_rows(resetting, [None] * len(resetting))
        # Two compiled calls write every row's result and observation in place: one flies and
        # observes the stepping rows, one reports the rows reset this step (NEXT_STEP) as a reset.
        full, obs = self.model._step_observe_rows(
            self._states,
            controls,
            self._steps,
            self._index.astype(np.int64),
            stepping.astype(np.int64),
            resetting.astype(np.int64),
        )
        self._states[:] = full.state
        self._steps[:] = full.step_index
        reward = full.reward
        rewards[stepping] = reward[stepping]
        terminated[stepping] = full.terminated[stepping]
        truncated[stepping] = full.truncated[stepping]
        if self.max_episode_steps is not None:  # TimeLimit's rule: elapsed >= limit truncates
            truncated[stepping] |= self._steps[stepping] >= self.max_episode_steps
        done = terminated | truncated
        if self.render_mode is not None:
            for i in stepping:
                self._tracks[i].append(self._states[i].copy())

        info = _vector_info(batched_info(full))

        if self.autoreset_mode == AutoresetMode.SAME_STEP and done.any():
            finished = np.flatnonzero(done)
            final_obs = np.full(n, None, dtype=object)
            for i in finished:
                final_obs[i] = obs[i].copy()
            final_info = _vector_info(
                {k: v[finished] for k, v in batched_info(full).items()}, finished, n
            )
            self._reset_rows(finished, [None] * len(finished))
            index = None if self.model.pool_size == 1 else self._index
            fresh = self.model.reset_result(
                self._states[finished], None if index is None else index[finished]
            )
            obs = self.model.observe(self._states, self._steps, None, index)
            reset_info = batched_info(fresh)
            for key, value in reset_info.items():
                info[key] = info[key].copy()
                info[key][finished] = value
            info["final_obs"], info["_final_obs"] = final_obs, done.copy()
            info["final_info"], info["_final_info"] = final_info, done.copy()
        else:
            self._autoreset = done
        return obs, rewards, terminated, truncated, info

    def render(self) -> tuple[np.ndarray, ...] | None:
        """One frame per sub-env (``rgb_array``)."""
        if self.render_mode is None:
            return None
        from uav_penetration_env.render import SceneRenderer

        frames = []
        for i in range(self.num_envs):
            model = PenetrationModel(self.model.built[self._index[i]])
            renderer = SceneRenderer(model, human=False)
            frames.append(renderer.draw(np.array(self._tracks[i]), self._states[i]))
            renderer.close()
        return tuple(frames)


POOL_MODES = ("shared", "per_env")


class UAVPenetrationRandomVectorEnv(UAVPenetrationVectorEnv):
    """Vector env of ``UAVPenetrationRandom-v0``: one shared scenario pool, or one per sub-env (model.md §7c).

    Args:
        num_envs: number of sub-envs.
        difficulty: d in [0, 1].
        pool_size: pool scenarios for seedless resets.
        pool_seed: seed of the shared pool (default: the first reset's seed for sub-env 0).
        profile: ``"benchmark"`` or ``"paper"``.
        render_mode: ``"rgb_array"`` or ``None``.
        autoreset_mode: ``NEXT_STEP`` (default), ``SAME_STEP`` or ``DISABLED``.
        max_episode_steps: as for :class:`UAVPenetrationVectorEnv`.
        pool: ``"shared"`` (one pool for all sub-envs, the default) or ``"per_env"`` (sub-env i
            has its own pool seeded by its first reset's seed, exactly as sync mode); see the
            module docstring.
        id_profile: the id's profile (set at registration).
        threads: compiled threads of the batched step (as for the fixed-scenario vector env).
    """

    def __init__(
        self,
        num_envs: int = 1,
        difficulty: float = 0.5,
        pool_size: int = 32,
        pool_seed: int | None = None,
        profile: str | None = None,
        render_mode: str | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        max_episode_steps: int | None = None,
        pool: str = "shared",
        *,
        id_profile: str | None = None,
        threads: int | None = None,
    ) -> None:
        if pool not in POOL_MODES:
            raise ValueError(f"pool: got {pool!r}, expected one of {', '.join(POOL_MODES)}")
        copies = 1 if pool == "shared" else int(num_envs) if isinstance(num_envs, (int, np.integer)) else 1
        sources = [
            RandomScenarioSource(difficulty, pool_size, pool_seed, profile or id_profile)
            for _ in range(copies)
        ]
        self.pool = pool
        self._setup(num_envs, sources, render_mode, autoreset_mode, max_episode_steps, threads)
