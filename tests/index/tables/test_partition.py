"""Row selection and partition for the adaptive tables: the rows end as the plain loops
leave them."""

import numba
import numpy as np
import pytest

from blockhash.index.tables.partition import kth_smallest, partition, photon_rows, select, swap


@numba.njit
def plain_partition(c, a, lo, hi, t):
    i, j = lo, hi - 1
    while i <= j:
        if c[i, a] < t:
            i += 1
        else:
            swap(c, i, j)
            j -= 1


def rows(n, seed, distinct):
    rng = np.random.default_rng(seed)
    return photon_rows(rng.integers(0, distinct, size=(n, 3)).astype(np.uint32))


@pytest.mark.parametrize("distinct", [3, 50, 2**32])
def test_partition_equals_the_plain_loop(distinct):
    for seed in range(200):
        n = 1 + seed % 97
        c = rows(n, seed, distinct)
        p = seed % n
        if seed % 2:  # split by a select first, as the build does for small nodes
            select(c, seed % 3, 0, n, p)
        t = np.uint32(c[p, seed % 3] + (seed % 4 == 0))
        below = int((c[:, seed % 3] < t).sum())
        fast, plain = c.copy(), c.copy()
        partition(fast, seed % 3, 0, n, t, below)
        plain_partition(plain, seed % 3, 0, n, t)
        np.testing.assert_array_equal(fast, plain)


@pytest.mark.parametrize("distinct", [2, 1000, 2**32])
def test_select_puts_the_rank_in_place(distinct):
    for seed in range(100):
        n = 1 + seed * 7
        c = rows(n, seed, distinct)
        ids = set(c[:, 3].tolist())
        p = seed % n
        select(c, 1, 0, n, p)
        assert (c[:p, 1] <= c[p, 1]).all() and (c[p + 1:, 1] >= c[p, 1]).all()
        assert set(c[:, 3].tolist()) == ids


def test_kth_smallest_is_the_sorted_value():
    rng = np.random.default_rng(4)
    for trial in range(500):
        n = int(rng.integers(1, 2500))
        values = [rng.integers(0, 2**32, n), rng.integers(0, 3, n) << 29,
                  rng.integers(0, 2**10, n) + 2**31, np.full(n, rng.integers(0, 2**32))][trial % 4]
        values = values.astype(np.uint32)
        k = int(rng.integers(0, n))
        kept = values.copy()
        assert kth_smallest(values, k) == np.sort(values)[k]
        np.testing.assert_array_equal(values, kept)
