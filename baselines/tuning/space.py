"""The search spaces of the tuned algorithms: what a study samples for PPO, SAC and TD3 (docs/rl.md §1.2).

Each sampler draws one trial's hyper-parameters, after rl-baselines3-zoo's ``hyperparams_opt.py``
samplers with the adaptations its docstring gives, as overrides of ``baselines/hyperparams/ALGO.yaml``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


def sample_ppo(trial: Any) -> dict[str, Any]:
    """PPO's search space, after rl-baselines3-zoo's ``sample_ppo_params``.

    Returns overrides of ``baselines/hyperparams/ppo.yaml`` in its format (``policy_kwargs`` with the
    activation by name). DECISION (docs/rl.md §1.2): the zoo's space with three adaptations. ``n_steps``
    is per sub-env here (8 by default), so its choices stop at 1024 (8192 transitions per update) and
    start at 64; ``batch_size`` 64-512. ``log_std_init`` (the initial exploration std, -3..0) is sampled,
    because the untuned set's hand-picked -1 was the one setting that changed whether PPO learned at all
    (hyperparams/ppo.yaml's provenance). ``norm_reward`` is sampled (the value scale is a suspect for
    the high corridor); observations are always normalised.
    """
    one_minus_gamma = trial.suggest_float("one_minus_gamma", 1e-4, 0.03, log=True)
    one_minus_gae_lambda = trial.suggest_float("one_minus_gae_lambda", 1e-4, 0.1, log=True)
    net = trial.suggest_categorical("net_arch", ["tiny", "small", "medium"])
    width = {"tiny": [64], "small": [64, 64], "medium": [256, 256]}[net]
    return {
        "n_steps": trial.suggest_categorical("n_steps", [64, 128, 256, 512, 1024]),
        "batch_size": trial.suggest_categorical("batch_size", [64, 128, 256, 512]),
        "gamma": 1.0 - one_minus_gamma,
        "gae_lambda": 1.0 - one_minus_gae_lambda,
        "learning_rate": trial.suggest_float("learning_rate", 1e-5, 2e-3, log=True),
        "ent_coef": trial.suggest_float("ent_coef", 1e-8, 0.1, log=True),
        "clip_range": trial.suggest_categorical("clip_range", [0.1, 0.2, 0.3, 0.4]),
        "n_epochs": trial.suggest_categorical("n_epochs", [1, 5, 10, 20]),
        "max_grad_norm": trial.suggest_float("max_grad_norm", 0.3, 2.0),
        "normalize": {"norm_reward": trial.suggest_categorical("norm_reward", [False, True])},
        "policy_kwargs": {
            "net_arch": {"pi": width, "vf": list(width)},
            "activation_fn": trial.suggest_categorical("activation_fn", ["tanh", "relu"]),
            "log_std_init": trial.suggest_float("log_std_init", -3.0, 0.0),
        },
    }


def _off_policy_common(trial: Any) -> dict[str, Any]:
    """The keys SAC and TD3 share, after the zoo's ``sample_sac_params`` / ``sample_td3_params``.

    DECISION (docs/rl.md §1.2): the zoo's gamma, learning-rate, batch, tau and network choices;
    three changes. ``train_freq`` counts vector steps of 8 transitions here, so its choices are
    1-16, and the update ratio is sampled on its own as ``updates_per_step`` (gradient steps per
    vector step: 1, 2, 4, i.e. 1/8 to 1/2 update per transition; the zoo ties gradient_steps to
    train_freq with one env, a ratio of 1). A ratio of 1 is left out: SAC then trains at ~50 steps
    per CPU-second (benchmarks/bench_rl.py), so a 50 k-step trial would take ~16 CPU-minutes and
    the ~20-minute final runs would see only ~60 k steps; a study at a fixed step budget would
    favour it for its sample efficiency, which the CPU-budgeted runs cannot afford.
    ``learning_starts`` is 1000-10000 (a trial is 50 k steps; the zoo's 20000 would spend 40 % of
    it acting at random). ``buffer_size`` is not tuned (300 000, the untuned set's): a trial never
    fills it, so a study cannot tell the choices apart.
    """
    gamma = trial.suggest_categorical("gamma", [0.95, 0.98, 0.99, 0.995, 0.999])
    train_freq = trial.suggest_categorical("train_freq", [1, 2, 4, 8, 16])
    updates = trial.suggest_categorical("updates_per_step", [1, 2, 4])
    net = trial.suggest_categorical("net_arch", ["small", "medium", "big"])
    return {
        "gamma": gamma,
        "learning_rate": trial.suggest_float("learning_rate", 1e-5, 3e-3, log=True),
        "batch_size": trial.suggest_categorical("batch_size", [64, 128, 256, 512]),
        "learning_starts": trial.suggest_categorical("learning_starts", [1000, 5000, 10000]),
        "tau": trial.suggest_categorical("tau", [0.001, 0.005, 0.01, 0.02, 0.05]),
        "train_freq": train_freq,
        "gradient_steps": train_freq * updates,
        "policy_kwargs": {"net_arch": {"small": [64, 64], "medium": [256, 256], "big": [400, 300]}[net]},
    }


def sample_sac(trial: Any) -> dict[str, Any]:
    """SAC's search space (:func:`_off_policy_common`; entropy coefficient ``auto``, as in the zoo)."""
    return {**_off_policy_common(trial), "ent_coef": "auto"}


def sample_td3(trial: Any) -> dict[str, Any]:
    """TD3's search space (:func:`_off_policy_common` plus the zoo's action noise: type and std).

    DECISION (docs/rl.md §1.2): the zoo samples the noise std in [0, 1]; here 0.05-0.5 (log), as a std of
    1 in the [-1, 1] box saturates most actions, and no noise at all is not offered (TD3 then explores
    only through its initial random steps).
    """
    return {
        **_off_policy_common(trial),
        "noise_type": trial.suggest_categorical("noise_type", ["normal", "ornstein-uhlenbeck"]),
        "noise_std": trial.suggest_float("noise_std", 0.05, 0.5, log=True),
    }


SAMPLERS: dict[str, Callable[[Any], dict[str, Any]]] = {
    "ppo": sample_ppo,
    "sac": sample_sac,
    "td3": sample_td3,
}
