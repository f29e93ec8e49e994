"""The photon records' power words of a traced map's float32 powers, in float32 (the fast path
of :meth:`blockhash.index.records.codec.PhotonRecords.encode`).

Each channel is ``power / scale`` as an IEEE half float (:func:`.codec.encode_powers`), words 4
and 5 ``c1 | c2 << 16`` and ``c3 | c4 << 16`` (c4 = 0 for RGB).  The scale is a power of two,
so ``power / scale`` is exact in float32 as in float64 (a quotient below float32's normal range
is far below half's and rounds to a signed zero either way), and numpy rounds the same value to
the same half float: the records of the float64 statement, bit for bit, without its float64
working arrays (``tests/index/records/test_power_words.py``).
"""

from __future__ import annotations

import numpy as np


def power_words(powers: np.ndarray, scale: float, out4: np.ndarray, out5: np.ndarray) -> int:
    """Writes words 4 and 5 of the records into ``out4`` and ``out5`` ((n,) uint32) from
    ``powers`` ((n, 3) or (n, 4) float32 watts) over ``scale`` (a power of two).  Returns the
    first row with a channel that is not finite, or whose half float overflows (-1: none)."""
    with np.errstate(over="ignore", invalid="ignore"):
        half = (powers / np.float32(scale)).astype(np.float16)
    bad = ~np.isfinite(half).all(axis=1)
    if bad.any():
        return int(np.argmax(bad))
    bits = half.view(np.uint16).astype(np.uint32)
    out4[:] = bits[:, 0] | (bits[:, 1] << 16)
    out5[:] = bits[:, 2] | (bits[:, 3] << 16) if bits.shape[1] == 4 else bits[:, 2]
    return -1
