"""The RL programme's campaign as data: which studies and runs it holds, read from a YAML file.

The programme (:mod:`baselines.programme`) is a generic runner; what it runs, one research campaign
(docs/rl.md §3), lives in ``baselines/campaigns/rl.yaml``, the packaged default, so another
campaign is another file (``python -m baselines.programme --campaign PATH``), not an edit of the
code. :func:`load_campaign` checks the whole file before anything runs and refuses bad input with
one line that names the field and the value it expects.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import yaml

from uav_penetration_env.suggest import did_you_mean

DEFAULT_CAMPAIGN = Path(__file__).with_name("campaigns") / "rl.yaml"


class Study(NamedTuple):
    """A tuning study: ``trials`` finished trials (complete + pruned) of ``algo`` on ``regime``."""

    algo: str
    regime: str
    trials: int


class Run(NamedTuple):
    """Long runs with a study's best set, one per training seed.

    ``timesteps`` ``None``: the campaign's CPU-time budget, converted into steps from the study.
    """

    algo: str
    regime: str
    seeds: tuple[int, ...]
    timesteps: int | None


class Experiment(NamedTuple):
    """Runs of the untuned set with ``overrides`` (a hyper-parameter file, or ``None``) on top, one per seed.

    ``flags``: the training formulation's ``uav-bench train`` flags (:data:`EXPERIMENT_FLAGS`, e.g.
    ``--action turn``; docs/rl.md §6), empty for today's formulation.
    """

    algo: str
    regime: str
    name: str
    overrides: str | None
    seeds: tuple[int, ...]
    timesteps: int
    flags: tuple[str, ...] = ()


# The ``uav-bench train`` flags an experiment may add (the formulations of docs/rl.md §6); the
# programme itself sets the algorithm, regime, steps, seed, output and cadence.
EXPERIMENT_FLAGS = ("--shaping", "--action", "--clearance", "--features", "--init-from", "--critic-warmup")


@dataclass(frozen=True)
class Campaign:
    """One campaign of the programme: its studies, runs and experiments, and how runs are trained.

    Attributes:
        studies: tuning studies, run first, in order.
        runs: long runs with each study's best set, in order, after the studies.
        experiments: runs of the untuned set with overrides, after the runs.
        off_policy_cpu_minutes: the CPU-time budget of a run whose ``timesteps`` is ``None``.
        confirmed: algorithms whose study's set is confirmed at the full budget against the untuned
            set before the remaining seeds train (docs/rl.md §3.1).
        eval_freq: environment steps between learning-curve evaluations, per algorithm.
        checkpoint_freq: environment steps between checkpoints, per algorithm.
        eval_episodes: learning-curve episodes per evaluation, per regime.
        regime_flags: the ``uav-bench train`` flags that select each regime's environment.
    """

    studies: tuple[Study, ...]
    runs: tuple[Run, ...]
    experiments: tuple[Experiment, ...]
    off_policy_cpu_minutes: float
    confirmed: tuple[str, ...]
    eval_freq: Mapping[str, int]
    checkpoint_freq: Mapping[str, int]
    eval_episodes: Mapping[str, int]
    regime_flags: Mapping[str, tuple[str, ...]]


class CampaignError(ValueError):
    """A campaign file that cannot be run; the message is one line naming the field."""


FIELDS = tuple(Campaign.__dataclass_fields__)
STUDY_KEYS = Study._fields
RUN_KEYS = Run._fields
EXPERIMENT_KEYS = Experiment._fields


def _fail(where: str, value: Any, expected: str) -> CampaignError:
    return CampaignError(f"{where}: got {value!r}; expected {expected}")


def _integer(where: str, value: Any, minimum: int) -> int:
    # bool is an int to Python, but `trials: true` is a typo, not a count.
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise _fail(where, value, f"an integer >= {minimum}")
    return value


def _one_of(value: Any, known: Any) -> str:
    """``one of a, b (did you mean 'a'?)``: the expected names, with the close ones first when any are."""
    names = list(known)
    hint = did_you_mean(value, names).strip()
    return f"one of {', '.join(names)}" + (f" ({hint})" if hint else "")


def _name(where: str, value: Any, known: Mapping[str, Any] | None = None) -> str:
    if not isinstance(value, str) or not value:
        raise _fail(where, value, "a non-empty string")
    if known is not None and value not in known:
        raise _fail(where, value, _one_of(value, sorted(known)))
    return value


def _mapping(
    where: str, value: Any, keys: tuple[str, ...] | None = None, optional: tuple[str, ...] = ()
) -> dict[str, Any]:
    """``value`` as a mapping; with ``keys``, exactly those keys, less any of ``optional`` (a missing or unknown one is named)."""
    if not isinstance(value, dict):
        expected = f"a mapping with {', '.join(keys)}" if keys else "a mapping"
        raise _fail(where, value, expected)
    if keys is not None:
        for key in value:
            if key not in keys:
                raise _fail(f"{where}.{key}", key, _one_of(key, keys))
        missing = [key for key in keys if key not in value and key not in optional]
        if missing:
            raise CampaignError(f"{where}: {missing[0]} is missing; expected the keys {', '.join(keys)}")
    return value


def _items(where: str, value: Any) -> list[Any]:
    if not isinstance(value, list):
        raise _fail(where, value, "a list")
    return value


def _seeds(where: str, value: Any) -> tuple[int, ...]:
    seeds = tuple(_integer(f"{where}[{i}]", seed, 0) for i, seed in enumerate(_items(where, value)))
    if not seeds or len(set(seeds)) != len(seeds):
        raise _fail(where, value, "a non-empty list of distinct seeds")
    return seeds


def _per_name(where: str, value: Any, minimum: int) -> dict[str, int]:
    table = _mapping(where, value)
    return {_name(f"{where} key", k, None): _integer(f"{where}.{k}", v, minimum) for k, v in table.items()}


def _regime_flags(where: str, value: Any) -> dict[str, tuple[str, ...]]:
    flags = {}
    for regime, argv in _mapping(where, value).items():
        items = _items(f"{where}.{regime}", argv)
        if not all(isinstance(arg, str) for arg in items):
            raise _fail(f"{where}.{regime}", argv, 'a list of strings (quote numbers: "0.5")')
        flags[_name(f"{where} key", regime)] = tuple(items)
    return flags


def _studies(value: Any, algos: Mapping[str, Any], regimes: Mapping[str, Any]) -> tuple[Study, ...]:
    studies: list[Study] = []
    for i, item in enumerate(_items("studies", value)):
        where = f"studies[{i}]"
        entry = _mapping(where, item, STUDY_KEYS)
        study = Study(_name(f"{where}.algo", entry["algo"], algos),
                      _name(f"{where}.regime", entry["regime"], regimes),
                      _integer(f"{where}.trials", entry["trials"], 1))  # fmt: skip
        if any(s[:2] == study[:2] for s in studies):
            raise _fail(where, f"{study.algo}-{study.regime}", "one study per algorithm and regime")
        studies.append(study)
    return tuple(studies)


def _runs(value: Any, studies: tuple[Study, ...], algos: Mapping[str, Any]) -> tuple[Run, ...]:
    tuned = {(s.algo, s.regime): s for s in studies}
    runs = []
    for i, item in enumerate(_items("runs", value)):
        where = f"runs[{i}]"
        entry = _mapping(where, item, RUN_KEYS)
        algo = _name(f"{where}.algo", entry["algo"], algos)
        regime = _name(f"{where}.regime", entry["regime"])
        # A run trains with its study's best set, so it needs that study in the campaign.
        if (algo, regime) not in tuned:
            studied = ", ".join(f"{a}-{r}" for a, r in tuned)
            raise _fail(where, f"{algo}-{regime}", f"the algorithm and regime of a study ({studied})")
        timesteps = entry["timesteps"]
        if timesteps is not None:
            timesteps = _integer(f"{where}.timesteps", timesteps, 1)
        runs.append(Run(algo, regime, _seeds(f"{where}.seeds", entry["seeds"]), timesteps))
    return tuple(runs)


def _experiments(value: Any, algos: Mapping[str, Any], regimes: Mapping[str, Any]) -> tuple[Experiment, ...]:
    experiments = []
    for i, item in enumerate(_items("experiments", value)):
        where = f"experiments[{i}]"
        entry = _mapping(where, item, EXPERIMENT_KEYS, optional=("flags",))
        overrides = entry["overrides"]
        experiments.append(
            Experiment(
                _name(f"{where}.algo", entry["algo"], algos),
                _name(f"{where}.regime", entry["regime"], regimes),
                _name(f"{where}.name", entry["name"]),
                None if overrides is None else _name(f"{where}.overrides", overrides),
                _seeds(f"{where}.seeds", entry["seeds"]),
                _integer(f"{where}.timesteps", entry["timesteps"], 1),
                _flags(f"{where}.flags", entry.get("flags", [])),
            )
        )
    return tuple(experiments)


def _flags(where: str, value: Any) -> tuple[str, ...]:
    """An experiment's formulation flags: pairs ``FLAG VALUE`` with FLAG in :data:`EXPERIMENT_FLAGS`."""
    items = [str(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else v for v in _items(where, value)]
    if len(items) % 2:
        raise _fail(where, value, "pairs of a flag and its value")
    for i in range(0, len(items), 2):
        flag, argument = items[i], items[i + 1]
        if flag not in EXPERIMENT_FLAGS:
            raise _fail(f"{where}[{i}]", flag, _one_of(str(flag), EXPERIMENT_FLAGS))
        _name(f"{where}[{i + 1}]", argument)
    return tuple(items)


def campaign_from_mapping(data: Any) -> Campaign:
    """Check a parsed campaign file and build its :class:`Campaign`.

    Algorithms are the keys of ``eval_freq`` (``checkpoint_freq`` must have the same), regimes the
    keys of ``regime_flags`` (``eval_episodes`` must have the same): a study, run or experiment
    naming another could not build its command.

    Raises:
        CampaignError: the first bad field, named with the value it expects.
    """
    top = _mapping("campaign", data, FIELDS)
    eval_freq = _per_name("eval_freq", top["eval_freq"], 1)
    checkpoint_freq = _per_name("checkpoint_freq", top["checkpoint_freq"], 1)
    if set(checkpoint_freq) != set(eval_freq):
        raise _fail(
            "checkpoint_freq", sorted(checkpoint_freq), f"the algorithms of eval_freq, {sorted(eval_freq)}"
        )
    regime_flags = _regime_flags("regime_flags", top["regime_flags"])
    eval_episodes = _per_name("eval_episodes", top["eval_episodes"], 1)
    if set(eval_episodes) != set(regime_flags):
        raise _fail(
            "eval_episodes", sorted(eval_episodes), f"the regimes of regime_flags, {sorted(regime_flags)}"
        )
    minutes = top["off_policy_cpu_minutes"]
    if isinstance(minutes, bool) or not isinstance(minutes, (int, float)) or not minutes > 0:
        raise _fail("off_policy_cpu_minutes", minutes, "a number > 0")
    confirmed = tuple(
        _name(f"confirmed[{i}]", algo, eval_freq)
        for i, algo in enumerate(_items("confirmed", top["confirmed"]))
    )
    studies = _studies(top["studies"], eval_freq, regime_flags)
    runs = _runs(top["runs"], studies, eval_freq)
    for i, run in enumerate(runs):
        # The confirmation compares the seed-0 runs of both sets (docs/rl.md §3.1): without seed 0
        # the remaining seeds would wait for it forever.
        if run.algo in confirmed and 0 not in run.seeds:
            raise _fail(f"runs[{i}].seeds", list(run.seeds), f"seeds including 0 ({run.algo} is confirmed)")
    return Campaign(
        studies=studies,
        runs=runs,
        experiments=_experiments(top["experiments"], eval_freq, regime_flags),
        off_policy_cpu_minutes=float(minutes),
        confirmed=confirmed,
        eval_freq=eval_freq,
        checkpoint_freq=checkpoint_freq,
        eval_episodes=eval_episodes,
        regime_flags=regime_flags,
    )


def load_campaign(path: str | Path = DEFAULT_CAMPAIGN) -> Campaign:
    """Read and check the campaign file at ``path`` (default: the packaged ``campaigns/rl.yaml``).

    Raises:
        CampaignError: a missing or unparsable file, or a bad field (one line, prefixed with the path).
    """
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as error:
        raise CampaignError(
            f"{path}: cannot be read ({error.strerror}); expected a campaign YAML file"
        ) from None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        line = f" at line {mark.line + 1}" if mark is not None else ""
        raise CampaignError(f"{path}: not valid YAML{line}; expected a campaign YAML file") from None
    try:
        return campaign_from_mapping(data)
    except CampaignError as error:
        raise CampaignError(f"{path}: {error}") from None


@functools.cache
def default_campaign() -> Campaign:
    """The packaged campaign, read once (what the programme runs without ``--campaign``)."""
    return load_campaign(DEFAULT_CAMPAIGN)
