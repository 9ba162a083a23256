"""Best-known trajectories: the offline reference planner, per-scenario records, and their replay.

* :mod:`.record`: :class:`BestKnownRecord`, one JSON file per scenario hash in ``records/``
  (package data), :func:`load_record`, :func:`best_known_total`, :func:`replay_record`.
* :mod:`.planner`: the offline search over a whole episode's controls (the separable CMA-ES
  restarts and refinement of :mod:`optimizers.sep_cma_restarts`, resumable).
* :mod:`.checkpoint`: the search's state saved to and found again in the ``--work`` folder.
* :mod:`.compute`: the starts (greedy episode, stored tracks, the record), the seeded and unseeded
  searches, and the rule that a record is only ever replaced by a cheaper one.

The leaderboards' gap columns read :func:`best_known_total`; ``uav-bench best-known`` drives the
rest (docs/best-known.md).
"""

from __future__ import annotations

from uav_penetration_env.benchmark.bestknown.record import (
    RECORDS_DIR,
    REPLAY_TOLERANCE,
    BestKnownRecord,
    RecordError,
    best_known_total,
    load_record,
    records,
    replay_controls,
    replay_record,
    write_record,
)

__all__ = [
    "RECORDS_DIR",
    "REPLAY_TOLERANCE",
    "BestKnownRecord",
    "RecordError",
    "best_known_total",
    "load_record",
    "records",
    "replay_controls",
    "replay_record",
    "write_record",
]
