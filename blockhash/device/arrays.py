"""Host arrays handed to the device kernels: flattened copies in the kernels' types, aligned
to :data:`ALIGN` bytes.

Dr.Jit's LLVM backend reads a host array in place and states the pointer's alignment in the
kernel it compiles, so the same kernel over an array that numpy's allocator placed at another
alignment is compiled again (the camera's film kernel, handed fresh film points each frame,
compiled up to four ways before its inputs went through here: ``tests/device/test_rays.py``).
Every table and ray array the device modules make goes through :func:`floats` or
:func:`uints`.
"""

from __future__ import annotations

import numpy as np

#: Bytes every host array handed to the device is aligned to (a cache line, and the widest
#: vector Dr.Jit's LLVM backend loads).
ALIGN = 64


def aligned(a, dtype) -> np.ndarray:
    """``a`` flattened into a new ``dtype`` array whose data starts on an :data:`ALIGN`-byte
    boundary."""
    flat = np.asarray(a).reshape(-1)
    size = np.dtype(dtype).itemsize
    buf = np.empty(flat.size + ALIGN // size, dtype=dtype)
    first = (-buf.ctypes.data % ALIGN) // size
    out = buf[first:first + flat.size]
    out[...] = flat
    return out


def floats(mi, a):
    """``a`` as Mitsuba's Float (float32), from an aligned copy."""
    return mi.Float(aligned(a, np.float32))


def uints(mi, a):
    """``a`` as Mitsuba's UInt32, from an aligned copy."""
    return mi.UInt32(aligned(a, np.uint32))
