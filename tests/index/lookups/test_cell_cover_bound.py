"""blockhash.index.lookups.cell_cover (tools/cell_cover_bound.py): the least a one-level
cell lookup must read, against a per-photon count written independently."""

import numpy as np

from blockhash.index.lookups.cell_cover import cover_bound, level_counts
from blockhash.index.lookups.cells import CODE_SHIFT


def brute_force(codes, centre, radius, max_cells, levels):
    """Per level: each photon's cell, kept when the cell's box meets the ball; the level's
    read is the photons of those cells when they are at most max_cells cells."""
    best = np.inf
    for level in levels:
        side = float(1 << (CODE_SHIFT + level))
        cell = codes.astype(np.int64) >> (CODE_SHIFT + level)
        near = np.clip(centre, cell * side, (cell + 1) * side)
        meet = ((near - centre) ** 2).sum(axis=1) <= radius ** 2
        # Cells meeting the ball, empty ones included, from the ball's bounding cells.
        lo = np.floor((centre - radius) / side).astype(np.int64)
        hi = np.floor((centre + radius) / side).astype(np.int64)
        if (hi - lo + 1).prod() > 8 * max_cells:  # far more than max_cells meet the ball
            continue
        grid = np.stack(np.meshgrid(*[np.arange(lo[a], hi[a] + 1) for a in range(3)],
                                    indexing="ij"), axis=-1).reshape(-1, 3)
        gnear = np.clip(centre, grid * side, (grid + 1) * side)
        cells = ((gnear - centre) ** 2).sum(axis=1) <= radius ** 2
        if (cells & (grid >= 0).all(axis=1)).sum() <= max_cells:
            best = min(best, int(meet.sum()))
    return best


def test_cover_bound_matches_a_per_photon_count():
    rng = np.random.default_rng(3)
    # A dense cluster and a sparse background in 32-bit codes.
    codes = np.concatenate([rng.normal(2.0**31, 2.0**24, (3000, 3)),
                            rng.uniform(0, 2.0**32, (1000, 3))]).clip(0, 2.0**32 - 1)
    codes = codes.astype(np.uint32)
    levels = range(8, 22)
    tables = {lv: level_counts(codes, lv) for lv in levels}
    centres = 12345.6 + np.array([[2.0**31 + 2.0**26, 2.0**31, 2.0**31],   # beside the cluster
                        [2.0**30, 2.0**30, 2.0**30],             # far from it
                        [2.0**31, 2.0**31, 2.0**31]])            # inside it
    radii = np.array([1.37 * 2.0**25, 1.61 * 2.0**27, 1.13 * 2.0**22])  # off the cell grid
    for max_cells in (8, 27, 125):
        got = cover_bound(centres, radii, tables, max_cells)
        want = [brute_force(codes, c, r, max_cells, levels) for c, r in zip(centres, radii)]
        assert np.array_equal(got, want), (max_cells, got, want)
        assert np.isfinite(got).all()
    # More cells allowed never read more.
    assert (cover_bound(centres, radii, tables, 125) <= cover_bound(centres, radii, tables, 8)).all()
