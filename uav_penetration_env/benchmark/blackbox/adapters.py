"""The black-box problems as IOHprofiler problems and nevergrad experiment functions (docs/blackbox.md §2).

Both libraries are optional (extra ``blackbox``) and imported inside the functions, with the
install line when they are missing.

DECISION (docs/blackbox.md §2, IOH bounds): an IOH problem of a :class:`~.problems.BlackBoxProblem`
searches [-1, 1]^d, each variable mapped affinely onto its own interval of the problem's box
(``centre + x * half_width``; on a window's box, symmetric about zero, x times the action
limits, as the offline problem already is). ``ioh.wrap_problem`` takes one scalar lower and one
upper bound for every variable, and a window's box has two different widths (metres per second,
radians); the mapping keeps one IOH problem per black-box problem with the bounds IOH can state.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from uav_penetration_env.benchmark.blackbox.problems import BlackBoxProblem
from uav_penetration_env.benchmark.plugins import Needs
from uav_penetration_env.types import FloatArray

BLACKBOX = Needs(
    modules=("ioh", "nevergrad"),
    install="the blackbox extra: pip install -e '.[blackbox]' in a checkout, or pip install 'uav-penetration[blackbox]'",
)


def _require(module: str) -> Any:
    """Import ``module`` of the blackbox extra, or raise an ImportError with the install line."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as error:
        raise ImportError(f"{module} is missing; install {BLACKBOX.install}") from error


def ioh_name(problem: BlackBoxProblem) -> str:
    """The problem's IOH name: its name with ``/`` and other path characters as ``_`` (IOH names files after it)."""
    return "uavpen_" + re.sub(r"[^A-Za-z0-9.-]", "_", problem.name)


def unit_to_box(problem: BlackBoxProblem, x: FloatArray) -> FloatArray:
    """Points of [-1, 1]^d (IOH's view) as points of the problem's box: ``centre + x * half_width``."""
    centre = (problem.upper + problem.lower) / 2
    half = (problem.upper - problem.lower) / 2
    return centre + np.asarray(x, dtype=np.float64) * half


def box_to_unit(problem: BlackBoxProblem, x: FloatArray) -> FloatArray:
    """The inverse of :func:`unit_to_box`."""
    centre = (problem.upper + problem.lower) / 2
    half = (problem.upper - problem.lower) / 2
    return (np.asarray(x, dtype=np.float64) - centre) / half


def ioh_problem(problem: BlackBoxProblem) -> Any:
    """Register ``problem`` with IOHprofiler (``ioh.wrap_problem``) and return the IOH problem.

    The problem is registered under :func:`ioh_name`, so ``ioh.get_problem(name, instance,
    dimension)`` builds it again in the same process; its instance id is the problem's (a suite
    member's position), its optimum the best-known value where there is one.

    Args:
        problem: a problem of :mod:`.problems`.

    Returns:
        An ``ioh.problem.RealSingleObjective`` over [-1, 1]^d (DECISION docs/blackbox.md §2): attach an
        ``ioh.logger.Analyzer`` to it and run any optimiser.

    Raises:
        ImportError: ioh is not installed (with the install line).
    """
    ioh = _require("ioh")

    def function(x: FloatArray) -> float:
        return float(problem.objective(unit_to_box(problem, x)[None])[0])

    calculate_objective = None
    if problem.optimum is not None:
        best_x = (
            box_to_unit(problem, problem.optimum_x)
            if problem.optimum_x is not None
            else np.zeros(problem.dimension)
        )
        optimum = float(problem.optimum)

        def calculate_objective(instance: int, dimension: int) -> Any:
            return ioh.RealSolution(best_x.tolist(), optimum)

    return ioh.wrap_problem(
        function,
        name=ioh_name(problem),
        dimension=problem.dimension,
        instance=problem.instance,
        lb=-1.0,
        ub=1.0,
        calculate_objective=calculate_objective,
    )


def nevergrad_function(problem: BlackBoxProblem) -> Any:
    """``problem`` as a nevergrad ``ExperimentFunction`` named after it.

    The parametrization is an ``ng.p.Array`` over the problem's own box (nevergrad takes one
    bound per variable); its descriptors carry ``name``, ``kind``, ``scenario``, ``instance`` and
    ``optimum`` (the best-known value, ``None`` without one), so a nevergrad benchmark's results
    name the problem.

    Raises:
        ImportError: nevergrad is not installed (with the install line).
    """
    _require("nevergrad")
    from uav_penetration_env.benchmark.blackbox.ng_experiment import UAVPenetrationFunction

    return UAVPenetrationFunction(problem)
