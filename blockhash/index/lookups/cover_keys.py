"""The cover gather's window keys (:mod:`.cover`): 63 bits, the octave's 6 above two coarse
cells and the fine cell, shared by the build's kernels (:mod:`.cover_build`), the CPU reference
and glsl/bh_cover.glsl's ``bh_cover_key``."""

from __future__ import annotations

import numba
import numpy as np

#: Bits of a window's key below the octave's 6: two coarse cells of 18, the fine cell's 21.
COARSE_BITS = 18
FINE_BITS = 21


@numba.njit(cache=True, nogil=True, inline="always")
def window_key64(level, cx, cy, f):
    """The 63-bit key of window (cx, cy, f) of ``level`` (coarse cells below 2^18, the fine cell
    below 2^21), ``f`` lowest, so a column's fine cells are consecutive keys."""
    return ((np.uint64(level) << np.uint64(2 * COARSE_BITS + FINE_BITS))
            | (np.uint64(cx) << np.uint64(COARSE_BITS + FINE_BITS))
            | (np.uint64(cy) << np.uint64(FINE_BITS)) | np.uint64(f))


@numba.njit(cache=True, nogil=True, inline="always")
def window_key(level, cx, cy, f):
    """The key's two words (hi, lo), as the cuckoo table stores them (glsl/bh_cover.glsl
    bh_cover_key computes the same words)."""
    key = window_key64(level, cx, cy, f)
    return np.uint32(key >> np.uint64(32)), np.uint32(key & np.uint64(0xFFFFFFFF))
