"""The adaptive layout: each table hashes by a kd-tree of count thresholds.

The paper's hash (section 3.1) counts the thresholds below a coordinate on each
axis, with thresholds from that axis' marginal distribution, and a table is the
product grid.  Photon maps lie on surfaces: a floor, walls, a curved receiver,
several at once.  A product grid cuts every slab and column into the same
number of buckets, so where one surface holds
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
  :func:`~blockhash.index.tables.thresholds.table_offsets`), so that the L tables'
  bucket borders interleave (section 4.2, Figure 2).  Photons with a code equal
  to the threshold go right (the paper's ``h(x) = #{t <= x}``); where the cut
  falls among photons sharing one code, the threshold moves to the side of that
  run that leaves the counts closer to the target, so a plane is never split
  and never swallows both children; the threshold lies mid-way in the gap
  between the codes on its two sides, so that a query a few codes off a plane
  (float rounding of a shading point) hashes to the plane's side.

Every bucket then holds about ``S`` photons whatever the surfaces, and buckets
are about as wide as they are long on each surface.  Each table is built over
all photons, partitioning a copy of their rows (codes and index) in place
(:mod:`~blockhash.index.tables.partition`: quickselect, linear time per level); a photon's bucket
is where its partition ends.  The axis probes and sampled cuts read rows at fixed places
of a node's current order, so the tree depends on that order, not on how the work is
shared: the nodes of a table holding more than ``1 / SPLIT_SHARE`` of its photons are cut
one at a time and the subtrees below them grown whole, the parts of all tables run on
parallel threads largest first (:mod:`~blockhash.index.tables.taskpool`), and the parts are then
numbered as one depth-first walk numbers the whole tree.  A query descends
``log2(N / S)`` nodes per table, one two-word node read each: about the comparisons of the
paper's three binary searches.

Row layout of one table, ``2 * nodes`` uint32 words; node ``i`` at ``2 i``::

    word 2i      threshold code t
    word 2i + 1  inner node: (left child << 3) | axis    (axis 0, 1, 2 = x, y, z)
                 bucket:     (bucket << 3) | 4
    descend:     i = left + (code[axis] >= t)

Rows of different tables differ in length and bucket count; they are padded to
the longest row (``THRESHOLD_PAD``) and the most buckets.
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.errors import InputError
from blockhash.index.tables.partition import kth_smallest, partition, photon_rows, select
from blockhash.index.tables.probe import PROBE_SLOTS
from blockhash.index.tables.probe import spreads as _spreads
from blockhash.index.tables.taskpool import run_largest_first
from blockhash.index.tables.thresholds import LEAF, MAX_DEPTH, THRESHOLD_PAD, table_offsets

#: Nodes larger than this take their cut's code from a strided sample of this many photons
#: (a selection in the sample) instead of a quickselect over all of them.
SELECT_SAMPLE = 2047


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
def _mid(below, above):
    """A threshold mid-way in the gap between codes ``below`` < ``above``: ``below`` goes
    left, ``above`` right, and a code off either by less than half the gap stays its side."""
    return np.uint32(below + 1 + (above - below - 1) // 2)


@numba.njit(cache=True, nogil=True)
def _cut(c, lo, hi, m, depth, offsets, scale, buf, probe, spread):
    """Cut rows ``lo:hi`` of a node at ``depth`` that wants ``m`` buckets: (axis, threshold,
    rows that go left), the rows partitioned in place; rows that go left <= 0 for a bucket."""
    size = hi - lo
    a = -1
    dims = 0
    if m >= 2 and size >= 2 and depth < MAX_DEPTH - 1:
        a, dims = _widest(_spreads(c, lo, hi, scale, probe, spread))
        gap = _gap_axis(spread)
        if gap >= 0:
            # Mid-way across the gap, whatever the counts on its two sides, where each side
            # holds at least half of one of the node's buckets.
            t = _mid(np.uint32(spread[gap, 4]), np.uint32(spread[gap, 5]))
            split = 0
            for r in range(lo, hi):
                if c[r, gap] < t:
                    split += 1
            if min(split, size - split) >= 0.5 * size / m:
                partition(c, gap, lo, hi, t, split)
                return gap, t, split
    split = -1
    t = np.uint32(0)
    if a >= 0:
        # Shift the cut by up to half a layer of buckets along the axis: m ** (1 / dims)
        # layers, at least the two children.
        layers = max(2.0, m ** (1.0 / dims))
        target = size * (0.5 + offsets[depth % offsets.shape[0]] / layers)
        if size > SELECT_SAMPLE:
            # The cut's code from a strided sample: its rank is off by about
            # size / sqrt(SELECT_SAMPLE), under 3% of the node.
            for r in range(SELECT_SAMPLE):
                buf[r] = c[lo + (r * size) // SELECT_SAMPLE, a]
            v = kth_smallest(buf, min(int(target / size * SELECT_SAMPLE), SELECT_SAMPLE - 1))
        else:
            p = min(max(int(target), 0), size - 1)
            select(c, a, lo, hi, lo + p)
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
                t = _mid(v, min_above)
                split = below + equal
        else:
            t = np.uint32(v - (v - max_below - 1) // 2)
            split = below
        if split > 0:
            partition(c, a, lo, hi, t, split)
    return a, t, split


@numba.njit(cache=True, nogil=True)
def _left_buckets(m, split, size):
    """Buckets the left child of a node wanting ``m`` wants, ``split`` of its ``size`` rows
    on the left."""
    return min(max(int(np.round(m * split / size)), 1), m - 1)


@numba.njit(cache=True, nogil=True)
def _buckets_wanted(n, S):
    return max(1, int(np.round(n / S)))


@numba.njit(cache=True, nogil=True)
def _cut_one(c, lo, hi, m, depth, offsets, scale):
    """:func:`_cut` for one node: (axis, threshold, rows left, buckets the left child wants)."""
    a, t, split = _cut(c, lo, hi, m, depth, offsets, scale, np.empty(SELECT_SAMPLE, dtype=np.uint32),
                       np.empty((PROBE_SLOTS, 4), dtype=np.uint32), np.zeros((3, 6)))
    return a, t, split, (_left_buckets(m, split, hi - lo) if split > 0 else 0)


@numba.njit(cache=True, nogil=True)
def _grow(c, lo, hi, m, depth0, offsets, scale):
    """The subtree of rows ``lo:hi`` (a node at ``depth0`` wanting ``m`` buckets), depth first:
    its nodes (2 words each, numbered from its root 0, buckets from 0) and its buckets' sizes
    left to right; its rows end in bucket order."""
    cap = 2 * m  # every bucket wants at least one of the m: at most 2 m - 1 nodes
    nodes = np.empty(2 * cap, dtype=np.uint32)
    depth = np.empty(cap, dtype=np.int64)
    sizes = np.empty(m, dtype=np.int64)
    stack = np.empty((MAX_DEPTH + 2, 4), dtype=np.int64)  # node, lo, hi, buckets wanted
    stack[0] = (0, lo, hi, m)
    depth[0] = depth0
    buf = np.empty(SELECT_SAMPLE, dtype=np.uint32)
    probe = np.empty((PROBE_SLOTS, 4), dtype=np.uint32)
    spread = np.zeros((3, 6))
    top = 1
    used = 1
    buckets = 0
    while top > 0:
        top -= 1
        node, lo, hi, m = stack[top]
        a, t, split = _cut(c, lo, hi, m, depth[node], offsets, scale, buf, probe, spread)
        if split <= 0:
            nodes[2 * node] = 0
            nodes[2 * node + 1] = (np.uint32(buckets) << 3) | LEAF
            sizes[buckets] = hi - lo
            buckets += 1
            continue
        left = used
        used += 2
        nodes[2 * node] = t
        nodes[2 * node + 1] = (np.uint32(left) << 3) | np.uint32(a)
        depth[left] = depth[left + 1] = depth[node] + 1
        m_left = _left_buckets(m, split, hi - lo)
        stack[top] = (left + 1, lo + split, hi, m - m_left)
        stack[top + 1] = (left, lo, lo + split, m_left)
        top += 2
    return nodes[:2 * used], sizes[:buckets]


@numba.njit(cache=True, nogil=True)
def _bucket_keys(c, sizes, keys):
    """``keys[photon] = bucket`` from rows in bucket order and the buckets' sizes."""
    r = 0
    for b in range(sizes.shape[0]):
        for _ in range(sizes[b]):
            keys[c[r, 3]] = b
            r += 1


def _stitch(parts, root, words, sizes):
    """One table's row (into ``words``) and bucket sizes (appended to ``sizes``) from its
    parts, numbered as one depth-first walk over the whole tree numbers them (children
    allocated as their parent is cut, the left subtree walked first), however the parts
    were grown.  Returns the nodes used.

    ``parts`` maps a node (its rows ``lo, hi``) to ``("cut", axis, threshold, left node,
    right node)`` or to ``("tree", nodes, sizes)`` from :func:`_grow`; ``root`` is the root."""
    stack = [(root, 0)]
    used = 1
    buckets = 0
    while stack:
        part, node = stack.pop()
        kind, *rest = parts[part]
        if kind == "cut":
            a, t, lpart, rpart = rest
            left = used
            used += 2
            words[2 * node] = t
            words[2 * node + 1] = (left << 3) | a
            stack.append((rpart, left + 1))
            stack.append((lpart, left))
            continue
        w, s = rest
        # The walk reaches a subtree's nodes one after another: its node k > 0 is
        # node used + k - 1 of the table, its bucket b is bucket buckets + b.
        meta = w[1::2].astype(np.int64)
        leaf = (meta & int(LEAF)) != 0
        ptr = meta >> 3
        meta = (np.where(leaf, ptr + buckets, used + ptr - 1) << 3) | (meta & 7)
        words[2 * node] = w[0]
        words[2 * node + 1] = meta[0]
        k = len(meta)
        words[2 * used:2 * (used + k - 1):2] = w[2::2]
        words[2 * used + 1:2 * (used + k - 1):2] = meta[1:]
        used += k - 1
        buckets += len(s)
        sizes.append(s)
    return used


#: Nodes of more than this share of a table's photons are cut one at a time, the rest
#: grown as whole subtrees: the work split into parts small enough to balance the threads.
SPLIT_SHARE = 8
#: ... and nodes of at most this many photons are always grown whole.
SPLIT_MIN = 50_000


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
    n = len(codes)
    if n >= 2**32:
        raise InputError(f"{n:,} photons: an adaptive table indexes at most 2**32 - 1")
    offsets = table_offsets(L * MAX_DEPTH)[:, 0].reshape(MAX_DEPTH, L).T.copy()
    scale = np.asarray(scale, dtype=np.float64)
    M = _buckets_wanted(n, float(photons_per_bucket))
    limit = max(n // SPLIT_SHARE, SPLIT_MIN)
    rows = [None] * L
    parts = [{} for _ in range(L)]  # per table: a node's rows lo, hi -> its part

    def grow(task):
        """Cut one large node, or grow a whole subtree; returns the parts to grow next."""
        t, lo, hi, m, depth = task
        if rows[t] is None:  # the root comes first
            rows[t] = photon_rows(codes)
        c = rows[t]
        if hi - lo > limit:
            a, thr, split, m_left = _cut_one(c, lo, hi, m, depth, offsets[t], scale)
            if split > 0:
                mid = lo + split
                parts[t][lo, hi] = ("cut", a, int(thr), (lo, mid), (mid, hi))
                return [(t, lo, mid, m_left, depth + 1), (t, mid, hi, m - m_left, depth + 1)]
        parts[t][lo, hi] = ("tree",) + _grow(c, lo, hi, m, depth, offsets[t], scale)
        return []

    run_largest_first([(t, 0, n, M, 0) for t in range(L)], grow, lambda task: task[2] - task[1])
    keys = np.empty((L, n), dtype=np.int64)
    tables = [None] * L

    def finish(t):
        """Number the table's parts as one tree; its photons' buckets from its rows."""
        words = np.empty(4 * M, dtype=np.uint32)
        sizes = []
        used = _stitch(parts[t], (0, n), words, sizes)
        sizes = np.concatenate(sizes)
        _bucket_keys(rows[t], sizes, keys[t])
        rows[t] = None
        tables[t] = (words[:2 * used], len(sizes))
        return []

    run_largest_first(range(L), finish, lambda t: 0)
    T = max(len(row) for row, _ in tables)
    out = np.full((L, T), THRESHOLD_PAD, dtype=np.uint32)
    for t, (row, _) in enumerate(tables):
        out[t, :len(row)] = row
    return out, keys, max(b for _, b in tables)
