"""The adaptive build's fast mechanics give the very tables of a plain reference build.

The reference below is the straightforward builder: one depth-first walk per table over an
(n, 3) copy of the codes with an int64 id column, Hoare's scalar quickselect and an in-place
two-way partition, keys written at each bucket.  The library builds the same trees with a
row layout, block partitioning, tables split into subtrees across threads and bucket keys
from the final row order; every cut, key and bucket count must agree exactly, because the
axis probes and the sampled cuts read rows at fixed places of each node's current order.

The per-node rules (``_spreads``, ``_widest``, ``_gap_axis``) are the library's own; the cut placement is
written out here as in the library, so a change to it must be made in both places.
"""

import numba
import numpy as np
import pytest

from blockhash.evaluate.photon_maps import MAPS
from blockhash.index.records.fixedpoint import Quantizer
from blockhash.index.tables.adaptive import (
    PROBE_SLOTS,
    SELECT_SAMPLE,
    _gap_axis,
    _spreads,
    _widest,
    build_adaptive,
)
from blockhash.index.tables.thresholds import LEAF, MAX_DEPTH, THRESHOLD_PAD, table_offsets


@numba.njit
def _swap(c, ids, i, j):
    for a in range(3):
        c[i, a], c[j, a] = c[j, a], c[i, a]
    ids[i], ids[j] = ids[j], ids[i]


@numba.njit
def _split(c, ids, a, lo, hi, t):
    """Rows lo..hi-1 with code < t on axis a first (plain two-pointer partition)."""
    i, j = lo, hi - 1
    while i <= j:
        if c[i, a] < t:
            i += 1
        else:
            _swap(c, ids, i, j)
            j -= 1


@numba.njit
def _select(c, ids, a, lo, hi, p):
    while hi - lo > 1:
        mid = (lo + hi - 1) // 2
        x, y, z = c[lo, a], c[mid, a], c[hi - 1, a]
        pivot = max(min(x, y), min(max(x, y), z))
        i, j = lo, hi - 1
        while i <= j:
            while c[i, a] < pivot:
                i += 1
            while c[j, a] > pivot:
                j -= 1
            if i <= j:
                _swap(c, ids, i, j)
                i += 1
                j -= 1
        if p <= j:
            hi = j + 1
        elif p >= i:
            lo = i
        else:
            return


@numba.njit
def _reference_tree(codes, S, offsets, scale):
    n = codes.shape[0]
    c = codes.copy()
    ids = np.arange(n)
    keys = np.empty(n, dtype=np.int64)
    cap = 2 * max(1, int(np.round(n / S))) + 64
    nodes = np.empty(2 * cap, dtype=np.uint32)
    depth = np.zeros(cap, dtype=np.int64)
    stack = np.empty((MAX_DEPTH + 2, 4), dtype=np.int64)
    stack[0] = (0, 0, n, max(1, int(np.round(n / S))))
    buf = np.empty(SELECT_SAMPLE, dtype=np.uint32)
    probe = np.empty((PROBE_SLOTS, 4), dtype=np.uint32)
    spread = np.zeros((3, 6))
    top = 1
    used = 1
    buckets = 0
    while top > 0:
        top -= 1
        node, lo, hi, m = stack[top]
        size = hi - lo
        a = -1
        dims = 0
        gap = -1
        if m >= 2 and size >= 2 and depth[node] < MAX_DEPTH - 1 and used + 2 <= cap:
            a, dims = _widest(_spreads(c, lo, hi, scale, probe, spread))
            gap = _gap_axis(spread)
        split = -1
        t = np.uint32(0)
        if gap >= 0:
            below_code = np.uint32(spread[gap, 4])
            t = np.uint32(below_code + 1 + (np.uint32(spread[gap, 5]) - below_code - 1) // 2)
            split = 0
            for r in range(lo, hi):
                if c[r, gap] < t:
                    split += 1
            if min(split, size - split) >= 0.5 * size / m:
                a = gap
                _split(c, ids, a, lo, hi, t)
            else:
                gap = -1
                split = -1
                t = np.uint32(0)
        if gap < 0 and a >= 0:
            layers = max(2.0, m ** (1.0 / dims))
            target = size * (0.5 + offsets[depth[node] % offsets.shape[0]] / layers)
            if size > SELECT_SAMPLE:
                for r in range(SELECT_SAMPLE):
                    buf[r] = c[lo + (r * size) // SELECT_SAMPLE, a]
                buf.sort()
                v = buf[min(int(target / size * SELECT_SAMPLE), SELECT_SAMPLE - 1)]
            else:
                p = min(max(int(target), 0), size - 1)
                _select(c, ids, a, lo, hi, lo + p)
                v = c[lo + p, a]
            below = 0
            equal = 0
            max_below = np.uint32(0)
            min_above = np.uint32(0xFFFFFFFF)
            for r in range(lo, hi):
                x = c[r, a]
                if x < v:
                    below += 1
                    max_below = max(max_below, x)
                elif x == v:
                    equal += 1
                else:
                    min_above = min(min_above, x)
            if below == 0 or (below + equal < size and abs(below + equal - target) < abs(below - target)):
                if below + equal < size:
                    t = np.uint32(v + 1 + (min_above - v - 1) // 2)
                    split = below + equal
            else:
                t = np.uint32(v - (v - max_below - 1) // 2)
                split = below
            if split > 0:
                _split(c, ids, a, lo, hi, t)
        if split <= 0:
            nodes[2 * node] = 0
            nodes[2 * node + 1] = (np.uint32(buckets) << 3) | LEAF
            for r in range(lo, hi):
                keys[ids[r]] = buckets
            buckets += 1
            continue
        left = used
        used += 2
        nodes[2 * node] = t
        nodes[2 * node + 1] = (np.uint32(left) << 3) | np.uint32(a)
        depth[left] = depth[left + 1] = depth[node] + 1
        m_left = min(max(int(np.round(m * split / size)), 1), m - 1)
        stack[top] = (left + 1, lo + split, hi, m - m_left)
        stack[top + 1] = (left, lo, lo + split, m_left)
        top += 2
    return nodes[:2 * used], keys, buckets


def reference_adaptive(codes, *, L, photons_per_bucket, scale):
    """``build_adaptive`` the plain way: tables one after another, nothing shared."""
    codes = np.ascontiguousarray(codes, dtype=np.uint32)
    offsets = table_offsets(L * MAX_DEPTH)[:, 0].reshape(MAX_DEPTH, L).T.copy()
    scale = np.asarray(scale, dtype=np.float64)
    tables = [_reference_tree(codes, float(photons_per_bucket), offsets[t], scale) for t in range(L)]
    T = max(len(r) for r, _, _ in tables)
    out = np.full((L, T), THRESHOLD_PAD, dtype=np.uint32)
    for t, (row, _, _) in enumerate(tables):
        out[t, :len(row)] = row
    return out, np.stack([k for _, k, _ in tables]), max(b for _, _, b in tables)


def hilbert_ordered(name, n, seed=0):
    """Codes of a map in block (Hilbert) order, as the index builds its tables over them."""
    from blockhash.index.records.blocks import make_blocks
    from blockhash.index.records.hilbert import hilbert_keys

    points = MAPS[name].photons(n, np.random.default_rng(seed))
    q = Quantizer.for_points(points)
    codes = q.encode(points)
    return np.ascontiguousarray(codes[make_blocks(hilbert_keys(codes)).order]), q


def assert_same_build(codes, scale, L, S):
    fast = build_adaptive(codes, L=L, photons_per_bucket=S, scale=scale)
    slow = reference_adaptive(codes, L=L, photons_per_bucket=S, scale=scale)
    np.testing.assert_array_equal(fast[0], slow[0])
    np.testing.assert_array_equal(fast[1], slow[1])
    assert fast[2] == slow[2]
    assert fast[0].dtype == np.uint32 and fast[1].dtype == np.int64


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(MAPS))
@pytest.mark.parametrize("n, S", [(50_000, 25.0), (120_000, 7.0)])
def test_tables_equal_the_reference_build(name, n, S):
    codes, q = hilbert_ordered(name, n)
    assert_same_build(codes, q.step, L=5, S=S)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["uniform", "room", "caustic"])
def test_unordered_codes_and_other_table_counts(name):
    """Codes in the caller's order (no Hilbert sort), L of 1, 2 and 7, large buckets."""
    points = MAPS[name].photons(30_000, np.random.default_rng(3))
    q = Quantizer.for_points(points)
    codes = q.encode(points)
    for L, S in ((1, 25.0), (2, 300.0), (7, 60.0)):
        assert_same_build(codes, q.step, L=L, S=S)


@pytest.mark.parametrize("n", [1, 2, 3, 24, 25, 26, 51, 140, 2047, 2048, 2049, 5000])
def test_small_and_boundary_sizes(n):
    codes, q = hilbert_ordered("room", max(n, 1), seed=n)
    assert_same_build(codes[:n], q.step, L=3, S=25.0)


def test_ties_planes_and_duplicates():
    """Many photons sharing codes: whole planes, exact duplicates, a few distinct values."""
    rng = np.random.default_rng(5)
    n = 40_000
    codes = rng.integers(0, 2**32 - 1, size=(n, 3), dtype=np.uint32)
    codes[: n // 2, 1] = 7_000_000                      # a plane
    codes[n // 2: n // 2 + 5000] = codes[n // 2]        # 5000 copies of one photon
    codes[-8000:, 0] = rng.integers(0, 4, 8000).astype(np.uint32) * 1000  # four x values
    assert_same_build(codes, np.array([1e-9, 2e-9, 1e-9]), L=4, S=25.0)
    assert_same_build(np.full((3000, 3), 9, dtype=np.uint32), np.ones(3), L=2, S=25.0)


@pytest.mark.slow
def test_tables_cut_into_many_parts(monkeypatch):
    """Every node above 100 photons cut on its own (quickselected ones and buckets too), the
    rest grown as subtrees, in whatever order the threads take them."""
    import blockhash.index.tables.adaptive as adaptive

    monkeypatch.setattr(adaptive, "SPLIT_MIN", 100)
    monkeypatch.setattr(adaptive, "SPLIT_SHARE", 1 << 20)
    for name in ("caustic", "room", "plane"):
        codes, q = hilbert_ordered(name, 20_000, seed=2)
        assert_same_build(codes, q.step, L=3, S=25.0)
        assert_same_build(codes, q.step, L=2, S=900.0)
