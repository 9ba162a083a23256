"""Figures: every file for every scenario group, non-blank, with and without optimiser histories."""

from __future__ import annotations

import contextlib
import json

import numpy as np
import pandas as pd
import pytest
import yaml
from conftest import successful_episode, tiny_scenario
from scipy import stats as scipy_stats

from uav_penetration_env.benchmark import figures
from uav_penetration_env.benchmark.leaderboard import prepare_episodes
from uav_penetration_env.benchmark.store import ResultsStore


def assert_images(paths, stems, formats=("png", "pdf")):
    from matplotlib.image import imread

    names = {p.name for p in paths}
    expected = {f"{stem}-{name}.{ext}" for stem in stems for name in figures.FIGURES for ext in formats}
    assert names == expected
    for path in paths:
        assert path.is_file()
        if path.suffix == ".pdf":
            assert path.read_bytes()[:5] == b"%PDF-"
            continue
        image = imread(path)[..., :3]
        assert image.shape[0] >= 400 and image.shape[1] >= 400
        drawn = (image < 0.9).any(axis=-1).mean()  # share of pixels that are not (near) white
        assert drawn > 0.01, f"{path.name} looks blank"
        packed = np.round(image[::5, ::5] * 255).astype(np.uint32) @ np.array(
            [1, 256, 65536], dtype=np.uint32
        )
        assert np.unique(packed).size > 20, f"{path.name} looks blank"


# --- a store from a real sweep -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def real_store(tmp_path_factory):
    from uav_penetration_env.benchmark.evaluate import evaluate
    from uav_penetration_env.benchmark.policies import make_policy

    path = tmp_path_factory.mktemp("fig") / "real.sqlite"
    policies = {"pso": make_policy("pso", max_evals=200), "greedy": make_policy("greedy")}
    policies["random"] = make_policy("random")
    evaluate(policies, [tiny_scenario(time={"max_steps": 15})], range(2), store=path, progress=False)
    return path


def test_every_figure_of_a_real_sweep(real_store, tmp_path):
    paths = figures.write_figures(real_store, tmp_path)
    assert_images(paths, ["tiny"])
    assert paths[0].name == "tiny-tracks-top.png"


# --- a synthetic store: two groups, one without its scenario YAML, an error row -------------------------


def synthetic_steps(seed: int, n: int, history: bool) -> list[dict]:
    rows = []
    for k in range(1, n + 1):
        row = {
            "step": k,
            "x_km": 2.5 * k,
            "y_km": 2.0 * k + seed,
            "z_m": 150.0 + 20 * k,
            "altitude_agl": 100.0 + 10 * (k % 3),
            "J": 0.3 + 0.05 * ((k + seed) % 4),
            "penalty": 0.0,
            "detection_prob": 0.1 * (k % 5),
        }
        if history:
            best = 3.0 - 0.5 * np.arange(4) - 0.1 * k
            row |= {"history": best.tolist(), "history_nfev": [50, 100, 150, 200]}
        rows.append(row)
    return rows


def synthetic_episode(
    policy: str, seed: int, scenario: str, scenario_hash: str, cost: float, **changes
) -> dict:
    return successful_episode(policy, seed, scenario, scenario_hash, cost) | {"steps": 8, "error": ""} | changes


@contextlib.contextmanager
def store_with_tiny(path):
    """An open results store at ``path`` with the tiny scenario registered: yields (store, scenario)."""
    tiny = tiny_scenario()
    with ResultsStore(path) as store:
        store.register({}, {tiny.hash: ("tiny", yaml.safe_dump(tiny.to_dict(), sort_keys=False))})
        yield store, tiny


@pytest.fixture(scope="module")
def synthetic_store(tmp_path_factory):
    path = tmp_path_factory.mktemp("fig") / "synthetic.sqlite"
    # Only the first group's scenario is stored: the second draws its tracks without terrain.
    with store_with_tiny(path) as (store, tiny):
        for seed in range(3):
            for policy, history, cost in (("ihpso", True, 5.0 + seed), ("greedy", False, 6.0)):
                episode = synthetic_episode(policy, seed, "tiny", tiny.hash, cost)
                store.write_episode(episode, synthetic_steps(seed, 8 - seed, history))
            # The second group holds floors only: no optimiser history anywhere.
            for policy, cost in (("greedy", 6.0), ("random", 9.0 + seed)):
                episode = synthetic_episode(policy, seed, "other map", "f" * 16, cost)
                store.write_episode(episode, synthetic_steps(seed, 6, False))
        error = synthetic_episode("random", 0, "tiny", tiny.hash, 0.0, outcome="error", error="boom")
        store.write_episode(error, [])
    return path


def test_two_groups_floors_only_and_no_stored_scenario(synthetic_store, tmp_path):
    paths = figures.write_figures(synthetic_store, tmp_path, formats=("png",))
    assert_images(paths, ["other-map", "tiny"], formats=("png",))
    assert paths[0].name.startswith("other-map-")  # groups sorted by name


def test_unknown_format(synthetic_store, tmp_path):
    with pytest.raises(ValueError, match="formats"):
        figures.write_figures(synthetic_store, tmp_path, formats=("png", "gif"))


def test_missing_store_is_an_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="results store"):
        figures.write_figures(tmp_path / "nothing.sqlite", tmp_path)


# --- the pure helpers, by hand ------------------------------------------------------------------------


def test_mean_band_by_hand():
    mean, low, high, count = figures.mean_band(np.array([[1.0, 2.0, np.nan], [3.0, np.nan, np.nan]]))
    assert np.allclose(mean[:2], [2.0, 2.0]) and np.isnan(mean[2])
    assert count.tolist() == [2, 1, 0]
    half = scipy_stats.t.ppf(0.975, 1) * np.sqrt(2.0) / np.sqrt(2.0)
    assert low[0] == pytest.approx(2.0 - half) and high[0] == pytest.approx(2.0 + half)
    assert np.isnan(low[1:]).all() and np.isnan(high[1:]).all()


def test_performance_profile_by_hand():
    table = pd.DataFrame({"a": [1.0, 2.0], "b": [2.0, 2.0], "c": [4.0, np.nan], "gone": [np.nan, np.nan]})
    ratios, shift = figures.performance_profile(table)
    assert shift == 0.0
    assert {k: v.tolist() for k, v in ratios.items()} == {"a": [1.0], "b": [2.0], "c": [4.0]}
    ratios, shift = figures.performance_profile(pd.DataFrame({"a": [0.0, 1.0], "b": [1.0, 1.0]}))
    assert shift == 1.0  # costs 0 and 1 become 1 and 2
    assert ratios["a"].tolist() == [1.0, 1.0] and ratios["b"].tolist() == [2.0, 1.0]
    assert figures.performance_profile(pd.DataFrame({"a": [1.0, np.nan], "b": [np.nan, 1.0]})) == ({}, 0.0)


def test_convergence_curves_by_hand():
    steps = pd.DataFrame(
        {
            "history": [json.dumps([10.0, 6.0, 2.0]), json.dumps([5.0, 5.0]), None, "[]"],
            "history_nfev": [json.dumps([100, 200, 300]), json.dumps([100, 200]), None, "[]"],
        }
    )
    grid = np.array([0.0, 100.0, 150.0, 250.0, 300.0, 400.0])
    curves, flat = figures.convergence_curves(steps, grid)
    assert flat == 1  # [5, 5] never improved
    assert curves.shape == (1, 6)
    assert np.isnan(curves[0, 0])
    assert curves[0, 1:].tolist() == [1.0, 1.0, 0.5, 0.0, 0.0]


def test_track_seed_is_the_smallest_seed_every_planner_finished():
    episodes = prepare_episodes(
        pd.DataFrame(
            {
                "episode_id": [1, 2, 3, 4, 5, 6],
                "policy": ["a", "a", "a", "b", "b", "b"],
                "policy_hash": ["ha"] * 3 + ["hb"] * 3,
                "scenario_hash": ["s"] * 6,
                "seed": [0, 1, 2, 0, 1, 2],
                "outcome": ["success", "success", "success", "error", "collided", "success"],
                "error": ["", "", "", "boom", "", ""],
            }
        )
    )
    steps = pd.DataFrame({"episode_id": [1, 2, 3, 4, 5, 6]})
    assert figures.track_seed(episodes, steps) == 1
    assert figures.track_seed(episodes, steps[steps["episode_id"] != 5]) == 2
    assert figures.track_seed(episodes, steps[steps["episode_id"] == 1]) == 0  # fallback: most planners


def test_policy_colours_are_stable_and_never_red():
    colours = figures.policy_colours(["pso", "greedy", "ihpso", "random"])
    assert colours == figures.policy_colours(["random", "ihpso", "greedy", "pso"])
    assert len(set(colours.values())) == 4
    from matplotlib import colormaps

    assert colormaps["tab10"].colors[3] not in colours.values()


@pytest.mark.slow
def test_figures_of_the_paper_scenario(tmp_path):
    from uav_penetration_env import paper_scenario
    from uav_penetration_env.benchmark.evaluate import evaluate
    from uav_penetration_env.benchmark.policies import make_policy

    policies = {"ihpso": make_policy("ihpso", max_evals=500), "greedy": make_policy("greedy")}
    evaluate(policies, [paper_scenario()], range(2), store=tmp_path / "paper.sqlite", progress=False)
    paths = figures.write_figures(tmp_path / "paper.sqlite", tmp_path / "out")
    assert_images(paths, ["paper-2022-sec5"])


# --- figures a reader can read: 25 policies, families, unique styles, legends outside -------------------

MANY_POLICIES = (
    ["ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism", "ihpso-eq37", "hpso-literal"]
    + ["pso", "pso-ldw", "cem", "cmaes", "de"]
    + ["ihpso-literal", "ihpso-noterm", "ihpso-random", "ihpso-scheme1"]
    + ["greedy", "random"]
    + [f"sb3:{algo}-paper-seed{seed}-1000000steps" for algo in ("ppo", "sac") for seed in range(3)]
)
RL_ALTITUDE = 2000.0  # [m] the fake RL agents fly high; the coverage altitude must ignore them
RL_FIGURES = ("compute-axis", "rl-profile")  # RL agents pooled over training seeds, one panel


@pytest.fixture(scope="module")
def many_store(tmp_path_factory):
    path = tmp_path_factory.mktemp("fig") / "many.sqlite"
    with store_with_tiny(path) as (store, tiny):
        for index, policy in enumerate(MANY_POLICIES):
            family = figures.policy_family(policy)
            for seed in range(3):
                steps = synthetic_steps(seed, 8, history=family.endswith("(MPC)"))
                for row in steps:
                    row["y_km"] += 0.3 * index
                    if family == "RL agents":
                        row["z_m"] = RL_ALTITUDE
                episode = synthetic_episode(policy, seed, "tiny", tiny.hash, 5.0 + 0.1 * index + seed)
                # Decision times for the compute axis: MPC planners plan, the others only evaluate.
                seconds = (0.2 if family.endswith("(MPC)") else 1e-4) * (1.0 + 0.01 * index + 0.001 * seed)
                store.write_episode(
                    episode | {"policy_hash": f"h{index:015d}", "planning_seconds": seconds}, steps
                )
    return path


def drawn_figures(path, altitude=None, only=None):
    """Draw the figures of the store's one group as write_figures does: (name, figure), in FIGURES order.

    ``only``: the names to draw (default every figure); the others are not drawn at all.
    """
    from uav_penetration_env.benchmark.leaderboard import scenario_groups

    with ResultsStore(path) as store:
        episodes, scenarios = store.episodes(), store.scenarios()
        (group,) = scenario_groups(episodes)
        rows = store.steps(group.episodes["episode_id"].astype(int).tolist(), include_start=True)
    model = figures.scenario_model(scenarios[group.scenario_hash][1])
    styles = figures.policy_styles(group.episodes["label"].unique())
    inp = figures.FigureInput(group, rows[rows["step"] > 0], rows[rows["step"] == 0], model, styles, altitude)
    per_agent = figures.one_agent_per_group(inp)  # as write_figures draws them
    for name, spec in figures.FIGURES.items():
        if only is not None and name not in only:
            continue
        figure = spec.draw(inp if spec.pools_training_seeds else per_agent)
        figure.canvas.draw()
        yield name, figure


def style_key(artist, linestyle=None):
    from matplotlib.colors import to_hex

    dashes = getattr(artist, "_unscaled_dash_pattern", None) if linestyle is None else linestyle
    return to_hex(artist.get_edgecolor() if linestyle is not None else artist.get_color()), repr(dashes)


def test_families_group_the_policy_names():
    assert figures.policy_family("ihpso") == "paper planners (MPC)"
    assert figures.policy_family("ccpso-ism-eq37") == "paper planners (MPC)"
    assert figures.policy_family("ihpso-scheme2") == "IHPSO ablations (MPC)"
    assert figures.policy_family("cmaes") == "reference optimisers (MPC)"
    assert figures.policy_family("random") == "floors"
    assert figures.policy_family("sb3:ppo-paper") == "RL agents"
    assert figures.policy_family("distill-shield:c40-value-s0") == "imitation (distilled)"
    assert figures.policy_family("distill:turn-s0") == "imitation (distilled)"
    for classical in ("lattice", "lattice-c40", "value-greedy", "value-greedy-c40"):
        assert figures.policy_family(classical) == "classical planners"
    assert figures.policy_family("lattice-cx") == "reference optimisers (MPC)"  # not a clearance variant


def test_every_policy_has_a_unique_colour_and_line_style_and_legends_lie_outside(many_store):
    from matplotlib.axes import Axes
    from matplotlib.legend import Legend

    seen_names = []
    for name, figure in drawn_figures(many_store):
        seen_names.append(name)
        renderer = figure.canvas.get_renderer()
        axes = figure.findobj(Axes)
        pairs: dict[tuple[str, str], set[str]] = {}
        if name == "cost-box":
            (ax,) = axes
            labels = [t.get_text() for t in ax.get_xticklabels()]
            boxes = [p for p in ax.patches if p.get_linestyle() is not None][: len(labels)]
            assert sorted(labels) == sorted(MANY_POLICIES)
            for label, box in zip(labels, boxes, strict=True):
                pairs.setdefault(style_key(box, box._unscaled_dash_pattern), set()).add(label)
        elif name in RL_FIGURES:
            # One panel of methods: no label here ends in -sN, so each agent is an RL group of one.
            # The profile shows the RL groups with greedy and the best paper planner (ihpso: its
            # costs 5.0 + 0.1 index + seed are the lowest of its family); the compute axis shows all.
            (ax,) = axes
            handles, labels = ax.get_legend_handles_labels()
            drawn = {label.split(" (", 1)[0] for label in labels}
            rl = {p for p in MANY_POLICIES if p.startswith("sb3:")}
            assert drawn == (set(MANY_POLICIES) if name == "compute-axis" else rl | {"greedy", "ihpso"}), name
            for handle, label in zip(handles, labels, strict=True):
                if name == "compute-axis":  # an errorbar: marker and colour of its point, dashes of its bars
                    point, bars = handle.lines[0], handle.lines[2][0]
                    key = (*style_key(point), point.get_marker(), repr(bars.get_linestyle()))
                else:
                    key = style_key(handle)
                pairs.setdefault(key, set()).add(label.split(" (", 1)[0])
        else:
            for ax in axes:
                for line in ax.get_lines():
                    policy = line.get_label().split(" (", 1)[0]
                    if policy in MANY_POLICIES:
                        pairs.setdefault(style_key(line), set()).add(policy)
            drawn = set().union(*pairs.values())
            expected = {
                p
                for p in MANY_POLICIES
                if name != "convergence" or figures.policy_family(p).endswith("(MPC)")
            }
            assert drawn == expected, name
            # More than 10 policies: one panel per family (the track and line figures).
            assert len([s for s in figure.subfigs if s.legends]) == len(
                {figures.policy_family(p) for p in expected}
            ), name
        clashes = {pair: names for pair, names in pairs.items() if len(names) > 1}
        assert not clashes, f"{name}: policies sharing a (colour, line style): {clashes}"
        legends = figure.findobj(Legend)
        assert legends or name == "cost-box", name
        for legend in legends:
            box = legend.get_window_extent(renderer)
            for ax in axes:
                assert not box.overlaps(ax.get_window_extent(renderer)), f"{name}: a legend over an axes"
    assert seen_names == list(figures.FIGURES)


def title_texts(figure):
    """Every non-empty title of a figure: its own, its sub-figures' and its axes'."""
    from matplotlib.axes import Axes
    from matplotlib.figure import SubFigure

    containers = [figure, *figure.findobj(SubFigure)]
    texts = [c._suptitle for c in containers if c._suptitle is not None]
    texts += [t for ax in figure.findobj(Axes) for t in (ax.title, ax._left_title, ax._right_title)]
    return [t for t in texts if t.get_text().strip()]


def test_no_legend_covers_a_title_with_few_policies_and_a_long_scenario_name(tmp_path):
    # One panel (few policies) and titles longer than the axes: the complaint of issue 27 was the
    # legend beside the axes lying over the end of the title (j-per-point, performance-profile,
    # convergence).
    from matplotlib.legend import Legend

    path = tmp_path / "long.sqlite"
    tiny = tiny_scenario()
    name = "paper-2022-sec5-with-a-long-name"
    with ResultsStore(path) as store:
        store.register({}, {tiny.hash: (name, yaml.safe_dump(tiny.to_dict(), sort_keys=False))})
        for index, policy in enumerate(("ihpso", "pso", "greedy", "random")):
            for seed in range(3):
                episode = synthetic_episode(policy, seed, name, tiny.hash, 5.0 + index + seed)
                store.write_episode(episode | {"planning_seconds": 0.01},
                                    synthetic_steps(seed, 8, history=index < 2))  # fmt: skip
    for figure_name, figure in drawn_figures(path):
        renderer = figure.canvas.get_renderer()
        titles = title_texts(figure)
        assert titles, figure_name
        for legend in figure.findobj(Legend):
            box = legend.get_window_extent(renderer)
            for title in titles:
                extent = title.get_window_extent(renderer)
                assert not box.overlaps(extent), f"{figure_name}: the legend covers {title.get_text()!r}"


def test_the_coverage_is_drawn_at_the_mpc_planners_median_altitude_and_says_so(many_store):
    # Every synthetic MPC track point is at 150 + 20 k m, k = 1..8: median 240 m; the RL agents
    # fly at 2000 m and must not count.
    ((_, top),) = drawn_figures(many_store, only={"tracks-top"})
    title = " ".join(top._suptitle.get_text().split())  # the title wraps onto several lines
    assert "P_d ≥ 0.5 at 240 m above datum (the median altitude of the MPC planners' tracks)" in title
    ((_, top),) = drawn_figures(many_store, altitude=555.0, only={"tracks-top"})
    assert "at 555 m above datum (chosen with --altitude)" in " ".join(top._suptitle.get_text().split())


def test_few_policies_get_distinct_colours_and_one_panel(synthetic_store):
    styles = figures.policy_styles(["ihpso", "pso", "greedy", "random", "sb3:ppo"])
    assert len({s.colour for s in styles.values()}) == 5
    assert styles["greedy"].linestyle == styles["random"].linestyle != styles["ihpso"].linestyle


def test_the_compute_axis_turns_logarithmic_only_for_a_wide_cost_range(many_store, tmp_path):
    # many_store's costs: 5.0 + 0.1 index + seed, a span below 4x: linear.
    ((_, compute),) = drawn_figures(many_store, only={"compute-axis"})
    axis = compute.axes[0]
    assert axis.get_yscale() == "linear" and axis.get_xscale() == "log"
    wide = tmp_path / "wide.sqlite"
    with store_with_tiny(wide) as (store, tiny):
        for index, (policy, cost) in enumerate((("ihpso", 13.0), ("random", 150.0))):
            for seed in range(2):
                episode = synthetic_episode(policy, seed, "tiny", tiny.hash, cost + seed)
                store.write_episode(episode | {"policy_hash": f"h{index:015d}", "planning_seconds": 0.1},
                                    synthetic_steps(seed, 4, history=False))  # fmt: skip
    ((_, compute),) = drawn_figures(wide, only={"compute-axis"})
    axis = compute.axes[0]
    assert axis.get_yscale() == "log"  # 150 / 13 > 4


def test_figures_draw_one_agent_per_rl_group_except_those_that_pool_training_seeds(tmp_path):
    path = tmp_path / "seeds.sqlite"
    policies = [
        "greedy",
        "sb3:ppo-paper-s2",
        "sb3:ppo-paper-s0",
        "sb3:ppo-paper-s1",
        "ihpso+sb3:ppo-paper-s3",
    ]
    with store_with_tiny(path) as (store, tiny):
        for index, policy in enumerate(policies):
            for seed in range(2):
                store.write_episode(
                    synthetic_episode(policy, seed, "tiny", tiny.hash, 5.0 + index + seed)
                    | {"policy_hash": f"h{index:015d}", "planning_seconds": 0.01},
                    synthetic_steps(seed, 4, history=False),
                )
    drawn = dict(drawn_figures(path, only={"tracks-top", "j-per-point", "timeline", "compute-axis"}))
    for name in ("tracks-top", "j-per-point", "timeline"):
        labels = {line.get_label().split(" (", 1)[0] for ax in drawn[name].axes for line in ax.get_lines()}
        assert {"greedy", "sb3:ppo-paper-s0", "ihpso+sb3:ppo-paper-s3"} <= labels, name
        assert not labels & {"sb3:ppo-paper-s1", "sb3:ppo-paper-s2"}, name
    _, labels = drawn["compute-axis"].axes[0].get_legend_handles_labels()
    assert "sb3:ppo-paper (3 training seeds)" in labels  # pooled over its training seeds


def test_cost_axes_turn_logarithmic_when_costs_span_more_than_a_factor_of_four():
    from uav_penetration_env.benchmark.figures.common import COST_LOG_SPAN, cost_axis, new_figure

    ax = new_figure(3, 3).add_subplot()
    assert cost_axis(ax, [13.0, 13.0 * COST_LOG_SPAN, np.nan, np.inf], "total J", "mean") is False
    assert ax.get_yscale() == "linear" and ax.get_ylabel() == "total J (mean; lower is better)"
    ax = new_figure(3, 3).add_subplot()
    assert cost_axis(ax, np.array([[13.0, 148.0]]), "total J", "mean") is True  # the random floor's ~148
    assert ax.get_yscale() == "log" and ax.get_ylabel() == "total J (mean; log scale; lower is better)"
    ax = new_figure(3, 3).add_subplot()
    assert cost_axis(ax, [-1.0, 100.0], "total J", "mean") is False  # a log axis cannot show a cost <= 0
    ax = new_figure(3, 3).add_subplot()
    cost_axis(ax, [13.0, 148.0], "total J incl. failure penalty", "mean, 95% CI")
    # 71 characters on one line overran the axis: the detail goes to a second line
    assert ax.get_ylabel() == "total J incl. failure penalty\n(mean, 95% CI; log scale; lower is better)"


def test_log_axis_minor_labels_skip_the_crowded_ticks():
    from uav_penetration_env.benchmark.figures.costs import _sparse_log_label

    labels = [_sparse_log_label(v) for v in (1.2, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 12.0, 20.0, 90.0)]
    assert labels == ["1.2", "1.5", "2", "3", "", "5", "", "", "", "", "12", "20", ""]


def test_a_step_below_ground_is_drawn_at_zero_with_a_cross(tmp_path):
    path = tmp_path / "crash.sqlite"
    steps = synthetic_steps(0, 4, history=False)
    steps[-1]["altitude_agl"] = -480.0  # the collision step, as ihpso's seed 0 on the paper scenario
    with store_with_tiny(path) as (store, tiny):
        store.write_episode(synthetic_episode("ihpso", 0, "tiny", tiny.hash, 90.0, outcome="collided"), steps)
    ((_, timeline),) = drawn_figures(path, only={"timeline"})
    altitude = timeline.axes[0]
    track, cross = altitude.get_lines()
    assert track.get_ydata().tolist() == [110.0, 120.0, 100.0, 0.0]
    assert cross.get_marker() == "x" and cross.get_xdata().tolist() == [4] and cross.get_ydata().tolist() == [0.0]
    assert altitude.get_ylim()[0] > -50.0 and "below ground" in altitude.get_ylabel()


def test_clip_to_box_moves_only_the_points_outside_and_says_which():
    from uav_penetration_env.benchmark.figures.tracks import clip_to_box

    x, y, z = np.array([0.0, 5.0, 12.0]), np.array([1.0, 2.0, 3.0]), np.array([150.0, -480.0, 90.0])
    cx, cy, cz, moved = clip_to_box(x, y, z, ((0.0, 10.0), (0.0, 10.0), (0.0, 1000.0)))
    assert cx.tolist() == [0.0, 5.0, 10.0] and cy.tolist() == [1.0, 2.0, 3.0] and cz.tolist() == [150.0, 0.0, 90.0]
    assert moved.tolist() == [False, True, True]


def test_the_3d_view_keeps_a_crash_inside_its_box(tmp_path):
    """A collision's last point, far below ground, is drawn on the box's floor with a cross."""
    path = tmp_path / "crash3d.sqlite"
    steps = synthetic_steps(0, 4, history=False)
    steps[-1]["z_m"], steps[-1]["altitude_agl"] = -900.0, -1000.0
    with store_with_tiny(path) as (store, tiny):
        store.write_episode(synthetic_episode("ihpso", 0, "tiny", tiny.hash, 90.0, outcome="collided"), steps)
    ((_, view),) = drawn_figures(path, only={"tracks-3d"})
    ax = view.axes[0]
    low, high = ax.get_zlim()
    drawn = [line for line in ax.get_lines() if len(line.get_data_3d()[2])]
    assert drawn and all(low <= v <= high for line in drawn for v in line.get_data_3d()[2])
    crosses = [line for line in drawn if line.get_marker() == "x"]
    assert len(crosses) == 1 and list(crosses[0].get_data_3d()[2]) == [low]
