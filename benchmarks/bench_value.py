"""The lattice value function's build: the reference iteration against the builder, and the incremental rebuild.

Cold builds (no disk cache) of V (docs/model.md §7e.2) on the paper scenario and procedural maps
of the suite's size (``random:50000-50009`` at difficulty 0.5), on one compiled thread and two,
each part timed (the moves, their costs, the sweeps, the route calibration) in CPU seconds
(``time.process_time``) beside the wall time; then the incremental rebuild after one radar is
added, moved and removed on the paper scenario, against a full build of the changed scenario. The
reference and the builder alternate within each repeat, so a machine's load falls on both alike;
the medians over the repeats are printed. The whole measurement runs idle and then beside ``--load``
busy processes (``python -c "while True: pass"``, killed after). Each build's V is compared with the
reference's: the largest relative difference over the finite nodes, and whether the doomed nodes
(+-inf) agree.

Usage: ``python benchmarks/bench_value.py [--maps paper random:50000-50009] [--repeat 3] [--load 2]``;
``--quick`` (the smoke test) builds a coarse lattice on one procedural map once, idle and beside
one busy process.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import subprocess
import sys
import time

import numpy as np

from uav_penetration_env.catalogue import resolve_scenario, resolve_scenarios
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.value_function import (
    LATTICE_DEFAULTS,
    BuildClock,
    LatticeSettings,
    ValueFunctionBuilder,
    build_arrays,
)

PARTS = ("moves", "costs", "sweeps", "route")
QUICK_LATTICE = LatticeSettings(spacing_m=5000.0, headings=8)


def largest_difference(got: np.ndarray, want: np.ndarray) -> float:
    """The largest relative difference at finite nodes; ``inf`` when the doomed nodes differ."""
    if not (np.array_equal(np.isposinf(got), np.isposinf(want)) and np.array_equal(np.isneginf(got), np.isneginf(want))):
        return float("inf")
    finite = np.isfinite(want)
    if not finite.any():
        return 0.0
    return float(np.max(np.abs(got[finite] - want[finite]) / np.maximum(np.abs(want[finite]), 1e-300)))


def timed_build(model: PenetrationModel, settings: LatticeSettings, method: str) -> tuple[dict[str, float], float, np.ndarray]:
    """(CPU seconds per part, wall seconds, table) of one cold build."""
    clock = BuildClock()
    start = time.perf_counter()
    arrays = build_arrays(model, settings, 0, method=method, clock=clock)
    return dict(clock.cpu), time.perf_counter() - start, arrays["table"]


def full_builds(scenarios, settings: LatticeSettings, repeat: int, threads: tuple[int, ...]) -> list[dict]:
    """Per map and thread count: median CPU per part and wall of each method, and the largest difference."""
    rows = []
    for scenario in scenarios:
        for count in threads:
            model = PenetrationModel(scenario, threads=count)
            runs: dict[str, list] = {"reference": [], "sweeps": []}
            tables = {}
            for _ in range(repeat):
                for method in runs:
                    cpu, wall, table = timed_build(model, settings, method)
                    runs[method].append((cpu, wall))
                    tables[method] = table
            row = {"map": scenario.name, "threads": count, "difference": largest_difference(tables["sweeps"], tables["reference"])}
            for method, measured in runs.items():
                for part in PARTS:
                    row[f"{method}_{part}"] = statistics.median(cpu[part] for cpu, _ in measured)
                row[f"{method}_cpu"] = statistics.median(sum(cpu.values()) for cpu, _ in measured)
                row[f"{method}_wall"] = statistics.median(wall for _, wall in measured)
            rows.append(row)
    return rows


def radar_changes(scenario):
    """(label, radars): one radar added (between the others), moved by 10 km, removed."""
    radars = scenario.radars
    xs = [r.x_km for r in radars]
    ys = [r.y_km for r in radars]
    added = dataclasses.replace(radars[0], name="added", x_km=float(np.mean(xs)) + 7.0, y_km=float(np.mean(ys)) - 7.0)
    moved = dataclasses.replace(radars[-1], x_km=radars[-1].x_km + 10.0)
    return [("added", (*radars, added)), ("moved", (*radars[:-1], moved)), ("removed", radars[:-1])]


def rebuilds(scenario, settings: LatticeSettings, repeat: int) -> list[dict]:
    """Incremental rebuilds after each radar change against full builds of the changed scenario (one thread)."""
    builder = ValueFunctionBuilder(PenetrationModel(scenario, threads=1), 0, settings)
    rows = []
    for label, radars in radar_changes(scenario):
        model = PenetrationModel(dataclasses.replace(scenario, radars=radars), threads=1)
        incremental, full = [], []
        for _ in range(repeat):
            rebuilt = builder.with_model(model)
            fresh = ValueFunctionBuilder(model, 0, settings)
            incremental.append(sum(rebuilt.cpu_seconds.values()))
            full.append(sum(fresh.cpu_seconds.values()))
        rows.append({
            "change": label,
            "incremental_cpu": statistics.median(incremental),
            "incremental_parts": rebuilt.cpu_seconds,
            "full_cpu": statistics.median(full),
            "changed_moves": rebuilt.changed_moves,
            "moves": fresh.changed_moves,
            "difference": largest_difference(rebuilt.value_function.table, fresh.value_function.table),
        })  # fmt: skip
    return rows


def report(label: str, builds: list[dict], changes: list[dict]) -> None:
    print(f"\n== {label}: cold builds of V, CPU seconds (medians), reference -> builder ==")
    for row in builds:
        parts = "  ".join(f"{p} {row[f'reference_{p}']:.3f}->{row[f'sweeps_{p}']:.3f}" for p in PARTS)
        print(
            f"  {row['map']:18s} threads {row['threads']}  cpu {row['reference_cpu']:.3f} -> {row['sweeps_cpu']:.3f} "
            f"(x{row['sweeps_cpu'] / row['reference_cpu']:.3f})  wall {row['reference_wall']:.3f} -> {row['sweeps_wall']:.3f}  "
            f"[{parts}]  max rel diff {row['difference']:.2e}"
        )
    for row in changes:
        parts = "  ".join(f"{p} {row['incremental_parts'].get(p, 0.0):.3f}" for p in PARTS)
        print(
            f"  radar {row['change']:8s} incremental {row['incremental_cpu']:.3f} s vs full {row['full_cpu']:.3f} s "
            f"(x{row['incremental_cpu'] / row['full_cpu']:.3f}), {row['changed_moves']} of {row['moves']} moves re-priced "
            f"[{parts}]  max rel diff {row['difference']:.2e}"
        )


def main(argv: list[str] | None = None) -> dict[str, tuple[list[dict], list[dict]]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maps", nargs="+", default=["paper", "random:50000-50009"], help="scenarios (random:... at difficulty 0.5)")
    parser.add_argument("--repeat", type=int, default=3, help="builds per method, map and thread count (medians)")
    parser.add_argument("--load", type=int, default=2, help="busy processes beside the loaded measurement")
    parser.add_argument("--quick", action="store_true", help="a coarse lattice on one procedural map, once (smoke test)")
    args = parser.parse_args(argv)
    settings = QUICK_LATTICE if args.quick else LATTICE_DEFAULTS
    maps = ["random:50000"] if args.quick else args.maps
    repeat = 1 if args.quick else args.repeat
    load = min(args.load, 1) if args.quick else args.load
    scenarios = [s for spec in maps for s in resolve_scenarios(spec, 0.5)]
    paper = scenarios[0] if args.quick else resolve_scenario("paper")
    # Compile every kernel first (a first call compiles for minutes on a fresh cache).
    small = PenetrationModel(scenarios[0], threads=1)
    full_builds([scenarios[0]], QUICK_LATTICE, 1, (1, 2))
    rebuilds(small.scenario, QUICK_LATTICE, 1)
    results = {}
    for busy in (0, load):
        spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(busy)]
        try:
            builds = full_builds(scenarios, settings, repeat, (1, 2))
            changes = rebuilds(paper, settings, repeat)
        finally:
            for process in spinners:
                process.kill()
                process.wait()
        label = f"{busy} busy processes beside it"
        report(label, builds, changes)
        results[label] = (builds, changes)
    return results


if __name__ == "__main__":
    main()
