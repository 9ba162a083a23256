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

from baselines.distill.config import DistillConfig
from baselines.distill.loop import DistillResult, run_distill
from baselines.distill.policy import (
    DistillPolicy,
    SafeDistillPolicy,
    load_distill_policy,
    load_safe_distill_policy,
)

__all__ = [
    "DistillConfig",
    "DistillPolicy",
    "DistillResult",
    "SafeDistillPolicy",
    "load_distill_policy",
    "load_safe_distill_policy",
    "run_distill",
]
