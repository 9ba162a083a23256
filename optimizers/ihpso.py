"""IHPSO: improved holonic PSO (Luo, Liang & Li 2022, the seed paper §3.2-3.3).

optimizers.md §5. IHPSO keeps HPSO's three holonic levels and velocity rules (§4: D8, D9, D10, D12;
shared through ``swarm.py``) and replaces three things:

1. random grouping, by clustering (near particles together) and information-entropy grouping (far
   particles together): ordinary complete-linkage hierarchical clustering of the distances (or of their
   inverses) cut into G clusters (§5.1, D13, D14; :mod:`optimizers.ihpso_grouping`);
2. the fixed 0.8 stage split, by the switch conditions of eqs. 25-28 on the slope of the fitness level
   (the mean of the best N/G personal-best costs, D16) (§5.2, D17, D18);
3. the fixed iteration count, by the adaptive termination of eqs. 29-33: a relative "slope = 0" and a
   comparison of root-mean-square within-group distances (§5.3, D15, D19, D20).

Scheme 4 of the paper's Table 1 is the default: entropy grouping in broad search, clustering in
accurate search. IHPSO has no planned-iteration schedule: it runs until eq. 33 holds or the budget ends.
One iteration reads and returns an explicit :class:`SearchState` (§5.4); the functions of the rules are
pure.

The first implementation's readings (equal-size cuts of an average-linkage leaf order, sums of
distances, the mean finite pbest cost, a 1e-9 relative tolerance) are the configuration
``ihpso-2022v0``, bit-identical to that implementation; the code only they need lives in
:mod:`optimizers.ihpso_2022v0` (optimizers.md §5.5).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from functools import partial
from itertools import count
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from optimizers.base import FloatArray, IntArray, coerce_pair, is_real, require, require_integer
from optimizers.ihpso_2022v0 import IHPSO_2022V0
from optimizers.ihpso_grouping import (
    GROUPING_CUTS,
    LINKAGE_METHODS,
    SPREAD_STATISTICS,
    Clustering,
    cluster_both_ways,
    clustering_spreads,
    dendrogram_groups,
    spreads_converge,
    termination_test,
)
from optimizers.registry import register_optimizer
from optimizers.swarm import (
    Swarm,
    SwarmOptimizer,
    holonic_attractors,
    holonic_velocity,
    random_equal_groups,
    validate_holonic,
)

__all__ = [
    "FITNESS_LEVELS",
    "GROUPING_METHODS",
    "IHPSO",
    "IHPSO_2022V0",
    "MESSAGE_TERMINATED",
    "SLOPE_RTOL_VARIANTS",
    "SearchState",
    "dendrogram_groups",
    "fitness_level",
    "fitness_slope",
    "front_size",
    "slope_is_zero",
    "start_trace",
    "switch_condition",
    "switch_due",
    "switch_window_open",
    "termination_test",
]

MESSAGE_TERMINATED = "adaptive termination (eqs. 29-33)"
GROUPING_METHODS = ("entropy", "cluster", "random")
FITNESS_LEVELS = ("front", "mean")  # D16; "mean" is the 2022v0 reading


# ----------------------------------------------------------------------------------------------
# §5.2 Switching from broad to accurate search
# ----------------------------------------------------------------------------------------------


def fitness_level(f_pbest: ArrayLike, front: int | None = None) -> float | None:
    """``J(t)``: the mean of the best ``front`` finite personal-best costs, ``None`` when there is none (D16).

    DECISION (optimizers.md D16): IHPSO's default ``front`` is one group's worth, ``ceil(N / G)``: the level
    follows the particles that lead the search, so it moves when they improve and not when a particle
    escapes a penalty region (a crash cost) to a cost still worse than theirs. A median would not do
    that while more than half the particles still carry penalties. ``front=None`` is the 2022v0 level:
    the mean of all finite personal-best costs.

    Args:
        f_pbest: (N,) personal-best costs (``+inf`` allowed).
        front: How many of the lowest costs to average (``1 <= front``; capped at N), or ``None`` for all.

    Returns:
        The mean of the finite costs among the ``front`` lowest, or ``None`` when none of them is finite
        (tested explicitly: no empty mean).
    """
    f_pbest = np.asarray(f_pbest, dtype=np.float64)
    if front is not None:
        k = min(int(front), f_pbest.shape[0])
        f_pbest = np.sort(f_pbest)[:k]  # sorted, so the mean's summation order is fixed
    finite = np.isfinite(f_pbest)
    count = int(np.count_nonzero(finite))
    if count == 0:
        return None
    if count == f_pbest.shape[0]:
        return float(f_pbest.mean())
    return float(f_pbest[finite].mean())


def front_size(n: int, n_groups: int) -> int:
    """``ceil(N / G)``, the number of personal bests the default fitness level averages (D16)."""
    return -(-int(n) // int(n_groups))


def fitness_slope(level: float | None, previous: float | None) -> float:
    """``k_t = |J(t) - J(t-1)|``, or ``+inf`` when either level is undefined (D16)."""
    if level is None or previous is None:
        return math.inf
    return abs(level - previous)


def switch_condition(k_a: float, k_b: float, k_c: float, omega: float, alpha: float) -> bool:
    """Eqs. 26-28: switch from broad to accurate search (slopes at ``t - 2j``, ``t - j``, ``t``).

    Both must hold, checked in the paper's order: (28') ``k_c < alpha k_b`` (D17: the current slope
    has not jumped up), and (27) ``k_b (k_a - k_b) < omega k_a (k_b - k_c)`` (eq. 26 without divisions:
    the rate of decrease is itself decreasing).

    An undefined (infinite) slope never switches; for every slope sequence IHPSO can produce this is
    what the inequalities give anyway, but it is tested explicitly so no ``inf - inf`` is formed.

    Args:
        k_a: Slope at ``t - 2j``.
        k_b: Slope at ``t - j``.
        k_c: Slope at ``t``.
        omega: Switch weight ω (not the inertia).
        alpha: Jump factor α.

    Returns:
        Whether to switch to accurate search.
    """
    if not (math.isfinite(k_a) and math.isfinite(k_b) and math.isfinite(k_c)):
        return False
    if not k_c < alpha * k_b:  # (28')
        return False
    return k_b * (k_a - k_b) < omega * k_a * (k_b - k_c)  # (27)


def switch_window_open(t: int, phase_start: int, lag: int) -> bool:
    """D18: the switch test at iteration ``t`` judges only slopes of the current broad phase.

    Args:
        t: Current iteration.
        phase_start: ``t0``, the iteration at which the broad phase began (0 for the first).
        lag: ``j``.

    Returns:
        ``t - 2j >= t0 + 1``.
    """
    return t - 2 * lag >= phase_start + 1


def switch_due(
    slopes: Sequence[float], t: int, phase_start: int, lag: int, omega: float, alpha: float
) -> bool:
    """The window (D18) and the switch condition (eqs. 26-28) at iteration ``t``.

    Args:
        slopes: ``slopes[s] = k_s`` for ``s = 0..t`` (entry 0 is unused).
        t: Current iteration.
        phase_start: ``t0``.
        lag: ``j``.
        omega: ω.
        alpha: α.

    Returns:
        Whether the broad phase switches to accurate search now.
    """
    if not switch_window_open(t, phase_start, lag):
        return False
    return switch_condition(slopes[t - 2 * lag], slopes[t - lag], slopes[t], omega, alpha)


# ----------------------------------------------------------------------------------------------
# §5.3 Adaptive termination
# ----------------------------------------------------------------------------------------------


def slope_is_zero(slope: float, level: float | None, atol: float = 1e-12, rtol: float = 1e-4) -> bool:
    """Eq. 29's "slope = 0", with a tolerance: ``k <= atol + rtol |J|`` (D15).

    DECISION (optimizers.md D15): ``rtol = 1e-4`` by default, fixed before any comparison was run. The
    default budget gives about 100 iterations (10 000 evaluations, 100 particles); a level that moves by
    less than ``1e-4 |J|`` per iteration, even if it kept that pace for the whole budget, would gain under
    1 % of J. 2022v0 used ``1e-9``, which a converging swarm's level practically never reaches.

    Args:
        slope: ``k_t``.
        level: ``J(t)`` (``None`` when undefined: never zero).
        atol: Absolute tolerance.
        rtol: Relative tolerance.

    Returns:
        Whether the fitness level has stopped moving.
    """
    if level is None or not math.isfinite(slope):
        return False
    return slope <= atol + rtol * abs(level)


# ----------------------------------------------------------------------------------------------
# §5.4 The state between iterations
# ----------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)  # eq=False: the labels are an array, which == cannot reduce to a bool
class SearchState:
    """What one IHPSO iteration hands the next (§5.4): the mode, the groups and the slopes so far.

    Attributes:
        labels: (N,) the current group labels.
        level: ``J(t)`` after the last iteration, ``None`` where undefined (D16).
        slopes: ``slopes[s] = k_s`` for ``s = 0..t``; ``k_0 = inf`` is never used.
        accurate: Accurate search (eq. 23) rather than broad search (eq. 22).
        locked: Accurate mode locked by a passing eq. 33 with ``terminate=False`` (D20).
        phase_start: ``t0``, the iteration the current broad phase began (0 for the first, D18).
        since_grouping: Iterations since the last grouping (the regrouping counter of broad mode).
    """

    labels: IntArray
    level: float | None
    slopes: tuple[float, ...] = (math.inf,)
    accurate: bool = False
    locked: bool = False
    phase_start: int = 0
    since_grouping: int = 0

    @property
    def mode(self) -> str:
        """``"accurate"`` or ``"broad"``, as the trace records it."""
        return "accurate" if self.accurate else "broad"


def start_trace(trace: dict[str, Any]) -> dict[str, Any]:
    """Add IHPSO's entries to a swarm's trace (docs/swarm.md §6), empty, and return it.

    The lists are filled as the run goes; ``stopped_by`` is ``"max_evals"`` until eq. 33 stops the run.
    """
    trace.update(mode=[], switch_iterations=[], reverse_switch_iterations=[], termination_tests=[],
                 termination_spreads=[], locked_at=None, levels=[], stopped_by="max_evals")
    return trace


# ----------------------------------------------------------------------------------------------
# The optimiser
# ----------------------------------------------------------------------------------------------


@register_optimizer("ihpso")
@dataclass(frozen=True)
class IHPSO(SwarmOptimizer):
    """Improved holonic PSO (Luo, Liang & Li 2022; optimizers.md §5).

    Attributes:
        swarm_size: N.
        n_groups: G.
        inertia_range: ``w ~ U[a, b]`` per particle per iteration (D28).
        acceleration: c, all levels.
        constriction: chi (D9); 1.0 in ``ihpso-literal``.
        stage2_sign: s in eq. 23 (D10); -1 in ``ihpso-literal``.
        scheme: (broad, accurate) grouping methods, each ``"entropy"``, ``"cluster"`` or ``"random"``.
        regroup_period: T_r, the regrouping period in broad mode (§5.4).
        switch_lag: j in eqs. 25-28.
        switch_weight: ω in eqs. 26-27 (not the inertia).
        jump_factor: α in eq. 28.
        slope_atol: Absolute tolerance of "slope = 0" (D15).
        slope_rtol: Relative tolerance of "slope = 0" (D15).
        terminate: Stop when eq. 33 holds (else lock accurate mode, D20).
        linkage: Agglomerative linkage method (D13).
        entropy_eps: ε in ``1 / (distance + ε)`` (D14).
        grouping_cut: ``"maxclust"`` (at most G clusters as the data give them) or ``"equal"`` (D14).
        spread: Eq. 30's within-group statistic, ``"rms"`` or ``"sum"`` (D19).
        level: Eq. 25's fitness level, ``"front"`` (best ``ceil(N/G)`` pbests) or ``"mean"`` (D16).
        switch: Whether broad search may switch to accurate search (False in ``ihpso-noswitch``).
        reverse_switch: Whether a failed eq. 33 test returns to broad search (False in ``ihpso-noreverse``:
            the run stays in accurate mode and tests again at the next zero slope).

    The shared swarm options are those of :class:`optimizers.swarm.SwarmOptimizer`. ``minimize`` may
    stop before the budget is spent (eq. 33, message ``"adaptive termination (eqs. 29-33)"``).
    ``ihpso-2022v0`` is ``IHPSO(**IHPSO_2022V0)``: ``linkage="average", grouping_cut="equal",
    spread="sum", level="mean", slope_rtol=1e-9``, the first implementation's readings (§5.5).
    """

    swarm_size: int = 100  # N, seed §5
    n_groups: int = 5  # G, seed §5
    inertia_range: tuple[float, float] = (0.95, 1.0)  # w ~ U[0.95, 1], seed §5
    acceleration: float = 1.3667  # c, seed §5
    constriction: float = 0.7298  # chi, DECISION: optimizers.md D9
    stage2_sign: int = 1  # s, DECISION: optimizers.md D10
    scheme: tuple[str, str] = ("entropy", "cluster")  # Table 1, scheme 4
    regroup_period: int = 10  # T_r in broad mode, DECISION: optimizers.md §5.4 (HPSO's period)
    switch_lag: int = 1  # j, seed §5
    switch_weight: float = 0.8  # ω, seed §5
    jump_factor: float = 3.0  # α, seed §5
    slope_atol: float = 1e-12  # DECISION: optimizers.md D15
    slope_rtol: float = 1e-4  # DECISION: optimizers.md D15 (1e-9 in ihpso-2022v0)
    terminate: bool = True  # seed §3.2.3; False in ihpso-noterm
    linkage: str = "complete"  # DECISION: optimizers.md D13 ("average" in ihpso-2022v0)
    entropy_eps: float = 1e-12  # DECISION: optimizers.md D14
    grouping_cut: str = "maxclust"  # DECISION: optimizers.md D14 ("equal" in ihpso-2022v0)
    spread: str = "rms"  # DECISION: optimizers.md D19 ("sum" in ihpso-2022v0)
    level: str = "front"  # DECISION: optimizers.md D16 ("mean" in ihpso-2022v0)
    switch: bool = True  # seed §3.2.2; False in ihpso-noswitch
    reverse_switch: bool = True  # seed §3.3 Step 7; False in ihpso-noreverse

    def __post_init__(self) -> None:
        super().__post_init__()
        validate_holonic(self)
        name = type(self).__name__
        scheme = coerce_pair(self, "scheme")
        require(all(s in GROUPING_METHODS for s in scheme), name, "scheme", scheme,
                f"a (broad, accurate) pair of {GROUPING_METHODS}")
        require_integer(self, "switch_lag", 1)
        require(is_real(self.switch_weight) and self.switch_weight > 0, name, "switch_weight",
                self.switch_weight, "a finite number > 0")
        require(is_real(self.jump_factor) and self.jump_factor > 0, name, "jump_factor", self.jump_factor,
                "a finite number > 0")
        for field in ("slope_atol", "slope_rtol"):
            value = getattr(self, field)
            require(is_real(value) and value >= 0, name, field, value, "a finite number >= 0")
        for field in ("terminate", "switch", "reverse_switch"):
            value = getattr(self, field)
            require(isinstance(value, bool), name, field, value, "True or False")
        require(self.linkage in LINKAGE_METHODS, name, "linkage", self.linkage, f"one of {LINKAGE_METHODS}")
        require(is_real(self.entropy_eps) and self.entropy_eps > 0, name, "entropy_eps", self.entropy_eps,
                "a finite number > 0")
        require(self.grouping_cut in GROUPING_CUTS, name, "grouping_cut", self.grouping_cut,
                f"one of {GROUPING_CUTS}")
        require(self.spread in SPREAD_STATISTICS, name, "spread", self.spread, f"one of {SPREAD_STATISTICS}")
        require(self.level in FITNESS_LEVELS, name, "level", self.level, f"one of {FITNESS_LEVELS}")

    def group(
        self, method: str, U: FloatArray, rng: np.random.Generator, clustering: Clustering | None = None
    ) -> IntArray:
        """Group the swarm with one of the scheme's methods (§5.1).

        Args:
            method: ``"entropy"``, ``"cluster"`` or ``"random"``.
            U: (N, d) current positions in normalised coordinates.
            rng: The run's Generator (used by ``"random"`` only).
            clustering: ``U``'s :class:`Clustering` under this configuration, where one was already made
                (by a termination test): its labels are taken instead of clustering ``U`` again.

        Returns:
            (N,) group labels.
        """
        if method == "random":
            return random_equal_groups(U.shape[0], self.n_groups, rng)
        if clustering is not None:
            return clustering.entropy if method == "entropy" else clustering.cluster
        return dendrogram_groups(U, self.n_groups, inverse=method == "entropy", method=self.linkage,
                                 eps=self.entropy_eps, cut=self.grouping_cut)

    def clustering(self, U: FloatArray) -> Clustering:
        """Both groupings of ``U`` under this configuration's readings (D13, D14), for eqs. 31-33."""
        return cluster_both_ways(U, self.n_groups, method=self.linkage, eps=self.entropy_eps,
                                 cut=self.grouping_cut)

    def fitness_level(self, f_pbest: FloatArray) -> float | None:
        """``J(t)`` under this configuration's reading (D16): the front's mean or the finite mean."""
        front = front_size(self.swarm_size, self.n_groups) if self.level == "front" else None
        return fitness_level(f_pbest, front)

    def iterate(self, swarm: Swarm, rng: np.random.Generator) -> Iterator[str | None]:
        """One iteration per ``next`` (§5.4 steps 1.1-1.5); yields the stop message on eq. 33.

        Each step is a method that takes the :class:`SearchState` and returns the next one; only the
        swarm (moved by :meth:`Swarm.fly`) and the trace change in place.

        The first switch test is at ``t = 2j + 1`` (3 for j = 1): eqs. 27-28 need the slopes
        ``k_{t-2j}, k_{t-j}, k_t`` of the current broad phase, and ``k_1`` is the first slope (D18). With
        j = 1 any local peak of the slope sequence (``k_{t-1} > k_{t-2}``, ``k_t < k_{t-1}``, ``k_t <
        α k_{t-1}``) satisfies eq. 27, so a noisy level can switch at the earliest allowed iteration; the
        trace records when it did (DECISION: optimizers.md D36, kept as printed and reported).

        Trace (docs/swarm.md §6): ``mode`` (the search mode each iteration moved in, ``"broad"`` or
        ``"accurate"``), ``switch_iterations`` (iterations after which broad search switched to accurate,
        eqs. 25-28), ``reverse_switch_iterations`` (accurate back to broad: zero slope but eq. 33 false),
        ``termination_tests`` (``(t, passed)`` for every evaluation of eq. 33), ``termination_spreads``
        (``(t, SD_pemin, SD_psmax)`` for each, as :func:`optimizers.ihpso_grouping.termination_spreads`
        gives them), ``locked_at`` (the iteration accurate mode was locked, ``ihpso-noterm`` only),
        ``levels`` (``J(0), J(1), ...``, ``None`` where undefined) and ``stopped_by`` (``"termination"``
        for eq. 33, ``"max_evals"`` otherwise).
        """
        trace = start_trace(swarm.trace)
        # Step 0 (§5.4) after initialisation: J(0), broad mode grouped by scheme[0].
        level = self.fitness_level(swarm.f_pbest)
        state = SearchState(labels=self.group(self.scheme[0], swarm.normalised(), rng), level=level)
        trace["levels"].append(level)
        for t in count(1):
            state = self._regroup_if_due(state, swarm, rng)
            self._fly(state, swarm, rng)
            trace["mode"].append(state.mode)
            state = self._measure(state, swarm)
            trace["levels"].append(state.level)
            stop = None
            if not state.accurate:
                state = self._switch_if_due(t, state, swarm, rng, trace)
            else:
                state, stop = self._test_if_due(t, state, swarm, rng, trace)
            yield stop

    def _regroup_if_due(self, state: SearchState, swarm: Swarm, rng: np.random.Generator) -> SearchState:
        """Step 1.1: in broad mode, a fresh ``scheme[0]`` grouping every ``regroup_period`` iterations.

        DECISION (optimizers.md §5.4): broad search regroups every T_r = 10 iterations, HPSO's period,
        not at every broad iteration as the paper's flow reads (its Step 3 returns to Step 2, which
        groups by information entropy). The paper's complexity remark counts its groupings and
        regroupings as "far less than the number of optimization iterations", and HPSO's own step sets a
        regrouping period; one period keeps the two comparable. Measured effect nil for the default: on
        the published window states the periodic regrouping never fired (the first switch comes at
        t = 3, D36), and regrouping every broad iteration (``regroup_period=1``, the paper's flow) left
        the final cost without a significant change (p = 0.09); only ``ihpso-noswitch`` gains a little from it.
        """
        if state.accurate or state.since_grouping != self.regroup_period:
            return state
        return replace(state, labels=self.group(self.scheme[0], swarm.normalised(), rng), since_grouping=0)

    def _fly(self, state: SearchState, swarm: Swarm, rng: np.random.Generator) -> None:
        """Steps 1.2-1.3: attractors, velocity (eq. 22 broad, eq. 23 accurate), clamp, move, evaluate."""
        n, d = swarm.n, swarm.d
        w_low, w_high = self.inertia_range
        attractors = holonic_attractors(swarm.pbest, swarm.f_pbest, state.labels)
        w = rng.uniform(w_low, w_high, size=(n, 1))  # DECISION: optimizers.md D28
        r = rng.random((3, n, d))
        sign = float(self.stage2_sign) if state.accurate else 1.0
        swarm.fly(holonic_velocity(swarm.v, swarm.x, attractors, r, w, acceleration=self.acceleration,
                                   constriction=self.constriction, sign=sign))

    def _measure(self, state: SearchState, swarm: Swarm) -> SearchState:
        """The end of step 1.3: ``J(t)`` and ``k_t`` of the moved swarm; one more iteration since grouping."""
        level = self.fitness_level(swarm.f_pbest)  # DECISION: optimizers.md D16
        return replace(state, level=level, slopes=(*state.slopes, fitness_slope(level, state.level)),
                       since_grouping=state.since_grouping + 1)

    def _switch_if_due(
        self, t: int, state: SearchState, swarm: Swarm, rng: np.random.Generator, trace: dict[str, Any]
    ) -> SearchState:
        """Step 1.4: broad -> accurate search, grouped by ``scheme[1]``, when eqs. 25-28 hold (window D18)."""
        if not self.switch or not switch_due(state.slopes, t, state.phase_start, self.switch_lag,
                                             self.switch_weight, self.jump_factor):
            return state
        trace["switch_iterations"].append(t)
        return replace(state, accurate=True, labels=self.group(self.scheme[1], swarm.normalised(), rng),
                       since_grouping=0)

    def _test_if_due(
        self, t: int, state: SearchState, swarm: Swarm, rng: np.random.Generator, trace: dict[str, Any]
    ) -> tuple[SearchState, str | None]:
        """Step 1.5: in accurate mode with a zero slope, eq. 33 stops the run, locks it or returns to broad.

        The positions are clustered once: the test, its trace entry and the broad grouping after a
        failed test all use that :class:`Clustering`.

        Returns:
            The next state and the stop message (``None`` to go on).
        """
        if state.locked or not slope_is_zero(state.slopes[t], state.level, self.slope_atol, self.slope_rtol):
            return state, None
        U = swarm.normalised()
        clustering = self.clustering(U)
        spreads = clustering_spreads(clustering, self.n_groups, swarm.d, spread=self.spread)
        converged = spreads_converge(spreads)
        trace["termination_tests"].append((t, converged))
        trace["termination_spreads"].append((t, *spreads))
        if converged and self.terminate:
            trace["stopped_by"] = "termination"
            return state, MESSAGE_TERMINATED  # DECISION: optimizers.md D20
        if converged:
            trace["locked_at"] = t
            return replace(state, locked=True), None
        if not self.reverse_switch:
            return state, None
        trace["reverse_switch_iterations"].append(t)
        labels = self.group(self.scheme[0], U, rng, clustering)
        return replace(state, accurate=False, phase_start=t, labels=labels, since_grouping=0), None


register_optimizer("ihpso-scheme1")(partial(IHPSO, scheme=("cluster", "cluster")))
register_optimizer("ihpso-scheme2")(partial(IHPSO, scheme=("entropy", "entropy")))
register_optimizer("ihpso-scheme3")(partial(IHPSO, scheme=("cluster", "entropy")))
register_optimizer("ihpso-random")(partial(IHPSO, scheme=("random", "random")))
register_optimizer("ihpso-noterm")(partial(IHPSO, terminate=False))
register_optimizer("ihpso-noswitch")(partial(IHPSO, switch=False))
register_optimizer("ihpso-noreverse")(partial(IHPSO, reverse_switch=False))
register_optimizer("ihpso-literal")(partial(IHPSO, constriction=1.0, stage2_sign=-1))
# The tolerance of "slope = 0" (eq. 29), varied around the default 1e-4 (D15) for the table of its
# effect (optimizers.md §5.6); none of them was used to choose the default.
SLOPE_RTOL_VARIANTS = {"ihpso-rtol1e-6": 1e-6, "ihpso-rtol1e-5": 1e-5, "ihpso-rtol1e-3": 1e-3, "ihpso-rtol1e-2": 1e-2}
for _name, _rtol in SLOPE_RTOL_VARIANTS.items():
    register_optimizer(_name)(partial(IHPSO, slope_rtol=_rtol))
# The first implementation's readings, bit-identical (optimizers.md §5.5; optimizers/ihpso_2022v0.py).
register_optimizer("ihpso-2022v0")(partial(IHPSO, **IHPSO_2022V0))
