"""The axis probe of the adaptive build: how far a node's photons spread on each axis.

:func:`spreads` reads ``AXIS_PROBE`` rows of a node at a fixed stride (one division for the
stride, not one per row) and sorts each axis' codes, the three axes side by side, by one
sorting network: Batcher's odd-even merge sort on ``PROBE_SLOTS`` codes, the slots past the
probed rows holding the largest code (exchanges that would only move that padding are left
out).  A network has no data-dependent branches, where an insertion sort mispredicts about
once per code; it sorts the uint32 codes themselves, so the ranges in metres come from the
same float64 differences of the same sorted codes as before.

numba's on-disk cache of :mod:`.adaptive`, which calls :func:`spreads`, is not refreshed
when only this file changes: delete the ``*.nbi`` and ``*.nbc`` files under
``__pycache__`` after editing it.
"""

from __future__ import annotations

import numba
import numpy as np

#: Photons of a node looked at to choose its axis (a strided subset).
AXIS_PROBE = 31
#: Rows of the sorting network: a power of two, at least ``AXIS_PROBE``.
PROBE_SLOTS = 32


def odd_even_merge_sort(n: int) -> list[tuple[int, int]]:
    """Batcher's odd-even merge sort network of ``n`` = 2^m wires, as (low, high) pairs."""
    pairs = []
    p = 1
    while p < n:
        k = p
        while k >= 1:
            for j in range(k % p, n - k, 2 * k):
                for i in range(min(k, n - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        pairs.append((i + j, i + j + k))
            k //= 2
        p *= 2
    return pairs


def _network(n: int) -> np.ndarray:
    """(exchanges, 2) row pairs (low, high) of :func:`odd_even_merge_sort` of ``n`` values,
    less those that only move a largest value out of the last slot."""
    largest = {n - 1}  # slots that surely hold the padding
    kept = []
    for lo, hi in odd_even_merge_sort(n):
        if hi not in largest:
            if lo in largest:
                largest = (largest - {lo}) | {hi}
            kept.append((lo, hi))
    return np.array(kept, dtype=np.uint64)  # unsigned: no negative-index wrap in numba


_NETWORK = _network(PROBE_SLOTS)


@numba.njit(cache=True, nogil=True)
def spreads(c, lo, hi, scale, v, out):
    """``out`` (3, 6) per axis: interquartile, 5th-95th percentile and full range in metres,
    the widest gap between consecutive probed codes in metres and that gap's two codes,
    from ``m = min(n, AXIS_PROBE)`` rows ``lo + r * n // m`` (r < m) of the ``n`` rows
    ``c[lo:hi]``.  ``v`` is a (``PROBE_SLOTS``, 4) uint32 scratch."""
    n = hi - lo
    m = min(n, AXIS_PROBE)
    step, rest = divmod(n, m)
    row = lo
    frac = 0  # row = lo + (r * n) // m, frac = (r * n) % m
    for r in range(m):
        v[r, 0] = c[row, 0]
        v[r, 1] = c[row, 1]
        v[r, 2] = c[row, 2]
        row += step
        frac += rest
        if frac >= m:
            frac -= m
            row += 1
    for r in range(m, PROBE_SLOTS):
        v[r, 0] = v[r, 1] = v[r, 2] = np.uint32(0xFFFFFFFF)
    for p in range(_NETWORK.shape[0]):
        i = _NETWORK[p, 0]
        j = _NETWORK[p, 1]
        x0, x1, x2 = v[i, 0], v[i, 1], v[i, 2]
        y0, y1, y2 = v[j, 0], v[j, 1], v[j, 2]
        v[i, 0], v[i, 1], v[i, 2] = min(x0, y0), min(x1, y1), min(x2, y2)
        v[j, 0], v[j, 1], v[j, 2] = max(x0, y0), max(x1, y1), max(x2, y2)
    for a in range(3):
        s = scale[a]
        out[a, 0] = (np.float64(v[(3 * m) // 4, a]) - np.float64(v[m // 4, a])) * s
        out[a, 1] = (np.float64(v[(19 * m) // 20, a]) - np.float64(v[m // 20, a])) * s
        out[a, 2] = (np.float64(v[m - 1, a]) - np.float64(v[0, a])) * s
        out[a, 3] = 0.0
        if 1e-290 < s < 1e290:
            # The widest gap in codes is the widest in metres (the first of equal ones):
            # a positive scale far from under- and overflow keeps their order.
            widest = np.uint32(0)
            at = 0
            for r in range(1, m):
                if v[r, a] - v[r - 1, a] > widest:
                    widest = v[r, a] - v[r - 1, a]
                    at = r
            first, last = max(at, 1), at + 1
        else:
            first, last = 1, m
        for r in range(first, last):
            if (np.float64(v[r, a]) - np.float64(v[r - 1, a])) * s > out[a, 3]:
                out[a, 3] = (np.float64(v[r, a]) - np.float64(v[r - 1, a])) * s
                out[a, 4] = v[r - 1, a]
                out[a, 5] = v[r, a]
    return out
