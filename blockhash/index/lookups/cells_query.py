"""CPU reference of the cell lookup, the oracle for ``glsl/bh_cells.glsl``.

Three rounds of fetches, each independent within itself, bounded whatever N or the photon
distribution:

1. **own cells.**  The query's code (:meth:`Quantizer.quantize_query`, 21 bits per axis)
   names its cell at every level; the counts of those cells, from ``first`` (the coarsest
   level whose cells all hold at most ``cap = A k`` photons, :meth:`CellTable.first_level`)
   up to the top, are looked up at once.  They grow with the level; ``top`` is the
   coarsest level whose own cell holds at most ``cap``.
2. **groups.**  At the levels ``top - 2``, ``top - 1`` and ``top`` (:data:`TRIED`), the query's group is
   the 3 x 3 x 3 cells around its own: it holds every photon within one cell side of the
   query.  The 81 cells are looked up at once.  The group chosen is the coarsest one
   with ``k <= count <= cap``; failing that, the finest holding at least ``k``; failing
   that, the coarsest.
3. **photons.**  The chosen group's cells, own cell first, then the 6 sharing a face, the
   12 sharing an edge and the 8 sharing a corner (:data:`SHELL_ORDER`), are read as runs
   of photon slots until ``cap`` candidates are taken (a cell that would pass the cap is
   cut to fit).

The k nearest candidates by float32 squared distance ``((dx*dx + dy*dy) + dz*dz)``,
``d = p - q``, ties by slot, are the result.  The shader finds the same k by counting
(bh_cells.glsl); the order it reports them in is restored by the caller.
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.index.lookups.cells import CODE_SHIFT, LEVEL_MIN, LEVEL_TOP, cell_lookup

#: Rounds of dependent fetches of one cell query: own cells, group cells, photons.
CELL_ROUNDS = 3
#: Levels tried in round 2, relative to ``top``.
TRIED = (-2, -1, 0)
#: Cells of a group: the 3 x 3 x 3 around the query's own.
GROUP_CELLS = 27
#: The order a group's cells are read in: by shell (|dx| + |dy| + |dz|), then by index
#: j = (dx + 1) + 3 (dy + 1) + 9 (dz + 1); bh_cells.glsl visits them the same way.
SHELL_ORDER = np.array(sorted(range(27), key=lambda j: (abs(j % 3 - 1) + abs(j // 3 % 3 - 1) + abs(j // 9 - 1), j)), dtype=np.int64)


@numba.njit(cache=True, nogil=True, inline="always")
def _group(slots, mask, level, c0x, c0y, c0z, gfirst, gcount):
    """The 27 cells of the query's group at ``level``: their runs into gfirst/gcount (count 0 for a cell outside the grid or not stored); returns the total."""
    side = np.int64(1) << np.int64(LEVEL_TOP - level)
    cq = (c0x >> level, c0y >> level, c0z >> level)
    total = np.int64(0)
    for j in range(GROUP_CELLS):
        x = cq[0] + (j % 3) - 1
        y = cq[1] + (j // 3) % 3 - 1
        z = cq[2] + j // 9 - 1
        if x < 0 or y < 0 or z < 0 or x >= side or y >= side or z >= side:
            gfirst[j], gcount[j] = 0, 0
            continue
        f, n = cell_lookup(slots, mask, level, x, y, z)
        gfirst[j], gcount[j] = f, n
        total += n
    return total


@numba.njit(cache=True, parallel=True)
def cells_query(qcodes, qpos, slots, buckets, first, positions, k, cap):
    """k nearest of each query's candidates.  Returns (d2 (m, k) float32, slots (m, k)
    int64 (-1: none), examined, blocks) per query."""
    m = qcodes.shape[0]
    mask = np.uint32(buckets - 1)
    d2 = np.full((m, k), np.inf, dtype=np.float32)
    out = np.full((m, k), -1, dtype=np.int64)
    examined = np.zeros(m, dtype=np.int64)
    blocks = np.zeros(m, dtype=np.int64)
    for i in numba.prange(m):
        c0x = np.int64(qcodes[i, 0] >> CODE_SHIFT)
        c0y = np.int64(qcodes[i, 1] >> CODE_SHIFT)
        c0z = np.int64(qcodes[i, 2] >> CODE_SHIFT)
        qx, qy, qz = qpos[i, 0], qpos[i, 1], qpos[i, 2]
        # Round 1: own cells above ``first``.
        top = first
        for level in range(first + 1, LEVEL_TOP + 1):
            _, n = cell_lookup(slots, mask, level, c0x >> level, c0y >> level, c0z >> level)
            if n <= cap:
                top = level
        # Round 2: the groups at top - 2, top - 1, top.
        gf = np.zeros((3, GROUP_CELLS), dtype=np.int64)
        gc = np.zeros((3, GROUP_CELLS), dtype=np.int64)
        tot = np.zeros(3, dtype=np.int64)
        lev = np.zeros(3, dtype=np.int64)
        for t in range(3):
            level = min(max(top + TRIED[t], LEVEL_MIN), LEVEL_TOP)
            lev[t] = level
            tot[t] = _group(slots, mask, level, c0x, c0y, c0z, gf[t], gc[t])
        pick = -1
        for t in range(3):
            if tot[t] >= k and tot[t] <= cap:
                pick = t
        if pick < 0:
            for t in range(2, -1, -1):
                if tot[t] >= k:
                    pick = t
        if pick < 0:
            pick = 2
        level = lev[pick]
        # Round 3: the group's cells in shell order, cut at the cap.
        dist = np.empty(cap, dtype=np.float32)
        cand = np.empty(cap, dtype=np.uint64)
        taken = 0
        nblocks = 0
        for oj in range(GROUP_CELLS):
            j = SHELL_ORDER[oj]
            n = min(gc[pick, j], cap - taken)
            if n <= 0:
                continue
            f = gf[pick, j]
            nblocks += (f + n - 1) // 10 - f // 10 + 1
            for s in range(f, f + n):
                dx = positions[s, 0] - qx
                dy = positions[s, 1] - qy
                dz = positions[s, 2] - qz
                dist[taken] = (dx * dx + dy * dy) + dz * dz
                cand[taken] = np.uint64(s)
                taken += 1
        examined[i] = taken
        blocks[i] = nblocks
        bits = dist[:taken].view(np.uint32)
        keys = (bits.astype(np.uint64) << np.uint64(32)) | cand[:taken]
        best = np.sort(keys)
        for j in range(min(k, taken)):
            key = best[j]
            hi = np.empty(1, dtype=np.uint32)
            hi[0] = np.uint32(key >> np.uint64(32))
            d2[i, j] = hi.view(np.float32)[0]
            out[i, j] = np.int64(key & np.uint64(0xFFFFFFFF))
    return d2, out, examined, blocks


__all__ = ["cells_query", "CELL_ROUNDS", "SHELL_ORDER"]
