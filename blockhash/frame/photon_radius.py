"""Each photon's own radius, for the power-conserving density estimate.

The ``conserving`` estimate (:mod:`.estimate`) spreads every photon over a disc of its
own radius h_p, fixed before rendering: the distance from the photon to its j-th nearest
other photon, floored at the photon map's position error (:func:`blockhash.index.records.fixedpoint.min_radius`).
Because h_p belongs to the photon and not to the shading point, each photon's filter
integrates to its power over its surface (Silverman's sample-point estimator, 1986,
section 5.3.2), whatever the density beside it: the estimate puts no extra light beside
caustic fold lines and edges, where the k-nearest estimate's radius, growing away from
the caustic, does.

The shading point sums the photons it found (its k nearest) whose discs cover it.  A
photon whose disc covers the point but is not among its k nearest is missed, so j must
sit below k by more than the count's fluctuation: a disc that holds k photons on average
holds k +- sqrt(k), and ``j = round(k - 2 sqrt(k))`` (at least 1) leaves two standard
deviations (k = 10: 4, k = 50: 36, k = 100: 80).  A larger j lowers the noise (relative
standard deviation about sqrt(1.5 / j) with the cone filter) and raises the flux lost.
On synthetic fold lines and step edges (``tools/fold_bias.py --estimate conserving
--photons 100000,1000000 --ks 10,50,100``, no scene) the rule keeps the flux within 0.2 %
with the cone, Epanechnikov and Silverman filters (0.7 % with the box, whose weight does
not fall to 0 at the disc's edge).  A map with fewer than j + 1 photons uses each
photon's farthest other photon; a map of one photon has no radius (infinite: the photon
adds nothing).

The j-th nearest other photon comes from an exact search over the octree of the index's
Hilbert order (:mod:`blockhash.index.lookups.octree_knn`: the 3 x 3 x 3 cubes around each photon,
read up the levels until the j-th lies within a cube's side), in about the index build's time
(BENCHMARKS.md, "Photon radii"); :func:`exact_radii2` (scipy's cKDTree) is the oracle it is
tested against, value for value.
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from blockhash.errors import InputError
from blockhash.index.records.fixedpoint import min_r2

#: j = k - MARGIN_SIGMAS sqrt(k): the standard deviations of the count left as margin.
MARGIN_SIGMAS = 2.0

_CACHE: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def neighbours_for(k: int) -> int:
    """j, the rank of the other photon that sets each photon's radius, for k neighbours."""
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise InputError(f"k={k!r}: the conserving estimate needs k >= 1 neighbours (each "
                         "photon's radius reaches its round(k - 2 sqrt(k))-th nearest other photon)")
    return max(1, round(int(k) - MARGIN_SIGMAS * math.sqrt(int(k))))


def own_radii2(index, k: int) -> np.ndarray:
    """(n,) float64 squared radius of every photon (input order), for an estimate with k
    neighbours (module docstring).  Computed once per index and k, by the octree search."""
    def jth(rank):
        from blockhash.index.lookups.octree_knn import jth_distances

        codes = index.records.records[:, :3]  # in Hilbert order
        out = np.empty(len(index))
        out[index.order] = jth_distances(codes, index.quantizer.decode(codes), rank,
                                         index.quantizer)
        return out
    return _radii2(index, neighbours_for(k), jth, "own")


def exact_radii2(index, k: int) -> np.ndarray:
    """:func:`own_radii2` with the exact j-th nearest other photon (scipy's cKDTree)."""
    from scipy.spatial import cKDTree

    def jth(rank):
        pos = np.asarray(index.positions, dtype=np.float64)
        d, _ = cKDTree(pos).query(pos, k=[rank + 1], workers=-1)
        return d[:, 0]
    return _radii2(index, neighbours_for(k), jth, "exact")


def _radii2(index, j: int, jth, kind: str) -> np.ndarray:
    """Squared radii from ``jth(rank)``, the distance to each photon's rank-th
    nearest other photon (its (rank + 1)-th nearest, itself first), floored at the map's
    position error; in float32 steps, as the shader reads them.  Cached per index, j and
    ``kind``."""

    per_index = _CACHE.setdefault(index, {})
    if (kind, j) in per_index:
        return per_index[kind, j]
    n = len(index)
    rank = min(j, n - 1)
    if rank < 1:
        r2 = np.full(n, np.inf)
    else:
        r2 = np.maximum(jth(rank) ** 2, min_r2(index)).astype(np.float32).astype(np.float64)
    per_index[kind, j] = r2
    return r2


def slot_radii2(index, k: int, radii=None) -> np.ndarray:
    """(slots,) float32 squared radii (``radii(index, k)``, default :func:`own_radii2`) in
    block slot order (block b, photon i: slot 10 b + i), as the caustic pass reads them by
    the slot that its lookup returns; 0 in empty slots."""
    from blockhash.index.records.blocks import PHOTONS_PER_BLOCK

    r2 = (radii or own_radii2)(index, k)
    out = np.zeros(len(index.block_words) * PHOTONS_PER_BLOCK, dtype=np.float32)
    out[index.slot_of] = r2.astype(np.float32)
    return out
