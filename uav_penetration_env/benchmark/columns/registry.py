"""Every built-in result column, declared once: the step, episode, statistic, window-run and RL tables.

Adding a column is one line here: a step column with its source (``_step``), or an episode column
with a ``summary`` (``_episode``, and a ``board`` to show it). Stores written before it gain it on
their next open (``ALTER TABLE ... ADD COLUMN``, NULL for old rows; :class:`~uav_penetration_env.benchmark.store.ResultsStore`).

* :data:`STEP` (the store's ``steps`` table): one row per track point, each column with its source.
* :data:`EPISODE` (the ``episodes`` table): one row per episode. A column with a ``summary`` is
  computed from the episode's step rows (the step-0 row is never part of a sum); the others are
  set by the harness (keys, timings, policy metadata).
* :data:`STATISTICS`: leaderboard columns computed by the leaderboard's statistics code rather
  than aggregated from one episode column (success with its Wilson interval, the bootstrap
  intervals of total cost, ranks, paired tests).
* :data:`WINDOW_RUN`: the window runs (``uav-bench windows``).
* :data:`RL_GROUP`: the RL table of a scenario group (one row per RL group of training seeds
  and per reference policy; IQM, probability of improvement, compute), printed by
  :mod:`~uav_penetration_env.benchmark.leaderboard.rl` (docs/rl-statistics.md §2).

DECISION (api.md §4.3, §4.5): the leaderboard's layout follows this file (section, then declaration
order), so the episode columns are declared in the order the leaderboard prints them (``fuel_kg``
after ``path_length_km``); a store's ``episodes`` table reads in declaration order whatever its
physical order.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np

from uav_penetration_env.benchmark.columns.definition import (
    Action,
    Board,
    Column,
    EpisodeSteps,
    Info,
    Planner,
    Source,
)

# --- how an episode summarises its step rows -----------------------------------------------------------


def _outcome(steps: EpisodeSteps) -> str:
    info = steps.final_info
    if info["reached_goal"]:
        return "success"
    if info["collided"]:
        return "collided"
    if info["out_of_area"]:
        return "out_of_area"
    return "truncated" if steps.truncated else "unfinished"


def _path_length_km(steps: EpisodeSteps) -> float:
    states = np.asarray(steps.states, dtype=np.float64)
    segments = np.array([float(np.linalg.norm(b[:3] - a[:3])) for a, b in itertools.pairwise(states)])
    return float(segments.sum() / 1000.0)


def _total(name: str) -> Callable[[EpisodeSteps], float]:
    return lambda steps: steps.sum(name)


def _mean(name: str) -> Callable[[EpisodeSteps], float]:
    return lambda steps: steps.mean(name)


def _mean_recorded(name: str) -> Callable[[EpisodeSteps], float | None]:
    """The mean over the steps that recorded a value; ``None`` (NULL) when none did (floors, RL)."""

    def summary(steps: EpisodeSteps) -> float | None:
        values = np.array(
            [row.get(name) for row in steps.rows if row.get(name) is not None], dtype=np.float64
        )
        return float(values.mean()) if values.size else None

    return summary


# --- the tables ------------------------------------------------------------------------------------------


def _episode(name: str, sql: str, definition: str, summary=None, board: Board | None = None) -> Column:
    return Column(name, "episodes", sql, definition, summary=summary, board=board)


def _step(name: str, sql: str, definition: str, source: Source) -> Column:
    return Column(name, "steps", sql, definition, source=source)


def _window(name: str, sql: str, definition: str) -> Column:
    return Column(name, "window_runs", sql, definition)


def _statistic(name: str, board: Board, definition: str | None = None) -> Column:
    return Column(name, "leaderboard", None, definition or board.legend or board.header, board=board)


_TERMS = "mean raw (unnormalised) per-term sums Σ Th_e, Σ Th_r, Σ C"
_TRAINING = (
    "RL agents only: environment steps and wall-clock seconds spent training, a cost the planners "
    "pay per step instead"
)

STEP: tuple[Column, ...] = (
    _step("step", "INTEGER NOT NULL", "track point k: 0 is the start state, k >= 1 follows transition k", Info("step", kind=int)),
    _step("x_km", "REAL", "x of the state [km]", Info("position", 0)),
    _step("y_km", "REAL", "y of the state [km]", Info("position", 1)),
    _step("z_m", "REAL", "altitude of the state above the datum [m]", Info("position", 2)),
    _step("altitude_agl", "REAL", "height above the terrain [m]", Info("altitude_agl")),
    _step("distance_to_goal", "REAL", "horizontal distance to the goal [km]", Info("distance_to_goal")),
    _step("speed", "REAL", "speed v [m/s]", Info("state", 3)),
    _step("heading", "REAL", "heading φ [rad]", Info("state", 4)),
    _step("pitch", "REAL", "pitch θ [rad]", Info("state", 5)),
    _step("J", "REAL", "normalised weighted cost J(k) of the transition (0 at the start)", Info("J")),
    _step("penalty", "REAL", "failure penalty of the transition (0 unless it failed)", Info("penalty")),
    _step("terrain_threat", "REAL", "raw terrain threat Th_e at the state", Info("terrain_threat")),
    _step("radar_threat", "REAL", "raw radar threat Th_r at the state, fused over radars", Info("radar_threat")),
    _step("third_term", "REAL", "raw third term C(k) of the transition (0 at the start)", Info("third_term")),
    _step("terrain_threat_n", "REAL", "normalised terrain threat of the transition (0 at the start)", Info("terrain_threat_n")),
    _step("radar_threat_n", "REAL", "normalised radar threat of the transition (0 at the start)", Info("radar_threat_n")),
    _step("third_term_n", "REAL", "normalised third term of the transition (0 at the start)", Info("third_term_n")),
    _step("fuel_kg", "REAL", "fuel burnt on the transition [kg] (0 at the start)", Info("fuel_kg")),
    _step("detection_prob", "REAL", "network detection probability at the state", Info("detection_prob")),
    _step("detected", "INTEGER", "1 when the detection probability exceeds 0.5", Info("detected", kind=bool)),
    _step("action_dv", "REAL", "speed change of the action [m/s] (NULL at the start)", Action(0)),
    _step("action_dphi", "REAL", "heading change of the action [rad] (NULL at the start)", Action(1)),
    _step("action_dtheta", "REAL", "pitch change of the action [rad] (NULL at the start)", Action(2)),
    _step("nfev", "INTEGER", "objective evaluations spent planning the action (0 without an optimiser)", Planner("nfev", int, 0)),
    _step("planning_seconds", "REAL", "wall-clock seconds the policy took to act", Planner("planning_seconds", float)),
    _step("planning_cpu_seconds", "REAL", "CPU seconds of the process while the policy acted (api.md §4.12)", Planner("planning_cpu_seconds", float)),
    _step("objective_seconds", "REAL", "seconds of the planning spent inside rollout_cost", Planner("objective_seconds", float, 0.0)),
    _step("plan_cost", "REAL", "the planner's best window cost J^(H) for the action", Planner("plan_cost")),
    _step("history", "TEXT", "JSON list: the optimiser's best-so-far after each iteration", Planner("history")),
    _step("history_nfev", "TEXT", "JSON list: evaluations spent at each history entry", Planner("history_nfev")),
    _step("stopped_early", "INTEGER", "1 when the optimiser stopped before its budget (nfev < max_evals), NULL without an optimiser", Planner("stopped_early")),
    _step("switches", "INTEGER", "broad -> accurate search switches of the plan (IHPSO eqs. 25-28; NULL for optimisers without them)", Planner("switches")),
    _step("reverse_switches", "INTEGER", "accurate -> broad search switches of the plan (IHPSO eq. 33; NULL for optimisers without them)", Planner("reverse_switches")),
    _step("extinctions", "INTEGER", "iterations in which species died out (PS2O; NULL for optimisers without them)", Planner("extinctions")),
)  # fmt: skip

EPISODE: tuple[Column, ...] = (
    _episode("policy", "TEXT NOT NULL", "the policy's display name"),
    _episode("policy_hash", "TEXT NOT NULL", "16 hex digits of the policy configuration"),
    _episode("scenario", "TEXT NOT NULL", "the scenario's name"),
    _episode("scenario_hash", "TEXT NOT NULL", "16 hex digits of the scenario content (seeds every episode)"),
    _episode("seed", "INTEGER NOT NULL", "the episode seed, paired across policies"),
    _episode("outcome", "TEXT", "success | collided | out_of_area | truncated | error", _outcome),
    _episode("total_J", "REAL", "ΣJ(k) over the episode, without the failure penalty", _total("J"),
             Board("ΣJ", "mean ΣJ(k) without the penalty", out="total_J_mean")),
    _episode("total_penalty", "REAL", "Σ failure penalty over the episode", _total("penalty")),
    _episode("total_cost", "REAL", "total_J + total_penalty = −return", lambda s: s.sum("J") + s.sum("penalty")),
    _episode("mean_J", "REAL", "total_J / K: the mean J per track point", lambda s: s.sum("J") / s.count,
             Board("J per point", "mean over episodes of ΣJ(k)/K: the mean J per executed track point (model.md A30)")),
    _episode("terrain_total", "REAL", "Σ raw terrain threat Th_e", _total("terrain_threat"), Board("terrain Σ", _TERMS)),
    _episode("radar_total", "REAL", "Σ raw radar threat Th_r", _total("radar_threat"), Board("radar Σ", _TERMS)),
    _episode("third_total", "REAL", "Σ raw third term C", _total("third_term"), Board("third Σ", _TERMS)),
    _episode("p_detected", "REAL", "1 − Π_k (1 − detection_prob_k): the chance of being detected at least once",
             lambda s: float(1.0 - np.prod(1.0 - s.column("detection_prob"))),
             Board("P(detected)", "mean of 1 − Π_k (1 − detection_prob_k)", digits=3)),
    _episode("detected_steps", "INTEGER", "track points with detection probability above 0.5", lambda s: int(s.column("detected").sum())),
    _episode("max_detection_prob", "REAL", "largest detection probability of a track point", lambda s: float(s.column("detection_prob").max())),
    _episode("path_length_km", "REAL", "flown path length from the start state [km]", _path_length_km,
             Board("path [km]", "mean flown path length")),
    _episode("fuel_kg", "REAL", "fuel burnt over the episode [kg]", _total("fuel_kg"), Board("fuel [kg]", "mean fuel burnt")),
    _episode("steps", "INTEGER", "K, the number of transitions (track points after the start)", lambda s: s.count,
             Board("steps", "mean number of track points K", digits=3)),
    _episode("nfev", "INTEGER", "objective evaluations over the episode", lambda s: int(s.column("nfev").sum())),
    _episode("nfev_per_step", "REAL", "mean objective evaluations per step", _mean("nfev"),
             Board("evals/step", "mean objective evaluations per MPC step (0 for floors and RL)")),
    _episode("stopped_early_share", "REAL", "share of steps whose optimiser stopped before its budget", _mean_recorded("stopped_early"),
             Board("stopped early", "share of MPC steps whose optimiser stopped before its budget (IHPSO: adaptive termination, eqs. 29-33); blank without an optimiser", digits=3, recorded_only=True)),
    _episode("switches_per_step", "REAL", "mean broad -> accurate switches per step", _mean_recorded("switches"),
             Board("switches/step", "mean broad → accurate and accurate → broad search switches per MPC step (IHPSO eqs. 25-28, 33); blank for optimisers without them", digits=3, recorded_only=True)),
    _episode("reverse_switches_per_step", "REAL", "mean accurate -> broad switches per step", _mean_recorded("reverse_switches"),
             Board("reverse/step", "mean broad → accurate and accurate → broad search switches per MPC step (IHPSO eqs. 25-28, 33); blank for optimisers without them", digits=3, recorded_only=True)),
    _episode("extinctions_per_step", "REAL", "mean species-extinction iterations per step (PS2O)", _mean_recorded("extinctions")),
    _episode("planning_seconds", "REAL", "mean wall-clock seconds per action", _mean("planning_seconds"),
             Board("planning [s/step]", "mean wall-clock seconds per action (machine-dependent; not a benchmark score)", digits=3)),
    _episode("objective_seconds", "REAL", "mean seconds per step spent inside rollout_cost", _mean("objective_seconds")),
    _episode("planning_cpu_seconds", "REAL", "mean CPU seconds per action (api.md §4.12)", _mean("planning_cpu_seconds")),
    _episode("setup_seconds", "REAL", "wall-clock seconds of the policy's reset: its per-map setup in this episode (value function, weights; loaded when cached, api.md §4.12)"),
    _episode("setup_cpu_seconds", "REAL", "CPU seconds of the policy's reset (api.md §4.12)"),
    _episode("episode_seconds", "REAL", "wall-clock seconds of the whole episode"),
    _episode("weights", "TEXT", "the cost weights (w1, w2, w3)"),
    _episode("profile", "TEXT", "the scenario profile: benchmark or paper"),
    _episode("horizon", "INTEGER", "MPC horizon H (planners only)"),
    _episode("max_evals", "INTEGER", "objective evaluations allowed per MPC step (planners only)"),
    _episode("train_timesteps", "INTEGER", "environment steps an RL agent trained for",
             board=Board("train steps", _TRAINING, section="training", aggregate="mean_recorded", style="count", optional=True)),
    _episode("train_seconds", "REAL", "wall-clock seconds an RL agent trained for",
             board=Board("train [s]", _TRAINING, section="training", aggregate="mean_recorded", digits=3, optional=True)),
    _episode("error", "TEXT NOT NULL DEFAULT ''", "the exception and traceback when the planner raised, else empty", lambda s: ""),
    _episode("run_id", "INTEGER", "the `runs` row (provenance) of the sweep that wrote the episode"),
    _episode("finished", "TEXT", "UTC time the episode finished (ISO 8601)"),
)  # fmt: skip

# Columns measured on the machine (durations and times of day): the same seeds give other values on
# another run, so comparisons of two runs (resume, parallel vs sequential, reproduction) leave them out.
MEASURED = (
    "planning_seconds", "planning_cpu_seconds", "objective_seconds", "setup_seconds", "setup_cpu_seconds",
    "episode_seconds", "finished",
)  # fmt: skip

STATISTICS: tuple[Column, ...] = (
    _statistic("policy", Board("policy", None, section="outcomes", aggregate="statistic", csv=("policy", "policy_hash")),
               "the policy's name, or name@hash8 when one name has several configurations (the reference in bold)"),
    _statistic("episodes", Board("episodes", "episodes that finished (any outcome except a harness error); all statistics use only these", section="outcomes", aggregate="statistic")),
    _statistic("members", Board("members", "frozen-suite tables only (docs/suite.md §5): members with a finished episode of the policy; its means cover these", section="outcomes", aggregate="statistic", recorded_only=True)),
    _statistic("errors", Board("errors", "episodes whose planner raised (stored with `error`; excluded from every statistic)", section="outcomes", aggregate="statistic")),
    _statistic("success_rate", Board("success [95% CI]", "share of episodes that reached the goal, with the Wilson 95 % interval", name="success", section="outcomes", aggregate="statistic",
                                          csv=("successes", "success_rate", "success_rate_ci_low", "success_rate_ci_high"))),
    _statistic("outcome_counts", Board("collided/out/truncated", "episodes that hit the terrain, left the map or exceeded the ceiling, or ran out of steps", section="outcomes", aggregate="statistic",
                                        csv=("collided", "out_of_area", "truncated"))),
    _statistic("failure_kinds", Board(
        "failures: goal pass/terrain/edge/ceiling/trunc",
        "failed episodes by kind (api.md §4.11): goal pass (came within two turn radii at v_max of the goal, then "
        "moved away; counted first, however the episode ended), terrain (collided), edge (left the map's x/y bounds), "
        "ceiling (climbed above the map's ceiling), trunc (ran out of steps); read from the step rows, blank for a "
        "policy with a failure whose track is not stored",
        name="failures", section="outcomes", aggregate="statistic", out="fail_goal_pass",
        csv=("fail_goal_pass", "fail_terrain", "fail_edge", "fail_ceiling", "fail_truncation"), recorded_only=True)),
    _statistic("total_cost_mean", Board(
        "total J (incl. penalty) mean [95% CI]",
        "ΣJ(k) + failure penalty = −return, per episode; mean with a percentile-bootstrap 95 % interval "
        "over episodes ({resamples} resamples, seeded). The penalty (crash_penalty_per_step × remaining steps) "
        "makes a crash cost at least as much as flying on, so lower is better and a crash never looks cheap",
        name="total J (incl. penalty)", section="outcomes", aggregate="statistic",
        csv=("total_cost_mean", "total_cost_mean_ci_low", "total_cost_mean_ci_high"))),
    _statistic("total_cost_iqm", Board("IQM [95% CI]", "interquartile mean (mean of the middle 50 %) of total J (incl. penalty), bootstrap 95 % interval", name="IQM", section="outcomes", aggregate="statistic",
                                            csv=("total_cost_iqm", "total_cost_iqm_ci_low", "total_cost_iqm_ci_high"))),
    _statistic("friedman_rank", Board(
        "rank",
        "Friedman average rank of total J (incl. penalty) over the seeds every policy finished "
        "(1 = cheapest on a seed; ties share the mean rank); rows are sorted by it, then by mean cost",
        section="comparison", aggregate="statistic")),
    _statistic("delta_mean", Board(
        "Δ vs {reference} [95% CI]",
        "mean paired difference of total J (this policy − reference) over shared seeds, with a paired "
        "bootstrap 95 % interval; positive = costlier than the reference",
        name="Δ vs reference", section="comparison", aggregate="statistic",
        csv=("delta_mean", "delta_mean_ci_low", "delta_mean_ci_high"))),
    _statistic("median_difference", Board(
        "median Δ",
        "median paired difference of total J (this policy − reference): the location the Wilcoxon test "
        "judges, robust to a single crash; its sign says cheaper (−) or costlier (+) in the Statistics",
        section="comparison", aggregate="statistic")),
    _statistic("pvalue_holm", Board(
        "p (Holm)",
        "two-sided Wilcoxon signed-rank test of total J against the reference over shared seeds, "
        "Holm–Bonferroni adjusted over the comparisons in this table",
        section="comparison", aggregate="statistic", csv=("n_pairs", "wilcoxon_statistic", "pvalue", "pvalue_holm"))),
    _statistic("gap_mean", Board(
        "gap to J* mean [95% CI]",
        "relative gap (J − J*)/J* of each episode's total J (incl. penalty) to the best-known total J* of its own "
        "scenario (docs/best-known.md), in %: mean with a percentile-bootstrap 95 % interval; only episodes of "
        "scenarios with a record count; negative = the episode beat the record (run `uav-bench best-known update`)",
        name="gap to J* mean", section="comparison", aggregate="statistic",
        csv=("gap_mean", "gap_mean_ci_low", "gap_mean_ci_high"), recorded_only=True)),
    _statistic("gap_iqm", Board(
        "gap to J* IQM [95% CI]", "interquartile mean of the relative gap to J*, in %, bootstrap 95 % interval",
        name="gap to J* IQM", section="comparison", aggregate="statistic",
        csv=("gap_iqm", "gap_iqm_ci_low", "gap_iqm_ci_high"), recorded_only=True)),
    _statistic("within_1pct", Board(
        "≤1% of J*", "share of the policy's episodes (of scenarios with a record) whose total J is within 1 %, 5 % or 10 % of J* (gap ≤ 0.01, 0.05, 0.10)",
        section="comparison", aggregate="statistic", recorded_only=True)),
    _statistic("within_5pct", Board(
        "≤5% of J*", "share of the policy's episodes (of scenarios with a record) whose total J is within 1 %, 5 % or 10 % of J* (gap ≤ 0.01, 0.05, 0.10)",
        section="comparison", aggregate="statistic", recorded_only=True)),
    _statistic("within_10pct", Board(
        "≤10% of J*", "share of the policy's episodes (of scenarios with a record) whose total J is within 1 %, 5 % or 10 % of J* (gap ≤ 0.01, 0.05, 0.10)",
        section="comparison", aggregate="statistic", recorded_only=True)),
)  # fmt: skip

WINDOW_RUN: tuple[Column, ...] = (
    _window("scenario", "TEXT NOT NULL", "the scenario's name"),
    _window("scenario_hash", "TEXT NOT NULL", "16 hex digits of the scenario content"),
    _window("source_policy", "TEXT NOT NULL", "the policy whose stored episode gave the window state"),
    _window("source_policy_hash", "TEXT NOT NULL", "its configuration hash"),
    _window("episode_seed", "INTEGER NOT NULL", "the seed of that episode"),
    _window("step", "INTEGER NOT NULL", "the window's step index k (the state after k transitions)"),
    _window("state", "TEXT", "JSON list: the exact state (x, y, z [m], v, φ, θ) the window starts from"),
    _window("optimizer", "TEXT NOT NULL", "the optimiser's registry name"),
    _window("optimizer_hash", "TEXT NOT NULL", "16 hex digits of the MPC configuration (optimiser, budget, H, γ, c_T)"),
    _window("seed", "INTEGER NOT NULL", "the run's seed, shared by every optimiser on the window (api.md §4.8)"),
    _window("max_evals", "INTEGER", "the run's evaluation budget"),
    _window("horizon", "INTEGER", "MPC horizon H"),
    _window("nfev", "INTEGER", "evaluations the run spent"),
    _window("nit", "INTEGER", "iterations after initialisation"),
    _window("fun", "REAL", "the best window cost J^(H) found"),
    _window("stopped_early", "INTEGER", "1 when the run stopped before its budget"),
    _window("switches", "INTEGER", "broad -> accurate switches (NULL for optimisers without them)"),
    _window("reverse_switches", "INTEGER", "accurate -> broad switches (NULL for optimisers without them)"),
    _window("extinctions", "INTEGER", "iterations in which species died out (NULL for optimisers without them)"),
    _window("history", "TEXT", "JSON list: the best-so-far after initialisation and each iteration"),
    _window("history_nfev", "TEXT", "JSON list: evaluations spent at each history entry"),
    _window("message", "TEXT", "why the optimiser stopped"),
    _window("seconds", "REAL", "wall-clock seconds of the run"),
    _window("run_id", "INTEGER", "the `runs` row (provenance) of the command that wrote the row"),
    _window("finished", "TEXT", "UTC time the run finished (ISO 8601)"),
)  # fmt: skip


def _rl(name: str, board: Board, definition: str) -> Column:
    return Column(name, "rl_groups", None, definition, board=board)


_RUNS = (
    "stratified bootstrap 95 % interval: runs resampled within each scenario ({resamples} resamples, seeded)"
)
_POI = (
    "probability of improvement P(X < Y) + ½ P(X = Y): the chance that a run of this row has a lower total J "
    "(incl. penalty) than a run of {versus}, from the Mann-Whitney U over all run pairs of each scenario, "
    "averaged over scenarios; 0.5 = no preference; interval: both sides resampled independently, stratified "
    "by scenario"
)

# The RL table of a scenario group (leaderboard/rl.py; docs/rl-statistics.md §2): one row per RL
# group (an algorithm and regime: all its training seeds) and per reference policy (greedy, the
# best swarm planner).
RL_GROUP: tuple[Column, ...] = (
    _rl("group", Board("group", "an RL group (all training seeds of one algorithm and regime: the label without its `-sN`) or a reference policy (greedy, the best swarm planner; kind `reference`)",
                       csv=("group", "kind", "members")),
        "the RL group, e.g. sb3:ppo-paper, or a reference policy"),
    _rl("runs", Board("runs", "independent runs: an RL group's training seeds (each scored by its mean episode cost), a reference policy's episode seeds"),
        "runs of the row: training seeds of a group, episode seeds of a reference policy"),
    _rl("tasks", Board("scenarios", "scenarios every run finished: the strata of the bootstrap"), "scenarios (strata) the row's scores cover"),
    _rl("episodes", Board("episodes", "finished episodes behind the row's scores"), "finished episodes behind the row's scores"),
    _rl("iqm", Board("IQM [95% CI]", "interquartile mean of total J (incl. penalty) over all runs x scenarios, " + _RUNS, csv=("iqm", "iqm_ci_low", "iqm_ci_high")),
        "interquartile mean of the run scores (total J incl. penalty), with its stratified-bootstrap interval"),
    _rl("mean", Board("mean [95% CI]", "mean of the run scores (scenarios weigh alike), " + _RUNS, csv=("mean", "mean_ci_low", "mean_ci_high")),
        "mean of the run scores, with its stratified-bootstrap interval"),
    _rl("poi_greedy", Board("P(< greedy) [95% CI]", _POI.format(versus="the greedy floor"), csv=("poi_greedy", "poi_greedy_ci_low", "poi_greedy_ci_high")),
        "probability of improvement over the greedy floor, with its interval"),
    _rl("delta_greedy", Board("Δ vs greedy [95% CI]", "paired difference of total J (incl. penalty) to the greedy floor: the mean over the scenarios both finished of (the row's mean run score − greedy's), negative = cheaper; interval: two-stage percentile bootstrap, scenarios then runs within each ({resamples} resamples; docs/rl-statistics.md §1)",
                              csv=("delta_greedy", "delta_greedy_ci_low", "delta_greedy_ci_high")),
        "paired difference of total J to the greedy floor, with its two-stage bootstrap interval"),
    _rl("poi_planner", Board("P(< {planner}) [95% CI]", _POI.format(versus="the best swarm planner (the paper planner with the lowest mean total J in the group)"),
                             csv=("best_planner", "poi_planner", "poi_planner_ci_low", "poi_planner_ci_high")),
        "probability of improvement over the best swarm planner, with its interval"),
    _rl("gap", Board("gap to J*", "mean relative gap (J − J*)/J* of the row's finished episodes to the best-known total J* of their own scenario, in % (episodes of scenarios without a record left out; docs/best-known.md)", digits=3),
        "mean relative gap of the row's episodes to the best-known total J* of their scenarios"),
    _rl("decision_seconds", Board("decision [s/step]", "mean wall-clock seconds per action (network inference for agents, planning for MPC; machine-dependent)", digits=3),
        "mean wall-clock seconds per action over the row's episodes"),
    _rl("train_timesteps", Board("train steps", _TRAINING, style="count"), "mean environment steps the group's agents trained for"),
    _rl("train_seconds", Board("train [s]", _TRAINING, digits=3), "mean wall-clock seconds the group's agents trained for"),
)  # fmt: skip
