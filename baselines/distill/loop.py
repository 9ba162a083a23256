"""Behaviour cloning, then DAgger (Ross, Gordon & Bagnell 2011), resumable round by round.

Round 0 flies the expert on every training scenario and fits the network to its actions
(behaviour cloning). Round k >= 1 flies the network of round k-1 (the expert takes a step with
probability beta_k), labels every visited state by the expert, adds the labels to the data set and
refits on all rounds so far. Each episode is saved as soon as it is flown, each round's network
with its sidecar after the fit; rerunning continues from the last finished round (docs/rl.md §4.3).
"""

from __future__ import annotations

import dataclasses
import json
import shutil
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from baselines.distill.config import DistillConfig, checked, ignored_slots
from baselines.distill.episodes import FIELDS, fly_episode, fly_learner
from baselines.distill.features import input_size, value_prior
from baselines.distill.files import RunFolder, load_npz, save_npz, sha256_file, write_json
from baselines.distill.heads import TURNS, expert_clearance, learner_of, turn_classes
from baselines.distill.network import fit, observation_scaling
from uav_penetration_env.env import UAVPenetrationEnv
from uav_penetration_env.model import OBSERVATION_SIZE
from uav_penetration_env.value_function import LATTICE_GUIDANCE

FORMAT = "uav-penetration-distill-1"
# The third entropy word of the validation episodes' seeds (the rounds' episodes use the round index).
VALIDATION_STREAM = 1_000_003


@dataclass(frozen=True)
class DistillResult:
    """A finished run: its folder, the final policy's sidecar and each round's sidecar."""

    folder: RunFolder
    sidecar: dict[str, Any]
    rounds: list[dict[str, Any]]


class _Context:
    """The run's expert, scenarios and their envs (built on first use), shared by all rounds."""

    def __init__(self, config: DistillConfig) -> None:
        self.config = config
        self.scenarios = config._scenario_objects or ()
        # The maps the rounds are selected on: the validation maps, or (folders made before them) the training maps.
        self.validation = config._validation_objects or self.scenarios
        self.expert = _make_expert(config.expert)
        self._envs: dict[tuple[str, int], UAVPenetrationEnv] = {}

    def env(self, index: int, validation: bool = False) -> UAVPenetrationEnv:
        key = ("validation" if validation else "training", index)
        if key not in self._envs:
            self._envs[key] = UAVPenetrationEnv((self.validation if validation else self.scenarios)[index])
        return self._envs[key]


def _make_expert(expert: Any) -> Any:
    if not isinstance(expert, str):
        return expert
    from uav_penetration_env.benchmark.policies import make_policy

    return make_policy(expert)


def run_key(config: DistillConfig) -> dict[str, Any]:
    """What a run folder was made with: the config's key and the training scenarios' hashes."""
    scenarios = config._scenario_objects or ()
    validation = config._validation_objects or ()
    return {"format": FORMAT, **config.key(), "scenario_hashes": [s.hash for s in scenarios],
            **({"validation_hashes": [s.hash for s in validation]} if validation else {})}  # fmt: skip


def _check_key(folder: RunFolder, key: dict[str, Any]) -> None:
    """Write the run's key, or refuse to continue a folder made with another one (naming the field)."""
    if not folder.config.is_file():
        write_json(folder.config, key)
        return
    found = json.loads(folder.config.read_text())
    for name in sorted(set(found) | set(key)):
        if found.get(name) != key.get(name):
            flag = {"scenario_hashes": "scenarios"}.get(name, name).replace("_", "-")
            raise ValueError(
                f"--{flag}: the run folder {folder.out} was made with {found.get(name)!r}, "
                f"not {key.get(name)!r}; use another --out or the same settings"
            )


def collect_round(context: _Context, folder: RunFolder, k: int, learner: dict[str, np.ndarray] | None) -> dict[str, Any]:
    """Fly (or read back) every episode of round ``k``; returns the round's arrays and tallies.

    An episode already on disk is read, not flown: its expert labels are never computed again.

    DECISION (docs/rl.md §4.3): every visited state is labelled, including the steps the expert
    flies under beta-mixing (its label is then the action it applied), and each episode is saved
    as soon as it is flown: with an MPC expert at seconds per label, a cut round loses at most one
    episode of labels.
    """
    config = context.config
    beta = config.beta(k)
    fly = None if learner is None else learner_of(learner)
    parts, summaries, labels, seconds = [], [], 0, 0.0
    for i in range(len(context.scenarios)):
        for j in range(config.episodes):
            path = folder.episode(k, i * config.episodes + j)
            if not path.is_file():
                tick = time.process_time()
                data, count = fly_episode(
                    context.env(i), context.expert, fly, beta, np.random.SeedSequence([config.seed, k, i, j]),
                    config.features,
                )
                spent = time.process_time() - tick
                tallies = {"labels": np.int64(count), "cpu_seconds": np.float64(spent)}
                summary = {f"summary_{n}": np.asarray(v) for n, v in data.summary.items()}
                save_npz(path, {**data.arrays, **tallies, **summary})
            episode = load_npz(path)
            parts.append({name: episode[name] for name in FIELDS})
            labels += int(episode["labels"])
            seconds += float(episode["cpu_seconds"])
            summaries.append(
                {"scenario": context.scenarios[i].name, "episode": j}
                | {n.removeprefix("summary_"): episode[n].item() for n in episode if n.startswith("summary_")}
            )
    arrays = {name: np.concatenate([p[name] for p in parts]) for name in FIELDS}
    return {"arrays": arrays, "episodes": summaries, "labels": labels, "cpu_seconds": seconds, "beta": beta}


def _aggregate(folder: RunFolder, rounds: int) -> dict[str, np.ndarray]:
    """The data of rounds 0..rounds-1, in round order (DAgger's aggregated data set)."""
    parts = [load_npz(folder.round_data(k)) for k in range(rounds)]
    return {name: np.concatenate([p[name] for p in parts]) for name in FIELDS}


def _fit_round(config: DistillConfig, folder: RunFolder, k: int, start: dict[str, np.ndarray] | None) -> tuple[dict[str, np.ndarray], float, int, float]:
    """Refit on rounds 0..k; returns the arrays, the final loss, the data size and the fit's CPU seconds."""
    data = _aggregate(folder, k + 1)
    if start is not None:
        scaling = (start["obs_mean"], start["obs_scale"])
    else:
        width = data["observations"].shape[1]
        scaling = observation_scaling(data["observations"], ignored_slots(config.ignore, width))
    turn = config.head != "action"
    targets = turn_classes(data["actions"]) if turn else data["actions"]
    prior = value_prior(config.features, data["observations"]) if config.head == "turn-value" else None
    tick = time.process_time()
    arrays, loss = fit(
        data["observations"], targets, start=start, scaling=scaling, hidden=config.hidden,
        epochs=config.epochs, batch_size=config.batch_size, learning_rate=config.learning_rate,
        seed=(config.seed, k), loss=config.loss, classes=len(TURNS) if turn else 0, prior=prior,
    )  # fmt: skip
    if turn:
        arrays["turns"] = np.asarray(TURNS, dtype=np.float32)
        clearance = expert_clearance(_make_expert(config.expert))
        if clearance != LATTICE_GUIDANCE.clearance_m:  # a network of the default expert keeps its old arrays
            arrays["clearance_m"] = np.asarray(clearance)
    if config.features:
        arrays["features"] = np.asarray(config.features, dtype=str)
    return arrays, loss, len(data["actions"]), time.process_time() - tick


def _round_sidecar(key: dict[str, Any], k: int, collected: dict[str, Any], fitted: tuple, wall: float) -> dict[str, Any]:
    _, loss, rows, fit_seconds = fitted
    return {
        "round": k,
        "beta": collected["beta"],
        "episodes": collected["episodes"],
        "new_rows": len(collected["arrays"]["actions"]),
        "learner_rows": int((~collected["arrays"]["expert_flew"]).sum()),
        "data_rows": rows,
        "expert_labels": collected["labels"],
        "collect_cpu_seconds": collected["cpu_seconds"],
        "fit_cpu_seconds": fit_seconds,
        "wall_seconds": wall,
        "loss": loss,
        "key": key,
    }


def run_round(context: _Context, folder: RunFolder, key: dict[str, Any], k: int, start: dict[str, np.ndarray] | None) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Round ``k``: collect (or read) its episodes, save its data, refit, save the network and its sidecar."""
    tick = time.perf_counter()
    collected = collect_round(context, folder, k, start)
    save_npz(folder.round_data(k), collected["arrays"])
    fitted = _fit_round(context.config, folder, k, start)
    arrays = fitted[0]
    save_npz(folder.net(k), arrays)
    sidecar = _round_sidecar(key, k, collected, fitted, time.perf_counter() - tick)
    tock = time.process_time()
    sidecar["validation"] = validate(context, arrays)
    sidecar["validate_cpu_seconds"] = time.process_time() - tock
    # Each round's network is a policy of its own (``distill:OUT/nets/round-K.npz``), so the
    # rounds can be scored side by side; its sidecar is the policy sidecar plus the round's record.
    rounds = [*_read_rounds(folder, k), sidecar]
    full = policy_sidecar(context.config, key, rounds, sha256_file(folder.net(k)), k)
    write_json(folder.net_sidecar(k), {**full, "this_round": sidecar})  # last: the round is finished
    shutil.rmtree(folder.episode(k, 0).parent, ignore_errors=True)  # the round file holds them all
    return arrays, sidecar


def validate(context: _Context, arrays: dict[str, np.ndarray]) -> list[dict[str, Any]]:
    """The network alone on each validation scenario (one episode, no expert): its cost per scenario.

    The same seeds for every round, so the rounds' networks are compared on the same starts. The
    validation scenarios are apart from the training ones and from every published table
    (:class:`~baselines.distill.config.DistillConfig`); a folder made before they existed
    validates on its training scenarios.
    """
    rows = []
    for i, scenario in enumerate(context.validation):
        seeds = np.random.SeedSequence([context.config.seed, VALIDATION_STREAM, i])
        row = fly_learner(context.env(i, validation=True), learner_of(arrays), seeds)
        rows.append({"scenario": scenario.name, **row})
    return rows


def select_round(rounds: list[dict[str, Any]], rule: str) -> int:
    """The round whose network becomes the policy: the last, or the lowest mean validation cost.

    DECISION (docs/rl.md §4.5): by default the round with the lowest mean validation cost (total
    J + failure penalty, the tuning objective of §1.1) over the validation scenarios, ties to the
    later round, as Ross et al. return the best of the rounds' policies on validation: the last
    refit is the one network never flown before it is chosen, and one refit can break a route
    the previous network flew (measured in §4.6). The held-out scenarios are never used to choose.
    """
    if rule == "last":
        return len(rounds) - 1
    costs = [float(np.mean([v["cost"] for v in r["validation"]])) for r in rounds]
    best = min(costs)
    return max(k for k, c in enumerate(costs) if c == best)


def _read_rounds(folder: RunFolder, count: int) -> list[dict[str, Any]]:
    return [json.loads(folder.net_sidecar(k).read_text())["this_round"] for k in range(count)]


def policy_sidecar(
    config: DistillConfig, key: dict[str, Any], rounds: list[dict[str, Any]], weights_sha256: str, chosen: int
) -> dict[str, Any]:
    """A policy's sidecar: what it imitates, what it was fitted on, what the run cost.

    ``rounds`` are every round the run flew (the cost: labels and CPU seconds of them all, since
    choosing round ``chosen`` needed them); ``chosen`` is the round whose network this is (its
    data rows).
    """
    from uav_penetration_env.benchmark.provenance import provenance

    scenarios = config._scenario_objects or ()
    expert = _make_expert(config.expert)
    expert_config = expert.config() if callable(getattr(expert, "config", None)) else None
    collect = sum(r["collect_cpu_seconds"] + r["validate_cpu_seconds"] for r in rounds)
    fitting = sum(r["fit_cpu_seconds"] for r in rounds)
    return {
        "format": FORMAT,
        "expert": key["expert"],
        "expert_config": expert_config,
        "rounds": len(rounds) - 1,
        "round": chosen,
        "data_rows": rounds[chosen]["data_rows"],
        "learner_rows": sum(r["learner_rows"] for r in rounds),
        "expert_labels": sum(r["expert_labels"] for r in rounds),
        "train_cpu_seconds": collect + fitting,
        "collect_cpu_seconds": collect,
        "fit_cpu_seconds": fitting,
        "train_wall_seconds": sum(r["wall_seconds"] for r in rounds),
        "scenarios": [{"name": s.name, "hash": s.hash} for s in scenarios],
        "profiles": sorted({s.profile for s in scenarios}),
        "observation_size": OBSERVATION_SIZE,
        "input_size": input_size(config.features),
        "features": list(config.features),
        "hidden": list(config.hidden),
        "activation": "tanh",
        "head": config.head,
        "ignore": list(config.ignore),
        "action": "normalised to [-1, 1] by the env's action box; clipped",
        "weights_sha256": weights_sha256,
        "key": key,
        "provenance": provenance(),
    }


def run_distill(config: DistillConfig | None = None, /, *, log: Any = None, **fields: Any) -> DistillResult:
    """Run (or continue) a distillation into ``config.out``; returns the final policy's sidecar.

    Args:
        config: the run (default: :class:`DistillConfig` with ``fields``).
        log: a callable given one line per round (default: silent).
        **fields: changes to ``config``.

    Raises:
        ValueError: a bad setting, or a run folder made with other settings (naming the flag).
    """
    config = checked(dataclasses.replace(config or DistillConfig(), **fields))
    _set_threads(config.torch_threads)
    folder = RunFolder(config.out)
    key = run_key(config)
    _check_key(folder, key)
    done = folder.finished_rounds()
    context = _Context(config)
    start = load_npz(folder.net(done - 1)) if done else None
    for k in range(done, config.rounds + 1):
        start, sidecar = run_round(context, folder, key, k, start)
        if log is not None:
            log(_round_line(sidecar))
    rounds = _read_rounds(folder, config.rounds + 1)
    chosen = select_round(rounds, config.select)
    shutil.copyfile(folder.net(chosen), folder.policy)
    sidecar = policy_sidecar(config, key, rounds, sha256_file(folder.policy), chosen)
    sidecar["selected_round"] = chosen
    sidecar["select"] = config.select
    sidecar["validation_costs"] = [float(np.mean([v["cost"] for v in r["validation"]])) for r in rounds]
    write_json(folder.policy_sidecar, sidecar)
    if log is not None:
        log(f"selected round {chosen} ({config.select}); mean validation cost per round: "
            + ", ".join(f"{c:.2f}" for c in sidecar["validation_costs"]))  # fmt: skip
    return DistillResult(folder, sidecar, rounds)


def _round_line(sidecar: dict[str, Any]) -> str:
    episodes = sidecar["episodes"]
    success = sum(e["outcome"] == "success" for e in episodes)
    mean_j = float(np.mean([e["total_J"] for e in episodes]))
    return (
        f"round {sidecar['round']}: beta {sidecar['beta']:.3g}, {success}/{len(episodes)} episodes reached the goal "
        f"(mean J {mean_j:.2f}), +{sidecar['new_rows']} rows ({sidecar['learner_rows']} flown by the learner), "
        f"{sidecar['data_rows']} in all, loss {sidecar['loss']:.4g}, validation: {_validation_text(sidecar)}, "
        f"CPU {sidecar['collect_cpu_seconds']:.1f} s flying + {sidecar['fit_cpu_seconds']:.1f} s fitting"
    )


def _validation_text(sidecar: dict[str, Any]) -> str:
    rows = sidecar["validation"]
    success = sum(v["outcome"] == "success" for v in rows)
    return f"{success}/{len(rows)} reached the goal, mean cost {np.mean([v['cost'] for v in rows]):.2f}"


def _set_threads(threads: int) -> None:
    try:
        import torch
    except ImportError:  # pragma: no cover - fit() says what to install
        return
    torch.set_num_threads(threads)
