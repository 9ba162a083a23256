"""``uav-bench distill``: imitate a planner with behaviour cloning and DAgger (docs/rl.md §4).

A plug-in command (:data:`baselines.plugin.DISTILL_COMMAND`). Every flag is a field of
:class:`~baselines.distill.config.DistillConfig`; bad input exits with status 2 and one line naming
the flag. Rerunning the same command continues from the last finished round; a larger
``--rounds`` extends a finished run.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from baselines.distill.config import DEFAULT_SCENARIOS, DEFAULT_VALIDATION, DistillConfig
from uav_penetration_env.benchmark.commands.common import CLIError, path_argument

DEFAULTS = DistillConfig()


def add_distill_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``uav-bench distill`` (defaults: :class:`DistillConfig`'s)."""
    add = parser.add_argument
    add("--expert", default=DEFAULTS.expert, help="the planner imitated: any --policies name of `uav-bench run` "
        f"(lattice is cheap, an MPC planner such as ps2o expensive; default: {DEFAULTS.expert})")
    add("--out", type=path_argument, required=True, help="the run folder (round data, networks, policy.npz + policy.json)")
    add("--rounds", type=int, default=DEFAULTS.rounds, help=f"DAgger rounds after behaviour cloning (default: {DEFAULTS.rounds})")
    add("--scenarios", nargs="+", default=list(DEFAULT_SCENARIOS),
        help="training scenarios: names, random:SEED, random:A-B, YAML paths; never a published table's map "
        f"(default: {' '.join(DEFAULT_SCENARIOS)})")
    add("--validation", nargs="*", default=list(DEFAULT_VALIDATION),
        help="scenarios the rounds are selected on, apart from the training ones and every published table "
        f"(default: {' '.join(DEFAULT_VALIDATION)}; none: the training scenarios)")
    add("--allow-published-maps", action="store_true", help="train or validate on a published table's map "
        "(only to reproduce the v3 networks; their results there are in sample)")
    add("--difficulty", type=float, default=DEFAULTS.difficulty, help="difficulty of the random: forms (default: 0.5)")
    add("--episodes", type=int, default=DEFAULTS.episodes, help="episodes per scenario and round (default: 1)")
    add("--beta0", type=float, default=DEFAULTS.beta0, help=f"expert's share of the steps, beta_k = beta0 * decay^k (default: {DEFAULTS.beta0})")
    add("--decay", type=float, default=DEFAULTS.decay, help=f"see --beta0 (default: {DEFAULTS.decay})")
    add("--hidden", type=int, nargs="+", default=list(DEFAULTS.hidden), help="hidden widths (default: 256 256)")
    add("--epochs", type=int, default=DEFAULTS.epochs, help=f"passes over the data per refit (default: {DEFAULTS.epochs})")
    add("--batch-size", dest="batch_size", type=int, default=DEFAULTS.batch_size, help=f"minibatch (default: {DEFAULTS.batch_size})")
    add("--learning-rate", dest="learning_rate", type=float, default=DEFAULTS.learning_rate, help=f"Adam step (default: {DEFAULTS.learning_rate})")
    add("--loss", default=DEFAULTS.loss, help="mse: the normalised action's channels alike; mse-std: each divided by "
        f"its spread in the round-0 labels (default: {DEFAULTS.loss})")
    add("--select", default=DEFAULTS.select, help="the policy is the round with the best mean validation cost on the "
        f"--validation scenarios (best) or the last round (last; default: {DEFAULTS.select})")
    add("--head", default=DEFAULTS.head, help="action: the network regresses the whole action; turn: it chooses one "
        "of the lattice's five turns, flown with the lattice's speed and terrain-following pitch (docs/rl.md §4.8); "
        "turn-value: the turn head as a residual on the value-greedy rule (needs --features value; docs/rl.md §4.9; "
        f"default: {DEFAULTS.head})")
    add("--ignore", nargs="*", default=[], help="observation slots the network is blind to, e.g. position "
        "step_fraction (docs/rl.md §4.8; default: none)")
    add("--features", nargs="*", default=[], help="inputs appended to the observation: value (the cost-to-go "
        "field at five points one step ahead along the lattice's turns; docs/rl.md §4.9; default: none)")
    add("--seed", type=int, default=DEFAULTS.seed, help=f"the run's seed (default: {DEFAULTS.seed})")
    add("--torch-threads", dest="torch_threads", type=int, default=DEFAULTS.torch_threads, help="torch threads (default: 1)")  # fmt: skip


def distill_command(args: argparse.Namespace) -> int:
    """Run ``uav-bench distill``; returns 0, or 130 when interrupted (rerun to continue).

    Raises:
        CLIError: invalid input, or a run folder made with other settings.
    """
    from baselines.distill.config import checked
    from baselines.distill.loop import run_distill

    config = DistillConfig(
        out=Path(args.out), expert=args.expert, scenarios=tuple(args.scenarios), difficulty=args.difficulty,
        rounds=args.rounds, episodes=args.episodes, beta0=args.beta0, decay=args.decay, hidden=tuple(args.hidden),
        epochs=args.epochs, batch_size=args.batch_size, learning_rate=args.learning_rate, seed=args.seed,
        torch_threads=args.torch_threads, loss=args.loss, select=args.select, head=args.head,
        ignore=tuple(args.ignore), features=tuple(args.features), validation=tuple(args.validation),
        allow_published_maps=bool(args.allow_published_maps),
    )  # fmt: skip
    try:
        config = checked(config)
    except ValueError as error:
        raise CLIError(str(error)) from None
    print(
        f"uav-bench distill: expert {config.expert}, {len(config._scenario_objects or ())} scenarios, "
        f"{config.rounds} DAgger rounds -> {config.out}",
        flush=True,
    )
    try:
        result = run_distill(config, log=lambda line: print(line, flush=True))
    except ValueError as error:
        raise CLIError(str(error)) from None
    except KeyboardInterrupt:
        print(f"\ninterrupted: rerun the same command to continue from the last finished round in {config.out}",
              file=sys.stderr)  # fmt: skip
        return 130
    side = result.sidecar
    print(
        f"policy: {result.folder.policy} (round {side['round']}, fitted on {side['data_rows']} rows; the run: "
        f"{side['expert_labels']} expert labels, {side['train_cpu_seconds']:.1f} CPU s); "
        f"score it with: uav-bench run --policies distill:{config.out}"
    )
    return 0
