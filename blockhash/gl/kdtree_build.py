"""The CPU side of the exact kd-tree baseline: a balanced, left-complete kd-tree.

Built with numba on the CPU and uploaded by :mod:`.kdtree` for the fragment-shader
search.  Node ``i`` has children ``2i + 1`` and ``2i + 2``; each node stores its
photon's position and original index with the split axis in the top two bits.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numba
import numpy as np

from blockhash.errors import CapacityError
from blockhash.index.records.select import select_by
from blockhash.validate import as_points

#: The node's original index shares a 32-bit word with the split axis (2 bits).
AXIS_SHIFT = 30
MAX_PHOTONS = 1 << AXIS_SHIFT


@numba.njit(cache=True, inline="always")
def _left_size(n):
    """Nodes in the left subtree of a complete (left-balanced) tree of ``n`` nodes."""
    if n <= 1:
        return 0
    h = 0
    while (2 << h) <= n:  # h = floor(log2(n)): depth of the last level
        h += 1
    last = n - ((1 << h) - 1)  # nodes on the last level, 1 .. 2^h
    half = 1 << (h - 1)  # of which the left subtree can hold at most half
    return (half - 1) + min(last, half)


@numba.njit(cache=True)
def _build(pos):
    """(photon of each node, split axis of each node) of the left-balanced tree of ``pos``."""
    n = pos.shape[0]
    perm = np.arange(n, dtype=np.int64)
    node_index = np.empty(n, dtype=np.int64)
    node_axis = np.zeros(n, dtype=np.uint8)
    # explicit work stack of (node, lo, hi); depth-first keeps it at most height + 1 deep
    stack = np.empty((128, 3), dtype=np.int64)
    stack[0, 0], stack[0, 1], stack[0, 2] = 0, 0, n
    sp = 1
    coord = np.empty(n, dtype=np.float32)
    while sp > 0:
        sp -= 1
        node, lo, hi = stack[sp, 0], stack[sp, 1], stack[sp, 2]
        cnt = hi - lo
        m = lo + _left_size(cnt)
        axis = 0
        if cnt > 1:
            lox, loy, loz = np.inf, np.inf, np.inf
            hix, hiy, hiz = -np.inf, -np.inf, -np.inf
            for t in range(lo, hi):
                p = perm[t]
                x, y, z = pos[p, 0], pos[p, 1], pos[p, 2]
                lox, hix = min(lox, x), max(hix, x)
                loy, hiy = min(loy, y), max(hiy, y)
                loz, hiz = min(loz, z), max(hiz, z)
            ex, ey, ez = hix - lox, hiy - loy, hiz - loz
            if ey > ex:
                axis = 1
                if ez > ey:
                    axis = 2
            elif ez > ex:
                axis = 2
            for t in range(lo, hi):
                coord[perm[t]] = pos[perm[t], axis]
            select_by(perm, lo, hi, m, coord)
        node_index[node] = perm[m]
        node_axis[node] = axis
        if m + 1 < hi:
            stack[sp, 0], stack[sp, 1], stack[sp, 2] = 2 * node + 2, m + 1, hi
            sp += 1
        if lo < m:
            stack[sp, 0], stack[sp, 1], stack[sp, 2] = 2 * node + 1, lo, m
            sp += 1
    return node_index, node_axis


@dataclass(frozen=True, repr=False)
class KdTree:
    """A left-balanced kd-tree of N photons in N heap-ordered nodes (paper section 2).

    Attributes
    ----------
    positions : (n, 3) float32      node i's photon position (= its split value on ``axis[i]``)
    index : (n,) int64              node i's photon, as an index into the build positions
    axis : (n,) uint8               split axis of node i's subtree (0 for leaves)
    height : int                    levels of the tree, floor(log2 n) + 1 (the stack depth)
    lo, hi : (3,) float32           bounding box of the photons (the root's cell)
    build_seconds : float
    """

    positions: np.ndarray
    index: np.ndarray
    axis: np.ndarray
    height: int
    lo: np.ndarray
    hi: np.ndarray
    build_seconds: float = field(default=0.0, compare=False)

    def __len__(self) -> int:
        return len(self.index)

    def texels(self) -> np.ndarray:
        """(n, 4) uint32 node texels: x, y, z float bits and index | axis << 30."""
        out = np.empty((len(self), 4), dtype=np.uint32)
        out[:, :3] = self.positions.view(np.uint32)
        out[:, 3] = self.index.astype(np.uint32) | (self.axis.astype(np.uint32) << AXIS_SHIFT)
        return out

    def __repr__(self) -> str:
        return (f"KdTree(n={len(self):,}, height={self.height}, "
                f"build_seconds={self.build_seconds:.3f})")


def build_kdtree(positions) -> KdTree:
    """Build the balanced kd-tree of ``positions`` on the CPU.

    Parameters
    ----------
    positions : (n, 3) float
        Photon positions, finite, n >= 1; converted to float32 (the search runs in
        float32: pass ``BlockHashIndex.positions`` to search the photons that the Block
        Hashing index searches).

    Median split along the axis of largest extent of each subtree's photons; the
    left-balanced layout makes the tree complete, so node ``i`` has children
    ``2i + 1`` and ``2i + 2`` where those are below n.  Compiled with numba.
    """
    pos = as_points(positions, "positions", dtype=np.float32, allow_empty=False)
    n = len(pos)
    if n >= MAX_PHOTONS:
        raise CapacityError(f"positions has {n:,} photons; the kd-tree stores indices in "
                            f"{AXIS_SHIFT} bits, so at most {MAX_PHOTONS - 1:,}; use fewer photons")
    t0 = time.perf_counter()
    index, axis = _build(pos)
    seconds = time.perf_counter() - t0
    return KdTree(positions=pos[index], index=index, axis=axis, height=int(n).bit_length(),
                  lo=pos.min(axis=0), hi=pos.max(axis=0), build_seconds=seconds)


