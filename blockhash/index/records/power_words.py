"""The photon records' power words in one compiled pass (the fast path of
:meth:`blockhash.index.records.codec.PhotonRecords.encode`).

Each channel is ``power / scale`` as an IEEE half float (:func:`.codec.encode_powers`), words 4
and 5 ``c1 | c2 << 16`` and ``c3 | c4 << 16`` (c4 = 0 for RGB).  The scale is a power of two,
so ``power / scale`` is exact in float64, and its half is rounded to nearest, ties to even,
from the float64's bits: numpy's conversion of the same value (``np.float16``), bit for bit
(``tests/index/records/test_power_words.py``).
"""

from __future__ import annotations

import numba
import numpy as np

#: Photons per parallel task.
CHUNK = 16384


@numba.njit(cache=True, nogil=True, inline="always")
def half_bits(f):
    """The IEEE half float nearest the float64 of bits ``f`` (uint64), ties to even, as
    uint32: infinity past half's range, NaN kept NaN."""
    sign = np.uint32((f >> np.uint64(48)) & np.uint64(0x8000))
    e = np.int64((f >> np.uint64(52)) & np.uint64(0x7FF))
    m = f & np.uint64(0xFFFFFFFFFFFFF)
    if e >= 1039:  # 2^16 and beyond: infinity, or NaN
        return sign | np.uint32(0x7E00 if e == 2047 and m != 0 else 0x7C00)
    if e < 998:  # below 2^-25: a signed zero
        return sign
    if e <= 1008:  # half's subnormals, in units of 2^-24
        full = m | (np.uint64(1) << np.uint64(52))
        shift = np.uint64(1051 - e)  # 43 to 53
        h = full >> shift
        rest = full & ((np.uint64(1) << shift) - np.uint64(1))
        half_way = np.uint64(1) << (shift - np.uint64(1))
    else:
        h = (np.uint64(e - 1008) << np.uint64(10)) | (m >> np.uint64(42))
        rest = m & np.uint64((1 << 42) - 1)
        half_way = np.uint64(1 << 41)
    if rest > half_way or (rest == half_way and (h & np.uint64(1))):
        h += np.uint64(1)  # a carry into the exponent is right, up to infinity
    return sign | np.uint32(h)


@numba.njit(cache=True, nogil=True, parallel=True)
def power_words(powers, scale, out4, out5):
    """Writes words 4 and 5 of the records into ``out4`` and ``out5`` ((n,) uint32) from
    ``powers`` ((n, 3) or (n, 4) float32 or float64 watts) over ``scale`` (a power of two).
    Returns the first row with a channel that is not finite, or whose half float overflows
    (-1: none)."""
    n, channels = powers.shape
    tasks = (n + CHUNK - 1) // CHUNK
    bad = np.full(tasks, -1, dtype=np.int64)
    for t in numba.prange(tasks):
        q = np.zeros(4)  # c4 stays 0 for RGB
        bits = q.view(np.uint64)
        h = np.zeros(4, dtype=np.uint32)
        for i in range(t * CHUNK, min(n, (t + 1) * CHUNK)):
            for c in range(channels):
                q[c] = np.float64(powers[i, c]) / scale
            for c in range(4):
                h[c] = half_bits(bits[c])
                if (h[c] & np.uint32(0x7C00)) == np.uint32(0x7C00) and bad[t] < 0:
                    bad[t] = i
            out4[i] = h[0] | (h[1] << np.uint32(16))
            out5[i] = h[2] | (h[3] << np.uint32(16))
    for t in range(tasks):
        if bad[t] >= 0:
            return bad[t]
    return -1
