"""IHPSO's groupings of the positions and the spreads of eq. 33 (optimizers.md §5.1, §5.3).

Clustering (near particles together) and information-entropy grouping (far particles together) are one
hierarchical clustering, of the distances or of their inverses, cut into at most G clusters (§5.1, D13,
D14). Eq. 33 groups the current positions both ways and compares the least spread entropy group with
the most spread cluster group (§5.3, D19). Every function here is pure: positions in, numbers out.
IHPSO clusters a swarm once per termination test (:func:`cluster_both_ways`) and passes the
:class:`Clustering` on, so the test, the trace and the regrouping after a failed test share one
clustering without any cache.

The 2022v0 cut and sums live in :mod:`optimizers.ihpso_2022v0`; the functions here call them when asked
for ``cut="equal"`` or ``spread="sum"``.

Shapes: ``N`` particles, ``d`` coordinates, ``G`` groups; condensed distances in ``pdist`` order.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from scipy.cluster.hierarchy import fcluster, linkage
from scipy.spatial.distance import pdist

from optimizers.base import FloatArray, IntArray
from optimizers.ihpso_2022v0 import equal_cut, sum_spreads
from optimizers.swarm import group_sizes

LINKAGE_METHODS = ("average", "single", "complete", "weighted")  # valid for any dissimilarity (D13)
GROUPING_CUTS = ("maxclust", "equal")  # D14; "equal" is the 2022v0 reading
SPREAD_STATISTICS = ("rms", "sum")  # D19; "sum" is the 2022v0 reading


class Clustering(NamedTuple):
    """Both groupings of one set of positions, with the distances they were made from.

    Attributes:
        distances: Condensed pairwise distances of the N positions.
        entropy: (N,) information-entropy grouping labels (far particles together).
        cluster: (N,) clustering labels (near particles together).
    """

    distances: FloatArray
    entropy: IntArray
    cluster: IntArray


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
    ``cut="equal"`` is the 2022v0 reading (:func:`optimizers.ihpso_2022v0.equal_cut`).

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
        return equal_cut(tree, sizes)
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

    Raises:
        ValueError: As :func:`groups_from_distances`.
    """
    U = np.asarray(U, dtype=np.float64)
    return groups_from_distances(pdist(U), U.shape[0], n_groups, inverse=inverse, method=method, eps=eps,
                                 cut=cut)


def cluster_both_ways(
    U: ArrayLike, n_groups: int, *, method: str = "complete", eps: float = 1e-12, cut: str = "maxclust"
) -> Clustering:
    """The entropy and the cluster grouping of ``U`` from one distance computation (§5.3 eqs. 31-32).

    Each grouping equals :func:`dendrogram_groups` of ``U`` with the same arguments.

    Args:
        U: (N, d) current positions in normalised coordinates.
        n_groups: G.
        method: Linkage method (D13).
        eps: Inversion guard (D14).
        cut: Dendrogram cut (D14).

    Returns:
        The :class:`Clustering` of ``U``.

    Raises:
        ValueError: As :func:`groups_from_distances`.
    """
    U = np.asarray(U, dtype=np.float64)
    n = U.shape[0]
    distances = pdist(U)
    entropy = groups_from_distances(distances, n, n_groups, inverse=True, method=method, eps=eps, cut=cut)
    cluster = groups_from_distances(distances, n, n_groups, inverse=False, method=method, eps=eps, cut=cut)
    return Clustering(distances, entropy, cluster)


@lru_cache(maxsize=8)
def _pair_indices(n: int) -> tuple[IntArray, IntArray]:
    """Row and column of every entry of a condensed distance vector of ``n`` points (read-only arrays)."""
    i, j = np.triu_indices(n, k=1)
    i.flags.writeable = False  # shared between calls: a caller must not be able to change them
    j.flags.writeable = False
    return i, j


def group_rms_distances(distances: FloatArray, labels: IntArray) -> FloatArray:
    """Root-mean-square distance over the unordered pairs of each group; NaN for a group of one (D19).

    ``sqrt(sum_{i<j in p} ||u_i - u_j||^2 / (n_p (n_p - 1) / 2))``: a mean, so groups of different sizes
    compare (a sum grows with the number of pairs); squared, so it is ``sqrt(2 n_p / (n_p - 1))`` times
    the group's root-mean-square distance to its centroid. A group of one has no pair: its spread is
    undefined (NaN), and :func:`clustering_spreads` leaves it out.

    Args:
        distances: Condensed pairwise distances (``pdist`` order).
        labels: (N,) group labels in ``0..k-1``.

    Returns:
        (k,) spreads, in the units of the distances.
    """
    n_labels = int(labels.max()) + 1
    i, j = _pair_indices(labels.shape[0])
    li = labels[i]
    same = li == labels[j]
    squares = np.bincount(li[same], weights=distances[same] ** 2, minlength=n_labels)
    pairs = np.bincount(li[same], minlength=n_labels).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(pairs > 0, np.sqrt(squares / np.maximum(pairs, 1.0)), np.nan)


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


def clustering_spreads(clustering: Clustering, n_groups: int, dim: int, *, spread: str = "rms") -> tuple[float, float]:
    """Eqs. 31-32 of a :class:`Clustering`: ``(SD_pemin, SD_psmax)``.

    Args:
        clustering: The groupings of the positions (:func:`cluster_both_ways`).
        n_groups: G.
        dim: d, the positions' number of coordinates.
        spread: ``"rms"`` (root-mean-square distance, groups of one left out, ``SD_psmax`` scaled by
            :func:`spread_threshold`) or ``"sum"`` (the 2022v0 sums, :func:`optimizers.ihpso_2022v0.sum_spreads`).

    Returns:
        The least spread entropy group and the most spread cluster group; NaN for both when a side
        has no group with a pair (only when ``N == G``).

    Raises:
        ValueError: If ``spread`` is unknown.
    """
    if spread not in SPREAD_STATISTICS:
        raise ValueError(f"spread: got {spread!r}, expected one of {SPREAD_STATISTICS}")
    distances, entropy, cluster = clustering
    if spread == "sum":
        return sum_spreads(distances, entropy, cluster)
    sd_entropy = group_rms_distances(distances, entropy)
    sd_cluster = group_rms_distances(distances, cluster)
    if np.isnan(sd_entropy).all() or np.isnan(sd_cluster).all():
        return math.nan, math.nan
    return float(np.nanmin(sd_entropy)), spread_threshold(n_groups, dim) * float(np.nanmax(sd_cluster))


def spreads_converge(spreads: tuple[float, float]) -> bool:
    """Eq. 33: ``SD_pemin <= SD_psmax`` (the printed "SD_pmin" read as SD_pemin); NaN fails."""
    entropy_min, cluster_max = spreads
    return bool(entropy_min <= cluster_max)


def termination_spreads(
    U: ArrayLike,
    n_groups: int,
    *,
    method: str = "complete",
    eps: float = 1e-12,
    cut: str = "maxclust",
    spread: str = "rms",
) -> tuple[float, float]:
    """Eqs. 31-32 of positions: :func:`clustering_spreads` of :func:`cluster_both_ways`.

    Args:
        U: (N, d) current positions in normalised coordinates.
        n_groups: G.
        method: Linkage method (D13).
        eps: Inversion guard (D14).
        cut: Dendrogram cut (D14).
        spread: Spread statistic, ``"rms"`` or ``"sum"`` (D19).

    Returns:
        ``(SD_pemin, SD_psmax)``; NaN when a side has no group with a pair (only when ``N == G``).

    Raises:
        ValueError: If ``spread`` or ``cut`` is unknown.
    """
    if spread not in SPREAD_STATISTICS:
        raise ValueError(f"spread: got {spread!r}, expected one of {SPREAD_STATISTICS}")
    U = np.asarray(U, dtype=np.float64)
    clustering = cluster_both_ways(U, n_groups, method=method, eps=eps, cut=cut)
    return clustering_spreads(clustering, n_groups, U.shape[1], spread=spread)


def termination_test(
    U: ArrayLike,
    n_groups: int,
    *,
    method: str = "complete",
    eps: float = 1e-12,
    cut: str = "maxclust",
    spread: str = "rms",
) -> bool:
    """Eqs. 31-33: whether ``SD_pemin <= SD_psmax`` on the current positions (:func:`termination_spreads`).

    When the swarm has gathered into one cloud, grouping far particles together no longer produces
    groups much wider than grouping near particles together; when it is split into clumps, every
    entropy group spans clumps while every cluster group stays inside one. No evaluations are spent
    ([S] seed §3.2.3).

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

    Raises:
        ValueError: If ``spread`` or ``cut`` is unknown.
    """
    return spreads_converge(termination_spreads(U, n_groups, method=method, eps=eps, cut=cut, spread=spread))
