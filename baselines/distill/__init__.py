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

from uav_penetration_env.lazy import exported_modules, lazy_exports

# Imported on first use, so that `uav-bench distill --help` loads neither the env nor torch.
_EXPORTS = {
    ".config": ("DistillConfig",),
    ".loop": ("DistillResult", "run_distill"),
    ".policy": ("DistillPolicy", "SafeDistillPolicy", "load_distill_policy", "load_guarded_distill_policy"),
}

__all__ = sorted(exported_modules(_EXPORTS))

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
