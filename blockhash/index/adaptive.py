"""The adaptive layout: each table hashes by a kd-tree of count thresholds.

The paper's hash (section 3.1) counts the thresholds below a coordinate on each
axis, with thresholds from that axis' marginal distribution, and a table is the
product grid.  Photon maps lie on surfaces: a floor, walls, a curved receiver,
several at once.  A product grid, or the nested grid of
:class:`~blockhash.index.thresholds.ThresholdLayout` ``NESTED``, cuts every
slab and column into the same number of buckets, so where one surface holds
most photons of a slab (a floor under a lit wall; the faces of a room, where
every photon of a face shares one coordinate) its buckets overflow while the
others hold few photons.

``ADAPTIVE`` keeps the hash a sequence of threshold comparisons on fixed-point
codes, but lets every cut choose its axis and its place from the photons it
splits, as the grid files that section 4.1 cites do:

* a node holding ``c`` photons is a bucket when ``round(c / S) <= 1`` (``S``
  the target photons per bucket) or when its photons share one position;
* where the photons probed leave an empty gap on one axis wider than every axis'
  interquartile range (two surfaces apart: a floor and a plane above it, a bust and
  the floor, a cluster and its neighbours), the node is cut mid-way across that gap,
  whatever the counts on its two sides: a surface holding few of the node's photons
  gets buckets of its own instead of sharing the dense surface's small ones (a query
  on it then finds its neighbours, not the photons of the surface below);
* otherwise it is cut on its *widest* axis: the largest interquartile range of
  its photons (in metres), or where every interquartile range is zero (most
  photons on one plane, or one point), the largest 5th-95th percentile range,
  then the largest full range;
* the cut puts ``m_left + o`` buckets' worth of photons on the left, where the
  node needs ``m = round(c / S)`` buckets and ``m_left = m // 2``; ``o`` in
  [-1/2, 1/2) is the table's offset for that depth (Roberts' R3 sequence, as
  :func:`~blockhash.index.thresholds.table_offsets`), so that the L tables'
  bucket borders interleave (section 4.2, Figure 2).  Photons with a code equal
  to the threshold go right (the paper's ``h(x) = #{t <= x}``); where the cut
  falls among photons sharing one code, the threshold moves to the side of that
  run that leaves the counts closer to the target, so a plane is never split
  and never swallows both children; the threshold lies mid-way in the gap
  between the codes on its two sides, so that a query a few codes off a plane
  (float rounding of a shading point) hashes to the plane's side.

Every bucket then holds about ``S`` photons whatever the surfaces, and buckets
are about as wide as they are long on each surface.  Each table is built over
all photons, partitioning a copy of their codes in place (quickselect, linear
time per level, tables on parallel threads); a photon's bucket is where its
partition ends.  A query descends ``log2(N / S)`` nodes per table, one two-word node read
each: about the comparisons of the paper's three binary searches.

Row layout of one table, ``2 * nodes`` uint32 words; node ``i`` at ``2 i``::

    word 2i      threshold code t
    word 2i + 1  inner node: (left child << 3) | axis    (axis 0, 1, 2 = x, y, z)
                 bucket:     (bucket << 3) | 4
    descend:     i = left + (code[axis] >= t)

Rows of different tables differ in length and bucket count; they are padded to
the longest row (``THRESHOLD_PAD``) and the most buckets.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from .thresholds import LEAF, MAX_DEPTH, THRESHOLD_PAD, table_offsets

#: Nodes larger than this take their cut's code from a strided sample of this many photons
#: (one sort) instead of a quickselect over all of them.
SELECT_SAMPLE = 2047
#: Photons of a node looked at to choose its axis (a strided subset).
AXIS_PROBE = 31


@numba.njit(cache=True, nogil=True)
def _swap(c, ids, i, j):
    for a in range(3):
        c[i, a], c[j, a] = c[j, a], c[i, a]
    ids[i], ids[j] = ids[j], ids[i]


@numba.njit(cache=True, nogil=True)
def _select(c, ids, a, lo, hi, p):
    """Reorder rows ``lo:hi`` of ``c`` (and ``ids``) so that row ``p`` holds the code of rank
    ``p - lo`` on axis ``a``, smaller codes before it and larger after (Hoare's quickselect,
    median of three)."""
    while hi - lo > 1:
        mid = (lo + hi - 1) // 2
        x, y, z = c[lo, a], c[mid, a], c[hi - 1, a]
        pivot = max(min(x, y), min(max(x, y), z))
        i, j = lo, hi - 1
        while i <= j:
            while c[i, a] < pivot:
                i += 1
            while c[j, a] > pivot:
                j -= 1
            if i <= j:
                _swap(c, ids, i, j)
                i += 1
                j -= 1
        if p <= j:
            hi = j + 1
        elif p >= i:
            lo = i
        else:
            return


@numba.njit(cache=True, nogil=True)
def _spreads(c, lo, hi, scale, v, out):
    """``out`` (3, 6) per axis: interquartile, 5th-95th percentile and full range in metres,
    the widest gap between consecutive probed codes in metres and that gap's two codes,
    from at most ``AXIS_PROBE`` rows of ``c[lo:hi]`` taken at a fixed stride (``v`` is a
    scratch buffer of ``AXIS_PROBE`` values; insertion sort, which is fastest at this size)."""
    n = hi - lo
    m = min(n, AXIS_PROBE)
    for a in range(3):
        for r in range(m):
            x = np.float64(c[lo + (r * n) // m, a])
            j = r
            while j > 0 and v[j - 1] > x:
                v[j] = v[j - 1]
                j -= 1
            v[j] = x
        out[a, 0] = (v[(3 * m) // 4] - v[m // 4]) * scale[a]
        out[a, 1] = (v[(19 * m) // 20] - v[m // 20]) * scale[a]
        out[a, 2] = (v[m - 1] - v[0]) * scale[a]
        out[a, 3] = 0.0
        for r in range(1, m):
            if (v[r] - v[r - 1]) * scale[a] > out[a, 3]:
                out[a, 3] = (v[r] - v[r - 1]) * scale[a]
                out[a, 4] = v[r - 1]
                out[a, 5] = v[r]
    return out


@numba.njit(cache=True, nogil=True)
def _gap_axis(spread):
    """The axis of the widest empty gap between probed photons, when that gap is wider than
    every axis' interquartile range (two surfaces, or a surface and a cluster, apart by
    more than either's extent in the node), else -1."""
    a = 0
    for j in range(3):
        if spread[j, 3] > spread[a, 3]:
            a = j
    for j in range(3):
        if spread[a, 3] <= spread[j, 0]:
            return -1
    return a if spread[a, 3] > 0.0 else -1


@numba.njit(cache=True, nogil=True)
def _widest(spread):
    """(axis to cut, number of axes the photons spread along), axis -1 when every photon
    probed shares one position."""
    for kind in range(3):
        a = 0
        dims = 0
        for j in range(3):
            if spread[j, kind] > spread[a, kind]:
                a = j
            if spread[j, kind] > 0.0:
                dims += 1
        if dims > 0:
            return a, dims
    return -1, 0


@numba.njit(cache=True, nogil=True)
def _build_tree(codes, S, offsets, scale):
    """Nodes (2 words each), the bucket of every photon and the bucket count of one table."""
    n = codes.shape[0]
    c = codes.copy()
    ids = np.arange(n)
    keys = np.empty(n, dtype=np.int64)
    cap = 2 * max(1, int(np.round(n / S))) + 64
    nodes = np.empty(2 * cap, dtype=np.uint32)
    depth = np.zeros(cap, dtype=np.int64)
    stack = np.empty((MAX_DEPTH + 2, 4), dtype=np.int64)  # node, lo, hi, buckets wanted
    stack[0] = (0, 0, n, max(1, int(np.round(n / S))))
    buf = np.empty(SELECT_SAMPLE, dtype=np.uint32)
    probe = np.empty(AXIS_PROBE)
    spread = np.zeros((3, 6))
    top = 1
    used = 1
    buckets = 0
    while top > 0:
        top -= 1
        node, lo, hi, m = stack[top]
        size = hi - lo
        a = -1
        dims = 0
        gap = -1
        if m >= 2 and size >= 2 and depth[node] < MAX_DEPTH - 1 and used + 2 <= cap:
            a, dims = _widest(_spreads(c, lo, hi, scale, probe, spread))
            gap = _gap_axis(spread)
        split = -1
        t = np.uint32(0)
        if gap >= 0:
            # Cut mid-way across the gap, whatever the counts on its two sides, when each
            # side holds at least half a bucket of photons.
            below_code = np.uint32(spread[gap, 4])
            t = np.uint32(below_code + 1 + (np.uint32(spread[gap, 5]) - below_code - 1) // 2)
            split = 0
            for r in range(lo, hi):
                if c[r, gap] < t:
                    split += 1
            if min(split, size - split) >= 0.5 * S:
                a = gap
                i, j = lo, hi - 1
                while i <= j:
                    if c[i, a] < t:
                        i += 1
                    else:
                        _swap(c, ids, i, j)
                        j -= 1
            else:
                gap = -1
                split = -1
        if gap < 0 and a >= 0:
            # Shift the cut by up to half a layer of buckets along the axis: m ** (1 / dims)
            # layers, at least the two children.
            layers = max(2.0, m ** (1.0 / dims))
            target = size * (0.5 + offsets[depth[node] % offsets.shape[0]] / layers)
            if size > SELECT_SAMPLE:
                # The cut's code from a strided sample: its rank is off by about
                # size / sqrt(SELECT_SAMPLE), under 3% of the node.
                for r in range(SELECT_SAMPLE):
                    buf[r] = c[lo + (r * size) // SELECT_SAMPLE, a]
                buf.sort()
                v = buf[min(int(target / size * SELECT_SAMPLE), SELECT_SAMPLE - 1)]
            else:
                p = min(max(int(target), 0), size - 1)
                _select(c, ids, a, lo, hi, lo + p)
                v = c[lo + p, a]
            below = 0
            equal = 0
            max_below = np.uint32(0)
            min_above = np.uint32(0xFFFFFFFF)
            for r in range(lo, hi):
                x = c[r, a]
                if x < v:
                    below += 1
                    max_below = max(max_below, x)
                elif x == v:
                    equal += 1
                else:
                    min_above = min(min_above, x)
            # The run of code v goes right (left = below) or left (left = below + equal), as
            # leaves the counts nearer the target; the threshold sits mid-way in the gap to
            # the next code, so that a query a few codes off a plane of photons (rounding)
            # still falls on the plane's side.
            if below == 0 or (below + equal < size and abs(below + equal - target) < abs(below - target)):
                if below + equal < size:
                    t = np.uint32(v + 1 + (min_above - v - 1) // 2)
                    split = below + equal
            else:
                t = np.uint32(v - (v - max_below - 1) // 2)
                split = below
            if split > 0:
                i, j = lo, hi - 1
                while i <= j:
                    if c[i, a] < t:
                        i += 1
                    else:
                        _swap(c, ids, i, j)
                        j -= 1
        if split <= 0:
            nodes[2 * node] = 0
            nodes[2 * node + 1] = (np.uint32(buckets) << 3) | LEAF
            for r in range(lo, hi):
                keys[ids[r]] = buckets
            buckets += 1
            continue
        left = used
        used += 2
        nodes[2 * node] = t
        nodes[2 * node + 1] = (np.uint32(left) << 3) | np.uint32(a)
        depth[left] = depth[left + 1] = depth[node] + 1
        if gap >= 0:  # each side's buckets from its own count
            m_left = max(1, int(np.round(split / S)))
            m_right = max(1, int(np.round((size - split) / S)))
        else:
            m_left = min(max(int(np.round(m * split / size)), 1), m - 1)
            m_right = m - m_left
        stack[top] = (left + 1, lo + split, hi, m_right)
        stack[top + 1] = (left, lo, lo + split, m_left)
        top += 2
    return nodes[:2 * used], keys, buckets


def build_adaptive(codes, *, L: int, photons_per_bucket: float,
                   scale) -> tuple[np.ndarray, np.ndarray, int]:
    """Rows of ``L`` adaptive tables over ``codes``.

    Parameters
    ----------
    codes : (n, 3) uint32      photon position codes
    L : int                    tables
    photons_per_bucket : float target photons per bucket, S (> 0)
    scale : (3,) float         metres per code step on each axis (extents compare in metres)

    Returns
    -------
    thresholds : (L, T) uint32 rows, padded with ``THRESHOLD_PAD``
    keys : (L, n) int64 bucket of every photon in every table
    buckets : int              buckets per table (the largest table's count)
    """
    codes = np.ascontiguousarray(codes, dtype=np.uint32)
    offsets = table_offsets(L * MAX_DEPTH)[:, 0].reshape(MAX_DEPTH, L).T.copy()
    scale = np.asarray(scale, dtype=np.float64)
    S = float(photons_per_bucket)
    workers = max(1, min(L, os.cpu_count() or 1))
    with ThreadPoolExecutor(max_workers=workers) as pool:  # numba releases the GIL (nogil)
        tables = list(pool.map(lambda t: _build_tree(codes, S, offsets[t], scale), range(L)))
    T = max(len(r) for r, _, _ in tables)
    out = np.full((L, T), THRESHOLD_PAD, dtype=np.uint32)
    keys = np.empty((L, len(codes)), dtype=np.int64)
    for t, (row, k, _) in enumerate(tables):
        out[t, :len(row)] = row
        keys[t] = k
    return out, keys, max(b for _, _, b in tables)
