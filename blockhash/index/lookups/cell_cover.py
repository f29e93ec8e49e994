"""The least a lookup that reads whole octree cells of one level must read to be exact
(``tools/cell_cover_bound.py``): the cells of each level that meet a query's ball of radius
``r_k`` (its exact k-th distance), and among the levels where those are at most a given
number of cells, the fewest photons they hold.  No bounded cell lookup
(:mod:`.cells_query`) of that many cells of one level is exact with fewer candidates,
however its cells are chosen."""

from __future__ import annotations

import numpy as np

from blockhash.index.lookups.cells import CODE_SHIFT


def level_counts(codes: np.ndarray, level: int):
    """Sorted packed cell keys of level ``level`` and the photons in each."""
    c = (codes.astype(np.int64) >> (CODE_SHIFT + level))
    keys = (c[:, 0] << 42) | (c[:, 1] << 21) | c[:, 2]
    return np.unique(keys, return_counts=True)


def cover_bound(q_codes: np.ndarray, r_codes: np.ndarray, tables, max_cells: int) -> np.ndarray:
    """(m,) fewest photons in at most ``max_cells`` cells of one level that meet each
    query's ball (centre and radius in 32-bit code units; ``tables`` maps a level to its
    :func:`level_counts`); inf where no level qualifies."""
    best = np.full(len(q_codes), np.inf)
    for level, (keys, counts) in tables.items():
        side = float(1 << (CODE_SHIFT + level))
        lo = np.floor((q_codes - r_codes[:, None]) / side).astype(np.int64)
        hi = np.floor((q_codes + r_codes[:, None]) / side).astype(np.int64)
        span = (hi - lo + 1).prod(axis=1)
        for i in np.flatnonzero(span <= 8 * max_cells):  # the box around the ball first
            axes = [np.arange(lo[i, a], hi[i, a] + 1) for a in range(3)]
            g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
            near = np.clip(q_codes[i], g * side, (g + 1) * side)
            meet = ((near - q_codes[i]) ** 2).sum(axis=1) <= r_codes[i] ** 2
            g = g[meet & (g >= 0).all(axis=1)]
            if len(g) > max_cells:
                continue
            key = (g[:, 0] << 42) | (g[:, 1] << 21) | g[:, 2]
            j = np.searchsorted(keys, key)
            j = np.minimum(j, len(keys) - 1)
            total = np.where(keys[j] == key, counts[j], 0).sum()
            best[i] = min(best[i], total)
    return best
