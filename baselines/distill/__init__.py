"""Imitation of the planners: behaviour cloning, then DAgger, into a small MLP (docs/rl.md §4).

- :mod:`~baselines.distill.config`: :class:`DistillConfig`, checked (flags, training scenarios);
- :mod:`~baselines.distill.episodes`: one episode flown by the learner and labelled by the expert;
- :mod:`~baselines.distill.network`: the MLP, its fit (torch) and its forward pass (NumPy);
- :mod:`~baselines.distill.files`: the run folder, written atomically;
- :mod:`~baselines.distill.loop`: the rounds, resumable (:func:`run_distill`);
- :mod:`~baselines.distill.policy`: ``distill:PATH`` as a harness Policy;
- :mod:`~baselines.distill.cli`: ``uav-bench distill``.

Torch is imported only when fitting, so the policy kind loads and flies without the rl extra.
"""

from __future__ import annotations

from uav_penetration_env.lazy import lazy_exports

# Imported on first use, so that `uav-bench distill --help` loads neither the env nor torch.
_EXPORTS = {
    "DistillConfig": "baselines.distill.config",
    "DistillResult": "baselines.distill.loop",
    "run_distill": "baselines.distill.loop",
    "DistillPolicy": "baselines.distill.policy",
    "SafeDistillPolicy": "baselines.distill.policy",
    "load_distill_policy": "baselines.distill.policy",
    "load_guarded_distill_policy": "baselines.distill.policy",
}

__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
