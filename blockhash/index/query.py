"""CPU reference of the Block Hashing query (paper section 4.4).

This is the oracle for the GLSL lookup, so it runs exactly the algorithm the
shader runs, in arithmetic the shader reproduces bit for bit:

1. quantize the float32 query to uint32 codes (:meth:`Quantizer.quantize_query`)
   and hash it in every table by integer threshold comparisons
   (:func:`blockhash.index.thresholds.bucket_of`);
2. fetch the L buckets and order them by priority alpha, smallest first
   (ties keep table order);
3. walk the buckets in that order and their valid references in slot order,
   skipping blocks already taken, until at least ``A * k`` candidate photons
   have been taken (the check is made before each block, so a query examines
   at most ``A * k + 9`` photons);
4. keep the k nearest candidates by float32 squared distance
   ``((dx*dx + dy*dy) + dz*dz)`` with ``d = p - q`` and ``p`` the decoded
   float32 photon position; equal distances are ordered by the photon's
   position in block order (the shader's candidate slot order).

Block hashing is approximate: there is no (1 + eps) guarantee on the
distances; :mod:`blockhash.index.metrics` reports recall and dilation instead.
"""

from __future__ import annotations

import numba
import numpy as np

from .thresholds import bucket_of


@numba.njit(cache=True, nogil=True, parallel=True)
def bh_query(qcodes, qpos, thresholds, P, nested, refs, priority, starts, positions, k, cap,
             by_priority=True, slot_bits=0):
    """Approximate k nearest photons of each query.

    Parameters
    ----------
    qcodes : (m, 3) uint32      hashing codes of the queries
    qpos : (m, 3) float32       query positions
    thresholds : (L, T) uint32  see :mod:`blockhash.index.thresholds`
    P : (3,) int64              buckets per axis
    nested : bool               threshold layout is NESTED
    refs : (L, buckets, B) int32
    priority : (L, buckets) int32
    starts : (nblocks + 1,) int64
    positions : (n, 3) float32  decoded photon positions in block order
    k : int                     neighbours kept
    cap : int                   A * k, candidates examined before stopping
    by_priority : bool          order buckets by priority (False: table order, a shader variant)
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
    for qi in numba.prange(m):
        packed = np.full(k, np.uint32(0xFFFFFFFF), dtype=np.uint32)
        bits = np.empty(1, dtype=np.float32)
        bits_u = bits.view(np.uint32)
        keys = np.empty(L, dtype=np.int64)
        order = np.empty(L, dtype=np.int64)
        taken = np.empty(L * B, dtype=np.int32)
        ntaken = 0
        for t in range(L):
            key = bucket_of(thresholds[t], P[0], P[1], P[2], nested,
                            qcodes[qi, 0], qcodes[qi, 1], qcodes[qi, 2])
            keys[t] = key
            # Stable insertion by priority.
            j = t
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
            key = keys[t]
            for r in range(B):
                if count >= cap:
                    break
                blk = refs[t, key, r]
                if blk < 0:
                    break
                dup = False
                for j in range(ntaken):
                    if taken[j] == blk:
                        dup = True
                        break
                if dup:
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
        if slot_bits > 0:
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
        examined[qi] = count
        fetched[qi] = ntaken
    return d2, slots, examined, fetched
