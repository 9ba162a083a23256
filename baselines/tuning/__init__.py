"""Tuning the SB3 baselines with Optuna, split by job; ``uav-bench tune`` (:mod:`baselines.tune`) drives it.

- :mod:`~baselines.tuning.space`: the search spaces, one sampler per algorithm (docs/rl.md §1.2);
- :mod:`~baselines.tuning.config`: a study's settings (:class:`TuneConfig`), checked and completed
  into the :class:`TunePlan` it runs, and the files it writes;
- :mod:`~baselines.tuning.objective`: one trial, trained and scored (docs/rl.md §1.1);
- :mod:`~baselines.tuning.trials`: reading a study's trials (counts, the best, a table) and
  repairing the ones an interrupted run left (docs/rl.md §1.4);
- :mod:`~baselines.tuning.study`: opening, locking and running a study until it has its trials;
- :mod:`~baselines.tuning.outputs`: the best set as YAML with its provenance, the trials as CSV and
  Markdown.

Nothing here imports Optuna, SB3 or torch at import time, so the CLI can list ``uav-bench tune``
without the extra.
"""
