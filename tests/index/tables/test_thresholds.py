import numpy as np
import pytest
from conftest import photon_set

from blockhash.errors import InputError
from blockhash.index.records.fixedpoint import Quantizer
from blockhash.index.tables.thresholds import (
    THRESHOLD_PAD,
    ThresholdLayout,
    build_thresholds,
    count_le,
    hash_codes,
    row_starts,
    table_offsets,
)

MARGINAL = ThresholdLayout.MARGINAL  # the grid; the adaptive layout: test_adaptive.py


def codes_of(points):
    return Quantizer.for_points(points).encode(points)


def brute_force_keys(codes, thresholds, P):
    """The marginal row of the module docstring, written out with linear counts."""
    px, py, pz = P
    keys = np.empty((len(thresholds), len(codes)), dtype=np.int64)
    for t, row in enumerate(thresholds):
        for j, (cx, cy, cz) in enumerate(codes):
            hx = int(np.sum(row[0:px - 1] <= cx))
            ys = px - 1
            hy = int(np.sum(row[ys:ys + py - 1] <= cy))
            zs = (px - 1) + (py - 1)
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
@pytest.mark.parametrize("P", [(4, 3, 5), (6, 1, 4), (1, 1, 1), (2, 2, 1)])
def test_build_keys_equal_the_documented_hash(P):
    codes = codes_of(photon_set("clustered", 3000))
    thr, keys = build_thresholds(codes, P, 3, MARGINAL)
    assert thr.shape == (3, row_starts(P)[3])
    expected = brute_force_keys(codes, thr, P)
    np.testing.assert_array_equal(keys, expected)
    np.testing.assert_array_equal(hash_codes(codes, thr, P, MARGINAL), expected)


def test_thresholds_are_each_axis_quantiles_offset_per_table():
    """Table t's thresholds on an axis are the inverse empirical CDF of that axis' codes at
    (i + o[t, a]) / P_a, interpolated between order statistics and floored."""
    codes = codes_of(photon_set("caustic", 5000))
    P, L = (5, 4, 6), 3
    thr, _ = build_thresholds(codes, P, L, MARGINAL)
    starts = row_starts(P)
    offsets = table_offsets(L)
    for a in range(3):
        values = np.sort(codes[:, a]).astype(np.float64)
        m = len(values)
        for t in range(L):
            fractions = (np.arange(1, P[a]) + offsets[t, a]) / P[a]
            pos = np.clip(fractions * m - 0.5, 0.0, m - 1.0)
            lo = np.floor(pos).astype(int)
            hi = np.minimum(lo + 1, m - 1)
            w = pos - lo
            want = np.floor(values[lo] * (1 - w) + values[hi] * w).astype(np.uint32)
            np.testing.assert_array_equal(thr[t, starts[a]:starts[a] + P[a] - 1], want)


def test_every_threshold_list_is_sorted():
    P = (5, 4, 6)
    thr, _ = build_thresholds(codes_of(photon_set("caustic", 20000)), P, 4, MARGINAL)
    ox, oy, oz, T = row_starts(P)
    for start, count in [(ox, P[0] - 1), (oy, P[1] - 1), (oz, P[2] - 1)]:
        assert (np.diff(thr[:, start:start + count].astype(np.int64), axis=1) >= 0).all()


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


def test_marginal_buckets_overflow_on_hot_spots():
    """The paper's grid on a caustic: the product of marginals puts many times the median
    bucket's photons into the hot spot's buckets (what the adaptive layout avoids)."""
    codes = codes_of(photon_set("caustic", 100000))
    _, keys = build_thresholds(codes, (20, 1, 20), 1, MARGINAL)
    counts = np.bincount(keys[0], minlength=400)
    assert counts.max() / max(np.median(counts), 1) > 5


def test_flat_axis_with_several_buckets_puts_every_photon_in_one_of_them():
    codes = codes_of(photon_set("planar", 5000))
    _, keys = build_thresholds(codes, (4, 3, 4), 2, ThresholdLayout.MARGINAL)
    hy = (keys // 4) % 3
    assert len(np.unique(hy)) == 1


def test_build_thresholds_builds_only_the_marginal_layout():
    with pytest.raises(InputError, match="builds the marginal layout.*build_adaptive"):
        build_thresholds(codes_of(photon_set("uniform", 100)), (2, 2, 2), 1, ThresholdLayout.ADAPTIVE)


@pytest.mark.parametrize("count", [0, 1, 2, 7, 16])
def test_binary_search_count_equals_linear_count_with_duplicates(count, rng):
    row = np.sort(rng.integers(0, 20, count).astype(np.uint32))
    row = np.concatenate([[THRESHOLD_PAD] * 3, row]).astype(np.uint32)
    for code in range(-1, 22):
        c = np.uint32(max(code, 0))
        assert count_le(row, 3, count, c) == int(np.sum(row[3:] <= c))
