"""The compiled steps of :meth:`blockhash.index.lookups.cover.CoverGather.build`: each record's
octave and window key, and the gather's records; and the window table's entries.

Each is one compiled pass over the records (numba, on one core: a parallel loop's
compilation costs a cold start more than it saves a pass), where the numpy build they replace
made a dozen, each with its own working array: the octave of a record is the first whose side
holds ``2 (h (1 + 2^-20) + margin)`` codes (a binary search of the sides, as
``np.searchsorted(sides, need, side="left")``).  The results are the numpy build's, bit for
bit (``tests/index/lookups/test_cover_build.py`` holds them to a plain numpy statement of
each step).
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.index.lookups.cover_keys import COARSE_BITS, FINE_BITS, window_key64


@numba.njit(cache=True, nogil=True)
def record_keys(codes, kept, r2, sides, fines, order, step, margin):
    """(octave (m,) int64, window key (m,) uint64) of the records ``kept`` ((m,) rows of
    ``codes``, (n, >= 3) uint32 position codes) with squared radii ``r2[kept]`` (float64, in
    record order); ``order`` the code axes coarse, coarse, fine (:func:`.cover.axis_order`)."""
    m = kept.shape[0]
    octave = np.empty(m, dtype=np.int64)
    key = np.empty(m, dtype=np.uint64)
    top = sides.shape[0] - 1
    for i in range(m):
        row = kept[i]
        need = 2.0 * ((np.sqrt(r2[row]) / step) * (1.0 + 2.0**-20) + margin)
        lo, hi = 0, top + 1  # the first side >= need, else past the end
        while lo < hi:
            mid = (lo + hi) // 2
            if sides[mid] < need:
                lo = mid + 1
            else:
                hi = mid
        o = min(lo, top)
        side = sides[o]
        octave[i] = o
        key[i] = window_key64(o, np.int64(codes[row, order[0]]) // side,
                              np.int64(codes[row, order[1]]) // side,
                              np.int64(codes[row, order[2]]) // fines[o])
    return octave, key


@numba.njit(cache=True, nogil=True)
def gather_records(codes, rows, r2, lo, step, toward, normal, out, out_float):
    """Fills ``out`` ((m, 8) uint32; ``out_float`` its float32 view) with the gather's records
    of index records ``rows``: the decoded float32 position (``lo + float32(code) * step``, as
    the quantizer decodes it) and squared radius ``r2[row]`` as float32 bits, the octahedral
    direction and normal from the polar codes of word 3 (tables ``toward``, ``normal``), and
    the power words 4-5."""
    m = rows.shape[0]
    for i in range(m):
        row = rows[i]
        for a in range(3):
            out_float[i, a] = lo[a] + np.float32(codes[row, a]) * step[a]
        out_float[i, 3] = np.float32(r2[row])
        word = codes[row, 3]
        out[i, 4] = toward[word & np.uint32(0xFFFF)]
        out[i, 5] = normal[word >> np.uint32(16)]
        out[i, 6] = codes[row, 4]
        out[i, 7] = codes[row, 5]


def window_entries(key, fine, octaves):
    """The window table's entries ((w, 4) uint32: key hi, key lo, first record, count) from
    the records' sorted keys, and the most records a window of each of ``octaves`` holds.

    A window starts at any fine cell that has a photon within ``fine`` cells after it in its
    column (the fine cell, the key's low bits, never goes below 0).  In numpy: a compiled scan
    saved less than its compilation cost a cold start."""
    change = np.ones(len(key), dtype=bool)
    change[1:] = key[1:] != key[:-1]
    first = np.flatnonzero(change)
    cells = key[first]
    ends = np.append(first[1:], len(key))
    f = (cells & np.uint64((1 << FINE_BITS) - 1)).astype(np.int64)
    back = np.arange(fine + 1, dtype=np.uint64)
    starts = np.unique((cells[:, None] - back[None, :])[f[:, None] >= back[None, :].astype(np.int64)])
    lo = np.searchsorted(cells, starts, side="left")
    hi = np.searchsorted(cells, starts + np.uint64(fine), side="right")
    begin = first[lo]
    count = ends[hi - 1] - begin
    level = (starts >> np.uint64(2 * COARSE_BITS + FINE_BITS)).astype(np.int64)
    entries = np.stack([(starts >> np.uint64(32)).astype(np.uint32),
                        (starts & np.uint64(0xFFFFFFFF)).astype(np.uint32),
                        begin.astype(np.uint32), count.astype(np.uint32)], axis=1)
    max_count = np.zeros(octaves, dtype=np.int64)
    np.maximum.at(max_count, level, count)
    return entries, max_count
