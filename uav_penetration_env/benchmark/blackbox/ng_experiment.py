"""The nevergrad ``ExperimentFunction`` subclass (imported only when nevergrad is installed; docs/blackbox.md §2)."""

from __future__ import annotations

import nevergrad as ng
import numpy as np
from nevergrad.functions import ExperimentFunction

from uav_penetration_env.benchmark.blackbox.problems import BlackBoxProblem
from uav_penetration_env.types import FloatArray


class UAVPenetrationFunction(ExperimentFunction):
    """A black-box problem of the testbed as a nevergrad experiment function.

    Args:
        problem: a problem of :mod:`uav_penetration_env.benchmark.blackbox.problems`.
    """

    def __init__(self, problem: BlackBoxProblem) -> None:
        self.problem = problem
        parametrization = ng.p.Array(
            init=(problem.lower + problem.upper) / 2, lower=problem.lower, upper=problem.upper
        )
        parametrization.set_name(problem.kind)  # nevergrad wants a short parametrization name
        super().__init__(self._evaluate, parametrization)
        self.add_descriptors(
            name=problem.name,
            kind=problem.kind,
            scenario=problem.scenario,
            instance=problem.instance,
            optimum=problem.optimum,
        )

    def _evaluate(self, x: FloatArray) -> float:
        """The cost of one point of the problem's box."""
        return float(self.problem.objective(np.asarray(x, dtype=np.float64)[None])[0])
