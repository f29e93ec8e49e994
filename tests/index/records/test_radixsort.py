"""The radix argsort orders keys exactly as numpy's stable argsort."""

import numpy as np
import pytest

from blockhash.index.records.radixsort import stable_argsort


@pytest.mark.parametrize("n", [1, 2, 17, 5000, 200_000])
def test_equals_numpy_stable_argsort(n):
    rng = np.random.default_rng(n)
    cases = [
        rng.integers(0, 2**63, n, dtype=np.uint64),                   # Hilbert keys' range
        rng.integers(0, 2**64 - 1, n, dtype=np.uint64, endpoint=True),  # every bit
        rng.integers(0, 5, n).astype(np.uint64),                       # many ties
        np.full(n, 2**40 + 3, dtype=np.uint64),                        # one key
        np.zeros(n, dtype=np.uint64),
        (rng.integers(0, 7, n).astype(np.uint64) << np.uint64(50)),    # only high digits vary
    ]
    for keys in cases:
        order = stable_argsort(keys)
        assert order.dtype == np.int64
        np.testing.assert_array_equal(order, np.argsort(keys, kind="stable"))
