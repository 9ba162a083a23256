"""Hyper-parameters of the SB3 algorithms: the tuned YAML files, overrides, validation, SB3 keywords.

``baselines/hyperparams/<algo>.yaml`` holds each tuned set with its provenance (rl-baselines3-zoo);
:func:`resolve_hyperparams` merges a user's overrides into it and checks every key against the
algorithm's constructor, so a typo fails before training with a did-you-mean.
"""

from __future__ import annotations

import inspect
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from baselines.install import RL_INSTALL
from uav_penetration_env.suggest import did_you_mean
from uav_penetration_env.yaml_mapping import read_yaml_mapping

# Continuous-action SB3 algorithms (DQN needs a discrete action space, so it is not offered).
KNOWN_ALGORITHMS = {"a2c": "A2C", "ddpg": "DDPG", "ppo": "PPO", "sac": "SAC", "td3": "TD3"}
HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams"
# Keys of a hyper-parameter file that are not keywords of the algorithm's constructor.
SPECIAL_KEYS = ("provenance", "policy", "normalize", "policy_kwargs", "noise_type", "noise_std")
# Keywords train_agent sets itself; a hyper-parameter file must not.
RESERVED_KEYS = ("env", "seed", "verbose", "device", "_init_setup_model", "tensorboard_log")
VECNORMALIZE_KEYS = ("norm_obs", "norm_reward", "clip_obs", "clip_reward", "gamma", "epsilon")
ACTIVATIONS = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU", "gelu": "GELU"}
NOISE_TYPES = ("normal", "ornstein-uhlenbeck")


def algorithm_class(name: str) -> type:
    """The SB3 class of an algorithm name (``ppo``, ``sac``, ``td3``, ``a2c``, ``ddpg``; any case).

    Raises:
        ValueError: an unknown name, with a did-you-mean and the known names.
    """
    key = str(name).lower()
    if key not in KNOWN_ALGORITHMS:
        raise ValueError(
            f"unknown algorithm {name!r} — {did_you_mean(key, KNOWN_ALGORITHMS)}known: {', '.join(KNOWN_ALGORITHMS)}"
        )
    try:
        import stable_baselines3
    except ImportError as error:  # pragma: no cover - depends on the installed extras
        raise ImportError(f"training needs the RL extra: {RL_INSTALL} ({error})") from error
    return getattr(stable_baselines3, KNOWN_ALGORITHMS[key])


def resolve_hyperparams(
    algo: str,
    overrides: Mapping[str, Any] | str | Path | None = None,
    defaults: tuple[str, Mapping[str, Any]] | None = None,
) -> tuple[dict[str, Any], str]:
    """The tuned hyper-parameters of ``algo`` with ``overrides`` merged in, validated.

    Without a tuned file (e.g. ``a2c``) SB3's defaults are used, with a warning. ``overrides`` (a
    mapping or a YAML file with the same keys) replaces keys; ``policy_kwargs`` and ``normalize``
    mappings are merged key by key. ``defaults`` (a name and a mapping, e.g. the warm start's
    fine-tuning settings, docs/rl.md §6.5) is merged the same way before ``overrides``, so the
    user's keys still win.

    Returns:
        The hyper-parameters and where they came from.

    Raises:
        ValueError: an unknown algorithm or key (with a did-you-mean), or a reserved key.
    """
    cls = algorithm_class(algo)
    key = str(algo).lower()
    path = HYPERPARAMS_DIR / f"{key}.yaml"
    if path.is_file():
        params = read_yaml_mapping(path, "hyperparams", "hyper-parameter names")
        source = f"baselines/hyperparams/{key}.yaml"
    else:
        warnings.warn(
            f"no tuned hyper-parameters for {key!r} (baselines/hyperparams/{key}.yaml); using SB3's defaults",
            UserWarning,
            stacklevel=2,
        )
        params = {"provenance": f"SB3 {cls.__name__} defaults (no tuned file)", "policy": "MlpPolicy"}
        source = f"stable_baselines3.{cls.__name__} defaults"
    layers: list[Mapping[str, Any]] = []
    if defaults is not None:
        source += f" + {defaults[0]}"
        layers.append(defaults[1])
    if overrides is not None:
        if isinstance(overrides, (str, Path)):
            source += f" + {overrides}"
            overrides = read_yaml_mapping(Path(overrides), "hyperparams", "hyper-parameter names")
        else:
            source += " + overrides"
        layers.append(overrides)
    for layer in layers:
        for name, value in dict(layer).items():
            current = params.get(name)
            if (
                name in ("policy_kwargs", "normalize")
                and isinstance(current, dict)
                and isinstance(value, dict)
            ):
                params[name] = {**current, **value}
            else:
                params[name] = value
    _validate_hyperparams(params, cls)
    return params, source


def _validate_hyperparams(params: Mapping[str, Any], cls: type) -> None:
    accepted = [p for p in inspect.signature(cls.__init__).parameters if p not in ("self", "policy")]
    for name in params:
        if name in RESERVED_KEYS:
            raise ValueError(
                f"hyperparams: {name!r} is set by train_agent (seed=, verbose=, device=), not here"
            )
        if name not in SPECIAL_KEYS and name not in accepted:
            allowed = sorted([*SPECIAL_KEYS, *(a for a in accepted if a not in RESERVED_KEYS)])
            raise ValueError(
                f"hyperparams: unknown key {name!r} for {cls.__name__} — {did_you_mean(name, allowed)}"
                f"allowed: {', '.join(allowed)}"
            )
    normalize = params.get("normalize", False)
    if not isinstance(normalize, (bool, dict)):
        raise ValueError(
            f"hyperparams: normalize: got {normalize!r}, expected false or a mapping of VecNormalize keywords"
        )
    for name in normalize if isinstance(normalize, dict) else ():
        if name not in VECNORMALIZE_KEYS:
            raise ValueError(
                f"hyperparams: normalize.{name}: unknown VecNormalize keyword — "
                f"{did_you_mean(name, VECNORMALIZE_KEYS)}allowed: {', '.join(VECNORMALIZE_KEYS)}"
            )
    noise = params.get("noise_type")
    if noise is not None:
        if "action_noise" not in accepted:
            raise ValueError(f"hyperparams: noise_type: {cls.__name__} takes no action noise")
        if noise not in NOISE_TYPES:
            raise ValueError(
                f"hyperparams: noise_type: got {noise!r}, expected one of {', '.join(NOISE_TYPES)}"
            )
    activation = (params.get("policy_kwargs") or {}).get("activation_fn")
    if activation is not None and activation not in ACTIVATIONS:
        raise ValueError(
            f"hyperparams: policy_kwargs.activation_fn: got {activation!r}, expected one of {', '.join(ACTIVATIONS)}"
        )


def normalize_kwargs(params: Mapping[str, Any]) -> dict[str, Any] | None:
    """VecNormalize keywords of the hyper-parameters (``None``: no normalisation)."""
    normalize = params.get("normalize", False)
    if normalize is False:
        return None
    kwargs = {"norm_obs": True, "norm_reward": False}
    if isinstance(normalize, dict):
        kwargs.update(normalize)
    if kwargs["norm_reward"] and "gamma" not in kwargs and "gamma" in params:
        kwargs["gamma"] = params["gamma"]  # the return statistics must use the agent's discount
    return kwargs


def algorithm_kwargs(params: Mapping[str, Any], action_dim: int) -> dict[str, Any]:
    """The constructor keywords of the SB3 algorithm: names resolved to torch classes and noise objects."""
    import torch

    kwargs = {k: v for k, v in params.items() if k not in SPECIAL_KEYS}
    if isinstance(kwargs.get("train_freq"), list):
        kwargs["train_freq"] = tuple(kwargs["train_freq"])  # YAML has no tuples; SB3 wants (n, unit)
    policy_kwargs = dict(params.get("policy_kwargs") or {})
    if "activation_fn" in policy_kwargs:
        policy_kwargs["activation_fn"] = getattr(torch.nn, ACTIVATIONS[policy_kwargs["activation_fn"]])
    if policy_kwargs:
        kwargs["policy_kwargs"] = policy_kwargs
    if params.get("noise_type") is not None:
        from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise

        noise = NormalActionNoise if params["noise_type"] == "normal" else OrnsteinUhlenbeckActionNoise
        sigma = float(params.get("noise_std", 0.1)) * np.ones(action_dim)
        kwargs["action_noise"] = noise(mean=np.zeros(action_dim), sigma=sigma)
    return kwargs
