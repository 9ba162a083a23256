"""IHPSO's first readings of the paper, kept as the configuration ``ihpso-2022v0`` (optimizers.md §5.5).

The first implementation read §5.1 and §5.3 differently from the readings IHPSO now uses: it cut the
average-linkage dendrogram's leaf order into consecutive blocks of the equal sizes of optimizers.md
§2.12, compared eq. 30's plain sums of within-group distances, took the mean of all finite
personal-best costs as the fitness level and called a slope zero below ``1e-9 |J|``. Those readings did
not act as the paper says (optimizers.md §5.5 gives the measurements), but published results were made
with them, so ``ihpso-2022v0`` reproduces that optimiser bit for bit.

Two of those readings need code of their own, and it lives here: the equal-block cut
(:func:`equal_cut`) and the sums of distances (:func:`group_distance_sums`, :func:`sum_spreads`).
:mod:`optimizers.ihpso_grouping` calls them when a configuration asks for ``grouping_cut="equal"`` or
``spread="sum"``; the other two readings are values of ordinary fields (``linkage``, ``slope_rtol``) or
the ``front=None`` case of :func:`optimizers.ihpso.fitness_level`. The configuration itself is
registered with the other IHPSO configurations, in :mod:`optimizers.ihpso`.

Shapes: ``N`` points, ``G`` groups; condensed distances in ``scipy.spatial.distance.pdist`` order.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.cluster.hierarchy import leaves_list

from optimizers.base import FloatArray, IntArray
from optimizers.swarm import labels_from_order

IHPSO_2022V0: dict[str, Any] = {"linkage": "average", "grouping_cut": "equal", "spread": "sum", "level": "mean", "slope_rtol": 1e-9}
"""The field overrides that make :class:`optimizers.ihpso.IHPSO` the ``ihpso-2022v0`` configuration."""


def equal_cut(tree: FloatArray, sizes: tuple[int, ...]) -> IntArray:
    """The dendrogram's leaf order cut into consecutive blocks of ``sizes`` (the 2022v0 grouping, D14).

    Args:
        tree: A scipy linkage matrix of ``N`` points, shape (N - 1, 4).
        sizes: The block sizes (``optimizers.swarm.group_sizes(N, G)``), summing to N.

    Returns:
        (N,) labels in ``0..G-1``; block g of the leaf order gets label g.
    """
    return labels_from_order(leaves_list(tree), sizes)


def group_distance_sums(distances: FloatArray, labels: IntArray, n_groups: int) -> FloatArray:
    """``SD_p = sum_{i<j in p} ||u_i - u_j||`` for every group p (eq. 30 read literally, D19).

    Args:
        distances: Condensed pairwise distances of the N points.
        labels: (N,) group labels in ``0..n_groups-1``.
        n_groups: The number of sums to return (a label without members sums to 0).

    Returns:
        (n_groups,) sums; each unordered pair is counted once.
    """
    i, j = np.triu_indices(labels.shape[0], k=1)  # pdist's pair order
    li = labels[i]
    same = li == labels[j]
    return np.bincount(li[same], weights=distances[same], minlength=n_groups).astype(np.float64)


def sum_spreads(distances: FloatArray, entropy: IntArray, cluster: IntArray) -> tuple[float, float]:
    """Eqs. 31-32 with sums: ``(SD_pemin, SD_psmax)``, compared without a factor (the 2022v0 test, D19).

    Only the labels present are summed: a ``maxclust`` cut may give fewer than G groups, and an empty
    group's sum of 0 would pass the test. (The equal cut always fills every group.)

    Args:
        distances: Condensed pairwise distances of the N points.
        entropy: (N,) entropy-grouping labels.
        cluster: (N,) cluster-grouping labels.

    Returns:
        The smallest entropy-group sum and the largest cluster-group sum.
    """
    sd_entropy = group_distance_sums(distances, entropy, int(entropy.max()) + 1)
    sd_cluster = group_distance_sums(distances, cluster, int(cluster.max()) + 1)
    return float(sd_entropy.min()), float(sd_cluster.max())
