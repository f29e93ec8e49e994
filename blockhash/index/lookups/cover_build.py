"""The compiled steps of :meth:`blockhash.index.lookups.cover.CoverGather.build`: each record's
octave and window key, the gather's records, and the window table's entries.

Each is one pass over the records (the keys and records in parallel), where the numpy build
they replace made a dozen, each with its own working array: the octave of a record is the
first whose side holds ``2 (h (1 + 2^-20) + margin)`` codes (a binary search of the sides, as
``np.searchsorted(sides, need, side="left")``); the windows are emitted in key order by one
scan of the sorted cell keys, where ``np.unique`` sorted the (FINE + 1)-fold starts again.
The results are the numpy build's, bit for bit (``tests/index/test_cover_build.py`` holds
them to a plain numpy statement of each step).
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.index.lookups.cover_keys import COARSE_BITS, FINE_BITS, window_key64

#: Records per parallel task.
CHUNK = 8192


@numba.njit(cache=True, nogil=True, parallel=True)
def record_keys(codes, kept, r2, sides, fines, order, step, margin):
    """(octave (m,) int64, window key (m,) uint64) of the records ``kept`` ((m,) rows of
    ``codes``, (n, >= 3) uint32 position codes) with squared radii ``r2[kept]`` (float64, in
    record order); ``order`` the code axes coarse, coarse, fine (:func:`.cover.axis_order`)."""
    m = kept.shape[0]
    octave = np.empty(m, dtype=np.int64)
    key = np.empty(m, dtype=np.uint64)
    top = sides.shape[0] - 1
    for t in numba.prange((m + CHUNK - 1) // CHUNK):
        for i in range(t * CHUNK, min(m, (t + 1) * CHUNK)):
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


@numba.njit(cache=True, nogil=True, parallel=True)
def gather_records(codes, rows, r2, lo, step, toward, normal, out, out_float):
    """Fills ``out`` ((m, 8) uint32; ``out_float`` its float32 view) with the gather's records of index records ``rows``: the
    decoded float32 position (``lo + float32(code) * step``, as the quantizer decodes it) and
    squared radius ``r2[row]`` as float32 bits, the octahedral direction and normal from the
    polar codes of word 3 (tables ``toward``, ``normal``), and the power words 4-5."""
    m = rows.shape[0]
    for t in numba.prange((m + CHUNK - 1) // CHUNK):
        for i in range(t * CHUNK, min(m, (t + 1) * CHUNK)):
            row = rows[i]
            for a in range(3):
                out_float[i, a] = lo[a] + np.float32(codes[row, a]) * step[a]
            out_float[i, 3] = np.float32(r2[row])
            word = codes[row, 3]
            out[i, 4] = toward[word & np.uint32(0xFFFF)]
            out[i, 5] = normal[word >> np.uint32(16)]
            out[i, 6] = codes[row, 4]
            out[i, 7] = codes[row, 5]


@numba.njit(cache=True, nogil=True)
def window_entries(key, fine, octaves):
    """The window table's entries ((w, 4) uint32: key hi, key lo, first record, count) from
    the records' sorted keys, and the most records a window of each of ``octaves`` holds.

    A window starts at any fine cell with a photon within ``fine`` cells after it in its
    column (the fine cell, the key's low bits, never below 0); the starts are emitted in
    increasing order, each once: a cell's run of starts begins past the last one emitted."""
    n = key.shape[0]
    low = np.uint64((1 << FINE_BITS) - 1)
    shift = np.uint64(2 * COARSE_BITS + FINE_BITS)
    width = np.uint64(fine)
    # the cells (distinct keys) and their first records
    first = np.empty(n + 1, dtype=np.int64)
    cells = 0
    for i in range(n):
        if i == 0 or key[i] != key[i - 1]:
            first[cells] = i
            cells += 1
    first[cells] = n
    entries = np.empty((cells * (fine + 1), 4), dtype=np.uint32)
    max_count = np.zeros(octaves, dtype=np.int64)
    w = 0
    have = False
    last = np.uint64(0)
    hi_cell = 0  # the first cell past the current window's end
    for c in range(cells):
        cell = key[first[c]]
        back = min(cell & low, width)
        s = cell - back
        if have and s <= last:
            s = last + np.uint64(1)
        while s <= cell:
            # the window [s, s + fine]: cells from the first >= s (c or an earlier one) on
            lo_cell = c
            while lo_cell > 0 and key[first[lo_cell - 1]] >= s:
                lo_cell -= 1
            if hi_cell < lo_cell:
                hi_cell = lo_cell
            while hi_cell < cells and key[first[hi_cell]] <= s + width:
                hi_cell += 1
            begin = first[lo_cell]
            count = first[hi_cell] - begin
            entries[w, 0] = np.uint32(s >> np.uint64(32))
            entries[w, 1] = np.uint32(s & np.uint64(0xFFFFFFFF))
            entries[w, 2] = np.uint32(begin)
            entries[w, 3] = np.uint32(count)
            level = np.int64(s >> shift)
            if count > max_count[level]:
                max_count[level] = count
            w += 1
            last = s
            have = True
            s += np.uint64(1)
    return entries[:w].copy(), max_count
