"""IHPSO's adaptive mechanisms on MPC window states of the paper scenario (optimizers.md §5.6).

Window states come from a greedy episode of the paper scenario through the env
(``UAVPenetrationEnv(paper_scenario())``); each chosen state's window is built by the harness's
:func:`~uav_penetration_env.benchmark.windows.window_at`, whose objective is
:func:`~uav_penetration_env.benchmark.policies.mpc_objective`, the one ``MPCPolicy`` plans on. The warm
start is the greedy episode's own next H controls from that state (as the harness's shifted previous
plan would be). ``uav-bench windows`` does the same from a results store and keeps every run's history
(api.md §4.8); this script adds the tolerance and ablation tables.

On each (state, seed) pair the script runs ``ihpso``, ``hpso`` and ``ihpso-2022v0`` with the full budget,
HPSO again with IHPSO's evaluation count (fixed budget), and IHPSO with a few other "slope = 0"
tolerances, and prints:

* the share of IHPSO runs with a reverse switch, with adaptive termination, and the first switch iteration;
* evaluations used (IHPSO / HPSO);
* fixed target: evaluations each needed to reach the worse of the two final costs (from ``history_nfev``);
* fixed budget: IHPSO's J against HPSO's J when HPSO gets IHPSO's evaluation count;
* paired Wilcoxon signed-rank tests over the pairs;
* the ablations ``ihpso-noswitch``, ``ihpso-noreverse``, ``ihpso-noterm`` on the same pairs;
* the tolerance table (evaluation share and final J per tolerance).

With ``--swarm-draws N`` it first prints how often eq. 33 (``termination_test``) passes on synthetic
swarms of 100 particles in 3-D and 15-D: Gaussian clumps (standard deviation 1 per coordinate, centres
10 apart) and single uniform or Gaussian clouds, N seeded draws each (the generators
``tests/optimizers/test_ihpso_mechanisms.py`` uses).

Usage: ``python benchmarks/ihpso_mechanisms.py [--states 8] [--seeds 3] [--max-evals 10000]
[--episode-seed 1] [--steps 4 10 ...] [--swarm-draws 1000]``; ``--states 0`` skips the MPC study. The
paper scenario's greedy episode is deterministic (the env seed does not change it), so other window
states are chosen with ``--steps``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from typing import Any

import numpy as np
from scipy.stats import wilcoxon

from uav_penetration_env.benchmark.windows import Window

HORIZON = 5
TOLERANCES = (1e-6, 1e-5, 1e-4, 1e-3, 1e-2)  # 1e-4 is the default (optimizers.md D15)
ABLATIONS = ("ihpso-noswitch", "ihpso-noreverse", "ihpso-noterm")
SWARM_SIZE, N_GROUPS = 100, 5
SEPARATION = 10.0  # clump centres, in standard deviations of a clump: far enough apart that eq. 33's test must see two
CLUMP_SIZES = ((50, 50), (70, 30), (80, 20), (90, 10), (34, 33, 33), (50, 30, 20), (60, 30, 10))


# ----------------------------------------------------------------------------------------------
# Synthetic swarms for eq. 33
# ----------------------------------------------------------------------------------------------


def clump_centres(n_clumps: int, dim: int, rng: np.random.Generator) -> np.ndarray:
    """Centres pairwise exactly ``SEPARATION`` apart in a random plane: 2 on a line, 3 an equilateral triangle.

    Returns:
        (n_clumps, dim) centres.
    """
    if n_clumps not in (2, 3):
        raise ValueError(f"n_clumps: got {n_clumps!r}, expected 2 or 3")
    basis, _ = np.linalg.qr(rng.normal(size=(dim, 2)))
    planar = (
        np.array([[-0.5, 0.0], [0.5, 0.0]])
        if n_clumps == 2
        else np.array([[0.0, 0.0], [1.0, 0.0], [0.5, math.sqrt(3) / 2]])
    )
    return SEPARATION * planar @ basis.T


def clumps(sizes: tuple[int, ...], dim: int, rng: np.random.Generator) -> np.ndarray:
    """(sum(sizes), dim) Gaussian clumps (standard deviation 1) around :func:`clump_centres`, shuffled."""
    centres = clump_centres(len(sizes), dim, rng)
    points = np.vstack([c + rng.normal(size=(size, dim)) for c, size in zip(centres, sizes, strict=True)])
    return points[rng.permutation(points.shape[0])]


def cloud(kind: str, dim: int, rng: np.random.Generator) -> np.ndarray:
    """(100, dim) single cloud: ``"uniform"`` in the unit cube or ``"gaussian"``."""
    return rng.random((SWARM_SIZE, dim)) if kind == "uniform" else rng.normal(size=(SWARM_SIZE, dim))


def termination_pass_rate(make: Any, draws: int, seed: int, **test_options: Any) -> float:
    """Share of ``draws`` swarms ``make(rng)`` on which eq. 33 (``termination_test``, G = 5) passes."""
    from optimizers.ihpso import termination_test

    rng = np.random.default_rng(seed)
    return float(np.mean([termination_test(make(rng), N_GROUPS, **test_options) for _ in range(draws)]))


def swarm_table(draws: int) -> None:
    """Print eq. 33's failure rate on clumps and pass rate on clouds, now and under 2022v0."""
    v0 = {"method": "average", "cut": "equal", "spread": "sum"}
    print(f"== eq. 33 on synthetic swarms (100 particles, G = 5, {draws} draws each) ==")
    print(f"{'swarm':<22} {'dim':>3} {'ihpso: fails':>13} {'2022v0: fails':>14}")
    for sizes in CLUMP_SIZES:
        for dim in (3, 15):
            label = "clumps " + "/".join(map(str, sizes))
            now = termination_pass_rate(lambda rng, s=sizes, d=dim: clumps(s, d, rng), draws, 1000 + dim)
            old = termination_pass_rate(
                lambda rng, s=sizes, d=dim: clumps(s, d, rng), draws, 1000 + dim, **v0
            )
            print(f"{label:<22} {dim:>3} {1 - now:>13.1%} {1 - old:>14.1%}")
    print(f"{'swarm':<22} {'dim':>3} {'ihpso: passes':>13} {'2022v0: passes':>14}")
    for kind in ("uniform", "gaussian"):
        for dim in (3, 15):
            now = termination_pass_rate(lambda rng, k=kind, d=dim: cloud(k, d, rng), draws, 2000 + dim)
            old = termination_pass_rate(lambda rng, k=kind, d=dim: cloud(k, d, rng), draws, 2000 + dim, **v0)
            print(f"{'cloud ' + kind:<22} {dim:>3} {now:>13.1%} {old:>14.1%}")
    print()


# ----------------------------------------------------------------------------------------------
# MPC window states
# ----------------------------------------------------------------------------------------------


def greedy_episode(seed: int) -> tuple[Any, list[tuple[np.ndarray, int]], list[np.ndarray]]:
    """A greedy episode of the paper scenario: the env, the (state, step) before each action, the actions."""
    from uav_penetration_env import paper_scenario
    from uav_penetration_env.benchmark.policies import make_policy
    from uav_penetration_env.env import UAVPenetrationEnv

    env = UAVPenetrationEnv(paper_scenario())
    observation, info = env.reset(seed=seed)
    policy = make_policy("greedy")
    policy.reset(env.unwrapped.model, seed)
    states, actions = [], []
    done = False
    while not done:
        states.append((np.asarray(info["state"], dtype=np.float64).copy(), int(info["step"])))
        action = np.asarray(policy.act(observation, info), dtype=np.float64)
        actions.append(action)
        observation, _, terminated, truncated, info = env.step(action)
        done = terminated or truncated
    return env, states, actions


def collect_windows(
    n_states: int, max_evals: int, episode_seed: int, steps: list[int] | None = None
) -> list[Window]:
    """Window states of a greedy episode: ``steps`` if given, else ``n_states`` spread evenly (step 0 excluded).

    Raises:
        ValueError: If a step is outside the episode.
    """
    from uav_penetration_env.benchmark.windows import window_at

    env, states, actions = greedy_episode(episode_seed)
    if steps:
        bad = [s for s in steps if not 0 <= s < len(states)]
        if bad:
            raise ValueError(
                f"steps: got {bad}, expected steps in [0, {len(states)}) (the greedy episode's length)"
            )
        picks = np.array(sorted(set(steps)))
    else:
        picks = np.unique(np.linspace(1, len(states) - 1, n_states).astype(int))
    model = env.unwrapped.model
    return [
        window_at(model, states[int(i)][0], states[int(i)][1], actions[int(i) :], horizon=HORIZON)
        for i in picks
    ]


def evals_to_target(result: Any, target: float) -> float:
    """Evaluations until the best-so-far first reaches ``target`` (``history_nfev``); inf if never."""
    from uav_penetration_env.benchmark.fixedtarget import runtime_to_target

    return runtime_to_target(result.history, result.history_nfev, target)


def run(optimizer: Any, window: Window, seed: int, max_evals: int) -> Any:
    """One run on the window, seeded with ``default_rng(seed)``, warm-started with ``window.x0``."""
    from uav_penetration_env.benchmark.windows import run_window

    return run_window(optimizer, window, np.random.default_rng(seed), max_evals)


def paired(label: str, a: np.ndarray, b: np.ndarray) -> str:
    """Median of a/b or a-b, wins, and a two-sided Wilcoxon signed-rank p-value."""
    diff = a - b
    if np.all(diff == 0):
        p = 1.0
    else:
        p = float(wilcoxon(a, b, zero_method="wilcox").pvalue)
    return (
        f"{label:<44} median A={np.median(a):.6g}  B={np.median(b):.6g}  A<B in {int(np.sum(a < b))}, "
        f"A>B in {int(np.sum(a > b))} of {a.size}  Wilcoxon p={p:.3g}"
    )


def main(argv: list[str] | None = None) -> int:
    from optimizers import get_optimizer

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=8)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--max-evals", type=int, default=10_000)
    parser.add_argument("--episode-seed", type=int, default=1)
    parser.add_argument("--swarm-draws", type=int, default=0)
    parser.add_argument(
        "--steps", type=int, nargs="*", default=None, help="window steps (overrides --states)"
    )
    args = parser.parse_args(argv)

    start = time.perf_counter()
    if args.swarm_draws > 0:
        swarm_table(args.swarm_draws)
    if args.states <= 0 and not args.steps:
        return 0
    windows = collect_windows(args.states, args.max_evals, args.episode_seed, args.steps)
    print(
        f"window states: greedy episode (env seed {args.episode_seed}) of the paper scenario, steps "
        f"{[w.step for w in windows]}; seeds 0..{args.seeds - 1}; {args.max_evals} evaluations; H = {HORIZON}"
    )
    ihpso, hpso, old = get_optimizer("ihpso"), get_optimizer("hpso"), get_optimizer("ihpso-2022v0")
    ablation_optimizers = {name: get_optimizer(name) for name in ABLATIONS}
    rows = []
    for window in windows:
        for seed in range(args.seeds):
            r_i = run(ihpso, window, seed, args.max_evals)
            r_h = run(hpso, window, seed, args.max_evals)
            r_o = run(old, window, seed, args.max_evals)
            r_hb = run(hpso, window, seed, int(r_i.nfev))
            ablations = {
                name: run(opt, window, seed, args.max_evals) for name, opt in ablation_optimizers.items()
            }
            target = max(r_i.fun, r_h.fun)
            tolerance = {}
            for rtol in TOLERANCES:
                r_t = (
                    r_i
                    if rtol == ihpso.slope_rtol
                    else run(replace(ihpso, slope_rtol=rtol), window, seed, args.max_evals)
                )
                tolerance[rtol] = (r_t.nfev, r_t.fun)
            switches = r_i.trace["switch_iterations"]
            rows.append(
                {
                    "step": window.step,
                    "seed": seed,
                    "J_i": r_i.fun,
                    "J_h": r_h.fun,
                    "J_o": r_o.fun,
                    "J_hb": r_hb.fun,
                    "n_i": r_i.nfev,
                    "n_h": r_h.nfev,
                    "n_o": r_o.nfev,
                    "ft_i": evals_to_target(r_i, target),
                    "ft_h": evals_to_target(r_h, target),
                    "reverse": len(r_i.trace["reverse_switch_iterations"]),
                    "terminated": r_i.trace["stopped_by"] == "termination",
                    "terminated_o": r_o.trace["stopped_by"] == "termination",
                    "reverse_o": len(r_o.trace["reverse_switch_iterations"]),
                    "first_switch": switches[0] if switches else None,
                    "switches": len(switches),
                    "tests": len(r_i.trace["termination_tests"]),
                    "accurate_share": r_i.trace["mode"].count("accurate") / max(len(r_i.trace["mode"]), 1),
                    "tolerance": tolerance,
                    "spreads": r_i.trace["termination_spreads"],
                    "ablations": {name: (r.nfev, r.fun) for name, r in ablations.items()},
                    "nit": r_i.nit,
                }
            )
            row = rows[-1]
            print(
                f"  step {window.step:3d} seed {seed}: ihpso J={row['J_i']:.6g} nfev={row['n_i']:5d} "
                f"switches={row['switches']} reverse={row['reverse']} tests={row['tests']} "
                f"stop={'term' if row['terminated'] else 'budget'} | hpso J={row['J_h']:.6g} "
                f"| hpso@{row['n_i']} J={row['J_hb']:.6g} | 2022v0 J={row['J_o']:.6g} nfev={row['n_o']}",
                flush=True,
            )

    n = len(rows)

    def col(key: str) -> np.ndarray:
        return np.array([r[key] for r in rows], dtype=np.float64)

    print(f"\n== IHPSO's mechanisms over {n} (state, seed) pairs ==")
    first = [r["first_switch"] for r in rows if r["first_switch"] is not None]
    print(
        f"runs with a broad->accurate switch: {len(first)}/{n}; first switch at t = 3 in "
        f"{sum(f == 3 for f in first)}/{len(first)} (median t = {np.median(first) if first else float('nan')})"
    )
    print(
        f"runs with a reverse switch: {sum(r['reverse'] > 0 for r in rows)}/{n} "
        f"(ihpso-2022v0: {sum(r['reverse_o'] > 0 for r in rows)}/{n})"
    )
    print(
        f"runs ended by adaptive termination: {sum(r['terminated'] for r in rows)}/{n} "
        f"(ihpso-2022v0: {sum(r['terminated_o'] for r in rows)}/{n})"
    )
    print(f"median share of iterations in accurate mode: {np.median(col('accurate_share')):.2f}")
    tests = [len(r["spreads"]) for r in rows]
    final = [r["spreads"][-1] for r in rows if r["terminated"]]
    print(
        f"eq. 33 tests per run: median {np.median(tests):.0f} (max {max(tests)}); at the stopping test "
        f"(normalised coordinates): median SD_pemin {np.median([f[1] for f in final]) if final else math.nan:.3g}, "
        f"median SD_pemin / SD_psmax {np.median([f[1] / f[2] for f in final]) if final else math.nan:.3f}; "
        f"median stopping iteration {np.median([r['nit'] for r in rows if r['terminated']]) if final else math.nan:.0f}"
    )
    print(
        f"evaluations used: IHPSO median {np.median(col('n_i')):.0f}, HPSO {np.median(col('n_h')):.0f}, "
        f"ratio of totals {col('n_i').sum() / col('n_h').sum():.3f}; 2022v0 ratio "
        f"{col('n_o').sum() / col('n_h').sum():.3f}"
    )
    ft_i, ft_h = col("ft_i"), col("ft_h")
    print(
        f"fixed target (worse of the two final J): evaluations IHPSO/HPSO, ratio of medians "
        f"{np.median(ft_i) / np.median(ft_h):.3f}, ratio of totals {ft_i.sum() / ft_h.sum():.3f}, "
        f"IHPSO faster in {int(np.sum(ft_i < ft_h))}/{n}"
    )
    print(paired("fixed target: evaluations (A=IHPSO, B=HPSO)", ft_i, ft_h))
    print(paired("fixed budget: J (A=IHPSO, B=HPSO at IHPSO's nfev)", col("J_i"), col("J_hb")))
    print(paired("full budget: J (A=IHPSO, B=HPSO 10k)", col("J_i"), col("J_h")))
    print(paired("J (A=IHPSO, B=IHPSO-2022v0)", col("J_i"), col("J_o")))

    print("\n== Ablations (same pairs) ==")
    print(
        f"{'configuration':<16} {'eval share':>11} {'median J':>12} {'median J/J_ihpso':>17} {'J < ihpso':>10}"
    )
    for name in ABLATIONS:
        nfev = np.array([r["ablations"][name][0] for r in rows], dtype=np.float64)
        fun = np.array([r["ablations"][name][1] for r in rows], dtype=np.float64)
        print(
            f"{name:<16} {nfev.sum() / col('n_h').sum():>11.3f} {np.median(fun):>12.6g} "
            f"{np.median(fun / col('J_i')):>17.4f} {int(np.sum(fun < col('J_i'))):>6}/{n}"
        )
    print('\n== Tolerance of "slope = 0" (rtol; default 1e-4, fixed before this run) ==')
    print(f"{'rtol':>8} {'eval share':>11} {'terminated':>11} {'median J':>12} {'median J/J_hpso':>16}")
    for rtol in TOLERANCES:
        nfev = np.array([r["tolerance"][rtol][0] for r in rows], dtype=np.float64)
        fun = np.array([r["tolerance"][rtol][1] for r in rows], dtype=np.float64)
        print(
            f"{rtol:>8.0e} {nfev.sum() / col('n_h').sum():>11.3f} {int(np.sum(nfev < args.max_evals)):>6}/{n:<4} "
            f"{np.median(fun):>12.6g} {np.median(fun / col('J_h')):>16.4f}"
        )
    print(f"\nelapsed {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
