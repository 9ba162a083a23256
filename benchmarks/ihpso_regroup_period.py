"""IHPSO's broad-mode regrouping period on the published window states (optimizers.md §5.4).

Rebuilds the 15 window states of the `windows` part (greedy episode seed 0 on paper-2022-sec5, steps
2, 5, ..., 44), checks that `ihpso` reproduces the committed window-run rows, then runs `ihpso` with
regroup_period=1 (the paper's flow: a fresh entropy grouping before every broad iteration) on the same
(window, seed) pairs and counts how often the default's periodic regrouping fires at all; then the
same for ``ihpso-noswitch``, whose broad search lasts the whole budget. Reads the v2 rows in
``leaderboards/rows/`` (their windows were planned with the ``distance`` terminal form).

Usage: ``python benchmarks/ihpso_regroup_period.py [SEEDS]`` (default 20: the published 300 runs)
"""
import sys
import time

import numpy as np
import pandas as pd
import yaml
from scipy.stats import wilcoxon

from optimizers import get_optimizer
from uav_penetration_env.benchmark.windows import ACTION_COLUMNS, replay, run_seed, run_window, window_at
from uav_penetration_env.scenario import load_scenario

ROWS = "leaderboards/rows/"
SEEDS = range(int(sys.argv[1]) if len(sys.argv) > 1 else 20)
terminal_kw = {}
runs = pd.read_parquet(ROWS + "leaderboard-window_runs.parquet")
runs = runs[(runs.scenario == "paper-2022-sec5")]
h = runs.scenario_hash.iloc[0]
scen = pd.read_parquet(ROWS + "leaderboard-scenarios.parquet")
flown = load_scenario(yaml.safe_load(scen[scen.scenario_hash == h].yaml.iloc[0]))
eps = pd.read_parquet(ROWS + "leaderboard-episodes.parquet")
ep = eps[(eps.policy == "greedy") & (eps.scenario_hash == h) & (eps.seed == 0)].iloc[0]
steps = pd.read_parquet(ROWS + "leaderboard-steps.parquet")
st = steps[steps.episode_id == ep.episode_id].sort_values("step")
st = st[st.step >= 1]
actions = st[list(ACTION_COLUMNS)].to_numpy(dtype=np.float64)
model, states = replay(flown, 0, h, actions)
windows = []
for k in sorted(runs.step.unique()):
    state, step = states[k]
    windows.append(window_at(model, state, step, actions[k:], terminal="distance", scenario="paper-2022-sec5", scenario_hash=h,
                             source_policy="greedy", episode_seed=0))


def run(name, **params):
    opt = get_optimizer(name, **params)
    out = []
    for w in windows:
        for s in SEEDS:
            res = run_window(opt, w, np.random.default_rng(run_seed(w, s)), 10_000)
            out.append((w.step, s, float(res.fun), int(res.nfev), res.trace))
    return out


t0 = time.time()
default = run("ihpso")
print(f"ihpso: {len(default)} runs in {time.time() - t0:.0f} s")
ref = runs[runs.optimizer == "ihpso"].set_index(["step", "seed"])
same = sum(ref.loc[(k, s)].fun == f and ref.loc[(k, s)].nfev == n for k, s, f, n, _ in default)
print(f"reproduces the committed ihpso rows exactly: {same}/{len(default)}")


def broad_regroupings(trace, period):
    """Iterations that began with a periodic broad regrouping (replayed from the trace's modes)."""
    since, fired = 0, []
    modes = trace["mode"]
    switches, reverses = set(trace["switch_iterations"]), set(trace["reverse_switch_iterations"])
    for t, mode in enumerate(modes, start=1):
        if mode == "broad" and since == period:
            fired.append(t)
            since = 0
        since += 1
        if t in switches or t in reverses:
            since = 0
    return fired


fired = [broad_regroupings(tr, 10) for *_, tr in default]
print(f"default: runs with a periodic broad regrouping: {sum(bool(f) for f in fired)}/{len(fired)}; "
      f"regroupings in all: {sum(map(len, fired))}")
broad = [sum(m == "broad" for m in tr["mode"]) for *_, tr in default]
print(f"default: broad iterations per run: median {np.median(broad)}, max {max(broad)}")
t0 = time.time()
paper = run("ihpso", regroup_period=1)
print(f"regroup_period=1: {len(paper)} runs in {time.time() - t0:.0f} s")
fa = np.array([f for _, _, f, _, _ in default])
fb = np.array([f for _, _, f, _, _ in paper])
na = np.array([n for _, _, _, n, _ in default])
nb = np.array([n for _, _, _, n, _ in paper])
print(f"identical runs (fun and nfev): {int(np.sum((fa == fb) & (na == nb)))}/{len(fa)}")
print(f"median J: T_r=10 {np.median(fa):.4f}, T_r=1 {np.median(fb):.4f}; "
      f"T_r=1 lower in {int(np.sum(fb < fa))}, higher in {int(np.sum(fb > fa))}")
d = fb - fa
if np.any(d != 0):
    print(f"Wilcoxon (paired, ties dropped): p = {wilcoxon(fb[d != 0], fa[d != 0]).pvalue:.3g}")
print(f"evaluations per run: T_r=10 {na.mean():.0f}, T_r=1 {nb.mean():.0f}")
rel = d / fa
print(f"relative J difference: median {np.median(rel):+.2e}, quartiles {np.percentile(rel, 25):+.2e} "
      f"{np.percentile(rel, 75):+.2e}")
sw = [tr["switch_iterations"][:1] for *_, tr in paper]
print(f"T_r=1 first switch at t=3 in {sum(s == (3,) for s in sw)}/{len(sw)}")

# Where broad search lasts the whole budget: ihpso-noswitch, T_r = 10 against 1.
ns10, ns1 = run("ihpso-noswitch"), run("ihpso-noswitch", regroup_period=1)
ref = runs[runs.optimizer == "ihpso-noswitch"].set_index(["step", "seed"])
print(f"noswitch reproduces the committed rows: {sum(ref.loc[(k, s)].fun == f for k, s, f, _, _ in ns10)}/{len(ns10)}")
fa = np.array([f for _, _, f, _, _ in ns10])
fb = np.array([f for _, _, f, _, _ in ns1])
d = fb - fa
print(f"noswitch median J: T_r=10 {np.median(fa):.4f}, T_r=1 {np.median(fb):.4f}; T_r=1 lower in "
      f"{int(np.sum(fb < fa))}, higher in {int(np.sum(fb > fa))}; Wilcoxon p = {wilcoxon(fb[d != 0], fa[d != 0]).pvalue:.3g}")
