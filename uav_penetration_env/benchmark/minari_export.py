"""Stored episodes as Farama Minari datasets, re-flown through the env (``uav-bench export --minari``, api.md §4.10).

:func:`plan_datasets` groups a store's finished episodes into datasets, one per (policy
configuration, scenario set) by default; :func:`refly_episode` flies one stored episode again
through ``gym.make`` of the dataset's env spec with the stored actions, records what the env
produced (observations, rewards, terminations, truncations, infos) and checks it against the
stored rows; :func:`write_datasets` writes the datasets under a local root, atomically. Minari
is imported only here, inside the functions (the ``offline`` extra).

DECISION (api.md §4.10, dataset layout): a dataset holds the finished episodes of one policy
configuration (``policy_hash``) on one scenario set, where the set of a scenario is its name with a
trailing ``-N`` removed (``random-10003`` is in ``random``, ``paper`` in ``paper``), so a held-out
sweep of procedural scenarios becomes one dataset. Its id is
``uav-penetration/<set>-<policy>-v<version>`` (lower case, other characters than letters,
digits, ``_`` and ``-`` replaced by ``-``; ``-<hash8>`` appended when the selection holds several
configurations of one policy name); ``--dataset-id`` names a selection that makes one dataset.
Episodes are ordered by scenario name, seed and store episode id. The dataset's env spec is the
first episode's scenario's; a set of several scenarios records each one's ``gym.make`` kwargs in
the metadata, and must share one action box (a dataset has one action space).

DECISION (api.md §4.10, what is recorded): observations, rewards, terminations, truncations and
infos are those the env returns when the stored actions are flown again from the stored seed, not
values read back from the store (which keeps no observation); the infos are the env's own info
dict (reset info first, so K + 1 rows, the exact float64 ``state`` among them). Actions are the
stored float64 actions clipped to the scenario's float64 limits, i.e. exactly what the env
consumed (it converts to float64 and clips, api.md §2.2): the dataset's action space is the env's
box with float64 bounds and dtype, since casting to the env's float32 box would change the flown
episode. The observation space is the env's own.

DECISION (api.md §4.10, replay tolerance): every re-flown episode must match the store: the same
number of steps, the end flag on the last step only, each state within ``atol + rtol * |value|``
of the stored row and the return within that of ``-total_cost`` (``total_J + total_penalty``),
with ``rtol = atol = 1e-9``. The env is deterministic, so on the machine and version that wrote
the store the states are bit for bit the stored ones and the return differs only by the rounding
of summing J and the penalty apart (about 1e-15 relative); the tolerance admits only the last-bit
differences of another compiler or CPU (the compiled model agrees with the numpy oracle to about
1e-15 relative), six orders of magnitude below the four significant digits a leaderboard prints.
An episode outside it is refused with its id, and nothing is written.

DECISION (api.md §4.10, reference scores): Minari's normalised score is
``(return - ref_min_score) / (ref_max_score - ref_min_score)`` and the env's return is minus the
episode's total cost, so a dataset's ``ref_min_score`` is minus the greedy floor's total cost
(``GreedyPolicy``, the harness's floor) and its ``ref_max_score`` minus the best-known total J*
(docs/best-known.md): the floor scores 0 and the best-known track 1. They are those of the
dataset's evaluation env, its first scenario (``recover_environment(eval_env=True)``), the env whose
returns ``get_normalized_score`` is meant for; every scenario's pair is in the project's metadata
entry (``reference_scores``). A dataset gets none when that scenario has no best-known record, a
jittered start (a record is one start state), or a record no cheaper than the greedy floor (the
score would divide by zero or flip); ``get_normalized_score`` then raises Minari's own error, and
``reference_scores`` says why.
"""

from __future__ import annotations

import contextlib
import dataclasses
import fnmatch
import json
import os
import re
import shutil
import tempfile
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from uav_penetration_env import __version__
from uav_penetration_env.benchmark.plugins import Needs
from uav_penetration_env.benchmark.store import ResultsStore

NAMESPACE = "uav-penetration"
ENV_ID = "UAVPenetration-v0"
RTOL = 1e-9
ATOL = 1e-9
REPOSITORY = "https://github.com/uav-penetration/uav-penetration"
STATE_COLUMNS = ("x_km", "y_km", "z_m", "speed", "heading", "pitch")
ACTION_COLUMNS = ("action_dv", "action_dphi", "action_dtheta")
METADATA_KEY = "uav_penetration"  # the dataset metadata entry this project adds
MINARI = Needs(
    modules=("minari",),
    install="the offline extra: pip install -e '.[offline]' in a checkout, or pip install 'uav-penetration[offline]'",
)


class MinariExportError(ValueError):
    """A selection or a stored episode that cannot become a dataset; the message names the flag or episode."""


@dataclass(frozen=True)
class DatasetPlan:
    """One dataset to write.

    Attributes:
        dataset_id: ``namespace/name-vN``.
        policy: the policy's name.
        policy_hash: its configuration hash.
        scenario_set: the scenario set's label.
        episodes: the store's episode rows, in dataset order.
    """

    dataset_id: str
    policy: str
    policy_hash: str
    scenario_set: str
    episodes: pd.DataFrame


@dataclass(frozen=True)
class Reflown:
    """One stored episode flown again: what the env produced, and how far it is from the store.

    Attributes:
        observations: (K + 1, 67) float32, the reset observation first.
        actions: (K, 3) float64, the actions the env consumed.
        rewards: (K,) float64.
        terminations, truncations: (K,) bool.
        infos: each info key -> its K + 1 values, the reset info first ((K + 1, n) arrays, lists of scalars).
        env_seed: the seed ``reset`` was given.
        return_error: |Σ rewards + total_cost|.
        state_error: the largest |re-flown state - stored state| over the track points.
    """

    observations: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    terminations: np.ndarray
    truncations: np.ndarray
    infos: dict[str, Any]
    env_seed: int
    return_error: float
    state_error: float


def scenario_set(name: str) -> str:
    """The set a scenario belongs to: its name without a trailing ``-N`` (``random-17`` -> ``random``)."""
    return re.sub(r"-\d+$", "", name) or name


def slug(text: str) -> str:
    """``text`` as a part of a Minari name: lower case, runs of other characters than ``[a-z0-9_-]`` as ``-``."""
    return re.sub(r"[^a-z0-9_-]+", "-", text.lower()).strip("-") or "x"


def plan_datasets(
    episodes: pd.DataFrame,
    *,
    policies: Sequence[str] | None = None,
    scenarios: Sequence[str] | None = None,
    dataset_id: str | None = None,
    version: int = 0,
) -> list[DatasetPlan]:
    """The datasets of a store's episodes (the module's layout decision).

    Args:
        episodes: the store's episode rows (:meth:`ResultsStore.episodes`); error rows are left out.
        policies: policy names to export (default: all).
        scenarios: scenario names, scenario-set labels or shell patterns of names
            (``random-100*``) to export (default: all).
        dataset_id: the id of the one dataset the selection makes (default: one id per dataset).
        version: the ``-vN`` of the default ids.

    Returns:
        The plans, sorted by id.

    Raises:
        MinariExportError: an unknown policy or scenario (with what the store holds), nothing to
            export, a malformed ``dataset_id``, or ``dataset_id`` for a selection of several datasets.
    """
    from uav_penetration_env.suggest import did_you_mean

    finished = episodes[episodes["error"].fillna("") == ""]
    if policies:
        names = sorted(finished["policy"].unique())
        for policy in policies:
            if policy not in names:
                raise MinariExportError(
                    f"--policy: {policy!r} has no finished episode in the store — {did_you_mean(policy, names)}"
                    f"stored: {', '.join(names) or 'none'}"
                )
        finished = finished[finished["policy"].isin(list(policies))]
    sets = finished["scenario"].map(scenario_set)
    if scenarios:
        keep = pd.Series(False, index=finished.index)
        for name in scenarios:
            chosen = (finished["scenario"] == name) | (sets == name)
            chosen |= finished["scenario"].map(
                lambda scenario, name=name: fnmatch.fnmatchcase(scenario, name)
            )
            if not chosen.any():
                known = sorted(set(finished["scenario"]) | set(sets))
                shown = ", ".join(known[:8]) + (", ..." if len(known) > 8 else "")
                raise MinariExportError(
                    f"--scenarios: {name!r} is neither a stored scenario, a scenario set nor a pattern of "
                    f"stored scenarios — {did_you_mean(name, known)}stored: {shown or 'none'}"
                )
            keep |= chosen
        finished, sets = finished[keep], sets[keep]
    if finished.empty:
        raise MinariExportError(
            "--store: no finished episode to export (the store holds only error rows or none)"
        )
    finished = finished.assign(_set=sets)
    hashes_per_name = finished.groupby("policy")["policy_hash"].nunique()
    plans = []
    for (policy_hash, label), rows in finished.groupby(["policy_hash", "_set"], sort=True):
        policy = str(rows["policy"].iloc[0])
        name = f"{slug(str(label))}-{slug(policy)}"
        if hashes_per_name[policy] > 1:
            name += f"-{str(policy_hash)[:8]}"
        ordered = rows.sort_values(["scenario", "seed", "episode_id"], kind="mergesort").drop(columns="_set")
        plans.append(
            DatasetPlan(f"{NAMESPACE}/{name}-v{version}", policy, str(policy_hash), str(label), ordered)
        )
    if dataset_id is not None:
        check_dataset_id(dataset_id)
        if len(plans) > 1:
            shown = ", ".join(p.dataset_id for p in plans[:4]) + (", ..." if len(plans) > 4 else "")
            raise MinariExportError(
                f"--dataset-id: the selection makes {len(plans)} datasets ({shown}); expected one "
                "(narrow it with --policy and --scenarios)"
            )
        plans = [dataclasses.replace(plans[0], dataset_id=dataset_id)]
    return sorted(plans, key=lambda plan: plan.dataset_id)


def check_dataset_id(dataset_id: str) -> None:
    """Refuse an id that is not Minari's ``namespace/name-vN`` (the version is required here).

    Raises:
        MinariExportError: the id does not match.
    """
    pattern = (
        r"[-_\w][-_\w/]*[-_\w]/[-_\w]+?-v\d+"  # minari.dataset.minari_dataset.DATASET_ID_RE, with both parts
    )
    if not re.fullmatch(pattern, dataset_id):
        raise MinariExportError(
            f"--dataset-id: got {dataset_id!r}, expected Minari's NAMESPACE/NAME-vN, e.g. {NAMESPACE}/paper-2022-sec5-ihpso-v0"
        )


def env_spec(scenario: Any) -> Any:
    """The Gymnasium spec that makes the env of ``scenario``: ``UAVPenetration-v0`` with the scenario as kwargs.

    The kwargs are the scenario's full mapping and its profile (so the id's benchmark profile does
    not replace a paper-profile scenario's), and ``max_episode_steps`` is its K_max, so
    ``gym.make(spec)`` (Minari's ``recover_environment``) flies the stored scenario to the hash it recorded.
    """
    import gymnasium as gym

    import uav_penetration_env  # noqa: F401  (registers the ids)

    base = gym.spec(ENV_ID)
    kwargs = {**base.kwargs, "scenario": scenario.to_dict(), "profile": scenario.profile}
    return dataclasses.replace(base, kwargs=kwargs, max_episode_steps=int(scenario.time.max_steps))


def stored_scenario(store: ResultsStore, scenario_hash: str) -> Any:
    """The stored scenario of ``scenario_hash``, read back from its YAML.

    Raises:
        MinariExportError: the scenario is not stored, does not load, or loads to another hash.
    """
    import yaml

    from uav_penetration_env.scenario import load_scenario

    name, text = store.scenarios().get(scenario_hash, (None, None))
    if text is None:
        raise MinariExportError(
            f"--store: scenario {scenario_hash} is not stored; its episodes cannot be re-flown"
        )
    try:
        scenario = load_scenario(yaml.safe_load(text))
    except (ValueError, KeyError, TypeError, yaml.YAMLError) as error:  # ScenarioError is a ValueError
        raise MinariExportError(
            f"--store: scenario {name!r} ({scenario_hash}) does not load ({error})"
        ) from None
    if scenario.hash != scenario_hash:
        raise MinariExportError(
            f"--store: scenario {name!r} loads to hash {scenario.hash}, not the {scenario_hash} its episodes "
            "recorded (written by another version?); its episodes cannot be re-flown as stored"
        )
    return scenario


def reference_scores(scenario: Any, records: str | Path | None = None) -> dict[str, Any]:
    """The greedy floor's and the best-known total cost of a scenario, as Minari reference scores.

    Args:
        scenario: the scenario.
        records: a best-known records folder (default: the package's committed records).

    Returns:
        ``greedy_total_cost``, ``best_known_total_cost`` (``None`` without a record),
        ``ref_min_score`` and ``ref_max_score`` (minus those costs; both ``None`` when they cannot
        normalise, DECISION api.md §4.10) and ``reason`` (why not, ``""`` when they can).
    """
    from uav_penetration_env.benchmark.bestknown import best_known_total
    from uav_penetration_env.benchmark.bestknown.compute import greedy_track

    jitter = scenario.start.jitter
    if jitter.xy_km > 0 or jitter.heading_deg > 0:
        return {
            "greedy_total_cost": None,
            "best_known_total_cost": None,
            "ref_min_score": None,
            "ref_max_score": None,
            "reason": "a jittered start: no best-known record, and the greedy floor's cost depends on the seed",
        }
    _, greedy = greedy_track(scenario)
    best = best_known_total(scenario.hash, records)
    if best is None:
        reason = "no best-known record of this scenario (uav-bench best-known compute)"
    elif not best < greedy:
        reason = f"the best-known total {best!r} is not below the greedy floor's {greedy!r}"
    else:
        reason = ""
    return {
        "greedy_total_cost": greedy,
        "best_known_total_cost": best,
        "ref_min_score": None if reason else -greedy,
        "ref_max_score": None if reason else -float(best),  # type: ignore[arg-type]
        "reason": reason,
    }


def refly_episode(env: Any, episode: Mapping[str, Any], steps: pd.DataFrame) -> Reflown:
    """Fly a stored episode again with its stored actions and check it against the store (the module's tolerance).

    Args:
        env: ``gym.make`` of the episode's :func:`env_spec`.
        episode: its store row (``seed``, ``scenario_hash``, ``steps``, ``total_cost``, ``episode_id``).
        steps: its step rows, step 0 (the start state) included when stored, sorted by step.

    Raises:
        MinariExportError: the stored actions are missing or the flight differs from the store.
    """
    from uav_penetration_env.benchmark.seeding import episode_seeds

    label = f"episode {int(episode['episode_id'])} ({episode['policy']} on {episode['scenario']}, seed {int(episode['seed'])})"
    moves = steps[steps["step"] > 0]
    expected_steps = int(episode["steps"])
    if len(moves) != expected_steps or moves[list(ACTION_COLUMNS)].isna().any().any():
        raise MinariExportError(
            f"--store: {label} has {len(moves)} step rows with actions, its row says {expected_steps}; cannot re-fly it"
        )
    env_seed, _ = episode_seeds(int(episode["seed"]), str(episode["scenario_hash"]))
    high = np.asarray(env.unwrapped.model.limits.action_high, dtype=np.float64)
    actions = np.clip(moves[list(ACTION_COLUMNS)].to_numpy(dtype=np.float64), -high, high)
    observation, info = env.reset(seed=env_seed)
    observations, infos = [observation], [info]
    rewards, terminations, truncations = [], [], []
    for k, action in enumerate(actions):
        observation, reward, terminated, truncated, info = env.step(action)
        observations.append(observation)
        infos.append(info)
        rewards.append(float(reward))
        terminations.append(bool(terminated))
        truncations.append(bool(truncated))
        if (terminated or truncated) != (k == len(actions) - 1):
            when = f"ended at step {k + 1}" if terminated or truncated else "did not end at its last step"
            raise MinariExportError(
                f"--store: {label} re-flown {when}, the store has {len(actions)} steps; nothing written"
            )
    stored = steps[list(STATE_COLUMNS)].to_numpy(dtype=np.float64)
    flown = np.array([_state_row(i) for i in infos])
    flown = flown[len(flown) - len(stored) :]  # a store without the step-0 row compares from step 1
    state_error = float(np.max(np.abs(flown - stored), initial=0.0))
    if not np.allclose(flown, stored, rtol=RTOL, atol=ATOL):
        raise MinariExportError(
            f"--store: {label} re-flown leaves the stored track (largest state difference {state_error:.3g}, "
            f"tolerance {ATOL:g} + {RTOL:g}·|x|); this version does not fly it as stored, nothing written"
        )
    total = float(np.sum(rewards))
    target = -float(episode["total_cost"])
    return_error = abs(total - target)
    if not return_error <= ATOL + RTOL * abs(target):
        raise MinariExportError(
            f"--store: {label} re-flown returns {total!r}, the store's -total_cost is {target!r} "
            f"(difference {return_error:.3g} > {ATOL:g} + {RTOL:g}·|total|); nothing written"
        )
    return Reflown(
        observations=np.asarray(observations, dtype=env.observation_space.dtype),
        actions=actions,
        rewards=np.asarray(rewards, dtype=np.float64),
        terminations=np.asarray(terminations, dtype=bool),
        truncations=np.asarray(truncations, dtype=bool),
        infos={key: _info_column([i[key] for i in infos]) for key in infos[0]},
        env_seed=env_seed,
        return_error=return_error,
        state_error=state_error,
    )


def _info_column(values: list[Any]) -> Any:
    """One info key over the episode: a (K + 1, n) array for array values, a list for scalars.

    Minari's Arrow storage reads a 1-D array back only when it is given as a list (it records an
    empty shape for it otherwise, and fails to decode it).
    """
    if isinstance(values[0], np.ndarray):
        return np.stack(values)
    return [value.item() if isinstance(value, np.generic) else value for value in values]


def _state_row(info: Mapping[str, Any]) -> list[float]:
    """The stored step row's state columns, as the store derives them from an info (columns.STEP)."""
    return [*map(float, info["position"]), *map(float, info["state"][3:])]


def write_datasets(
    store: ResultsStore, plans: Sequence[DatasetPlan], out: Path, *, records: str | Path | None = None
) -> list[Path]:
    """Re-fly every planned episode, then write the datasets under the local Minari root ``out``.

    Each dataset is built in a temporary root inside ``out`` and renamed into place once whole, so
    an interrupted export leaves no dataset that looks complete; every episode of every plan is
    re-flown and checked before the first one is renamed. ``minari.load_dataset(id)`` with
    ``MINARI_DATASETS_PATH=out`` reads them back.

    Returns:
        The dataset folders written (``out/<namespace>/<name>-vN``).

    Raises:
        MinariExportError: a dataset id already in ``out``, or an episode that does not re-fly as stored.
    """
    import gymnasium as gym

    out = Path(out).absolute()  # Minari joins a relative dataset path to its root again (data/<root>/...)
    for plan in plans:
        if (out / plan.dataset_id).exists():
            raise MinariExportError(
                f"--out: {out / plan.dataset_id} exists; expected a new dataset id (remove it, or pass "
                "--dataset-version N or --dataset-id)"
            )
    runs = store.runs()
    policies = store.policies()
    scenarios: dict[str, Any] = {}
    flown: list[tuple[DatasetPlan, list[Reflown], dict[str, Any]]] = []
    for plan in plans:
        episodes = []
        specs: dict[str, Any] = {}
        envs: dict[str, Any] = {}  # one env per scenario, reset for each of its episodes
        rows = store.steps(plan.episodes["episode_id"].astype(int).tolist(), include_start=True)
        steps_of = dict(iter(rows.groupby("episode_id", sort=False)))
        for _, episode in plan.episodes.iterrows():
            scenario_hash = str(episode["scenario_hash"])
            if scenario_hash not in scenarios:
                scenarios[scenario_hash] = stored_scenario(store, scenario_hash)
            if scenario_hash not in specs:
                specs[scenario_hash] = env_spec(scenarios[scenario_hash])
                envs[scenario_hash] = gym.make(specs[scenario_hash])
            steps = steps_of.get(int(episode["episode_id"]), rows.iloc[:0]).sort_values("step")
            episodes.append(refly_episode(envs[scenario_hash], episode, steps))
        for env in envs.values():
            env.close()
        _check_one_action_box(plan, [scenarios[h] for h in specs])
        flown.append((plan, episodes, specs))
    out.mkdir(parents=True, exist_ok=True)  # after every episode re-flew: a refusal writes nothing
    temporary = Path(tempfile.mkdtemp(prefix=".minari-export-", dir=out))
    written = []
    try:
        built = []
        with _datasets_root(temporary):
            for plan, episodes, specs in flown:
                metadata = dataset_metadata(store, plan, episodes, specs, scenarios, policies, runs)
                references = {h: reference_scores(scenarios[h], records) for h in specs}
                metadata["reference_scenario"] = next(iter(specs))  # the evaluation env's scenario
                metadata["reference_scores"] = references
                _create(plan, episodes, specs, metadata, references[next(iter(specs))])
                built.append(plan.dataset_id)
        for dataset_id in built:
            target = out / dataset_id
            target.parent.mkdir(parents=True, exist_ok=True)
            _copy_namespace_metadata(temporary, out, dataset_id)
            os.replace(temporary / dataset_id, target)
            written.append(target)
    finally:
        shutil.rmtree(temporary, ignore_errors=True)
    return written


def dataset_metadata(
    store: ResultsStore,
    plan: DatasetPlan,
    episodes: Sequence[Reflown],
    specs: Mapping[str, Any],
    scenarios: Mapping[str, Any],
    policies: Mapping[str, tuple[str, Mapping[str, Any]]],
    runs: pd.DataFrame,
) -> dict[str, Any]:
    """The project's entry of a dataset's metadata (``metadata["uav_penetration"]``, api.md §4.10).

    Keys: ``project_version``, ``env_id``, ``policy`` (name, hash, config), ``scenario_set``,
    ``scenarios`` (hash -> name, episodes and the ``gym.make`` kwargs of its env), ``store`` (path,
    the provenance of the runs that wrote the episodes), ``replay`` (tolerances and the largest
    differences measured), ``reward`` (what a step's reward is); :func:`write_datasets` adds
    ``reference_scenario`` and ``reference_scores`` (DECISION api.md §4.10).
    """
    _, config = policies.get(plan.policy_hash, (plan.policy, {}))
    run_ids = sorted({int(r) for r in plan.episodes["run_id"].dropna()})
    provenance = [
        {"run_id": int(row["run_id"]), "started": row["started"], **json.loads(row["provenance"] or "{}")}
        for _, row in runs[runs["run_id"].isin(run_ids)].iterrows()
    ]
    counts = plan.episodes["scenario_hash"].value_counts()
    return {
        "project_version": __version__,
        "env_id": ENV_ID,
        "policy": {"name": plan.policy, "hash": plan.policy_hash, "config": dict(config)},
        "scenario_set": plan.scenario_set,
        "scenarios": {
            h: {"name": scenarios[h].name, "episodes": int(counts[h]), "env_kwargs": specs[h].kwargs}
            for h in sorted(specs)
        },
        "store": {"path": str(Path(store.path).resolve()), "runs": provenance},
        "replay": {
            "rtol": RTOL,
            "atol": ATOL,
            "max_return_error": max(e.return_error for e in episodes),
            "max_state_error": max(e.state_error for e in episodes),
        },
        "reward": "-(J + penalty) per step; an episode's sum is -total_cost of the store",
    }


def _create(
    plan: DatasetPlan,
    episodes: Sequence[Reflown],
    specs: Mapping[str, Any],
    metadata: dict,
    references: Mapping[str, Any],
) -> None:
    """One dataset in the current Minari root (:func:`_datasets_root`), with its per-episode metadata."""
    import gymnasium as gym
    import minari
    from minari.data_collector.episode_buffer import EpisodeBuffer

    from uav_penetration_env.benchmark.provenance import git_commit

    first = next(iter(specs))  # the first episode's scenario (the only one, unless the set has several)
    env: Any = gym.make(specs[first])
    high = np.asarray(env.unwrapped.model.limits.action_high, dtype=np.float64)
    buffers = [
        EpisodeBuffer(
            id=i,
            seed=e.env_seed,
            observations=e.observations,
            actions=e.actions,
            rewards=list(e.rewards),
            terminations=list(e.terminations),
            truncations=list(e.truncations),
            infos=e.infos,
        )
        for i, e in enumerate(episodes)
    ]
    # Both or neither: given ref_max_score alone, Minari would fly a random policy for ref_min_score.
    scores: dict[str, Any] = {}
    if references["ref_min_score"] is not None:
        scores = {
            "ref_min_score": references["ref_min_score"],
            "ref_max_score": references["ref_max_score"],
            "num_episodes_average_score": 1,  # one deterministic episode each: the floor, the record
        }
    commit = git_commit().removesuffix("-dirty")  # the permalink names the commit the code is based on
    with warnings.catch_warnings():
        # Minari asks for an author e-mail; the testbed has none to give.
        warnings.filterwarnings("ignore", message=".*author_email.*", category=UserWarning)
        dataset = minari.create_dataset_from_buffers(
            dataset_id=plan.dataset_id,
            buffer=buffers,
            env=specs[first],
            eval_env=specs[first],
            algorithm_name=plan.policy,
            author="uav-penetration testbed (uav-bench export --minari)",
            code_permalink=f"{REPOSITORY}/tree/{commit}" if commit != "unknown" else REPOSITORY,
            action_space=gym.spaces.Box(-high, high, dtype=np.float64),
            observation_space=env.observation_space,
            description=(
                f"{plan.policy} (configuration {plan.policy_hash}) on the {plan.scenario_set!r} scenarios of "
                f"uav-penetration {__version__}: stored episodes re-flown through {ENV_ID}; see docs/api.md §4.10"
            ),
            data_format="arrow",
            requirements=[f"uav-penetration=={__version__}"],
            **scores,
        )
    env.close()
    dataset.storage.update_metadata({METADATA_KEY: metadata})
    rows = plan.episodes.reset_index(drop=True)
    dataset.storage.update_episode_metadata(
        [
            {
                "store_episode_id": int(row["episode_id"]),
                "episode_seed": int(row["seed"]),
                "scenario": str(row["scenario"]),
                "scenario_hash": str(row["scenario_hash"]),
                "outcome": str(row["outcome"]),
                "total_J": float(row["total_J"]),
                "total_penalty": float(row["total_penalty"]),
                "total_cost": float(row["total_cost"]),
            }
            for _, row in rows.iterrows()
        ],
        range(len(rows)),
    )


def _check_one_action_box(plan: DatasetPlan, scenarios: Sequence[Any]) -> None:
    """Refuse a dataset whose scenarios have different action limits (a dataset has one action space).

    Raises:
        MinariExportError: two scenarios' per-step limits differ.
    """
    from uav_penetration_env.kinematics import UAVLimits

    first = UAVLimits.from_scenario(scenarios[0]).action_high
    for scenario in scenarios[1:]:
        if not np.array_equal(UAVLimits.from_scenario(scenario).action_high, first):
            raise MinariExportError(
                f"--scenarios: {plan.dataset_id} would mix {scenarios[0].name!r} and {scenario.name!r}, whose "
                "action limits differ; expected scenarios of one action box per dataset (export them apart)"
            )


def _copy_namespace_metadata(temporary: Path, out: Path, dataset_id: str) -> None:
    """Give ``out`` the namespace files Minari wrote in the temporary root, where it has none."""
    parts = dataset_id.split("/")[:-1]
    for depth in range(1, len(parts) + 1):
        name = Path(*parts[:depth]) / "namespace_metadata.json"
        if (temporary / name).is_file() and not (out / name).is_file():
            (out / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(temporary / name, out / name)


@contextlib.contextmanager
def _datasets_root(root: Path) -> Iterator[None]:
    """Minari's local root set to ``root`` (``MINARI_DATASETS_PATH``) for the block, then restored."""
    before = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(root)
    try:
        yield
    finally:
        if before is None:
            os.environ.pop("MINARI_DATASETS_PATH", None)
        else:
            os.environ["MINARI_DATASETS_PATH"] = before
