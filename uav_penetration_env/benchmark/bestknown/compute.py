"""Computing and updating best-known records: starts, the two searches, and the never-worse rule.

:func:`compute_record` runs the offline search (:mod:`.planner`) on one scenario twice: once from
the greedy episode and random starts alone (the *unseeded* search, whose result the record keeps
as ``unseeded_total``), then once more seeded with the best stored tracks of the scenario, the
existing record and the unseeded result (the *seeded* search). :func:`update_from_store` looks for
stored episodes (any policy) cheaper than the record. Both replace a record only when the new
total is lower (docs/best-known.md §3).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from uav_penetration_env.benchmark.bestknown.checkpoint import checkpoint_path
from uav_penetration_env.benchmark.bestknown.planner import (
    EpisodeObjective,
    SearchResult,
    SearchSettings,
    Start,
    search,
)
from uav_penetration_env.benchmark.bestknown.record import (
    REPLAY_TOLERANCE,
    BestKnownRecord,
    library_versions,
    load_record,
    relative_difference,
    replay_controls,
    utc_now,
    write_record,
)
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.scenario import Scenario, ScenarioError
from uav_penetration_env.types import FloatArray

TRACK_STARTS = 3  # stored tracks seeded into the search


@dataclass(frozen=True)
class StoredTrack:
    """A finished stored episode's controls and where they come from."""

    controls: FloatArray  # (K, 3) physical controls
    total_cost: float
    policy: str
    policy_hash: str
    seed: int
    run_id: int | None
    store: str

    @property
    def label(self) -> str:
        """``policy/seed`` for run summaries."""
        return f"{self.policy}/seed {self.seed}"

    def found_by(self) -> dict[str, Any]:
        """The record's ``found_by`` for this episode."""
        return {
            "method": "stored-episode",
            "policy": self.policy,
            "policy_hash": self.policy_hash,
            "seed": self.seed,
            "run_id": self.run_id,
            "store": self.store,
        }


@dataclass(frozen=True)
class Outcome:
    """What one compute or update did for one scenario.

    Attributes:
        record: the record now on disk (``None`` when there is none).
        previous: the total of the record before (``None`` when there was none).
        replaced: whether a new record was written.
        candidate: the best total this call found (search or stored episode).
        source: where the candidate came from.
    """

    record: BestKnownRecord | None
    previous: float | None
    replaced: bool
    candidate: float | None
    source: str

    def message(self, name: str) -> str:
        """One line: what happened, with the improvement in absolute terms and %."""
        if self.candidate is None:
            return f"{name}: no finished stored episode; record unchanged"
        if self.replaced and self.previous is None:
            return f"{name}: new record J* = {self.record.total_cost:.10g} ({self.source})"
        if self.replaced:
            gain = self.previous - self.record.total_cost
            return (
                f"{name}: record improved from {self.previous:.10g} to {self.record.total_cost:.10g} "
                f"(-{gain:.6g}, -{100 * gain / self.previous:.4g} %; {self.source})"
            )
        worse = self.candidate - self.previous
        return (
            f"{name}: kept the record J* = {self.previous:.10g}; the best candidate {self.candidate:.10g} "
            f"({self.source}) is not lower (+{worse:.6g}, +{100 * worse / self.previous:.4g} %)"
        )


def beats(candidate: float, record: float) -> bool:
    """Whether ``candidate`` is lower than ``record`` by more than the replay tolerance (relative).

    DECISION (docs/best-known.md §3): a record is replaced only by a total lower by more than
    1e-12 relative, so the same track found again (its controls normalised and back, a rounding
    apart) never rewrites the file.
    """
    return candidate < record - REPLAY_TOLERANCE * abs(record)


def check_fixed_start(scenario: Scenario) -> None:
    """Refuse a scenario whose start is jittered: a record is one control sequence from one start.

    Raises:
        ScenarioError: ``start.jitter`` is not zero.
    """
    jitter = scenario.start.jitter
    if jitter.xy_km > 0 or jitter.heading_deg > 0:
        raise ScenarioError(
            "start.jitter",
            f"xy_km={jitter.xy_km}, heading_deg={jitter.heading_deg}",
            "0 and 0 (a best-known record is one control sequence from one fixed start state)",
        )


def greedy_track(scenario: Scenario) -> tuple[FloatArray, float]:
    """The greedy floor's episode (:class:`~..policies.GreedyPolicy`): (K, 3) controls and its total cost."""
    from uav_penetration_env.benchmark.evaluate import EpisodeTask, run_episode
    from uav_penetration_env.benchmark.policies import GreedyPolicy

    row, steps = run_episode(EpisodeTask("greedy", GreedyPolicy(), "greedy", scenario, 0))
    if row.get("outcome") == "error":
        raise RuntimeError(f"greedy episode on {scenario.name}: {str(row['error']).splitlines()[0]}")
    controls = np.array([[s["action_dv"], s["action_dphi"], s["action_dtheta"]] for s in steps[1:]])
    return controls, float(row["total_cost"])


def stored_tracks(
    store: str | Path, scenario_hash: str, count: int | None = TRACK_STARTS
) -> list[StoredTrack]:
    """The cheapest finished episodes of a scenario in a results store, with their controls.

    The store keeps every step's action (``action_dv``, ``action_dphi``, ``action_dtheta``, exact
    float64), so a stored episode replays exactly.

    Args:
        store: the results store.
        scenario_hash: the scenario.
        count: how many (cheapest first); ``None`` for all.

    Returns:
        The tracks, cheapest first (ties by policy, then seed).
    """
    from uav_penetration_env.benchmark.store import ResultsStore

    with ResultsStore(store, create=False) as results:
        episodes = results.episodes(include_errors=False)
        if episodes.empty:
            return []
        rows = episodes[episodes["scenario_hash"].astype(str) == scenario_hash]
        rows = rows[rows["total_cost"].notna()]
        rows = rows.sort_values(["total_cost", "policy", "seed"], kind="mergesort")
        if count is not None:
            rows = rows.head(count)
        tracks = []
        for _, row in rows.iterrows():
            steps = results.steps([int(row["episode_id"])]).sort_values("step")
            steps = steps[steps["step"] >= 1]
            controls = steps[["action_dv", "action_dphi", "action_dtheta"]].to_numpy(dtype=np.float64)
            if len(controls) == 0 or not np.all(np.isfinite(controls)):
                continue  # an episode without recorded actions cannot be replayed
            run_id = row.get("run_id")
            tracks.append(
                StoredTrack(
                    controls=controls,
                    total_cost=float(row["total_cost"]),
                    policy=str(row["policy"]),
                    policy_hash=str(row["policy_hash"]),
                    seed=int(row["seed"]),
                    run_id=None if run_id is None or pd_isna(run_id) else int(run_id),
                    store=str(store),
                )
            )
    return tracks


def pd_isna(value: Any) -> bool:
    """Whether a store value is missing (None or NaN)."""
    return value is None or (isinstance(value, float) and math.isnan(value))


def _record_from(
    scenario: Scenario,
    controls: FloatArray,
    expected_total: float | None,
    found_by: dict[str, Any],
    budget: dict[str, Any],
    previous: BestKnownRecord | None,
    unseeded: tuple[float, dict[str, Any]] | None,
) -> BestKnownRecord:
    """Replay ``controls`` through the env and make the record of what it flew.

    Raises:
        RuntimeError: the replay's total differs from ``expected_total`` by more than the replay
            tolerance (the batched cost and the env disagree: a bug, never a record).
    """
    replay = replay_controls(scenario, controls)
    if (
        expected_total is not None
        and relative_difference(replay.total_cost, expected_total) > REPLAY_TOLERANCE
    ):
        raise RuntimeError(
            f"{scenario.name}: the env replay gives total_cost {replay.total_cost!r}, the search "
            f"{expected_total!r}; expected equal to {REPLAY_TOLERANCE:g} relative"
        )
    flown = np.asarray(controls, dtype=np.float64).reshape(-1, 3)[: replay.steps]
    history = ()
    if previous is not None:
        history = (
            *previous.history,
            {"total_cost": previous.total_cost, "found_by": previous.found_by, "found_at": previous.found_at},
        )
    unseeded_total, unseeded_budget = (None, None) if unseeded is None else unseeded
    if previous is not None and previous.unseeded_total is not None:
        if unseeded_total is None or previous.unseeded_total <= unseeded_total:
            # The best unseeded result so far stays, whichever search found the record.
            unseeded_total, unseeded_budget = previous.unseeded_total, previous.unseeded_budget
    return BestKnownRecord(
        scenario_name=scenario.name,
        scenario_hash=scenario.hash,
        scenario=scenario.to_dict(),
        total_cost=replay.total_cost,
        outcome=replay.outcome,
        steps=replay.steps,
        controls=tuple(tuple(float(v) for v in row) for row in flown),
        found_by=found_by,
        found_at=utc_now(),
        budget=budget,
        versions=library_versions(),
        unseeded_total=unseeded_total,
        unseeded_budget=unseeded_budget,
        history=history,
    )


def _search_found_by(settings: SearchSettings, result: SearchResult, mode: str) -> dict[str, Any]:
    return {
        "method": "offline-search",
        "mode": mode,
        "optimizer": "cmaes.SepCMA restarts + refinement (docs/best-known.md)",
        "settings": {**settings.key(), "seconds": settings.seconds, "max_evals": settings.max_evals},
        "starts": result.starts,
        "best_run": result.label,
        "runs": len(result.runs),
    }


def _what_to_record(
    settings: SearchSettings, best: SearchResult, mode: str, tracks: list[StoredTrack]
) -> tuple[FloatArray, float, dict[str, Any], str]:
    """The controls, expected total, ``found_by`` and source line of the search's best track."""
    found_by = _search_found_by(settings, best, mode)
    track = next((t for t in tracks if best.label == f"start:{t.label}"), None)
    if mode == "seeded" and track is not None:
        # The search found nothing cheaper than a stored episode: record that episode as stored
        # (its exact controls, not their normalised round trip) and say the search confirmed it.
        source = (
            f"stored episode: {track.policy}, seed {track.seed}, run {track.run_id}; no cheaper track found"
        )
        return track.controls, track.total_cost, {**track.found_by(), "confirmed_by": found_by}, source
    return best.controls, best.total, found_by, f"offline search ({mode})"


def compute_record(
    scenario: Scenario,
    settings: SearchSettings,
    *,
    store: str | Path | None = None,
    track_seeds: bool = True,
    work: str | Path | None = None,
    folder: str | Path | None = None,
    progress: Callable[[str, Any, float], None] | None = None,
) -> Outcome:
    """Run the offline searches on one scenario and keep the record if they beat it (module docstring).

    Args:
        scenario: the scenario (its start must not be jittered).
        settings: each search's settings (budget per search).
        store: a results store whose cheapest episodes of the scenario seed the seeded search.
        track_seeds: ``False`` runs the unseeded search alone.
        work: folder of the searches' checkpoints (``None``: no checkpoints).
        folder: the records folder (default: the package's).
        progress: called as ``progress(mode, state, share)`` after every generation.

    Returns:
        The :class:`Outcome`.

    Raises:
        ScenarioError: a jittered start.
    """
    check_fixed_start(scenario)
    previous = load_record(scenario.hash, folder)
    model = PenetrationModel(scenario)
    objective = EpisodeObjective(model, model.initial_state(None))
    greedy, _ = greedy_track(scenario)

    def run(mode: str, starts: list[Start]) -> SearchResult:
        return search(
            objective,
            starts,
            settings,
            scenario_hash=scenario.hash,
            checkpoint=None if work is None else checkpoint_path(work, scenario.hash, mode),
            progress=None if progress is None else (lambda state, share: progress(mode, state, share)),
        )

    unseeded = run("unseeded", [Start("greedy", objective.normalise(greedy))])
    best, best_mode = unseeded, "unseeded"
    tracks: list[StoredTrack] = []
    budget = {"seconds": unseeded.seconds, "evaluations": unseeded.evals}
    if track_seeds:
        starts = [Start("unseeded-best", objective.normalise(unseeded.controls))]
        if previous is not None:
            starts.append(Start("record", objective.normalise(previous.control_array)))
        if store is not None:
            tracks = stored_tracks(store, scenario.hash)
            starts += [Start(t.label, objective.normalise(t.controls)) for t in tracks]
        starts.append(Start("greedy", objective.normalise(greedy)))
        if len(starts) > 2:  # something beyond the unseeded search's own starts
            seeded = run("seeded", starts)
            budget = {
                "seconds": unseeded.seconds + seeded.seconds,
                "evaluations": unseeded.evals + seeded.evals,
            }
            if seeded.total < best.total:
                best, best_mode = seeded, "seeded"
    unseeded_info = (unseeded.total, {"seconds": unseeded.seconds, "evaluations": unseeded.evals})
    if previous is not None and not beats(best.total, previous.total_cost):
        # Never worse: keep the record, but note the unseeded result if the record lacks one.
        kept = previous
        if previous.unseeded_total is None or unseeded.total < previous.unseeded_total:
            kept = replace(previous, unseeded_total=unseeded_info[0], unseeded_budget=unseeded_info[1])
            write_record(kept, folder)
        return Outcome(kept, previous.total_cost, False, best.total, f"offline search ({best_mode})")
    controls, expected, found_by, source = _what_to_record(settings, best, best_mode, tracks)
    record = _record_from(scenario, controls, expected, found_by, budget, previous, unseeded_info)
    if previous is not None and not beats(record.total_cost, previous.total_cost):
        return Outcome(previous, previous.total_cost, False, record.total_cost, source)
    write_record(record, folder)
    prior = None if previous is None else previous.total_cost
    return Outcome(record, prior, True, record.total_cost, source)


def update_from_store(scenario: Scenario, store: str | Path, *, folder: str | Path | None = None) -> Outcome:
    """Replace the record with the cheapest stored episode of the scenario when it is cheaper.

    The episode's controls are replayed through the env; the replayed total (equal to the stored
    ``total_cost`` to the replay tolerance) is the one compared and recorded.

    Raises:
        RuntimeError: the stored episode does not replay to its stored total (a changed model).
    """
    check_fixed_start(scenario)
    previous = load_record(scenario.hash, folder)
    tracks = stored_tracks(store, scenario.hash, count=1)
    if not tracks:
        prior = None if previous is None else previous.total_cost
        return Outcome(previous, prior, False, None, "stored episodes")
    track = tracks[0]
    source = f"stored episode: {track.policy}, seed {track.seed}, run {track.run_id}"
    if previous is not None and not beats(track.total_cost, previous.total_cost):
        return Outcome(previous, previous.total_cost, False, track.total_cost, source)
    budget = {"seconds": 0.0, "evaluations": 0}
    record = _record_from(
        scenario, track.controls, track.total_cost, track.found_by(), budget, previous, None
    )
    if previous is not None and not beats(record.total_cost, previous.total_cost):
        return Outcome(previous, previous.total_cost, False, record.total_cost, source)
    write_record(record, folder)
    prior = None if previous is None else previous.total_cost
    return Outcome(record, prior, True, record.total_cost, source)
