import numpy as np
import pytest
from conftest import photon_set

from blockhash.index.fixedpoint import Quantizer
from blockhash.index.thresholds import (
    THRESHOLD_PAD,
    ThresholdLayout,
    build_thresholds,
    count_le,
    hash_codes,
    row_starts,
    table_offsets,
)

LAYOUTS = [ThresholdLayout.MARGINAL, ThresholdLayout.NESTED]  # the grids; adaptive: test_adaptive.py


def codes_of(points):
    return Quantizer.for_points(points).encode(points)


def brute_force_keys(codes, thresholds, P, layout):
    """The layout of the module docstring, written out with linear counts."""
    px, py, pz = P
    nested = layout == ThresholdLayout.NESTED
    keys = np.empty((len(thresholds), len(codes)), dtype=np.int64)
    for t, row in enumerate(thresholds):
        for j, (cx, cy, cz) in enumerate(codes):
            hx = int(np.sum(row[0:px - 1] <= cx))
            ys = (px - 1) + (hx * (py - 1) if nested else 0)
            hy = int(np.sum(row[ys:ys + py - 1] <= cy))
            zs = ((px - 1) + px * (py - 1) + (hx * py + hy) * (pz - 1) if nested
                  else (px - 1) + (py - 1))
            hz = int(np.sum(row[zs:zs + pz - 1] <= cz))
            keys[t, j] = hx + px * (hy + py * hz)
    return keys


def test_offsets_differ_per_table_and_axis_and_stay_in_range():
    o = table_offsets(16)
    assert o.shape == (16, 3)
    assert (o >= -0.5).all() and (o < 0.5).all()
    assert np.all(o[0] == 0.0)  # table 0 samples the plain quantiles i / P
    assert len(np.unique(np.round(o, 9), axis=0)) == 16


@pytest.mark.slow
@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("P", [(4, 3, 5), (6, 1, 4), (1, 1, 1), (2, 2, 1)])
def test_build_keys_equal_the_documented_hash(layout, P):
    codes = codes_of(photon_set("clustered", 3000))
    thr, keys = build_thresholds(codes, P, 3, layout)
    assert thr.shape == (3, row_starts(P, layout)[3])
    expected = brute_force_keys(codes, thr, P, layout)
    np.testing.assert_array_equal(keys, expected)
    np.testing.assert_array_equal(hash_codes(codes, thr, P, layout), expected)


@pytest.mark.parametrize("layout", LAYOUTS)
def test_every_threshold_list_is_sorted(layout):
    P = (5, 4, 6)
    thr, _ = build_thresholds(codes_of(photon_set("caustic", 20000)), P, 4, layout)
    ox, oy, oz, T = row_starts(P, layout)
    lists = [(ox, P[0] - 1, 1), (oy, P[1] - 1, P[0] if layout else 1),
             (oz, P[2] - 1, P[0] * P[1] if layout else 1)]
    for start, count, groups in lists:
        block = thr[:, start:start + count * groups].reshape(4, groups, count)
        assert (np.diff(block.astype(np.int64), axis=2) >= 0).all()


def test_table_zero_marginal_buckets_hold_equal_shares():
    codes = codes_of(photon_set("uniform", 40000))
    _, keys = build_thresholds(codes, (8, 1, 1), 1, ThresholdLayout.MARGINAL)
    counts = np.bincount(keys[0], minlength=8)
    # Exact quantiles of 40,000 points: each of the 8 buckets gets 5,000 +- 1.
    assert np.abs(counts - 5000).max() <= 1


def test_offset_tables_shift_their_bucket_borders():
    codes = codes_of(photon_set("uniform", 40000))
    thr, _ = build_thresholds(codes, (8, 1, 1), 4, ThresholdLayout.MARGINAL)
    assert len({tuple(row[:7]) for row in thr}) == 4


def test_nested_buckets_hold_equal_counts_where_marginal_ones_do_not():
    codes = codes_of(photon_set("caustic", 100000))
    P = (20, 1, 20)
    spread = {}
    for layout in LAYOUTS:
        _, keys = build_thresholds(codes, P, 1, layout)
        counts = np.bincount(keys[0], minlength=400)
        spread[layout] = counts.max() / max(np.median(counts), 1)
    # Nested: within a few photons of 250 per bucket; marginal: hot spots hold many times the median.
    assert spread[ThresholdLayout.NESTED] < 1.1
    assert spread[ThresholdLayout.MARGINAL] > 5


def test_flat_axis_with_several_buckets_puts_every_photon_in_one_of_them():
    codes = codes_of(photon_set("planar", 5000))
    _, keys = build_thresholds(codes, (4, 3, 4), 2, ThresholdLayout.MARGINAL)
    hy = (keys // 4) % 3
    assert len(np.unique(hy)) == 1


def test_empty_nested_slab_hashes_to_bucket_zero_through_padding():
    pts = np.zeros((100, 3))
    pts[:50, 0] = 0.0
    pts[50:, 0] = 1.0
    pts[:, 2] = np.linspace(0, 1, 100)
    codes = codes_of(pts)
    thr, _ = build_thresholds(codes, (3, 1, 2), 1, ThresholdLayout.NESTED)
    # Three x slabs from two x values: one slab is empty, its z list is padding.
    zs = row_starts((3, 1, 2), ThresholdLayout.NESTED)[2]
    assert (thr[0, zs:zs + 3] == THRESHOLD_PAD).sum() >= 1


@pytest.mark.parametrize("count", [0, 1, 2, 7, 16])
def test_binary_search_count_equals_linear_count_with_duplicates(count, rng):
    row = np.sort(rng.integers(0, 20, count).astype(np.uint32))
    row = np.concatenate([[THRESHOLD_PAD] * 3, row]).astype(np.uint32)
    for code in range(-1, 22):
        c = np.uint32(max(code, 0))
        assert count_le(row, 3, count, c) == int(np.sum(row[3:] <= c))
