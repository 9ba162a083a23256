"""Figures of a results store, per scenario group, as PNG and PDF (the paper's Figs. 14-18 and more).

For each scenario group (:func:`~uav_penetration_env.benchmark.leaderboard.scenario_groups`):

* ``<stem>-tracks-top`` / ``<stem>-tracks-3d``: every planner's track for one seed over the terrain,
  with the radars and their coverage at a stated altitude: the median altitude of the MPC
  planners' tracks, or ``altitude`` (Figs. 14/16). The seed is the
  smallest one every planner finished, so the tracks are paired (same start, same jitter).
* ``<stem>-j-per-point``: mean J(k) per track point against k with 95 % bands over seeds, runs of
  different length NaN-padded, and the number of runs still flying at each k (Figs. 15/18, A30).
* ``<stem>-cost-box``: total cost (ΣJ + failure penalty) per planner.
* ``<stem>-performance-profile``: Dolan-Moré profile of total cost over seeds.
* ``<stem>-convergence``: the optimisers' normalised best-so-far against evaluations, averaged
  over MPC steps (policies without an optimiser history, e.g. floors, are left out).
* ``<stem>-timeline``: altitude above ground and detection probability per step, same seed as the tracks.
* ``<stem>-compute-axis``: total J against decision time per step (log x), one point per policy or
  RL group (all training seeds) with 95 % intervals in both directions (docs/rl-statistics.md §2).
* ``<stem>-rl-profile``: rliable's run-score performance profiles (fraction of runs with total J
  below tau) with stratified-bootstrap bands, RL agents pooled over training seeds.
* ``<stem>-runtime-ecdf``: when the store has window runs (``uav-bench windows``), the share of
  (run, target) pairs each optimiser solved within x evaluations on identical MPC windows
  (api.md §4.8).

Policies are grouped by family (:data:`FAMILIES`: the paper's planners, reference optimisers,
IHPSO ablations, floors, RL agents): line style by family, colour by member, never the same
(colour, line style) pair twice in a figure; with more than ``PANEL_THRESHOLD`` policies the
line figures get one panel per family. Legends lie outside the plotting area.

Each figure is one entry of :data:`FIGURES` (a draw function and whether it shows one
scenario) or, drawn from window runs, of :data:`WINDOW_FIGURES`; the modules hold one idea each: :mod:`.common` (canvas, colours, bands),
:mod:`.tracks` (one seed's tracks over the scenario), :mod:`.costs` (costs over seeds),
:mod:`.convergence` (optimiser histories).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from uav_penetration_env.benchmark.figures.common import (
    FAMILIES,
    PNG_DPI,
    FigureInput,
    PolicyStyle,
    family_figure,
    finished_steps,
    mean_band,
    new_figure,
    note_empty,
    outside_legend,
    policy_colours,
    policy_family,
    policy_styles,
    save_figure,
)
from uav_penetration_env.benchmark.figures.convergence import (
    CONVERGENCE_NODES,
    convergence_curves,
    plot_convergence,
)
from uav_penetration_env.benchmark.figures.costs import (
    performance_profile,
    plot_cost_box,
    plot_j_per_point,
    plot_performance_profile,
)
from uav_penetration_env.benchmark.figures.rl import plot_compute_axis, plot_rl_profile
from uav_penetration_env.benchmark.figures.runtime_ecdf import plot_runtime_ecdf
from uav_penetration_env.benchmark.figures.tracks import (
    COVERAGE_LEVEL,
    SURFACE_NODES,
    coverage_altitude,
    plot_timeline,
    plot_tracks_3d,
    plot_tracks_top,
    scenario_model,
    start_state,
    track_seed,
)
from uav_penetration_env.benchmark.leaderboard import scenario_groups, suite_group
from uav_penetration_env.benchmark.leaderboard.rl import TRAINING_SEED
from uav_penetration_env.benchmark.store import ResultsStore


@dataclass(frozen=True)
class FigureSpec:
    """One figure of a scenario group.

    Attributes:
        draw: ``(FigureInput) -> Figure``.
        per_scenario: drawn over one scenario's terrain (left out of a suite's figures).
        pools_training_seeds: pools an RL group's training seeds itself (compute axis, RL profile);
            every other figure draws one agent per RL group (:func:`one_agent_per_group`).
    """

    draw: Callable[[FigureInput], Any]
    per_scenario: bool = False
    pools_training_seeds: bool = False


# The figures, in file order: name -> how to draw it. A new figure is one entry here.
FIGURES: dict[str, FigureSpec] = {
    "tracks-top": FigureSpec(plot_tracks_top, per_scenario=True),
    "tracks-3d": FigureSpec(plot_tracks_3d, per_scenario=True),
    "j-per-point": FigureSpec(plot_j_per_point),
    "cost-box": FigureSpec(plot_cost_box),
    "performance-profile": FigureSpec(plot_performance_profile),
    "convergence": FigureSpec(plot_convergence),
    "timeline": FigureSpec(plot_timeline, per_scenario=True),
    "compute-axis": FigureSpec(plot_compute_axis, pools_training_seeds=True),
    "rl-profile": FigureSpec(plot_rl_profile, pools_training_seeds=True),
}
# Figures of the window runs (``uav-bench windows``, api.md §4.8), drawn after the others for a scenario
# whose window runs the store holds: ``(group, window_runs, styles per optimiser) -> Figure``.
WINDOW_FIGURES: dict[str, Callable[..., Any]] = {
    "runtime-ecdf": plot_runtime_ecdf,
}
SCENARIO_FIGURES = tuple(name for name, spec in FIGURES.items() if spec.per_scenario)

__all__ = [
    "CONVERGENCE_NODES",
    "COVERAGE_LEVEL",
    "FAMILIES",
    "FIGURES",
    "PNG_DPI",
    "SCENARIO_FIGURES",
    "SURFACE_NODES",
    "WINDOW_FIGURES",
    "FigureInput",
    "FigureSpec",
    "PolicyStyle",
    "convergence_curves",
    "coverage_altitude",
    "family_figure",
    "finished_steps",
    "mean_band",
    "new_figure",
    "note_empty",
    "one_agent_per_group",
    "outside_legend",
    "performance_profile",
    "plot_compute_axis",
    "plot_convergence",
    "plot_cost_box",
    "plot_j_per_point",
    "plot_performance_profile",
    "plot_rl_profile",
    "plot_runtime_ecdf",
    "plot_timeline",
    "plot_tracks_3d",
    "plot_tracks_top",
    "policy_colours",
    "policy_family",
    "policy_styles",
    "save_figure",
    "scenario_model",
    "start_state",
    "track_seed",
    "write_figures",
]


def one_agent_per_group(inp: FigureInput) -> FigureInput:
    """The same input with one agent per RL group: the member with the lowest training seed.

    DECISION (api.md §4.6): the figures that draw one line, box or track per policy show an RL group
    (``sb3:ppo-paper-s0`` ... ``-s4``, hybrids alike) by its first training seed; five near-identical
    lines per group would repeat colours and bury the rest. The group's spread over training seeds
    is what the compute axis, the RL profile and the RL table show; every agent's episodes stay in
    the tables and the exported rows.
    """
    labels = list(inp.group.episodes["label"].astype(str).unique())
    first: dict[str, tuple[int, str]] = {}
    for label in labels:
        match = TRAINING_SEED.search(label)
        if match is None or policy_family(label) != "RL agents":
            continue
        seed = int(match.group()[2:])
        group = label[: match.start()]
        if group not in first or seed < first[group][0]:
            first[group] = (seed, label)
    keep = {
        label for label in labels if not (TRAINING_SEED.search(label) and policy_family(label) == "RL agents")
    }
    keep |= {label for _, label in first.values()}
    if len(keep) == len(labels):
        return inp
    episodes = inp.group.episodes[inp.group.episodes["label"].astype(str).isin(keep)]
    ids = set(episodes["episode_id"].astype(int))
    return FigureInput(
        replace(inp.group, episodes=episodes),
        inp.steps[inp.steps["episode_id"].astype(int).isin(ids)],
        inp.starts[inp.starts["episode_id"].astype(int).isin(ids)],
        inp.model,
        policy_styles(sorted(keep)),
        inp.altitude,
    )


def frozen_suite_groups(store: ResultsStore) -> list[Any]:
    """One group per frozen suite a ``run --suite`` of the store recorded, over its members' episodes.

    DECISION (api.md §4.6): the figures that aggregate over episodes (box plot, profiles, the
    compute axis) are drawn over every member of such a suite as well, named after it
    (``uavpen-heldout-v1-rl-profile.png``): with its members flown at one seed each, these are the
    suite's only figures, and the RL profile over the held-out members is the Random-regime agents'
    test. A suite this package does not ship is skipped (its tables say why).
    """
    from uav_penetration_env.benchmark.leaderboard.suite import recorded_suites, suite_episodes
    from uav_penetration_env.suites import SuiteError, load_suite

    episodes, groups = store.episodes(), []
    for name in recorded_suites(store.runs()):
        try:
            members = suite_episodes(episodes, load_suite(name))
        except SuiteError:
            continue
        if not members.empty:
            groups.append(suite_group(members.drop(columns=["member", "member_group", "member_index"]), name))
    return groups


def write_figures(
    store_path: str | Path,
    out_dir: str | Path,
    *,
    formats: Sequence[str] = ("png", "pdf"),
    suite: str | None = None,
    altitude: float | None = None,
    min_seeds: int = 1,
) -> list[Path]:
    """Write every figure of every scenario group of a results store, in each of ``formats``.

    With ``suite``, the store's episodes form one group (see ``leaderboard.suite_group``) and only
    the figures that aggregate over episodes are drawn (no tracks or timeline: they show one
    scenario).

    Args:
        store_path: the SQLite results store.
        out_dir: output folder (created if needed).
        formats: file types, each one of ``png``, ``pdf``, ``svg``.
        suite: draw one group over all scenarios, named ``suite``.
        altitude: the altitude of the radar coverage in the track figures [m above datum]
            (default: the median altitude of the MPC planners' tracks, named in the title).
        min_seeds: draw only the scenario groups flown with at least this many seeds (not with
            ``suite``). DECISION (api.md §4.6): a suite's procedural members are flown at one seed
            each; their figures (a box of one point, bands over one run) show nothing the suite
            tables do not, and 60 of them would bury the rest, so the published report uses 2.

    Returns:
        The written paths, ``<stem>-<figure>.<format>`` in the order of ``formats``, groups sorted
        by (name, hash) and figures in the order of :data:`FIGURES`, then :data:`WINDOW_FIGURES`
        for a group whose window runs the store holds (not in a suite); then, without ``suite``, the
        aggregate figures of every frozen suite the store's runs recorded (:func:`frozen_suite_groups`).

    Raises:
        FileNotFoundError: there is no store at ``store_path``.
        ValueError: an unknown format.
    """
    unknown = [f for f in formats if f not in ("png", "pdf", "svg")]
    if unknown:
        raise ValueError(f"formats: got {unknown}, expected png, pdf or svg")
    if isinstance(min_seeds, bool) or not isinstance(min_seeds, int) or min_seeds < 1:
        raise ValueError(f"min_seeds: got {min_seeds!r}, expected an integer >= 1")
    store_path, out_dir = Path(store_path), Path(out_dir)
    if not store_path.is_file():
        raise FileNotFoundError(
            f"results store {store_path}: not found; expected an SQLite file from `uav-bench run`"
        )
    out_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    with ResultsStore(store_path, create=False) as store:
        episodes = store.episodes()
        scenarios = store.scenarios()
        window_runs = store.window_runs()
        aggregate = [f for f in FIGURES if f not in SCENARIO_FIGURES]
        if suite is not None and not episodes.empty:
            plan = [(suite_group(episodes, suite), aggregate)]
        else:
            groups = [g for g in scenario_groups(episodes) if g.episodes["seed"].nunique() >= min_seeds]
            plan = [(g, list(FIGURES)) for g in groups] + [(g, aggregate) for g in frozen_suite_groups(store)]
        for group, names in plan:
            rows = store.steps(group.episodes["episode_id"].astype(int).tolist(), include_start=True)
            starts, steps = rows[rows["step"] == 0], rows[rows["step"] > 0]
            model = (
                None
                if group.scenarios
                else scenario_model(scenarios.get(group.scenario_hash, (None, None))[1])
            )
            styles = policy_styles(group.episodes["label"].unique())
            inp = FigureInput(group, steps, starts, model, styles, altitude)
            per_agent = one_agent_per_group(inp)
            for name in names:
                figure = FIGURES[name].draw(inp if FIGURES[name].pools_training_seeds else per_agent)
                written += save_figure(figure, out_dir, f"{group.stem}-{name}", formats)
            runs = window_runs[window_runs["scenario_hash"].astype(str) == group.scenario_hash]
            if suite is None and not runs.empty:
                for name, draw in WINDOW_FIGURES.items():
                    figure = draw(group, runs, policy_styles(runs["optimizer"].unique()))
                    written += save_figure(figure, out_dir, f"{group.stem}-{name}", formats)
    return written
