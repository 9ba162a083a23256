"""Benchmark every registered optimiser on the classic test functions (optimizers.md §12, §12b).

Runs each optimiser on the shifted sphere, Rosenbrock, shifted Rastrigin, Ackley and Griewank in
10-D and 30-D with equal budgets (1,000 evaluations per dimension) and 10 seeds, and prints, per
dimension, the median final error ``f - f*`` with its interquartile range and the evaluations used.
A second table gives each optimiser's own overhead per iteration (wall time outside the objective)
at 100 particles x 15 dimensions, the MPC planner's batch shape.

``--biased`` runs the biased-initialisation case instead (docs/swarm.md): the sphere
``sum x^2`` in [-100, 100]^d with every swarm started in [50, 100]^d, under each boundary rule, 30-D,
30,000 evaluations, 10 seeds; it prints per swarm optimiser and rule the median final error and the share
of runs that end with a coordinate exactly on a wall (stuck).

Usage::

    python benchmarks/bench_optimizers.py                 # full: 10-D and 30-D, 10 seeds
    python benchmarks/bench_optimizers.py --dims 10       # 10-D only
    python benchmarks/bench_optimizers.py --quick         # smoke run: 5-D, 2 seeds, small budgets
    python benchmarks/bench_optimizers.py --optimizers ihpso pso --seeds 3 --csv results.csv
    python benchmarks/bench_optimizers.py --biased           # biased start, every swarm x every rule

This is a script, not a test: the numbers are for orientation (compare with optimizers.md §12).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from optimizers import available_optimizers, get_optimizer
from optimizers.swarm import BOUNDARY_RULES, SwarmOptimizer
from uav_penetration_env.atomic import atomic_open

SHIFT = 1.5


def sphere(x: np.ndarray) -> np.ndarray:
    """Shifted sphere, sum (x - 1.5)^2."""
    z = x - SHIFT
    return (z * z).sum(axis=1)


def rosenbrock(x: np.ndarray) -> np.ndarray:
    """Rosenbrock, sum 100 (x_{i+1} - x_i^2)^2 + (1 - x_i)^2 (minimum 0 at x = 1)."""
    head, tail = x[:, :-1], x[:, 1:]
    return (100.0 * (tail - head * head) ** 2 + (1.0 - head) ** 2).sum(axis=1)


def rastrigin(x: np.ndarray) -> np.ndarray:
    """Shifted Rastrigin, 10 d + sum [(x - s)^2 - 10 cos 2 pi (x - s)]."""
    z = x - SHIFT
    return 10.0 * x.shape[1] + (z * z - 10.0 * np.cos(2.0 * np.pi * z)).sum(axis=1)


def ackley(x: np.ndarray) -> np.ndarray:
    """Shifted Ackley with a = 20, b = 0.2, c = 2 pi."""
    z = x - SHIFT
    a, b, c = 20.0, 0.2, 2.0 * np.pi
    return (-a * np.exp(-b * np.sqrt((z * z).mean(axis=1))) - np.exp(np.cos(c * z).mean(axis=1))
            + a + math.e)


def griewank(x: np.ndarray) -> np.ndarray:
    """Shifted Griewank, 1 + sum (x - s)^2 / 4000 - prod cos((x_i - s) / sqrt(i))."""
    z = x - SHIFT
    i = np.arange(1, x.shape[1] + 1)
    return 1.0 + (z * z).sum(axis=1) / 4000.0 - np.cos(z / np.sqrt(i)).prod(axis=1)


@dataclass(frozen=True)
class Problem:
    """A benchmark function with its domain (optimizers.md §12b); every minimum is 0."""

    name: str
    fun: Callable[[np.ndarray], np.ndarray]
    lower: float
    upper: float


PROBLEMS = (
    Problem("sphere", sphere, -5.0, 5.0),
    Problem("rosenbrock", rosenbrock, -5.0, 10.0),
    Problem("rastrigin", rastrigin, -5.12, 5.12),
    Problem("ackley", ackley, -32.768, 32.768),
    Problem("griewank", griewank, -600.0, 600.0),
)
PROBLEM_BY_NAME = {p.name: p for p in PROBLEMS}


def run_one(optimizer: str, problem: str, dim: int, seed: int, max_evals: int) -> dict:
    """One optimiser run; returns a flat result row."""
    spec = PROBLEM_BY_NAME[problem]
    bounds = [(spec.lower, spec.upper)] * dim  # (d, 2) pairs: a (lower, upper) pair is ambiguous for d = 2
    start = time.perf_counter()
    res = get_optimizer(optimizer).minimize(spec.fun, bounds, rng=seed, max_evals=max_evals)
    seconds = time.perf_counter() - start
    return {
        "optimizer": optimizer, "problem": problem, "dim": dim, "seed": seed, "max_evals": max_evals,
        "error": float(res.fun), "nfev": int(res.nfev), "nit": int(res.nit), "seconds": seconds,
        "message": res.message,
    }


BIASED_BOUNDS = (-100.0, 100.0)
BIASED_START = (50.0, 100.0)


def plain_sphere(x: np.ndarray) -> np.ndarray:
    """Sphere ``sum x^2`` (minimum 0 at the origin): the biased-initialisation case."""
    return (x * x).sum(axis=1)


def run_biased(optimizer: str, rule: str, dim: int, seed: int, max_evals: int) -> dict:
    """One biased-start run: sphere in [-100, 100]^d, swarm initialised in [50, 100]^d, one boundary rule.

    A run is *stuck* when its best point has a coordinate exactly on a wall: with the optimum at the
    origin, such a coordinate alone costs 100^2 = 10^4.
    """
    lower, upper = BIASED_BOUNDS
    opt = get_optimizer(optimizer, boundary=rule, init_bounds=[BIASED_START] * dim)
    res = opt.minimize(plain_sphere, [BIASED_BOUNDS] * dim, rng=seed, max_evals=max_evals)
    return {
        "optimizer": optimizer, "boundary": rule, "dim": dim, "seed": seed, "max_evals": max_evals,
        "error": float(res.fun), "stuck": bool(np.any((res.x == lower) | (res.x == upper))),
        "nfev": int(res.nfev),
    }


def print_biased_table(rows: list[dict], optimizers: Sequence[str], dim: int, budget: int, seeds: int) -> None:
    """Median final error and share of stuck runs per swarm optimiser and boundary rule."""
    print(f"\nBiased start: sphere in [{BIASED_BOUNDS[0]:g}, {BIASED_BOUNDS[1]:g}]^{dim} initialised in "
          f"[{BIASED_START[0]:g}, {BIASED_START[1]:g}]^{dim}, budget {budget} evaluations, {seeds} seeds: "
          "median final error / share of runs with a coordinate stuck on a wall")
    width = 18
    header = f"{'optimizer':<15}" + "".join(f"{rule:<{width}}" for rule in BOUNDARY_RULES)
    print(header)
    print("-" * len(header))
    for name in optimizers:
        cells = []
        for rule in BOUNDARY_RULES:
            sel = [r for r in rows if r["optimizer"] == name and r["boundary"] == rule]
            errors = np.array([r["error"] for r in sel])
            stuck = sum(r["stuck"] for r in sel)
            cells.append(f"{fmt(float(np.median(errors)))} {stuck}/{len(sel)}")
        print(f"{name:<15}" + "".join(f"{c:<{width}}" for c in cells))


def run_tasks(function: Callable[..., dict], tasks: list[tuple], n_jobs: int) -> list[dict]:
    """Run ``function(*task)`` for every task, in ``n_jobs`` joblib workers (1 = in this process)."""
    start = time.perf_counter()
    if n_jobs == 1:
        rows = [function(*task) for task in tasks]
    else:
        from joblib import Parallel, delayed

        rows = Parallel(n_jobs=n_jobs)(delayed(function)(*task) for task in tasks)
    print(f"done in {time.perf_counter() - start:.0f} s", flush=True)
    return rows


def write_csv(path: str, rows: list[dict]) -> None:
    """Write every run as a CSV row."""
    with atomic_open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"\nwrote {len(rows)} rows to {path}")


def biased_main(args: argparse.Namespace) -> int:
    """The ``--biased`` run: every swarm optimiser under every boundary rule."""
    dim = (args.dims or ([5] if args.quick else [30]))[0]
    seeds = args.seeds or (2 if args.quick else 10)
    budget = (args.evals_per_dim or (200 if args.quick else 1_000)) * dim
    names = [n for n in (args.optimizers or available_optimizers())
             if isinstance(get_optimizer(n), SwarmOptimizer)]
    tasks = [(name, rule, dim, seed, budget) for name in names for rule in BOUNDARY_RULES for seed in range(seeds)]
    print(f"{len(tasks)} runs: {len(names)} swarm optimisers x {len(BOUNDARY_RULES)} boundary rules x {seeds} "
          f"seeds, {dim}-D, {args.n_jobs} worker(s)", flush=True)
    rows = run_tasks(run_biased, tasks, args.n_jobs)
    print_biased_table(rows, names, dim, budget, seeds)
    if args.csv:
        write_csv(args.csv, rows)
    return 0


class TimedObjective:
    """Wraps an objective and accumulates the wall time spent inside it."""

    def __init__(self, fun: Callable[[np.ndarray], np.ndarray]) -> None:
        self.fun = fun
        self.seconds = 0.0

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Evaluate and time one batch."""
        start = time.perf_counter()
        out = self.fun(x)
        self.seconds += time.perf_counter() - start
        return out


def overhead_per_iteration(optimizer: str, dim: int, max_evals: int, repeats: int) -> float:
    """Median over ``repeats`` seeds of (total time - objective time) / iterations, in seconds."""
    bounds = [(-5.0, 5.0)] * dim
    get_optimizer(optimizer).minimize(sphere, bounds, rng=0, max_evals=1_000)  # warm-up, untimed
    samples = []
    for seed in range(repeats):
        objective = TimedObjective(sphere)
        start = time.perf_counter()
        res = get_optimizer(optimizer).minimize(objective, bounds, rng=seed, max_evals=max_evals)
        total = time.perf_counter() - start
        samples.append((total - objective.seconds) / max(res.nit, 1))
    return float(np.median(samples))


def fmt(value: float) -> str:
    """Compact scientific notation for errors."""
    if not math.isfinite(value):
        return str(value)
    if value == 0.0:
        return "0"
    return f"{value:.1e}"


def print_results_table(rows: list[dict], optimizers: Sequence[str], problems: Sequence[str], dim: int,
                        budget: int, seeds: int) -> None:
    """Median final error [25 %, 75 %] per optimiser and problem, plus the median evaluations used."""
    print(f"\n{dim}-D, budget {budget} evaluations, {seeds} seeds: median final error f - f* [IQR]; "
          "evals = median evaluations used (min-max over all runs)")
    width = 27
    header = f"{'optimizer':<15}" + "".join(f"{p:<{width}}" for p in problems) + "evals"
    print(header)
    print("-" * len(header))
    for name in optimizers:
        cells, nfevs = [], []
        for problem in problems:
            sel = [r for r in rows if r["optimizer"] == name and r["problem"] == problem and r["dim"] == dim]
            errors = np.array([r["error"] for r in sel])
            nfevs += [r["nfev"] for r in sel]
            q25, q50, q75 = np.quantile(errors, [0.25, 0.5, 0.75])
            cells.append(f"{fmt(q50)} [{fmt(q25)}, {fmt(q75)}]")
        evals = f"{int(np.median(nfevs))} ({min(nfevs)}-{max(nfevs)})"
        print(f"{name:<15}" + "".join(f"{c:<{width}}" for c in cells) + evals)


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true",
                        help="smoke run: 5-D, 2 seeds, 200 evaluations per dimension, short overhead runs")
    parser.add_argument("--dims", type=int, nargs="+", default=None, help="dimensions (default: 10 30)")
    parser.add_argument("--seeds", type=int, default=None, help="seeds per (optimiser, function) (default 10)")
    parser.add_argument("--optimizers", nargs="+", default=None, help="registered names (default: all)")
    parser.add_argument("--functions", nargs="+", default=None, choices=[p.name for p in PROBLEMS],
                        help="test functions (default: all five)")
    parser.add_argument("--evals-per-dim", type=int, default=None,
                        help="budget = this x dimension (default 1000: 10,000 in 10-D, 30,000 in 30-D)")
    parser.add_argument("--n-jobs", type=int, default=2, help="joblib workers (default 2)")
    parser.add_argument("--no-overhead", action="store_true", help="skip the overhead table")
    parser.add_argument("--overhead-repeats", type=int, default=None, help="seeds per overhead figure (default 3)")
    parser.add_argument("--csv", default=None, help="also write every run as a CSV row to this file")
    parser.add_argument("--biased", action="store_true",
                        help="run the biased-initialisation case instead (first of --dims, default 30)")
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark and print the tables; returns the exit status."""
    args = parse_args(argv)
    dims = args.dims or ([5] if args.quick else [10, 30])
    seeds = args.seeds or (2 if args.quick else 10)
    per_dim = args.evals_per_dim or (200 if args.quick else 1_000)
    problems = args.functions or [p.name for p in PROBLEMS]
    names = args.optimizers or available_optimizers()
    unknown = sorted(set(names) - set(available_optimizers()))
    if unknown:
        get_optimizer(unknown[0])  # raises KeyError with suggestions
    if args.biased:
        return biased_main(args)
    repeats = args.overhead_repeats or (1 if args.quick else 3)
    overhead_evals = 2_000 if args.quick else 10_000

    tasks = [(name, problem, dim, seed, per_dim * dim)
             for dim in dims for name in names for problem in problems for seed in range(seeds)]
    print(f"{len(tasks)} runs: {len(names)} optimisers x {len(problems)} functions x dims {dims} x {seeds} seeds, "
          f"{args.n_jobs} worker(s)", flush=True)
    rows = run_tasks(run_one, tasks, args.n_jobs)

    for dim in dims:
        print_results_table(rows, names, problems, dim, per_dim * dim, seeds)

    if not args.no_overhead:
        print(f"\nOptimiser overhead per iteration at 100 particles x 15 dimensions (sphere, {overhead_evals} "
              f"evaluations, median of {repeats} seed(s)); objective time excluded, one process")
        print(f"{'optimizer':<15}{'ms/iteration':>14}")
        for name in names:
            ms = 1e3 * overhead_per_iteration(name, 15, overhead_evals, repeats)
            print(f"{name:<15}{ms:>14.3f}")

    if args.csv:
        write_csv(args.csv, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
