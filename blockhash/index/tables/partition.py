"""In-place selection and two-way partition of photon rows, for the adaptive tables.

A table's working copy holds one row of ``ROW`` uint32 words per photon: its x, y and z
codes and its index (so that a row moves as one 16-byte unit).  The adaptive build
(:mod:`.adaptive`) reads rows at fixed places of a node's current order to choose each
cut, so the order that every step leaves matters, not only which rows end on which side:

* :func:`select` is Hoare's quickselect with a median-of-three pivot;
* :func:`partition` moves rows below a threshold to the front: a row that is not below
  trades places with the last unchecked row; on rows that a select already split it
  reduces to a shift, done as one.

:func:`kth_smallest` finds the cut's code in the strided sample of a large node, where
only the value counts.

numba's on-disk cache of the functions that call these (in :mod:`.adaptive`) holds them
compiled in and is not refreshed when only this file changes: delete the ``*.nbi`` and
``*.nbc`` files under ``__pycache__`` after editing it.
"""

from __future__ import annotations

import numba
import numpy as np

#: Words per photon row: x, y, z codes and the photon's index.
ROW = 4


@numba.njit(cache=True, nogil=True)
def photon_rows(codes):
    """(n, 3) uint32 codes -> (n, ``ROW``) rows: codes, then the row's index."""
    n = codes.shape[0]
    c = np.empty((n, ROW), dtype=np.uint32)
    for r in range(n):
        c[r, 0] = codes[r, 0]
        c[r, 1] = codes[r, 1]
        c[r, 2] = codes[r, 2]
        c[r, 3] = r
    return c


@numba.njit(cache=True, nogil=True)
def swap(c, i, j):
    for w in range(ROW):
        c[i, w], c[j, w] = c[j, w], c[i, w]


@numba.njit(cache=True, nogil=True)
def select(c, a, lo, hi, p):
    """Reorder rows ``lo:hi`` so that row ``p`` holds the code of rank ``p - lo`` on axis
    ``a``, smaller codes before it and larger after (Hoare's quickselect, median of three)."""
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
                swap(c, i, j)
                i += 1
                j -= 1
        if p <= j:
            hi = j + 1
        elif p >= i:
            lo = i
        else:
            return


@numba.njit(cache=True, nogil=True)
def partition(c, a, lo, hi, t, below):
    """Rows ``lo:hi`` with code below ``t`` on axis ``a`` (``below`` of them) to the front,
    the others after: a row that is not below trades places with the last unchecked row.

    Where the first ``below`` rows are already below (after :func:`select`, unless a run of
    equal codes straddles the cut) the loop would shift each later row one place down and
    put the first of them last: done so directly."""
    i, j = lo, hi - 1
    while i < lo + below and c[i, a] < t:
        i += 1
    if i == lo + below and i < hi:
        f0, f1, f2, f3 = c[i, 0], c[i, 1], c[i, 2], c[i, 3]
        for r in range(i, hi - 1):
            for w in range(ROW):
                c[r, w] = c[r + 1, w]
        c[hi - 1, 0], c[hi - 1, 1], c[hi - 1, 2], c[hi - 1, 3] = f0, f1, f2, f3
        return
    while i <= j:
        if c[i, a] < t:
            i += 1
        else:
            swap(c, i, j)
            j -= 1
@numba.njit(cache=True, nogil=True)
def kth_smallest(values, k):
    """The value of rank ``k`` in uint32 ``values`` (left as they are): a radix selection,
    a byte at a time from the top, keeping only the values that share the bytes chosen."""
    counts = np.zeros(256, dtype=np.int64)
    keep = np.empty(values.shape[0], dtype=np.uint32)
    src = values
    m = values.shape[0]
    for shift in range(24, -8, -8):
        byte = np.uint32(shift)
        counts[:] = 0
        for i in range(m):
            counts[(src[i] >> byte) & np.uint32(255)] += 1
        d = 0
        while k >= counts[d]:
            k -= counts[d]
            d += 1
        if counts[d] == m and shift < 24:
            continue  # every value left has this byte
        j = 0
        for i in range(m):
            x = src[i]
            keep[j] = x
            j += ((x >> byte) & np.uint32(255)) == d
        src = keep
        m = j
        if m == 1:
            break
    return src[0]
