"""The photon records' power words (Figure 4's c1 | c2 << 16 and c3 | c4 << 16), and the half
floats of a traced map's float32 powers computed in float32 (the fast path of
:meth:`blockhash.index.records.codec.PhotonRecords.encode`).

Each channel is ``power / scale`` as an IEEE half float (:func:`.codec.encode_powers`).  The
scale is a power of two, so ``power / scale`` is exact in float32 as in float64 (a quotient
below float32's normal range is far below half's and rounds to a signed zero either way), and
numpy rounds the same value to the same half float: :func:`float32_power_bits` gives the
float64 statement's bits, bit for bit, without its float64 working arrays
(``tests/index/records/test_power_words.py``).
"""

from __future__ import annotations

import numpy as np

from blockhash.errors import InputError


def pair_words(bits: np.ndarray) -> np.ndarray:
    """(n, 2) uint32 words 4 and 5 of the records, ``c1 | c2 << 16`` and ``c3 | c4 << 16``,
    from (n, 4) (or (1, 4), the same for every photon) half-float bits."""
    b = np.asarray(bits).astype(np.uint32)
    return np.stack([b[:, 0] | (b[:, 1] << 16), b[:, 2] | (b[:, 3] << 16)], axis=1)


def float32_power_bits(powers: np.ndarray, scale: float) -> np.ndarray:
    """(n, 4) uint16 half-float bits of ``powers`` ((n, 3) or (n, 4) float32 watts) over
    ``scale`` (a power of two), c4 = 0 for RGB; raises InputError naming the first row with a
    channel that is not finite, or whose half float overflows."""
    with np.errstate(over="ignore", invalid="ignore"):
        half = (powers / np.float32(scale)).astype(np.float16)
    bad = ~np.isfinite(half).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f"powers[{i}]: not finite, or past half floats over scale {scale!r}")
    bits = np.zeros((len(half), 4), dtype=np.uint16)
    bits[:, :half.shape[1]] = half.view(np.uint16)
    return bits
