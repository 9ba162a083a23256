"""IHPSO: improved holonic PSO (Luo, Liang & Li 2022, the seed paper §3.2-3.3).

optimizers.md §5. IHPSO keeps HPSO's three holonic levels and velocity rules (§4: D8, D9, D10, D12;
shared through ``swarm.py``) and replaces three things:

1. random grouping, by clustering (near particles together) and information-entropy grouping (far
   particles together): ordinary complete-linkage hierarchical clustering of the distances (or of their
   inverses) cut into G clusters (§5.1, D13, D14);
2. the fixed 0.8 stage split, by the switch conditions of eqs. 25-28 on the slope of the fitness level
   (the mean of the best N/G personal-best costs, D16) (§5.2, D17, D18);
3. the fixed iteration count, by the adaptive termination of eqs. 29-33: a relative "slope = 0" and a
   comparison of root-mean-square within-group distances (§5.3, D15, D19, D20).

Scheme 4 of the paper's Table 1 is the default: entropy grouping in broad search, clustering in
accurate search. IHPSO has no planned-iteration schedule: it runs until eq. 33 holds or the budget ends.

The readings used before issue 11 (equal-size cuts of an average-linkage leaf order, sums of distances,
the mean finite pbest cost, a 1e-9 relative tolerance) are kept, bit-identical, as ``ihpso-2022v0``
(optimizers.md §5.5).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import lru_cache, partial
from itertools import count
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.cluster.hierarchy import fcluster, leaves_list, linkage
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
GROUPING_CUTS = ("maxclust", "equal")  # D14; "equal" is the 2022v0 reading
SPREAD_STATISTICS = ("rms", "sum")  # D19; "sum" is the 2022v0 reading
FITNESS_LEVELS = ("front", "mean")  # D16; "mean" is the 2022v0 reading


# ----------------------------------------------------------------------------------------------
# §5.1 Grouping
# ----------------------------------------------------------------------------------------------


def groups_from_distances(
    distances: FloatArray,
    n: int,
    n_groups: int,
    *,
    inverse: bool,
    method: str = "complete",
    eps: float = 1e-12,
    cut: str = "maxclust",
) -> IntArray:
    """Dendrogram grouping from condensed distances (§5.1 steps 2-4).

    DECISION (optimizers.md D14): the dendrogram is cut into at most G clusters as a statistics
    package's ``cluster(Z, maxclust=G)`` does (scipy's ``fcluster(Z, G, criterion="maxclust")``), so
    groups have the sizes the data give them and a clump is never split or merged to equalise sizes.
    ``cut="equal"`` is the 2022v0 reading: the leaf order cut into consecutive blocks of the §2.12 sizes.

    Args:
        distances: Condensed pairwise distances (``pdist`` order) of ``n`` points.
        n: Number of points.
        n_groups: Number of groups G (``1 <= G <= n``).
        inverse: Cluster on ``1 / (distance + eps)`` (entropy grouping) instead of the distances.
        method: Agglomerative linkage method (D13).
        eps: Keeps coincident points finite under inversion (D14).
        cut: ``"maxclust"`` (at most G clusters of any size) or ``"equal"`` (the 2022v0 equal blocks).

    Returns:
        (n,) labels in ``0..k-1``, ``k <= G`` (``k < G`` only when merge heights tie, e.g. coincident
        points).

    Raises:
        ValueError: If ``n_groups`` is not between 1 and ``n``, or ``cut`` is unknown.
    """
    sizes = group_sizes(n, n_groups)
    if cut not in GROUPING_CUTS:
        raise ValueError(f"cut: got {cut!r}, expected one of {GROUPING_CUTS}")
    if n == 1:
        return np.zeros(1, dtype=np.int64)
    dissimilarity = 1.0 / (distances + eps) if inverse else distances
    tree = linkage(dissimilarity, method=method)
    if cut == "equal":
        return labels_from_order(leaves_list(tree), sizes)
    return fcluster(tree, t=n_groups, criterion="maxclust").astype(np.int64) - 1


def dendrogram_groups(
    U: ArrayLike,
    n_groups: int,
    *,
    inverse: bool,
    method: str = "complete",
    eps: float = 1e-12,
    cut: str = "maxclust",
) -> IntArray:
    """Clustering (``inverse=False``) or information-entropy (``inverse=True``) grouping (§5.1).

    Args:
        U: (N, d) current positions in normalised coordinates (§2.1).
        n_groups: Number of groups G.
        inverse: Entropy grouping: far particles share a group.
        method: Agglomerative linkage method (complete by default, D13).
        eps: Added to distances before inversion (D14).
        cut: ``"maxclust"`` (default, D14) or ``"equal"`` (2022v0).

    Returns:
        (N,) group labels in ``0..k-1``, ``k <= G``.
    """
    U = np.asarray(U, dtype=np.float64)
    last = _last_termination()
    if last.get("key") == _positions_key(U, n_groups, method, eps, cut):
        return last["groups"]["entropy" if inverse else "cluster"].copy()  # eq. 33's clustering of U
    return groups_from_distances(pdist(U), U.shape[0], n_groups, inverse=inverse, method=method, eps=eps,
                                 cut=cut)


@lru_cache(maxsize=8)
def _pair_indices(n: int) -> tuple[IntArray, IntArray]:
    """Row and column of every entry of a condensed distance vector of ``n`` points (``pdist`` order)."""
    i, j = np.triu_indices(n, k=1)
    return i, j


def group_distance_sums(distances: FloatArray, labels: IntArray, n_groups: int) -> FloatArray:
    """``SD_p`` (eq. 30 literally) from condensed distances: the sum over unordered pairs in each group.

    The 2022v0 reading (D19); the default compares :func:`group_rms_distances` instead.

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
    """``SD_p = sum_{i<j in p} ||u_i - u_j||`` for every group p (eq. 30 literally; 2022v0, D19).

    Args:
        U: (N, d) positions (normalised coordinates in IHPSO).
        labels: (N,) group labels in ``0..G-1``.

    Returns:
        (G,) sums; each unordered pair is counted once.
    """
    U = np.asarray(U, dtype=np.float64)
    labels = np.asarray(labels, dtype=np.int64)
    return group_distance_sums(pdist(U), labels, int(labels.max()) + 1)


def group_rms_distances(distances: FloatArray, labels: IntArray) -> FloatArray:
    """Root-mean-square distance over the unordered pairs of each group; NaN for a group of one (D19).

    ``sqrt(sum_{i<j in p} ||u_i - u_j||^2 / (n_p (n_p - 1) / 2))``: a mean, so groups of different sizes
    compare (a sum grows with the number of pairs); squared, so it is ``sqrt(2 n_p / (n_p - 1))`` times
    the group's root-mean-square distance to its centroid. A group of one has no pair: its spread is
    undefined (NaN), and :func:`termination_test` leaves it out.

    Args:
        distances: Condensed pairwise distances (``pdist`` order).
        labels: (N,) group labels in ``0..k-1``.

    Returns:
        (k,) spreads.
    """
    n_labels = int(labels.max()) + 1
    i, j = _pair_indices(labels.shape[0])
    li = labels[i]
    same = li == labels[j]
    squares = np.bincount(li[same], weights=distances[same] ** 2, minlength=n_labels)
    pairs = np.bincount(li[same], minlength=n_labels).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(pairs > 0, np.sqrt(squares / np.maximum(pairs, 1.0)), np.nan)


def within_group_rms_distances(U: ArrayLike, labels: ArrayLike) -> FloatArray:
    """:func:`group_rms_distances` of positions (eq. 30 as read in D19).

    Args:
        U: (N, d) positions (normalised coordinates in IHPSO).
        labels: (N,) group labels in ``0..k-1``.

    Returns:
        (k,) root-mean-square within-group distances, NaN for groups of one.
    """
    U = np.asarray(U, dtype=np.float64)
    return group_rms_distances(pdist(U), np.asarray(labels, dtype=np.int64))


def spread_threshold(n_groups: int, dim: int) -> float:
    """The factor ``G^(1/d)`` by which eq. 33's cluster spread is scaled (D19).

    A compact group holding ``N / G`` particles of one evenly filled cloud occupies about ``1 / G`` of the
    cloud's volume, so its linear spread is about ``G^(-1/d)`` times that of a cross-section of the cloud
    (an entropy group). Scaling the largest cluster spread by ``G^(1/d)`` makes one cloud pass; clumps
    confine every cluster group to one clump, far smaller than that.

    Args:
        n_groups: G.
        dim: d, the number of coordinates.

    Returns:
        ``G ** (1 / d)``: 1.71 for G = 5, d = 3; 1.11 for d = 15.
    """
    return float(n_groups) ** (1.0 / dim)


def termination_spreads(
    U: ArrayLike,
    n_groups: int,
    *,
    method: str = "complete",
    eps: float = 1e-12,
    cut: str = "maxclust",
    spread: str = "rms",
) -> tuple[float, float]:
    """Eqs. 31-32: ``(SD_pemin, SD_psmax)``, the least spread entropy group and the most spread cluster group.

    Args:
        U: (N, d) current positions in normalised coordinates.
        n_groups: G.
        method: Linkage method (D13).
        eps: Inversion guard (D14).
        cut: Dendrogram cut (D14).
        spread: ``"rms"`` (root-mean-square distance, groups of one left out; its ``SD_psmax`` already
            scaled by :func:`spread_threshold`) or ``"sum"`` (the 2022v0 sums, eq. 30 literally).

    Returns:
        ``(SD_pemin, SD_psmax)``; NaN when a side has no group with a pair (only when ``N == G``).

    Raises:
        ValueError: If ``spread`` or ``cut`` is unknown.
    """
    spreads, _ = termination_spreads_and_groups(U, n_groups, method=method, eps=eps, cut=cut, spread=spread)
    return spreads


def termination_spreads_and_groups(
    U: ArrayLike,
    n_groups: int,
    *,
    method: str = "complete",
    eps: float = 1e-12,
    cut: str = "maxclust",
    spread: str = "rms",
) -> tuple[tuple[float, float], dict[str, IntArray]]:
    """:func:`termination_spreads`, and the entropy and cluster groupings it was computed from.

    The groupings are those :func:`dendrogram_groups` gives for ``U`` (same distances, linkage and cut),
    so IHPSO regroups after a failed test without clustering the same positions again.

    Returns:
        ``((SD_pemin, SD_psmax), {"entropy": labels, "cluster": labels})``.

    Raises:
        ValueError: If ``spread`` or ``cut`` is unknown.
    """
    if spread not in SPREAD_STATISTICS:
        raise ValueError(f"spread: got {spread!r}, expected one of {SPREAD_STATISTICS}")
    U = np.asarray(U, dtype=np.float64)
    key = _positions_key(U, n_groups, method, eps, cut)
    last = _last_termination()
    if last.get("key") == key and spread in last["spreads"]:
        return last["spreads"][spread], {name: labels.copy() for name, labels in last["groups"].items()}
    spreads, groups = _termination_spreads_and_groups(U, n_groups, method=method, eps=eps, cut=cut,
                                                      spread=spread)
    if last.get("key") != key:
        last.clear()
        last.update(key=key, spreads={}, groups={name: labels.copy() for name, labels in groups.items()})
    last["spreads"][spread] = spreads
    return spreads, groups


# The last positions eq. 33 was evaluated on (per thread), with their spreads and groupings: IHPSO tests
# eq. 33, records its spreads in the trace and regroups after a failed test, all on the same positions, so
# the clustering is made once (pure functions of the positions: the numbers of a fresh computation).
_TERMINATION_CACHE = threading.local()


def _last_termination() -> dict[str, Any]:
    """This thread's record of the last eq. 33 clustering (key, spreads by statistic, groups)."""
    if not hasattr(_TERMINATION_CACHE, "last"):
        _TERMINATION_CACHE.last = {}
    return _TERMINATION_CACHE.last


def _positions_key(U: np.ndarray, n_groups: int, method: str, eps: float, cut: str) -> tuple[Any, ...]:
    """What a grouping of ``U`` depends on: the positions' bytes and shape, G, linkage, ε and cut."""
    return (U.shape, U.tobytes(), int(n_groups), method, float(eps), cut)


def _termination_spreads_and_groups(
    U: np.ndarray, n_groups: int, *, method: str, eps: float, cut: str, spread: str
) -> tuple[tuple[float, float], dict[str, IntArray]]:
    """:func:`termination_spreads_and_groups` computed (no cache)."""
    n = U.shape[0]
    distances = pdist(U)
    entropy = groups_from_distances(distances, n, n_groups, inverse=True, method=method, eps=eps, cut=cut)
    cluster = groups_from_distances(distances, n, n_groups, inverse=False, method=method, eps=eps, cut=cut)
    groups = {"entropy": entropy, "cluster": cluster}
    if spread == "sum":
        # Only the labels present: a maxclust cut may give fewer than G groups, and an empty group's sum
        # of 0 would pass the test. (The equal cut always fills all G, so 2022v0 is unchanged.)
        sd_entropy = group_distance_sums(distances, entropy, int(entropy.max()) + 1)
        sd_cluster = group_distance_sums(distances, cluster, int(cluster.max()) + 1)
        return (float(sd_entropy.min()), float(sd_cluster.max())), groups
    sd_entropy = group_rms_distances(distances, entropy)
    sd_cluster = group_rms_distances(distances, cluster)
    if np.isnan(sd_entropy).all() or np.isnan(sd_cluster).all():
        return (math.nan, math.nan), groups
    spreads = float(np.nanmin(sd_entropy)), spread_threshold(n_groups, U.shape[1]) * float(np.nanmax(sd_cluster))
    return spreads, groups


def termination_test(
    U: ArrayLike,
    n_groups: int,
    *,
    method: str = "complete",
    eps: float = 1e-12,
    cut: str = "maxclust",
    spread: str = "rms",
) -> bool:
    """Eqs. 31-33: ``SD_pemin <= SD_psmax`` on the current positions (:func:`termination_spreads`).

    When the swarm has gathered into one cloud, grouping far particles together no longer produces
    groups much wider than grouping near particles together; when it is split into clumps, every
    entropy group spans clumps while every cluster group stays inside one. No evaluations are spent
    ([S] seed §3.2.3). The printed "SD_pmin" of eq. 33 is read as SD_pemin.

    DECISION (optimizers.md D19): the default compares root-mean-square within-group distances, with the
    cluster side scaled by ``G^(1/d)`` (:func:`spread_threshold`); a group of one is left out, and a
    side without any pair (only ``N == G``) fails the test. ``spread="sum", cut="equal",
    method="average"`` is the 2022v0 test.

    Args:
        U: (N, d) current positions in normalised coordinates.
        n_groups: G.
        method: Linkage method (D13).
        eps: Inversion guard (D14).
        cut: Dendrogram cut (D14).
        spread: Spread statistic (D19).

    Returns:
        Whether the swarm counts as converged.
    """
    entropy_min, cluster_max = termination_spreads(U, n_groups, method=method, eps=eps, cut=cut, spread=spread)
    return bool(entropy_min <= cluster_max)  # NaN compares False


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
        grouping_cut: ``"maxclust"`` (at most G clusters as the data give them) or ``"equal"`` (D14).
        spread: Eq. 30's within-group statistic, ``"rms"`` or ``"sum"`` (D19).
        level: Eq. 25's fitness level, ``"front"`` (best ``ceil(N/G)`` pbests) or ``"mean"`` (D16).
        switch: Whether broad search may switch to accurate search (False in ``ihpso-noswitch``).
        reverse_switch: Whether a failed eq. 33 test returns to broad search (False in ``ihpso-noreverse``:
            the run stays in accurate mode and tests again at the next zero slope).

    The shared swarm options are those of :class:`optimizers.swarm.SwarmOptimizer`. ``minimize`` may
    stop before the budget is spent (eq. 33, message ``"adaptive termination (eqs. 29-33)"``).
    ``ihpso-2022v0`` is ``linkage="average", grouping_cut="equal", spread="sum", level="mean",
    slope_rtol=1e-9`` (the readings before issue 11, bit-identical).
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
        require(is_int(self.switch_lag) and self.switch_lag >= 1, name, "switch_lag", self.switch_lag,
                "an integer >= 1")
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
                                 eps=self.entropy_eps, cut=self.grouping_cut)

    def fitness_level(self, f_pbest: FloatArray) -> float | None:
        """``J(t)`` under this configuration's reading (D16): the front's mean or the finite mean."""
        front = front_size(self.swarm_size, self.n_groups) if self.level == "front" else None
        return fitness_level(f_pbest, front)

    def converged(self, U: FloatArray) -> bool:
        """Eqs. 31-33 under this configuration's readings (D13, D14, D19)."""
        return termination_test(U, self.n_groups, method=self.linkage, eps=self.entropy_eps,
                                cut=self.grouping_cut, spread=self.spread)

    def iterate(self, swarm: Swarm, rng: np.random.Generator) -> Iterator[str | None]:
        """One iteration per ``next`` (§5.4 steps 1.1-1.5); yields the stop message on eq. 33.

        The first switch test is at ``t = 2j + 1`` (3 for j = 1): eqs. 27-28 need the slopes
        ``k_{t-2j}, k_{t-j}, k_t`` of the current broad phase, and ``k_1`` is the first slope (D18). With
        j = 1 any local peak of the slope sequence (``k_{t-1} > k_{t-2}``, ``k_t < k_{t-1}``, ``k_t <
        α k_{t-1}``) satisfies eq. 27, so a noisy level can switch at the earliest allowed iteration; the
        trace records when it did (DECISION: optimizers.md D36, kept as printed and reported).

        Trace (docs/swarm.md §6): ``mode`` (the search mode each iteration moved in, ``"broad"`` or
        ``"accurate"``), ``switch_iterations`` (iterations after which broad search switched to accurate,
        eqs. 25-28), ``reverse_switch_iterations`` (accurate back to broad: zero slope but eq. 33 false),
        ``termination_tests`` (``(t, passed)`` for every evaluation of eq. 33), ``termination_spreads``
        (``(t, SD_pemin, SD_psmax)`` for each, as :func:`termination_spreads` gives them), ``locked_at``
        (the iteration accurate mode was locked, ``ihpso-noterm`` only), ``levels`` (``J(0), J(1), ...``,
        ``None`` where undefined) and ``stopped_by`` (``"termination"`` for eq. 33, ``"max_evals"``
        otherwise).
        """
        n, d = swarm.n, swarm.d
        w_low, w_high = self.inertia_range
        broad_method, accurate_method = self.scheme
        trace = swarm.trace
        modes: list[str] = []
        switches: list[int] = []
        reverse_switches: list[int] = []
        tests: list[tuple[int, bool]] = []
        spreads: list[tuple[int, float, float]] = []
        levels: list[float | None] = []
        trace.update(mode=modes, switch_iterations=switches, reverse_switch_iterations=reverse_switches,
                     termination_tests=tests, termination_spreads=spreads, locked_at=None, levels=levels,
                     stopped_by="max_evals")

        # Step 0 (§5.4) after initialisation: J(0), broad mode grouped by scheme[0].
        level = self.fitness_level(swarm.f_pbest)
        levels.append(level)
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
            previous, level = level, self.fitness_level(swarm.f_pbest)  # DECISION: optimizers.md D16
            levels.append(level)
            slopes.append(fitness_slope(level, previous))
            stop = None
            # Step 1.4: broad -> accurate (eqs. 25-28, window D18).
            if not accurate:
                if self.switch and switch_due(slopes, t, phase_start, self.switch_lag, self.switch_weight,
                                              self.jump_factor):
                    accurate = True
                    switches.append(t)
                    labels = self.group(accurate_method, swarm.normalised(), rng)
                    since_grouping = 0
            # Step 1.5: accurate mode with a zero slope: terminate, lock, or go back to broad search.
            elif not locked and slope_is_zero(slopes[t], level, self.slope_atol, self.slope_rtol):
                U = swarm.normalised()
                converged = self.converged(U)
                tests.append((t, converged))
                # termination_spreads reuses the clustering converged(U) just made (_last_termination).
                spreads.append((t, *termination_spreads(U, self.n_groups, method=self.linkage,
                                                        eps=self.entropy_eps, cut=self.grouping_cut,
                                                        spread=self.spread)))
                if converged:
                    if self.terminate:
                        trace["stopped_by"] = "termination"
                        stop = MESSAGE_TERMINATED  # DECISION: optimizers.md D20
                    else:
                        locked = True
                        trace["locked_at"] = t
                elif self.reverse_switch:
                    accurate = False
                    phase_start = t
                    reverse_switches.append(t)
                    labels = self.group(broad_method, U, rng)  # served from _last_termination for U
                    since_grouping = 0
            yield stop


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
IHPSO_2022V0 = {"linkage": "average", "grouping_cut": "equal", "spread": "sum", "level": "mean", "slope_rtol": 1e-9}
"""The readings before issue 11 (optimizers.md §5.5): ``ihpso-2022v0`` reproduces the old ``ihpso`` exactly."""
register_optimizer("ihpso-2022v0")(partial(IHPSO, **IHPSO_2022V0))
