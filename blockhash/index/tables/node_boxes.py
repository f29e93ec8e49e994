"""Tight boxes of the adaptive tables' nodes (the nearest-box-first walk's bounds).

The box of a bucket node is the float32 min and max, per axis, of the decoded
positions of the photons hashed to that bucket; the box of an inner node is the
union of its two children's.  A node with no photons (a padding word, or an
empty bucket) has the empty box ``lo = +inf, hi = -inf``.

A query's squared distance to a box is computed in float32 exactly as
glsl/bh_walk.glsl computes it (``precise``)::

    g = max(max(lo - q, q - hi), 0)        per axis
    d2 = (gx * gx + gy * gy) + gz * gz

so the CPU reference and the shader order boxes identically.  Boxes bound the
photons of a bucket, not its blocks: a block straddling bucket borders also
holds photons of neighbouring buckets.
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.index.tables.thresholds import LEAF, THRESHOLD_PAD

#: Words per node box: lo x, y, z, hi x, y, z (float32).
BOX_WORDS = 6


@numba.njit(cache=True, nogil=True, parallel=True)
def _boxes(thresholds, keys, positions, buckets, out):
    L, T = thresholds.shape
    nn = T // 2
    n = positions.shape[0]
    for t in numba.prange(L):
        leaf = np.empty((buckets, BOX_WORDS), dtype=np.float32)
        leaf[:, :3] = np.inf
        leaf[:, 3:] = -np.inf
        for s in range(n):
            b = keys[t, s]
            for a in range(3):
                v = positions[s, a]
                if v < leaf[b, a]:
                    leaf[b, a] = v
                if v > leaf[b, 3 + a]:
                    leaf[b, 3 + a] = v
        row = thresholds[t]
        # Children are numbered after their parent (blockhash/index/tables/adaptive.py): a walk
        # from the last node back to the root sees both children before their parent.
        for i in range(nn - 1, -1, -1):
            meta = row[2 * i + 1]
            if meta == THRESHOLD_PAD:
                continue
            if meta & LEAF:
                b = np.int64(meta >> 3)
                for a in range(BOX_WORDS):
                    out[t, i, a] = leaf[b, a]
            else:
                c = np.int64(meta >> 3)
                for a in range(3):
                    out[t, i, a] = min(out[t, c, a], out[t, c + 1, a])
                    out[t, i, 3 + a] = max(out[t, c, 3 + a], out[t, c + 1, 3 + a])


def node_boxes(thresholds, keys, positions, buckets: int) -> np.ndarray:
    """(L, nodes, 6) float32 box of every node of each adaptive table.

    Parameters
    ----------
    thresholds : (L, T) uint32  adaptive rows (:mod:`blockhash.index.tables.adaptive`), nodes = T // 2
    keys : (L, n) int64         bucket of every photon in every table
    positions : (n, 3) float32  decoded photon positions, in the order of ``keys``
    buckets : int               buckets per table (the largest table's count)
    """
    L, T = thresholds.shape
    out = np.empty((L, T // 2, BOX_WORDS), dtype=np.float32)
    out[:, :, :3] = np.inf
    out[:, :, 3:] = -np.inf
    _boxes(np.ascontiguousarray(thresholds), np.ascontiguousarray(keys),
           np.ascontiguousarray(positions, dtype=np.float32), int(buckets), out)
    return out


@numba.njit(cache=True, nogil=True, inline="always")
def box_dist2(box, qx, qy, qz):
    """float32 squared distance from (qx, qy, qz) to a non-empty box (0 inside)."""
    zero = np.float32(0.0)
    gx = max(max(box[0] - qx, qx - box[3]), zero)
    gy = max(max(box[1] - qy, qy - box[4]), zero)
    gz = max(max(box[2] - qz, qz - box[5]), zero)
    return (gx * gx + gy * gy) + gz * gz
