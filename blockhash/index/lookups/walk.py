"""Nearest-box-first query of the adaptive layout (the default preset's query).

The L adaptive tables are kd-trees whose nodes carry tight photon boxes
(:mod:`blockhash.index.tables.node_boxes`).  A query walks the first ``trees`` of them
(``BlockHashParams.walk_trees``: 1 for the default preset, L for all) at once, nearest
box first, and takes the blocks of each bucket it reaches as the hash query does
(:func:`blockhash.index.lookups.hash.take_bucket`: references in slot order, duplicates skipped,
the candidate cap checked before each block).  The walk has no cap on blocks (the
hash query's ``L * B``): the ``A * k`` cap alone ends it, so with compact blocks (all
full but the last) it takes at most ``ceil(A k / 10) + 1`` blocks (:func:`walk_taken_bound`;
at most ``MAX_LEAVES * B`` whatever the blocks):

1. a queue of (squared distance to the node's box, node id) is seeded with the
   ``trees`` roots, table order; node id = ``t * nodes + i`` for node ``i`` of table ``t``;
2. repeat at most ``MAX_POPS`` times: stop when ``A * k`` candidates were examined
   or the queue is empty; pop the entry with the smallest
   (distance, id); stop when k neighbours are held and its distance exceeds the k-th
   (``kth`` below); a bucket node: stop if ``MAX_LEAVES`` buckets were visited, else
   take its bucket's blocks; an inner node: push each child whose box is non-empty and
   not farther than ``kth``;
3. keep the k nearest candidates as :mod:`blockhash.index.lookups.hash` step 5 does.

Block culling: once k neighbours are held, a block of a reached bucket whose lower bound
of squared distances (:func:`blockhash.index.lookups.hash.block_gap2`, from its 16-bit code box,
:func:`blockhash.index.records.blocks.block_boxes`) is above 0 and, as float32 bits, above ``kth``
is skipped: not taken (it has no candidate number, and the taken-block bound holds), its
photons not examined and not counted toward the ``A * k`` cap, so the cap is spent on
blocks that can still hold a neighbour rather than on a visited bucket's far blocks.
The shader's walk always culls so, whatever its variant's ``cull`` field.

``kth`` is compared as float32 bits (distances are >= 0, so bits order as values):
the k-th (distance, slot) key's distance bits when k are held (exact selection), the
k-th packed key with its slot bits set (``slot_bits`` > 0: the shader's packed and
merge selections), and 0xFFFFFFFF (nothing is pruned) while fewer than k are held.

The queue is a plain array of at most ``QUEUE_CAPACITY`` entries, scanned linearly:
a pop takes the smallest (distance, id) and moves the last entry into its place; a
push onto a full queue keeps the ``QUEUE_CAPACITY`` smallest of the entries and the
new one (the largest is dropped, and counted).  Ids are unique, so the walk is the
same whatever the array order: glsl/bh_walk.glsl runs exactly this walk.
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.index.lookups.hash import take_bucket, unpack_selection
from blockhash.index.records.blocks import block_boxes
from blockhash.index.tables.node_boxes import box_dist2
from blockhash.index.tables.thresholds import LEAF

#: Entries the walk's queue holds (glsl/bh_walk.glsl BH_QUEUE; a multiple of 32, the
#: shader's unrolled scan chunk).  At N = 10^6, k = 50 the queue held at most 172
#: entries (99th percentile 97) on the far queries of the venus photon map.
QUEUE_CAPACITY = 192
#: Nodes one walk pops at most, and buckets it visits at most: bounds on the shader's
#: loops (llvmpipe's loop limit, blockhash/gl/limits.py).  At N = 10^6, k = 50, A = 8 and
#: 64 a venus query popped at most 914 nodes (99th percentile 525; 512 pops would raise
#: the false negatives from 2.80 to 3.30%) and visited at most 45 buckets (ring: 42).
MAX_POPS = 1024
MAX_LEAVES = 64
_NONE = np.uint32(0xFFFFFFFF)
#: Photons per block (blockhash.index.records.blocks.PHOTONS_PER_BLOCK).
_PPB = 10


def walk_taken_bound(B: int, cap: int) -> int:
    """Most blocks one walk takes: at most ``MAX_LEAVES`` buckets of ``B`` references, and
    with compact blocks (all full but the last; the cap checked before each block, so at
    most ``cap + 9`` photons are examined) at most ``ceil(cap / 10) + 1``."""
    return int(min(MAX_LEAVES * B, (cap + _PPB - 1) // _PPB + 1))


@numba.njit(cache=True, nogil=True, inline="always")
def _pop(qd, qn, size):
    """Index of the smallest (distance bits, id) among the first ``size`` entries."""
    j = 0
    for u in range(1, size):
        if qd[u] < qd[j] or (qd[u] == qd[j] and qn[u] < qn[j]):
            j = u
    return j


@numba.njit(cache=True, nogil=True, inline="always")
def _push(qd, qn, size, d, node):
    """Push (d, node); on a full queue the largest of its entries and the new one is
    dropped.  Returns (new size, 1 if an entry was dropped)."""
    if size < qd.shape[0]:
        qd[size] = d
        qn[size] = node
        return size + 1, 0
    j = 0
    for u in range(1, size):
        if qd[u] > qd[j] or (qd[u] == qd[j] and qn[u] > qn[j]):
            j = u
    if d < qd[j] or (d == qd[j] and node < qn[j]):
        qd[j] = d
        qn[j] = node
    return size, 1


def walk_cull(index):
    """The culling arguments of :func:`bf_query` for ``index``: (its blocks' box words,
    :func:`blockhash.index.records.blocks.block_boxes`; the quantizer's lo and step as float32),
    the box words computed once and kept on the index."""
    cb = getattr(index, "_block_box_words", None)
    if cb is None or len(cb) != len(index.block_words):
        cb = block_boxes(index.block_words)
        index._block_box_words = cb
    q = index.quantizer
    return cb, np.asarray(q.lo, dtype=np.float32), np.asarray(q.step, dtype=np.float32)


def bf_query(qpos, thresholds, boxes, refs, starts, positions, k, cap, slot_bits=0,
             queue=QUEUE_CAPACITY, max_pops=MAX_POPS, max_leaves=MAX_LEAVES, trees=1, *, cull):
    """Approximate k nearest photons of each query by the nearest-box-first walk.

    ``cull`` is :func:`walk_cull` of the index (the walk's block culling, module
    docstring), or None: no block culled (not the shader's walk; for studies).

    Parameters
    ----------
    qpos : (m, 3) float32       query positions
    thresholds : (L, T) uint32  adaptive rows
    boxes : (L, T // 2, 6) float32  node boxes (:func:`.node_boxes.node_boxes`)
    refs, starts, positions, k, cap, slot_bits : as :func:`blockhash.index.lookups.hash.bh_query`
    queue : int                 queue capacity
    max_pops : int              nodes popped at most
    max_leaves : int            buckets visited at most
    trees : int                 tables walked, the first ``trees`` (1 .. L; clamped)

    Returns
    -------
    d2, slots, examined, blocks : as :func:`blockhash.index.lookups.hash.bh_query`
    pops : (m,) int32           nodes popped
    drops : (m,) int32          entries dropped from a full queue
    longest : (m,) int32        most entries the queue held
    """
    if cull is None:
        cb, lo, step = np.empty((0, 3), np.uint32), np.zeros(3, np.float32), np.ones(3, np.float32)
    else:
        cb, lo, step = cull
        cb = np.ascontiguousarray(cb, dtype=np.uint32).reshape(-1, 3)
        lo = np.ascontiguousarray(lo, dtype=np.float32).reshape(3)
        step = np.ascontiguousarray(step, dtype=np.float32).reshape(3)
    return _bf_query(qpos, thresholds, boxes, refs, starts, positions, k, cap, slot_bits, queue,
                     max_pops, max_leaves, trees, cb, lo, step)


@numba.njit(cache=True, nogil=True, parallel=True)
def _bf_query(qpos, thresholds, boxes, refs, starts, positions, k, cap, slot_bits, queue,
              max_pops, max_leaves, trees, cbox, clo, cstep):
    """:func:`bf_query` compiled."""
    m = qpos.shape[0]
    L = refs.shape[0]
    B = refs.shape[2]
    nn = boxes.shape[1]
    d2 = np.full((m, k), np.inf, dtype=np.float32)
    slots = np.full((m, k), -1, dtype=np.int64)
    examined = np.zeros(m, dtype=np.int32)
    fetched = np.zeros(m, dtype=np.int32)
    pops = np.zeros(m, dtype=np.int32)
    drops = np.zeros(m, dtype=np.int32)
    longest = np.zeros(m, dtype=np.int32)
    mask = np.uint32((1 << slot_bits) - 1) if slot_bits > 0 else np.uint32(0)
    for qi in numba.prange(m):
        packed = np.full(k, _NONE, dtype=np.uint32)
        bits = np.empty(1, dtype=np.float32)
        bits_u = bits.view(np.uint32)
        taken = np.empty(max_leaves * B, dtype=np.int32)  # never full: no block cap
        qd = np.empty(queue, dtype=np.uint32)
        qn = np.empty(queue, dtype=np.int64)
        bd = d2[qi]
        bs = slots[qi]
        qx = qpos[qi, 0]
        qy = qpos[qi, 1]
        qz = qpos[qi, 2]
        size = 0
        ntaken = 0
        count = 0
        leaves = 0
        for t in range(min(max(trees, 1), L)):
            box = boxes[t, 0]
            if box[0] <= box[3]:
                bits[0] = box_dist2(box, qx, qy, qz)
                size, dropped = _push(qd, qn, size, bits_u[0], t * nn)
                drops[qi] += dropped
        longest[qi] = size
        for _ in range(max_pops):
            if count >= cap or size == 0:
                break
            j = _pop(qd, qn, size)
            d = qd[j]
            node = qn[j]
            size -= 1
            qd[j] = qd[size]
            qn[j] = qn[size]
            pops[qi] += 1
            if slot_bits > 0:
                kth = packed[k - 1] | mask
            elif bs[k - 1] >= 0:
                bits[0] = bd[k - 1]
                kth = bits_u[0]
            else:
                kth = _NONE
            if d > kth:
                break
            t = node // nn
            i = node % nn
            meta = thresholds[t, 2 * i + 1]
            if meta & LEAF:
                if leaves >= max_leaves:
                    break
                leaves += 1
                ntaken, count = take_bucket(t, np.int64(meta >> 3), refs, starts, positions, qx, qy, qz,
                                      taken, ntaken, count, cap, k, bd, bs, packed, mask,
                                      slot_bits, bits, bits_u, cbox, clo, cstep)
                continue
            c = np.int64(meta >> 3)
            for ch in range(2):
                box = boxes[t, c + ch]
                if box[0] <= box[3]:
                    bits[0] = box_dist2(box, qx, qy, qz)
                    if bits_u[0] <= kth:
                        size, dropped = _push(qd, qn, size, bits_u[0], t * nn + c + ch)
                        drops[qi] += dropped
            longest[qi] = max(longest[qi], size)
        if slot_bits > 0:
            unpack_selection(packed, mask, taken, starts, positions, qx, qy, qz, k, bd, bs)
        examined[qi] = count
        fetched[qi] = ntaken
    return d2, slots, examined, fetched, pops, drops, longest
