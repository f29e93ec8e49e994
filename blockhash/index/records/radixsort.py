"""Stable argsort of uint64 keys by least-significant-digit radix sort.

The bulk block build (:func:`~blockhash.index.records.btree.bulk_blocks`) orders photons by their
Hilbert keys with ties in input order: exactly ``np.argsort(keys, kind="stable")``, which
for 10^6 keys takes about 0.1 s (a merge sort).  Sorting ``DIGIT_BITS`` bits per pass,
lowest first, each pass a stable counting scatter, gives the same order in about a third
of that: 6 passes for 63-bit keys, fewer when the keys' high bits are all zero, and a pass
is skipped where every key has the same digit.
"""

from __future__ import annotations

import numba
import numpy as np

#: Bits per pass: 2048 counters stay in the L1 cache and the scatter writes 2048 streams.
DIGIT_BITS = 11


def stable_argsort(keys) -> np.ndarray:
    """(n,) int64 indices that sort ``keys`` ((n,) uint64), equal keys in input order."""
    return _radix_argsort(np.ascontiguousarray(keys, dtype=np.uint64), DIGIT_BITS)


@numba.njit(cache=True, nogil=True)
def _radix_argsort(keys, digit_bits):
    n = keys.shape[0]
    radix = 1 << digit_bits
    mask = np.uint64(radix - 1)
    bits = np.uint64(0)
    for i in range(n):
        bits |= keys[i]
    passes = 0
    while passes * digit_bits < 64 and (bits >> np.uint64(passes * digit_bits)) != 0:
        passes += 1
    counts = np.zeros((max(passes, 1), radix), dtype=np.int64)
    for i in range(n):
        k = keys[i]
        for d in range(passes):
            counts[d, (k >> np.uint64(d * digit_bits)) & mask] += 1
    order = np.arange(n)
    order_out = np.empty(n, dtype=np.int64)
    k_in = keys.copy()
    k_out = np.empty(n, dtype=np.uint64)
    start = np.empty(radix, dtype=np.int64)
    for d in range(passes):
        shift = np.uint64(d * digit_bits)
        if counts[d, (k_in[0] >> shift) & mask] == n:
            continue  # one digit for all keys: the pass would keep the order
        total = 0
        for b in range(radix):
            start[b] = total
            total += counts[d, b]
        for i in range(n):
            k = k_in[i]
            b = (k >> shift) & mask
            p = start[b]
            start[b] = p + 1
            k_out[p] = k
            order_out[p] = order[i]
        k_in, k_out = k_out, k_in
        order, order_out = order_out, order
    return order
