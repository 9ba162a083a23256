"""PPO fine-tuning from a distilled turn network: ``uav-bench train --init-from RUN_FOLDER`` (docs/rl.md §6.5).

A ``turn`` network of ``uav-bench distill`` (docs/rl.md §4.8) maps the learner's input (the
observation, with the value inputs when it reads them) through tanh layers to five logits, one per
lattice turn. PPO's categorical policy on the turn action (``--action turn``, ``Discrete(5)``) has
the same shape: SB3's ``MlpPolicy`` with ``net_arch.pi`` = the network's hidden widths, tanh, and an
``action_net`` of five outputs. :func:`load_into` copies the network into the actor, so the agent
starts as the imitation policy (its arg-max turn is the network's), and PPO improves it on the
benchmark reward.

- The network's input scaling ((x − obs_mean) / obs_scale, frozen in distillation) is folded into
  the first layer: W0' = W0 / obs_scale, b0' = b0 − W0' · obs_mean. The run therefore trains
  without observation normalisation (``normalize: false``): a running VecNormalize would move the
  inputs under the copied first layer.
- The critic (``net_arch.vf``, the same widths) starts untrained. For ``critic_warmup_steps`` the
  actor's parameters are frozen and only the critic learns (:class:`CriticWarmup`): PPO's first
  advantages would otherwise be the noise of a random value head, and the clipped updates they
  drive would move the imitation policy before anything is known of its value.

This module imports nothing heavy at import time (the CLI parser reads it).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from baselines.formulation import TURNS, Formulation

# DECISION (docs/rl.md §6.5, the fine-tuning settings): a third of ppo.yaml's learning rate and half
# its clip range, so one update moves the imitation policy less than it moves a fresh one; no
# entropy bonus (the categorical policy's own spread is the exploration; the high corridor of §3.2
# was an entropy-kept noise); ten rollouts of 2 048 steps train the critic alone first.
FINETUNE_HYPERPARAMS: dict[str, Any] = {
    "learning_rate": 1.0e-4,
    "clip_range": 0.1,
    "ent_coef": 0.0,
    "normalize": False,
}
CRITIC_WARMUP_STEPS = 20_480  # ten rollouts of ppo.yaml's 8 x 256 steps


@dataclass(frozen=True)
class WarmStart:
    """A distilled turn network to start the actor from.

    Attributes:
        folder: the distillation run folder (or its ``policy.npz``) as given.
        weights_sha256: the network's SHA-256 (its sidecar's, checked on load).
        hidden: the network's hidden widths (the actor's and the critic's ``net_arch``).
        expert: the planner the network imitated.
        critic_warmup_steps: environment steps with the actor frozen, at the start of training.
        expert_labels: the expert labels the network's distillation computed (its training cost).
        train_cpu_seconds: the distillation's CPU seconds (collection and fits).
    """

    folder: str
    weights_sha256: str
    hidden: tuple[int, ...]
    expert: str
    critic_warmup_steps: int = CRITIC_WARMUP_STEPS
    expert_labels: int = 0
    train_cpu_seconds: float = 0.0

    def to_json(self) -> dict[str, Any]:
        """The sidecar's ``warm_start`` entry (and the resume key's)."""
        return {
            "folder": self.folder,
            "weights_sha256": self.weights_sha256,
            "hidden": list(self.hidden),
            "expert": self.expert,
            "critic_warmup_steps": self.critic_warmup_steps,
            "expert_labels": self.expert_labels,
            "train_cpu_seconds": self.train_cpu_seconds,
        }

    def arrays(self) -> dict[str, np.ndarray]:
        """The network's arrays, re-read and checked against ``weights_sha256``.

        Raises:
            ValueError: the weights changed since the plan was made.
        """
        from baselines.distill.policy import load_distill_policy

        policy = load_distill_policy(self.folder)
        if policy.sidecar["weights_sha256"] != self.weights_sha256:
            raise ValueError(f"init_from: {self.folder} changed since the run was planned (its SHA-256 differs)")
        return policy.arrays


def warm_start_for(
    folder: str | Path, algo: str, formulation: Formulation, critic_warmup_steps: int = CRITIC_WARMUP_STEPS
) -> WarmStart:
    """Check that the network at ``folder`` can start ``algo``'s actor under ``formulation``.

    Raises:
        FileNotFoundError: no ``policy.npz``/``policy.json`` there.
        ValueError: (one line, naming the field) an algorithm other than PPO; a formulation
            whose action is not the discrete turn; a network whose head is not ``turn``, whose turns
            are not the lattice's, whose inputs are not the formulation's, or whose clearance is not
            the controller's; a negative warm-up.
    """
    from baselines.distill.features import features_of
    from baselines.distill.heads import head_of, turn_clearance
    from baselines.distill.policy import load_distill_policy

    if str(algo).lower() != "ppo":
        raise ValueError(f"init_from: got algorithm {algo!r}, expected ppo (a categorical actor over the turns)")
    if formulation.action != "turn" or formulation.turn_space != "discrete":
        raise ValueError("action: got 'physical', expected 'turn' with init_from (the network chooses a turn)")
    if isinstance(critic_warmup_steps, bool) or not isinstance(critic_warmup_steps, (int, np.integer)) or critic_warmup_steps < 0:
        raise ValueError(f"critic_warmup_steps: got {critic_warmup_steps!r}, expected an integer >= 0")
    policy = load_distill_policy(folder)
    arrays = policy.arrays
    head = head_of(arrays)
    if head != "turn":
        raise ValueError(
            f"init_from: {folder} is a {head!r} network, expected a 'turn' network (uav-bench distill --head turn)"
        )
    if tuple(float(t) for t in arrays["turns"]) != TURNS:
        raise ValueError(f"init_from: {folder} chooses among turns {arrays['turns'].tolist()}, expected {list(TURNS)}")
    wanted = ("value",) if formulation.features == "value" else ()
    if features_of(arrays) != wanted:
        needed = "value" if features_of(arrays) else "none"
        raise ValueError(
            f"features: got {formulation.features!r}, expected {needed!r} (the inputs the network at {folder} reads)"
        )
    clearance = turn_clearance(arrays)
    if clearance != float(formulation.clearance_m):
        raise ValueError(
            f"clearance_m: got {formulation.clearance_m:g}, expected {clearance:g}, the clearance {folder} flies"
        )
    return WarmStart(
        folder=str(folder),
        weights_sha256=str(policy.sidecar["weights_sha256"]),
        hidden=tuple(int(h) for h in policy.sidecar["hidden"]),
        expert=str(policy.sidecar.get("expert", "")),
        critic_warmup_steps=int(critic_warmup_steps),
        expert_labels=int(policy.sidecar.get("expert_labels", 0)),
        train_cpu_seconds=float(policy.sidecar.get("train_cpu_seconds", 0.0)),
    )


def warm_start_hyperparams(warm: WarmStart) -> dict[str, Any]:
    """The hyper-parameter defaults of a warm-started run (the user's overrides apply after them)."""
    hidden = list(warm.hidden)
    return {
        **FINETUNE_HYPERPARAMS,
        "policy_kwargs": {"net_arch": {"pi": hidden, "vf": hidden}, "activation_fn": "tanh"},
    }


def check_hyperparams(params: Mapping[str, Any], warm: WarmStart) -> None:
    """Refuse hyper-parameters that would not hold the copied network.

    Raises:
        ValueError: observation normalisation on, another actor width or activation (naming the key).
    """
    if params.get("normalize"):
        raise ValueError("hyperparams.normalize: got observation normalisation, expected false with init_from")
    kwargs = params.get("policy_kwargs") or {}
    arch = kwargs.get("net_arch")
    pi = arch.get("pi") if isinstance(arch, Mapping) else arch
    if list(pi or []) != list(warm.hidden):
        raise ValueError(f"hyperparams.policy_kwargs.net_arch.pi: got {pi!r}, expected {list(warm.hidden)} (the network's)")
    if str(kwargs.get("activation_fn", "")).lower() != "tanh":
        raise ValueError(
            f"hyperparams.policy_kwargs.activation_fn: got {kwargs.get('activation_fn')!r}, expected tanh (the network's)"
        )


def folded_layers(arrays: Mapping[str, np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """The network's linear layers [(W, b), ...] with the input scaling folded into the first (float64).

    W0' = W0 / obs_scale (a blinded slot, of infinite scale, gets a zero column) and
    b0' = b0 − W0' · obs_mean, so W0' x + b0' = W0 (x − obs_mean) / obs_scale + b0 for every x.
    """
    from baselines.distill.network import layer_count

    layers = [
        (np.asarray(arrays[f"W{i}"], dtype=np.float64), np.asarray(arrays[f"b{i}"], dtype=np.float64))
        for i in range(layer_count(arrays))
    ]
    mean = np.asarray(arrays["obs_mean"], dtype=np.float64)
    inverse_scale = 1.0 / np.asarray(arrays["obs_scale"], dtype=np.float64)  # 1/inf = 0
    w0, b0 = layers[0]
    w0 = w0 * inverse_scale[None, :]
    layers[0] = (w0, b0 - w0 @ mean)  # a blinded slot's mean is 0 (observation_scaling)
    return layers


def load_into(model: Any, arrays: Mapping[str, np.ndarray]) -> None:
    """Copy a turn network into the actor of an SB3 PPO ``model`` (hidden layers and ``action_net``).

    Raises:
        ValueError: the model's actor has another shape than the network.
    """
    import torch

    policy = model.policy
    linears = [m for m in policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]
    targets = [*linears, policy.action_net]
    layers = folded_layers(arrays)
    if len(targets) != len(layers) or any(t.weight.shape != w.shape for t, (w, _) in zip(targets, layers, strict=False)):
        raise ValueError(
            "init_from: the network's layers "
            f"{[tuple(w.shape) for w, _ in layers]} are not the actor's {[tuple(t.weight.shape) for t in targets]}"
        )
    with torch.no_grad():
        for target, (w, b) in zip(targets, layers, strict=True):
            target.weight.copy_(torch.from_numpy(w.astype(np.float32)))
            target.bias.copy_(torch.from_numpy(b.astype(np.float32)))


def actor_parameters(model: Any) -> list[Any]:
    """The actor's own parameters (its hidden layers and ``action_net``), which the warm-up freezes."""
    policy = model.policy
    return [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()]


def set_actor_trainable(model: Any, trainable: bool) -> None:
    """Freeze (``False``) or free the actor's parameters; the critic always trains."""
    for parameter in actor_parameters(model):
        parameter.requires_grad_(trainable)
