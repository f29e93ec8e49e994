"""3D Hilbert keys (paper section 4.1, Figure 7a): curve oracles on full grids."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from blockhash import BlockHashError, InputError
from blockhash.evaluate.datasets import clustered, uniform
from blockhash.index.records.fixedpoint import Quantizer
from blockhash.index.records.hilbert import KEY_BITS_PER_AXIS, hilbert_keys


def _grid(b: int) -> np.ndarray:
    """Every cell of a 2^b grid per axis, as integer cell coordinates (8^b, 3) uint32."""
    axis = np.arange(2**b, dtype=np.uint32)
    return np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)


def _grid_keys(b: int) -> tuple[np.ndarray, np.ndarray]:
    """Cells of the 2^b grid and their keys, the cell index placed in the top b bits."""
    cells = _grid(b)
    return cells, hilbert_keys(cells << np.uint32(32 - b), bits=b)


def _mean_group_diagonal(points: np.ndarray, order: np.ndarray, size: int) -> float:
    """Mean bounding-box diagonal of consecutive groups of ``size`` points in ``order``."""
    groups = points[order].reshape(-1, size, 3)
    return float(np.linalg.norm(groups.max(axis=1) - groups.min(axis=1), axis=1).mean())


@pytest.mark.parametrize("b", [1, 2, 3, 4])
def test_full_grid_keys_are_a_bijection_onto_curve_positions(b):
    _, keys = _grid_keys(b)
    assert keys.dtype == np.uint64
    np.testing.assert_array_equal(np.sort(keys), np.arange(8**b, dtype=np.uint64))


@pytest.mark.parametrize("b", [1, 2, 3, 4])
def test_consecutive_keys_are_face_adjacent_cells(b):
    cells, keys = _grid_keys(b)
    path = cells[np.argsort(keys)].astype(np.int64)
    steps = np.abs(np.diff(path, axis=0)).sum(axis=1)
    # Manhattan distance exactly 1 between integer cells: one axis moves by one cell.
    np.testing.assert_array_equal(steps, np.ones(8**b - 1, dtype=np.int64))


@pytest.mark.parametrize("b", range(2, KEY_BITS_PER_AXIS + 1))
def test_coarser_key_is_the_prefix_of_the_finer_key(b):
    # Each octree cell is one interval of the curve: dropping one level of the key
    # (3 bits) gives the key of the parent cell, so blocks cut from sorted keys stay compact.
    codes = np.random.default_rng(b).integers(0, 2**32, size=(2000, 3), dtype=np.uint32)
    np.testing.assert_array_equal(hilbert_keys(codes, bits=b) >> np.uint64(3),
                                  hilbert_keys(codes, bits=b - 1))


@pytest.mark.parametrize("bits", [1, 4, 11, KEY_BITS_PER_AXIS])
def test_keys_depend_only_on_the_top_bits(bits):
    rng = np.random.default_rng(bits)
    codes = rng.integers(0, 2**32, size=(5000, 3), dtype=np.uint32)
    low_mask = np.uint32((1 << (32 - bits)) - 1)
    noise = rng.integers(0, 2**32, size=codes.shape, dtype=np.uint32) & low_mask
    changed = (codes & ~low_mask) | noise
    assert (changed != codes).any()
    np.testing.assert_array_equal(hilbert_keys(changed, bits=bits), hilbert_keys(codes, bits=bits))


def test_default_keys_use_21_bits_and_fit_63_bits():
    codes = np.random.default_rng(7).integers(0, 2**32, size=(3000, 3), dtype=np.uint32)
    codes[0] = 2**32 - 1
    keys = hilbert_keys(codes)
    np.testing.assert_array_equal(keys, hilbert_keys(codes, bits=21))
    assert int(keys.max()) < 2**63


def test_empty_input_gives_empty_keys():
    keys = hilbert_keys(np.zeros((0, 3), dtype=np.uint32))
    assert keys.shape == (0,) and keys.dtype == np.uint64


@pytest.mark.parametrize("generate", [uniform, clustered], ids=["uniform", "clustered"])
def test_sorting_by_key_makes_groups_of_ten_far_tighter_than_random_groups(generate):
    # Section 4.1: photons sorted along the curve and cut into 10s cover compact regions.
    # Measured ratio (seeds 0-2): ~10x on uniform points, 44-56x on clustered ones; require 5x.
    points = generate(20_000, np.random.default_rng(1))
    keys = hilbert_keys(Quantizer.for_points(points).encode(points))
    hilbert = _mean_group_diagonal(points, np.argsort(keys, kind="stable"), 10)
    shuffled = _mean_group_diagonal(points, np.random.default_rng(3).permutation(len(points)), 10)
    assert hilbert < shuffled / 5


@pytest.mark.parametrize("codes", [
    pytest.param(np.zeros((4, 3), dtype=np.int64), id="int64"),
    pytest.param(np.zeros((4, 3), dtype=np.float32), id="float32"),
    pytest.param(np.zeros((4, 3), dtype=np.uint64), id="uint64"),
    pytest.param(np.zeros(3, dtype=np.uint32), id="1d"),
    pytest.param(np.zeros((4, 2), dtype=np.uint32), id="two-columns"),
    pytest.param(np.zeros((2, 4, 3), dtype=np.uint32), id="3d"),
])
def test_codes_that_are_not_n_by_3_uint32_are_rejected(codes):
    with pytest.raises(InputError, match=r"codes must be a \(n, 3\) uint32 array; got shape"):
        hilbert_keys(codes)


@pytest.mark.parametrize("bits", [0, -1, KEY_BITS_PER_AXIS + 1, 64])
def test_bits_outside_1_to_21_are_rejected(bits):
    with pytest.raises(InputError, match=rf"bits={bits} is out of range; allowed 1 <= bits <= 21"):
        hilbert_keys(np.zeros((4, 3), dtype=np.uint32), bits=bits)


@pytest.mark.parametrize("bits", [2.5, "3"])
def test_non_integer_bits_are_rejected(bits):
    with pytest.raises(BlockHashError, match="bits"):
        hilbert_keys(np.ones((4, 3), dtype=np.uint32) << np.uint32(31), bits=bits)


@numba.njit
def skilling_keys(codes, bits):
    """Skilling's AxesToTranspose loop, Gray code and bit interleave, one bit at a time."""
    n = codes.shape[0]
    keys = np.empty(n, dtype=np.uint64)
    x = np.empty(3, dtype=np.uint64)
    top = np.uint64(1) << np.uint64(bits - 1)
    for j in range(n):
        for i in range(3):
            x[i] = np.uint64(codes[j, i] >> np.uint32(32 - bits))
        q = top
        while q > 1:
            p = q - np.uint64(1)
            for i in range(3):
                if x[i] & q:
                    x[0] ^= p
                else:
                    t = (x[0] ^ x[i]) & p
                    x[0] ^= t
                    x[i] ^= t
            q >>= np.uint64(1)
        x[1] ^= x[0]
        x[2] ^= x[1]
        t = np.uint64(0)
        q = top
        while q > 1:
            if x[2] & q:
                t ^= q - np.uint64(1)
            q >>= np.uint64(1)
        key = np.uint64(0)
        for level in range(bits - 1, -1, -1):
            lv = np.uint64(level)
            for i in range(3):
                key = (key << np.uint64(1)) | (((x[i] ^ t) >> lv) & np.uint64(1))
        keys[j] = key
    return keys


@pytest.mark.slow
@pytest.mark.parametrize("b", range(1, KEY_BITS_PER_AXIS + 1))
def test_table_driven_keys_equal_skillings_loop(b):
    rng = np.random.default_rng(b)
    codes = rng.integers(0, 2**32, size=(20_000, 3), dtype=np.uint32)
    codes[:8] = np.array([[0, 0, 0], [2**32 - 1] * 3, [0, 2**32 - 1, 0], [2**31, 2**31 - 1, 7],
                          [1, 2, 3], [2**32 - 1, 0, 0], [0, 0, 2**32 - 1], [5, 5, 5]], dtype=np.uint32)
    np.testing.assert_array_equal(hilbert_keys(codes, bits=b), skilling_keys(codes, b))
    strided = np.zeros((len(codes), 6), dtype=np.uint32)
    strided[:, :3] = codes
    np.testing.assert_array_equal(hilbert_keys(strided[:, :3], bits=b), skilling_keys(codes, b))
