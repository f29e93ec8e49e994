"""The C heap of a rendering process: large blocks returned to the system when freed.

A pass allocates and frees arrays of every photon (tens to hundreds of MiB) on two threads
(the next pass's photons are traced while this pass renders).  glibc's malloc serves a block
below its mmap threshold from a heap arena, and raises that threshold (up to 32 MiB) each
time a larger mmapped block is freed; the arrays of a pass then land in the arenas, where
what is freed stays resident, and a render's resident memory climbs pass after pass
(BENCHMARKS.md, "What a photon costs").  :func:`return_large_blocks` fixes the threshold at
:data:`MMAP_THRESHOLD`: a block above it is mapped on its own and unmapped when freed.

It is called once per process by :class:`blockhash.passes.task.RenderSetup`; it changes
nothing off glibc, nor where ``MALLOC_MMAP_THRESHOLD_`` is set (the caller's choice stands).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os

#: Bytes above which a block is mapped on its own (fixing it stops glibc's dynamic raising).
#: The arrays of a whole map (4 bytes a photon of 10^6 photons and up) are mapped; a batch's
#: and a chunk's working arrays (2^16 to 2^17 photons) stay below and reuse the heap: at
#: 256 KiB their mapping and page faults made a pass 1.17-1.33x as long (BENCHMARKS.md,
#: "What a photon costs").
MMAP_THRESHOLD = 4 * 1024 * 1024
#: mallopt's parameter number for the threshold (malloc.h).
M_MMAP_THRESHOLD = -3

_done = False


def return_large_blocks() -> bool:
    """Fix glibc's mmap threshold at :data:`MMAP_THRESHOLD` for this process, once; whether
    it is fixed (False off glibc, or where the environment sets the threshold)."""
    global _done
    if _done:
        return True
    if "MALLOC_MMAP_THRESHOLD_" in os.environ:
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    _done = bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD))
    return _done
