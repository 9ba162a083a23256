"""What a distillation run is: :class:`DistillConfig`, checked into the scenarios it trains on.

Every field is declared once, with its flag, help, kind and domain
(:func:`uav_penetration_env.settings_fields.setting`): ``uav-bench distill``'s flags (``--FIELD``
with ``_`` as ``-``), the defaults and the checks are generated from it, so a bad value is refused
in one line naming that flag, from the command line or from Python. The training scenarios are checked against the scenarios the
published results are measured on: a procedural seed of the held-out set, a frozen suite or the
tuning validation is refused (docs/rl.md §4.4).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from uav_penetration_env.benchmark.commands.common import path_argument
from uav_penetration_env.catalogue import RANDOM_PREFIX, random_seeds, resolve_scenarios
from uav_penetration_env.observation import OBSERVATION_SIZE, SLOTS
from uav_penetration_env.scenario import Scenario
from uav_penetration_env.settings_fields import UNIT_INTERVAL, at_least, check_fields, one_of, setting

# Seeds of procedural scenarios that some published number is measured on (docs/rl.md §1.1): the
# held-out set, the frozen suite's procedural members, the learning-curve and tuning-validation seeds.
RESERVED_SEEDS: dict[str, range] = {
    "the held-out set": range(10000, 10050),
    "the learning curves": range(20000, 20020),
    "the suite uavpen-v1": range(30000, 30220),
    "the tuning validation": range(40000, 40050),
    "the held-out set uavpen-heldout-v2": range(70000, 70050),
}
# DECISION (docs/rl.md §4.4): procedural maps only, apart from every published table (the paper
# scenario is a member of uavpen-v1): training on 40 maps, round selection on 20 others.
DEFAULT_SCENARIOS = ("random:50000-50039",)
DEFAULT_VALIDATION = ("random:60000-60019",)
LOSSES = ("mse", "mse-std")
SELECTIONS = ("best", "last")
HEADS = ("action", "turn", "turn-value")  # what the network's outputs mean (baselines.distill.heads)


@dataclass(frozen=True)
class DistillConfig:
    """One behaviour-cloning + DAgger run (docs/rl.md §4).

    Attributes:
        out: the run folder (round data, networks, the final policy and its sidecar).
        expert: a harness policy spec (:func:`~uav_penetration_env.benchmark.policies.make_policy`),
            or, from Python, a policy object with ``reset``, ``act`` and ``config``.
        scenarios: scenario specs (names, ``random:SEED``, ``random:A-B``, YAML paths).
        difficulty: the difficulty of the ``random:`` forms.
        rounds: DAgger rounds after the behaviour-cloning round 0.
        episodes: episodes per scenario and round.
        beta0, decay: the expert flies a step with probability ``beta0 * decay**k`` in round k
            (round 0: the expert alone).
        hidden: the MLP's hidden widths.
        epochs: passes over the aggregated data at each refit.
        batch_size, learning_rate: the Adam minibatches and step size.
        seed: seeds the network's initialisation, the minibatches, the episodes and the mixing.
        torch_threads: torch's intra-op threads (1: repeatable sums, and fastest for this MLP).
        loss: ``mse`` (the normalised action's three channels weighted alike) or ``mse-std``
            (each channel divided by its spread in the round-0 labels; docs/rl.md §4.2).
        select: which round's network becomes the policy: ``best`` (lowest mean validation cost)
            or ``last`` (docs/rl.md §4.5); not part of the key, so a finished run can be re-selected.
        head: ``action`` (the network regresses the normalised action) or ``turn`` (it classifies
            the expert's turn into the lattice's five turns and flies the lattice's candidate
            control for it; docs/rl.md §4.8); ``turn-value``: the ``turn`` head whose logits add a
            learned multiple of minus each turn's value input to the network's own, a residual on
            the ``value-greedy`` rule (needs ``--features value``; docs/rl.md §4.9).
        ignore: observation slots the network is blind to (names of
            :data:`uav_penetration_env.observation.SLOTS`, e.g. ``position``, ``step_fraction``;
            docs/rl.md §4.8).
        features: inputs appended to the observation (names of
            :data:`baselines.distill.features.FEATURE_SETS`, e.g. ``value``: the cost-to-go field
            around the pose; docs/rl.md §4.9).
        validation: scenario specs the rounds' networks are flown on to select one (``select
            best``), apart from the training scenarios; empty: the training scenarios (the rule
            of the v3 networks).
        allow_published_maps: train or validate on the map of a published table (only to
            reproduce the v3 networks, which were trained on the paper scenario; their results on
            those tables are in sample).

    DECISION (docs/rl.md §4.1): beta_k = beta0 * decay**k with beta0 = 1 and decay = 0.5, Ross,
    Gordon & Bagnell's schedule beta_i = p**(i-1) with p = 1/2: round 0 is the expert alone
    (behaviour cloning), round 1 mixes half and half, and by round 4 the learner flies 15 steps of
    16, so the data soon come from the learner's own state distribution while the first refits,
    from a weak network, still see mostly the expert's route.

    DECISION (docs/rl.md §4.4): the default training scenarios are the procedural scenarios of
    seeds 50000-50039 at difficulty 0.5, one episode each per round, and the rounds are selected
    on seeds 60000-60019: no map of a published table (:mod:`uav_penetration_env.suites.published`,
    checked by :func:`checked`), so every published result of a network is out of sample; 40
    layouts of terrain and radars keep it from being a lookup table of one route.
    """

    out: Path = setting(
        Path("results/distill/run"), object, "the run folder (round data, networks, policy.npz + policy.json)",
        parse=path_argument, required=True, default_text="",
    )  # fmt: skip
    # Checked by make_policy in checked() (from Python, a policy object is accepted too).
    expert: Any = setting(
        "lattice", object, "the planner imitated: any --policies name of `uav-bench run` (lattice is cheap, "
        "an MPC planner such as ps2o expensive)",
    )  # fmt: skip
    scenarios: tuple[str, ...] = setting(
        DEFAULT_SCENARIOS, object, "training scenarios: names, random:SEED, random:A-B, YAML paths; never a "
        "published table's map", many="+",
    )  # fmt: skip
    difficulty: float = setting(0.5, float, "difficulty of the random: forms", **UNIT_INTERVAL)
    rounds: int = setting(6, int, "DAgger rounds after behaviour cloning", **at_least(0))
    episodes: int = setting(1, int, "episodes per scenario and round", **at_least(1))
    beta0: float = setting(
        1.0, float, "expert's share of the steps, beta_k = beta0 * decay^k", **UNIT_INTERVAL
    )
    decay: float = setting(0.5, float, "see --beta0", **UNIT_INTERVAL)
    hidden: tuple[int, ...] = setting(
        (256, 256), int, "hidden widths", "one or more integers >= 1", many="+",
        allowed=lambda widths: bool(widths) and min(widths) >= 1,
    )  # fmt: skip
    epochs: int = setting(100, int, "passes over the data per refit", **at_least(1))
    batch_size: int = setting(256, int, "minibatch", **at_least(1))
    learning_rate: float = setting(
        1e-3, float, "Adam step", "a positive number", allowed=lambda rate: math.isfinite(rate) and rate > 0
    )
    seed: int = setting(0, int, "the run's seed", **at_least(0))
    torch_threads: int = setting(1, int, "torch threads", **at_least(1))
    loss: str = setting(
        "mse", str, "mse: the normalised action's channels alike; mse-std: each divided by its spread in the "
        "round-0 labels", **one_of(LOSSES),
    )  # fmt: skip
    select: str = setting(
        "best", str, "the policy is the round with the best mean validation cost on the --validation scenarios "
        "(best) or the last round (last)", **one_of(SELECTIONS),
    )  # fmt: skip
    head: str = setting(
        "action", str, "action: the network regresses the whole action; turn: it chooses one of the lattice's "
        "five turns, flown with the lattice's speed and terrain-following pitch (docs/rl.md §4.8); turn-value: "
        "the turn head as a residual on the value-greedy rule (needs --features value; docs/rl.md §4.9)",
        **one_of(HEADS),
    )  # fmt: skip
    ignore: tuple[str, ...] = setting(
        (), str, "observation slots the network is blind to, e.g. position step_fraction (docs/rl.md §4.8)",
        f"observation slots among {', '.join(SLOTS)}", allowed=lambda name: name in SLOTS, many="*", each=True,
    )  # fmt: skip
    # Checked by baselines.distill.features.check_features in checked() (it reads the value function).
    features: tuple[str, ...] = setting(
        (), str, "inputs appended to the observation: value (the cost-to-go field at five points one step ahead "
        "along the lattice's turns; docs/rl.md §4.9)", many="*",
    )  # fmt: skip
    validation: tuple[str, ...] = setting(
        DEFAULT_VALIDATION, object, "scenarios the rounds are selected on, apart from the training ones and "
        "every published table", many="*",
        default_text=f"{' '.join(DEFAULT_VALIDATION)}; none: the training scenarios",
    )  # fmt: skip
    allow_published_maps: bool = setting(
        False, bool, "train or validate on a published table's map (only to reproduce the v3 networks; their "
        "results there are in sample)", "true or false", switch=True, default_text="",
    )  # fmt: skip
    _scenario_objects: tuple[Scenario, ...] | None = field(default=None, repr=False, compare=False)
    _validation_objects: tuple[Scenario, ...] | None = field(default=None, repr=False, compare=False)

    def beta(self, round_index: int) -> float:
        """The probability that the expert flies a step of round ``round_index`` (1 in round 0)."""
        return 1.0 if round_index == 0 else self.beta0 * self.decay**round_index

    def key(self) -> dict[str, Any]:
        """What must match for a run folder to be continued (all but ``rounds``, ``out``, threads)."""
        expert = self.expert if isinstance(self.expert, str) else _object_config(self.expert)
        return {
            "expert": expert,
            "scenarios": list(self.scenarios),
            "difficulty": self.difficulty,
            "episodes": self.episodes,
            "beta0": self.beta0,
            "decay": self.decay,
            "hidden": list(self.hidden),
            "epochs": self.epochs,
            "batch_size": self.batch_size,
            "learning_rate": self.learning_rate,
            "loss": self.loss,
            "seed": self.seed,
            # Only a non-default head enters the key, so the folders made before heads existed continue.
            **({"head": self.head} if self.head != "action" else {}),
            **({"ignore": list(self.ignore)} if self.ignore else {}),
            **({"features": list(self.features)} if self.features else {}),
            # Validation maps select the round; folders made before them (validated on the training maps) continue.
            **({"validation": list(self.validation)} if self.validation else {}),
        }


def _object_config(expert: Any) -> dict[str, Any]:
    config = getattr(expert, "config", None)
    described = config() if callable(config) else {}
    return {"object": type(expert).__name__, **described}


def _check_numbers(config: DistillConfig) -> None:
    """Raise ``ValueError`` naming the flag of the first field out of its declared domain."""
    check_fields(config, label="flag")
    # Imported here: the feature sets read the compiled value function, which the CLI parser must not load.
    from baselines.distill.features import check_features

    check_features(config.features)
    if config.head == "turn-value" and "value" not in config.features:
        raise ValueError("--head: got 'turn-value', which reads the value inputs; add --features value")


def ignored_slots(names: tuple[str, ...], width: int = OBSERVATION_SIZE) -> np.ndarray | None:
    """The boolean mask over the network's ``width`` inputs of the observation slots ``names`` (``None`` for none)."""
    if not names:
        return None
    mask = np.zeros(width, dtype=bool)
    for name in names:
        mask[SLOTS[name]] = True
    return mask


def _check_seeds(spec: str, flag: str = "--scenarios") -> None:
    """Refuse a procedural training or validation scenario whose seed a published result is measured on."""
    if not spec.startswith(RANDOM_PREFIX):
        return
    seeds = random_seeds(spec)
    for what, reserved in RESERVED_SEEDS.items():
        clash = [s for s in seeds if s in reserved]
        if clash:
            raise ValueError(
                f"{flag}: got {spec!r}, whose seed {clash[0]} belongs to {what} "
                f"({reserved.start}-{reserved.stop - 1}); use other seeds, e.g. random:50000-50039"
            )


def checked(config: DistillConfig) -> DistillConfig:
    """``config`` with its scenarios resolved, after checking every field.

    Raises:
        ValueError: one line naming the flag and the expected value.
    """
    _check_numbers(config)
    if isinstance(config.expert, str):
        from uav_penetration_env.benchmark.policies import make_policy

        try:
            make_policy(config.expert)
        except (KeyError, ValueError, ImportError) as error:
            message = error.args[0] if isinstance(error, KeyError) and error.args else error
            raise ValueError(f"--expert: {message}") from None
    elif not (callable(getattr(config.expert, "act", None)) and callable(getattr(config.expert, "reset", None))):
        raise ValueError(f"--expert: got {config.expert!r}, expected a policy spec or a Policy object")
    if not config.scenarios:
        raise ValueError("--scenarios: got none, expected one or more scenario specs")
    scenarios = _resolved(config.scenarios, config.difficulty, "--scenarios")
    validation = _resolved(config.validation, config.difficulty, "--validation")
    if not config.allow_published_maps:
        from uav_penetration_env.suites.published import check_unpublished

        check_unpublished(scenarios, "--scenarios")
        check_unpublished(validation, "--validation")
    shared = {s.map_hash for s in scenarios} & {s.map_hash for s in validation}
    if shared:
        name = next(s.name for s in validation if s.map_hash in shared)
        raise ValueError(f"--validation: {name!r} is also a training map; expected maps apart from --scenarios")
    names = tuple(s if isinstance(s, str) else s.name for s in config.scenarios)
    return dataclasses.replace(
        config, out=Path(config.out), scenarios=names, _scenario_objects=tuple(scenarios),
        validation=tuple(s if isinstance(s, str) else s.name for s in config.validation),
        _validation_objects=tuple(validation),
    )  # fmt: skip


def _resolved(specs: tuple[Any, ...], difficulty: float, flag: str) -> list[Scenario]:
    """Scenario objects of ``specs`` (names, ``random:`` forms, YAML paths or objects), reserved seeds refused."""
    out: list[Scenario] = []
    for spec in specs:
        if isinstance(spec, Scenario):
            out.append(spec)
            continue
        _check_seeds(spec, flag)
        try:
            out.extend(resolve_scenarios(spec, difficulty))
        except Exception as error:  # the catalogue's errors name the scenario; the flag is ours
            raise ValueError(f"{flag}: {error}") from None
    return out
