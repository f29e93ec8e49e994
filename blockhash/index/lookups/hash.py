"""CPU reference of the Block Hashing query (paper section 4.4).

This is the oracle for the GLSL lookup, so it runs exactly the algorithm the
shader runs, in arithmetic the shader reproduces bit for bit:

1. quantize the float32 query to uint32 codes (:meth:`Quantizer.quantize_query`)
   and hash it in every table by integer threshold comparisons
   (:func:`blockhash.index.tables.thresholds.bucket_of`);
2. fetch the L buckets and order them by priority alpha, smallest first
   (ties keep table order);
3. walk the buckets in that order and their valid references in slot order,
   skipping blocks already taken, until at least ``A * k`` candidate photons
   have been taken (the check is made before each block, so a query examines
   at most ``A * k + 9`` photons);
4. multi-probe (``probe``, adaptive layout; query-directed probing after Lv et
   al., VLDB 2007): while the cap allows, take the blocks of the bucket across
   the nearest cut of the query's path in each table (tables in the same
   order), then across the second nearest, up to ``PROBE_CUTS``: the query's
   code on the cut's axis is replaced by the code just across the cut, and the
   tree descended again.  In the adaptive layout, "priority" in step 2 is the
   query's distance to the nearest cut of its path, largest first (the table
   whose bucket holds the query deepest inside);
5. keep the k nearest candidates by float32 squared distance
   ``((dx*dx + dy*dy) + dz*dz)`` with ``d = p - q`` and ``p`` the decoded
   float32 photon position; equal distances are ordered by the photon's
   position in block order (the shader's candidate slot order).

Block hashing is approximate: there is no (1 + eps) guarantee on the
distances; :mod:`blockhash.evaluate.metrics` reports recall and dilation instead.
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.index.tables.thresholds import PROBE_CUTS, adaptive_bucket_of, adaptive_descend, bucket_of


@numba.njit(cache=True, nogil=True, inline="always")
def block_gap2(cbox, blk, lo, step, qx, qy, qz):
    """Lower bound of the float32 squared distance from q to every photon of block ``blk``
    whose box words (:func:`blockhash.index.records.blocks.block_boxes`) are ``cbox[blk]``: the
    float32 operations of glsl/bh_blocks.glsl bh_block_gap2 one by one (``lo``, ``step``:
    the quantizer's float32 values)."""
    one_18 = np.float32(1.0 / 262144.0)
    shrink = np.float32(1.0 - 1.0 / 65536.0)
    q = (qx, qy, qz)
    s = np.float32(0.0)
    for a in range(3):
        w = np.int64(cbox[blk, a])
        blo = lo[a] + np.float32(np.int64((w & 0xFFFF) << 16)) * step[a]
        bhi = lo[a] + np.float32(np.int64((w & 0xFFFF0000) | 0xFFFF)) * step[a]
        margin = (abs(lo[a]) + step[a] * np.float32(4294967296.0)) * one_18
        u = blo - q[a]
        v = q[a] - bhi
        g = (u if u > v else v) - margin
        if not g > np.float32(0.0):
            g = np.float32(0.0)
        if a == 0:
            s = g * g
        elif a == 1:
            s = s + g * g
        else:
            s = (s + g * g) * shrink
    return s


@numba.njit(cache=True, nogil=True, inline="always")
def take_bucket(ti, key, refs, starts, positions, qx, qy, qz, taken, ntaken, count, cap, k, bd, bs,
          packed, mask, slot_bits, bits, bits_u, cbox, clo, cstep):
    """Take the blocks of bucket ``key`` of table ``ti`` not yet taken, while under the cap.

    ``cbox`` non-empty (the walk, :mod:`blockhash.index.lookups.walk`): a block whose
    :func:`block_gap2` bound is above 0 and, as float32 bits, above the k-th key (as the
    walk compares it; nothing while fewer than k are held) is culled: not taken, its
    photons neither examined nor counted toward the cap.  Empty (0, 3): no culling."""
    B = refs.shape[2]
    for r in range(B):
        if count >= cap or ntaken >= taken.shape[0]:
            break
        blk = refs[ti, key, r]
        if blk < 0:
            break
        dup = False
        for j in range(ntaken):
            if taken[j] == blk:
                dup = True
                break
        if dup:
            continue
        if cbox.shape[0] > 0:
            if slot_bits > 0:
                kth = packed[k - 1] | mask
            elif bs[k - 1] >= 0:
                bits[0] = bd[k - 1]
                kth = bits_u[0]
            else:
                kth = np.uint32(0xFFFFFFFF)
            lb = block_gap2(cbox, blk, clo, cstep, qx, qy, qz)
            bits[0] = lb
            if lb > np.float32(0.0) and bits_u[0] > kth:
                continue
        taken[ntaken] = blk
        ntaken += 1
        for s in range(starts[blk], starts[blk + 1]):
            count += 1
            dx = positions[s, 0] - qx
            dy = positions[s, 1] - qy
            dz = positions[s, 2] - qz
            dd = (dx * dx + dy * dy) + dz * dz
            if slot_bits > 0:
                bits[0] = dd
                pkey = (bits_u[0] & ~mask) | np.uint32((ntaken - 1) * 10 + (s - starts[blk]))
                if pkey < packed[k - 1]:
                    j = k - 1
                    while j > 0 and packed[j - 1] > pkey:
                        packed[j] = packed[j - 1]
                        j -= 1
                    packed[j] = pkey
                continue
            if dd < bd[k - 1] or (dd == bd[k - 1] and s < bs[k - 1]) or bs[k - 1] < 0:
                j = k - 1
                while j > 0 and (bs[j - 1] < 0 or bd[j - 1] > dd or (bd[j - 1] == dd and bs[j - 1] > s)):
                    bd[j] = bd[j - 1]
                    bs[j] = bs[j - 1]
                    j -= 1
                bd[j] = dd
                bs[j] = s
    return ntaken, count


@numba.njit(cache=True, nogil=True, inline="always")
def unpack_selection(packed, mask, taken, starts, positions, qx, qy, qz, k, bd, bs):
    """The packed selection's keys (distance bits | candidate number) back to float32
    distances and photon slots, nearest first, into bd and bs."""
    for i in range(k):
        if packed[i] == np.uint32(0xFFFFFFFF):
            break
        cand = np.int64(packed[i] & mask)
        blk = taken[cand // 10]
        s = starts[blk] + cand % 10
        dx = positions[s, 0] - qx
        dy = positions[s, 1] - qy
        dz = positions[s, 2] - qz
        bd[i] = (dx * dx + dy * dy) + dz * dz
        bs[i] = s


@numba.njit(cache=True, nogil=True, parallel=True)
def bh_query(qcodes, qpos, thresholds, P, layout, refs, priority, starts, positions, k, cap,
             by_priority=True, slot_bits=0, probe=False, step=None):
    """Approximate k nearest photons of each query.

    Parameters
    ----------
    qcodes : (m, 3) uint32      hashing codes of the queries
    qpos : (m, 3) float32       query positions
    thresholds : (L, T) uint32  see :mod:`blockhash.index.tables.thresholds`
    P : (3,) int64              buckets per axis
    layout : int                the ThresholdLayout's id (0 marginal, 2 adaptive)
    refs : (L, buckets, B) int32
    priority : (L, buckets) int32
    starts : (nblocks + 1,) int64
    positions : (n, 3) float32  decoded photon positions in block order
    k : int                     neighbours kept
    cap : int                   A * k, candidates examined before stopping
    by_priority : bool          order buckets by priority (False: table order, a shader variant)
    probe : bool                multi-probe after the query's own buckets (step 4, the
                                adaptive layout); needs the quantizer's ``step`` (3,) float32
    slot_bits : int             0: select by exact (distance, slot).  > 0: the shader's
                                packed selection, keys (distance bits with the low
                                ``slot_bits`` bits replaced by the candidate's number,
                                10 * taken-block position + photon), kept in key order

    Returns
    -------
    d2 : (m, k) float32         squared distances, ascending, inf where missing
    slots : (m, k) int64        photon positions in block order, -1 where missing
    examined : (m,) int32       candidate photons examined
    blocks : (m,) int32         blocks fetched
    """
    m = qcodes.shape[0]
    L = refs.shape[0]
    B = refs.shape[2]
    d2 = np.full((m, k), np.inf, dtype=np.float32)
    slots = np.full((m, k), -1, dtype=np.int64)
    examined = np.zeros(m, dtype=np.int32)
    fetched = np.zeros(m, dtype=np.int32)
    mask = np.uint32((1 << slot_bits) - 1) if slot_bits > 0 else np.uint32(0)
    nocull = np.empty((0, 3), dtype=np.uint32)  # hashing culls no block
    nolo = np.zeros(3, dtype=np.float32)
    adaptive = layout == 2
    for qi in numba.prange(m):
        packed = np.full(k, np.uint32(0xFFFFFFFF), dtype=np.uint32)
        bits = np.empty(1, dtype=np.float32)
        bits_u = bits.view(np.uint32)
        keys = np.empty(L, dtype=np.int64)
        order = np.empty(L, dtype=np.int64)
        taken = np.empty(L * B, dtype=np.int32)
        pc = np.empty(3, dtype=np.uint32)
        cut_axis = np.empty((L, PROBE_CUTS), dtype=np.int64)
        cut_code = np.empty((L, PROBE_CUTS), dtype=np.uint32)
        cut_gap = np.empty((L, PROBE_CUTS), dtype=np.float32)
        ntaken = 0
        for t in range(L):
            if adaptive:
                key = adaptive_descend(thresholds[t], qcodes[qi, 0], qcodes[qi, 1], qcodes[qi, 2],
                                       step, cut_axis[t], cut_code[t], cut_gap[t])
                depth = cut_gap[t, 0]
            else:
                key = bucket_of(thresholds[t], P[0], P[1], P[2], layout,
                                qcodes[qi, 0], qcodes[qi, 1], qcodes[qi, 2])
            keys[t] = key
            # Stable insertion by priority: alpha ascending, or (adaptive) the query's
            # distance to its bucket's nearest cut descending.
            j = t
            if adaptive:
                while by_priority and j > 0 and cut_gap[order[j - 1], 0] < depth:
                    order[j] = order[j - 1]
                    j -= 1
            else:
                while by_priority and j > 0 and priority[order[j - 1], keys[order[j - 1]]] > priority[t, key]:
                    order[j] = order[j - 1]
                    j -= 1
            order[j] = t
        bd = d2[qi]
        bs = slots[qi]
        count = 0
        qx = qpos[qi, 0]
        qy = qpos[qi, 1]
        qz = qpos[qi, 2]
        for oi in range(L):
            t = order[oi]
            ntaken, count = take_bucket(t, keys[t], refs, starts, positions, qx, qy, qz, taken, ntaken,
                                  count, cap, k, bd, bs, packed, mask, slot_bits, bits, bits_u,
                                  nocull, nolo, nolo)
        if probe and adaptive:
            for j in range(PROBE_CUTS):
                for oi in range(L):
                    if count >= cap:
                        break
                    t = order[oi]
                    if cut_gap[t, j] == np.inf:
                        continue
                    for c in range(3):
                        pc[c] = qcodes[qi, c]
                    pc[cut_axis[t, j]] = cut_code[t, j]
                    key = adaptive_bucket_of(thresholds[t], pc[0], pc[1], pc[2])
                    if key != keys[t]:
                        ntaken, count = take_bucket(t, key, refs, starts, positions, qx, qy, qz, taken,
                                              ntaken, count, cap, k, bd, bs, packed, mask,
                                              slot_bits, bits, bits_u, nocull, nolo, nolo)
        if slot_bits > 0:
            unpack_selection(packed, mask, taken, starts, positions, qx, qy, qz, k, bd, bs)
        examined[qi] = count
        fetched[qi] = ntaken
    return d2, slots, examined, fetched
