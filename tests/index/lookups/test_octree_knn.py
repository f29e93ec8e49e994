"""The exact j-th nearest other photon over the octree of the Hilbert order
(blockhash/index/lookups/octree_knn.py), against scipy's cKDTree on the same decoded positions."""

import numpy as np
import pytest
from conftest import photon_set
from scipy.spatial import cKDTree

from blockhash.errors import InputError
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.index.lookups.octree_knn import jth_distances


def jth_both(positions, j, k=50):
    index = BlockHashIndex(positions, k=k)
    codes = index.records.records[:, :3]
    pos = index.quantizer.decode(codes)
    got = jth_distances(codes, pos, j, index.quantizer)
    want = cKDTree(pos.astype(np.float64)).query(pos.astype(np.float64), k=[j + 1])[0][:, 0]
    return got, want


@pytest.mark.parametrize("j", [1, 8, 36])
def test_equals_ckdtree_on_every_map(distribution, j):
    got, want = jth_both(photon_set(distribution, 20_000), j)
    np.testing.assert_array_equal(got, want)


@pytest.mark.filterwarnings("ignore::blockhash.index.block_hash_index.OrphanWarning")
def test_piles_far_photons_and_the_largest_rank():
    """Photons piled at one point (distance 0), one photon far from the rest (its search
    climbs to the top cube) and j = n - 1 (every other photon)."""
    rng = np.random.default_rng(2)
    pos = np.vstack([rng.random((500, 3)), np.zeros((60, 3)), [[40.0, 40.0, 40.0]]])
    for j in (5, 59, 80, len(pos) - 1):
        got, want = jth_both(pos, j, k=8)
        np.testing.assert_array_equal(got, want)


def test_a_rank_outside_the_map_is_refused():
    index = BlockHashIndex(np.random.default_rng(0).random((20, 3)), k=4)
    codes = index.records.records[:, :3]
    with pytest.raises(InputError, match=r"j=20 must lie in \[1, 19\]"):
        jth_distances(codes, index.quantizer.decode(codes), 20, index.quantizer)


@pytest.mark.filterwarnings("ignore::blockhash.index.block_hash_index.OrphanWarning")
def test_lone_photons_between_dense_clusters():
    """A photon's search starts from the radius of the one before it in Hilbert order: after
    a lone photon far from everything that guess is far too wide (the own-cube rule takes
    over), beside a dense cluster far too narrow (the search climbs); exact either way."""
    rng = np.random.default_rng(4)
    centres = rng.random((20, 3))
    dense = (centres[:, None, :] + rng.normal(0, 1e-3, (20, 3_000, 3))).reshape(-1, 3)
    lone = rng.uniform(-50, 50, (200, 3))
    pos = np.vstack([dense, lone])
    for j in (8, 36):
        got, want = jth_both(pos, j)
        np.testing.assert_array_equal(got, want)


def test_the_selection_in_a_band_is_the_kth_on_either_side_of_the_bound():
    """_kth_in_band ranks only one side of its bound: the kth smallest whether it lies below
    the bound, at it, or above it, with ties and values equal to the bound, past the rank
    count's size too (Hoare's selection)."""
    from blockhash.index.lookups.octree_knn import RANK_MAX, _kth_in_band

    rng = np.random.default_rng(3)
    for m in (1, 7, 53, RANK_MAX + 40):
        a = np.round(rng.random(m) * 20) / 20  # ties
        for low in (-1.0, 0.0, a[0], 0.5, 2.0):
            for kth in range(m):
                got = _kth_in_band(a.copy(), m, kth, low, np.empty(m, dtype=np.int64))
                assert got == np.sort(a)[kth], (m, low, kth)
