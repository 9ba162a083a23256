"""IHPSO: improved holonic PSO (Luo, Liang & Li 2022, the seed paper §3.2-3.3).

optimizers.md §5. IHPSO keeps HPSO's three holonic levels and velocity rules (§4: D8, D9, D10, D12;
shared through ``swarm.py``) and replaces three things:

1. random grouping, by clustering (near particles together) and information-entropy grouping (far
   particles together), both cut from one average-linkage dendrogram (§5.1, D13, D14);
2. the fixed 0.8 stage split, by the switch conditions of eqs. 25-28 on the slope of the fitness level
   (the mean finite pbest cost, D16) (§5.2, D17, D18);
3. the fixed iteration count, by the adaptive termination of eqs. 29-33 (§5.3, D15, D19, D20).

Scheme 4 of the paper's Table 1 is the default: entropy grouping in broad search, clustering in
accurate search. IHPSO has no planned-iteration schedule: it runs until eq. 33 holds or the budget ends.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import lru_cache, partial
from itertools import count

import numpy as np
from numpy.typing import ArrayLike
from scipy.cluster.hierarchy import leaves_list, linkage
from scipy.spatial.distance import pdist

from optimizers.base import FloatArray, IntArray, coerce_pair, is_int, is_real, require
from optimizers.registry import register_optimizer
from optimizers.swarm import (
    Swarm,
    SwarmOptimizer,
    group_sizes,
    holonic_attractors,
    holonic_velocity,
    labels_from_order,
    random_equal_groups,
    validate_holonic,
)

MESSAGE_TERMINATED = "adaptive termination (eqs. 29-33)"
GROUPING_METHODS = ("entropy", "cluster", "random")
LINKAGE_METHODS = ("average", "single", "complete", "weighted")  # valid for any dissimilarity (D13)


# ----------------------------------------------------------------------------------------------
# §5.1 Grouping
# ----------------------------------------------------------------------------------------------


def groups_from_distances(
    distances: FloatArray,
    n: int,
    n_groups: int,
    *,
    inverse: bool,
    method: str = "average",
    eps: float = 1e-12,
) -> IntArray:
    """Dendrogram grouping from condensed distances (§5.1 steps 2-4).

    Args:
        distances: Condensed pairwise distances (``pdist`` order) of ``n`` points.
        n: Number of points.
        n_groups: Number of groups G.
        inverse: Cluster on ``1 / (distance + eps)`` (entropy grouping) instead of the distances.
        method: Agglomerative linkage method (D13).
        eps: Keeps coincident points finite under inversion (D14).

    Returns:
        (n,) labels: the dendrogram's leaf order cut into consecutive blocks of the §2.12 sizes.
    """
    sizes = group_sizes(n, n_groups)
    if n == 1:
        return np.zeros(1, dtype=np.int64)
    dissimilarity = 1.0 / (distances + eps) if inverse else distances
    order = leaves_list(linkage(dissimilarity, method=method))
    return labels_from_order(order, sizes)


def dendrogram_groups(
    U: ArrayLike, n_groups: int, *, inverse: bool, method: str = "average", eps: float = 1e-12
) -> IntArray:
    """Clustering (``inverse=False``) or information-entropy (``inverse=True``) grouping (§5.1).

    Args:
        U: (N, d) current positions in normalised coordinates (§2.1).
        n_groups: Number of groups G.
        inverse: Entropy grouping: far particles share a group.
        method: Agglomerative linkage method (average by default, D13).
        eps: Added to distances before inversion (D14).

    Returns:
        (N,) group labels with the sizes of §2.12.
    """
    U = np.asarray(U, dtype=np.float64)
    return groups_from_distances(pdist(U), U.shape[0], n_groups, inverse=inverse, method=method, eps=eps)


@lru_cache(maxsize=8)
def _pair_indices(n: int) -> tuple[IntArray, IntArray]:
    """Row and column of every entry of a condensed distance vector of ``n`` points (``pdist`` order)."""
    i, j = np.triu_indices(n, k=1)
    return i, j


def group_distance_sums(distances: FloatArray, labels: IntArray, n_groups: int) -> FloatArray:
    """``SD_p`` (eq. 30) from condensed distances: the sum over unordered pairs within each group (D19).

    Args:
        distances: Condensed pairwise distances (``pdist`` order).
        labels: (N,) group labels in ``0..G-1``.
        n_groups: G.

    Returns:
        (G,) within-group distance sums.
    """
    i, j = _pair_indices(labels.shape[0])
    li = labels[i]
    same = li == labels[j]
    return np.bincount(li[same], weights=distances[same], minlength=n_groups).astype(np.float64)


def within_group_distance_sums(U: ArrayLike, labels: ArrayLike) -> FloatArray:
    """``SD_p = sum_{i<j in p} ||u_i - u_j||`` for every group p (eq. 30, D19).

    Args:
        U: (N, d) positions (normalised coordinates in IHPSO).
        labels: (N,) group labels in ``0..G-1``.

    Returns:
        (G,) sums; each unordered pair is counted once.
    """
    U = np.asarray(U, dtype=np.float64)
    labels = np.asarray(labels, dtype=np.int64)
    return group_distance_sums(pdist(U), labels, int(labels.max()) + 1)


def termination_test(U: ArrayLike, n_groups: int, *, method: str = "average", eps: float = 1e-12) -> bool:
    """Eqs. 31-33: ``min SD(entropy groups) <= max SD(cluster groups)`` on the current positions.

    When the swarm has gathered, grouping far particles together no longer produces larger groups than
    grouping near particles together. No evaluations are spent ([S] seed §3.2.3).

    Args:
        U: (N, d) current positions in normalised coordinates.
        n_groups: G.
        method: Linkage method (D13).
        eps: Inversion guard (D14).

    Returns:
        Whether the swarm counts as converged.
    """
    U = np.asarray(U, dtype=np.float64)
    n = U.shape[0]
    distances = pdist(U)
    entropy = groups_from_distances(distances, n, n_groups, inverse=True, method=method, eps=eps)
    cluster = groups_from_distances(distances, n, n_groups, inverse=False, method=method, eps=eps)
    sd_entropy = group_distance_sums(distances, entropy, n_groups)
    sd_cluster = group_distance_sums(distances, cluster, n_groups)
    return bool(sd_entropy.min() <= sd_cluster.max())  # the printed "SD_pmin" read as SD_pemin


# ----------------------------------------------------------------------------------------------
# §5.2 Switching from broad to accurate search
# ----------------------------------------------------------------------------------------------


def fitness_level(f_pbest: ArrayLike) -> float | None:
    """``J(t)``: the mean of the finite personal-best costs, ``None`` when there is none (D16).

    Args:
        f_pbest: (N,) personal-best costs.

    Returns:
        The mean, or ``None`` when no pbest cost is finite (tested explicitly: no empty mean).
    """
    f_pbest = np.asarray(f_pbest, dtype=np.float64)
    finite = np.isfinite(f_pbest)
    count = int(np.count_nonzero(finite))
    if count == 0:
        return None
    if count == f_pbest.shape[0]:
        return float(f_pbest.mean())
    return float(f_pbest[finite].mean())


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


def slope_is_zero(slope: float, level: float | None, atol: float = 1e-12, rtol: float = 1e-9) -> bool:
    """Eq. 29's "slope = 0", with a tolerance: ``k <= atol + rtol |J|`` (D15).

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
        regroup_period: T_r, regrouping period in broad mode (D11).
        switch_lag: j in eqs. 25-28.
        switch_weight: ω in eqs. 26-27 (not the inertia).
        jump_factor: α in eq. 28.
        slope_atol: Absolute tolerance of "slope = 0" (D15).
        slope_rtol: Relative tolerance of "slope = 0" (D15).
        terminate: Stop when eq. 33 holds (else lock accurate mode, D20).
        linkage: Agglomerative linkage method (D13).
        entropy_eps: ε in ``1 / (distance + ε)`` (D14).

    The shared swarm options are those of :class:`optimizers.swarm.SwarmOptimizer`. ``minimize`` may
    stop before the budget is spent (eq. 33, message ``"adaptive termination (eqs. 29-33)"``).
    """

    swarm_size: int = 100  # N, seed §5
    n_groups: int = 5  # G, seed §5
    inertia_range: tuple[float, float] = (0.95, 1.0)  # w ~ U[0.95, 1], seed §5
    acceleration: float = 1.3667  # c, seed §5
    constriction: float = 0.7298  # chi, DECISION: optimizers.md D9
    stage2_sign: int = 1  # s, DECISION: optimizers.md D10
    scheme: tuple[str, str] = ("entropy", "cluster")  # Table 1, scheme 4
    regroup_period: int = 10  # T_r in broad mode, DECISION: optimizers.md D11
    switch_lag: int = 1  # j, seed §5
    switch_weight: float = 0.8  # ω, seed §5
    jump_factor: float = 3.0  # α, seed §5
    slope_atol: float = 1e-12  # DECISION: optimizers.md D15
    slope_rtol: float = 1e-9  # DECISION: optimizers.md D15
    terminate: bool = True  # seed §3.2.3; False in ihpso-noterm
    linkage: str = "average"  # DECISION: optimizers.md D13
    entropy_eps: float = 1e-12  # DECISION: optimizers.md D14

    def __post_init__(self) -> None:
        super().__post_init__()
        validate_holonic(self)
        name = type(self).__name__
        scheme = coerce_pair(self, "scheme")
        require(all(s in GROUPING_METHODS for s in scheme), name, "scheme", scheme,
                f"a (broad, accurate) pair of {GROUPING_METHODS}")
        require(is_int(self.switch_lag) and self.switch_lag >= 1, name, "switch_lag", self.switch_lag,
                "an integer >= 1")
        require(is_real(self.switch_weight) and self.switch_weight > 0, name, "switch_weight",
                self.switch_weight, "a finite number > 0")
        require(is_real(self.jump_factor) and self.jump_factor > 0, name, "jump_factor", self.jump_factor,
                "a finite number > 0")
        for field in ("slope_atol", "slope_rtol"):
            value = getattr(self, field)
            require(is_real(value) and value >= 0, name, field, value, "a finite number >= 0")
        require(isinstance(self.terminate, bool), name, "terminate", self.terminate, "True or False")
        require(self.linkage in LINKAGE_METHODS, name, "linkage", self.linkage, f"one of {LINKAGE_METHODS}")
        require(is_real(self.entropy_eps) and self.entropy_eps > 0, name, "entropy_eps", self.entropy_eps,
                "a finite number > 0")

    def group(self, method: str, U: FloatArray, rng: np.random.Generator) -> IntArray:
        """Group the swarm with one of the scheme's methods (§5.1).

        Args:
            method: ``"entropy"``, ``"cluster"`` or ``"random"``.
            U: (N, d) current positions in normalised coordinates.
            rng: The run's Generator (used by ``"random"`` only).

        Returns:
            (N,) group labels.
        """
        if method == "random":
            return random_equal_groups(U.shape[0], self.n_groups, rng)
        return dendrogram_groups(U, self.n_groups, inverse=method == "entropy", method=self.linkage,
                                 eps=self.entropy_eps)

    def iterate(self, swarm: Swarm, rng: np.random.Generator) -> Iterator[str | None]:
        """One iteration per ``next`` (§5.4 steps 1.1-1.5); yields the stop message on eq. 33.

        Trace (docs/swarm.md §6): ``mode`` (the search mode each iteration moved in, ``"broad"`` or
        ``"accurate"``), ``switch_iterations`` (iterations after which broad search switched to accurate,
        eqs. 25-28), ``reverse_switch_iterations`` (accurate back to broad: zero slope but eq. 33 false),
        ``termination_tests`` (``(t, passed)`` for every evaluation of eq. 33), ``locked_at`` (the
        iteration accurate mode was locked, ``ihpso-noterm`` only) and ``stopped_by``
        (``"termination"`` for eq. 33, ``"max_evals"`` otherwise).
        """
        n, d = swarm.n, swarm.d
        w_low, w_high = self.inertia_range
        broad_method, accurate_method = self.scheme
        trace = swarm.trace
        modes: list[str] = []
        switches: list[int] = []
        reverse_switches: list[int] = []
        tests: list[tuple[int, bool]] = []
        trace.update(mode=modes, switch_iterations=switches, reverse_switch_iterations=reverse_switches,
                     termination_tests=tests, locked_at=None, stopped_by="max_evals")

        # Step 0 (§5.4) after initialisation: J(0), broad mode grouped by scheme[0].
        level = fitness_level(swarm.f_pbest)
        slopes: list[float] = [math.inf]  # slopes[t] = k_t; k_0 is never used
        accurate = False
        locked = False
        labels = self.group(broad_method, swarm.normalised(), rng)
        phase_start = 0  # t0 (D18)
        since_grouping = 0

        for t in count(1):
            # Step 1.1: periodic regrouping, broad mode only.
            if not accurate and since_grouping == self.regroup_period:
                labels = self.group(broad_method, swarm.normalised(), rng)  # DECISION: optimizers.md D11
                since_grouping = 0
            # Step 1.2: attractors and velocity (eq. 22 broad, eq. 23 accurate).
            attractors = holonic_attractors(swarm.pbest, swarm.f_pbest, labels)
            w = rng.uniform(w_low, w_high, size=(n, 1))  # DECISION: optimizers.md D28
            r = rng.random((3, n, d))
            sign = float(self.stage2_sign) if accurate else 1.0
            # Step 1.3: clamp, move, evaluate, pbest (the loop records the history), level and slope.
            swarm.fly(holonic_velocity(swarm.v, swarm.x, attractors, r, w, acceleration=self.acceleration,
                                       constriction=self.constriction, sign=sign))
            modes.append("accurate" if accurate else "broad")
            since_grouping += 1
            previous, level = level, fitness_level(swarm.f_pbest)  # DECISION: optimizers.md D16
            slopes.append(fitness_slope(level, previous))
            stop = None
            # Step 1.4: broad -> accurate (eqs. 25-28, window D18).
            if not accurate:
                if switch_due(slopes, t, phase_start, self.switch_lag, self.switch_weight, self.jump_factor):
                    accurate = True
                    switches.append(t)
                    labels = self.group(accurate_method, swarm.normalised(), rng)
                    since_grouping = 0
            # Step 1.5: accurate mode with a zero slope: terminate, lock, or go back to broad search.
            elif not locked and slope_is_zero(slopes[t], level, self.slope_atol, self.slope_rtol):
                U = swarm.normalised()
                converged = termination_test(U, self.n_groups, method=self.linkage, eps=self.entropy_eps)
                tests.append((t, converged))
                if converged:
                    if self.terminate:
                        trace["stopped_by"] = "termination"
                        stop = MESSAGE_TERMINATED  # DECISION: optimizers.md D20
                    else:
                        locked = True
                        trace["locked_at"] = t
                else:
                    accurate = False
                    phase_start = t
                    reverse_switches.append(t)
                    labels = self.group(broad_method, U, rng)
                    since_grouping = 0
            yield stop


register_optimizer("ihpso-scheme1")(partial(IHPSO, scheme=("cluster", "cluster")))
register_optimizer("ihpso-scheme2")(partial(IHPSO, scheme=("entropy", "entropy")))
register_optimizer("ihpso-scheme3")(partial(IHPSO, scheme=("cluster", "entropy")))
register_optimizer("ihpso-random")(partial(IHPSO, scheme=("random", "random")))
register_optimizer("ihpso-noterm")(partial(IHPSO, terminate=False))
register_optimizer("ihpso-literal")(partial(IHPSO, constriction=1.0, stage2_sign=-1))
