"""Stable-Baselines3 baselines: train agents on the UAV penetration envs and score them as Policies.

The only package that imports torch and stable-baselines3 (extra ``rl``), and only inside the
functions that need them, so ``import baselines`` and :func:`load_policy` stay light (the
evaluator's parent process reads sidecars without torch).

```python
from baselines import train_agent, load_policy
train_agent("ppo", env_id="UAVPenetration-v0", scenario=None, total_timesteps=200_000, seed=0,
            n_envs=8, out="results/models/ppo-paper-s0.zip")
policy = load_policy("results/models/ppo-paper-s0.zip")    # a Policy for evaluate()
```
"""

from __future__ import annotations

from uav_penetration_env.lazy import exported_modules, lazy_exports

# Imported on first use (PEP 562): the harness loads this package's entry points to list its
# commands, which must not import the env or torch.
_EXPORTS = {
    ".policy": ("SB3Policy", "load_policy"),
    ".train": ("KNOWN_ALGORITHMS", "TrainConfig", "TrainResult", "train_agent"),
}

__all__ = sorted(exported_modules(_EXPORTS))


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
