import numpy as np
import pytest
from conftest import photon_set

from blockhash.index.records.blocks import bulk_blocks
from blockhash.index.records.fixedpoint import Quantizer
from blockhash.index.records.hilbert import hilbert_keys
from blockhash.index.tables.hashtables import NO_BLOCK, insert_blocks
from blockhash.index.tables.thresholds import ThresholdLayout, build_thresholds


def table_inputs(name, n, P, L, layout=ThresholdLayout.MARGINAL):
    pts = photon_set(name, n)
    codes = Quantizer.for_points(pts).encode(pts)
    leaves = bulk_blocks(hilbert_keys(codes))
    _, keys = build_thresholds(codes[leaves.order], P, L, layout)
    return keys, leaves.starts


def demand(keys, starts, t, buckets):
    """Blocks with at least one photon in each bucket of table t."""
    block = np.repeat(np.arange(len(starts) - 1), np.diff(starts))
    out = [set() for _ in range(buckets)]
    for b, key in zip(block, keys[t]):
        out[key].add(int(b))
    return out


@pytest.mark.parametrize("name", ["uniform", "caustic", "clustered"])
@pytest.mark.parametrize("B", [1, 3, 12])
def test_tables_hold_only_blocks_that_hash_there_once_each(name, B):
    P, L = (5, 2, 4), 3
    keys, starts = table_inputs(name, 4000, P, L)
    tabs = insert_blocks(keys, starts, buckets=40, B=B)
    refcount = np.zeros(len(starts) - 1, dtype=np.int64)
    for t in range(L):
        want = demand(keys, starts, t, 40)
        for key in range(40):
            row = tabs.refs[t, key]
            e = tabs.entries[t, key]
            valid = row[:e]
            assert (row[e:] == NO_BLOCK).all() and (valid >= 0).all()
            assert len(set(valid.tolist())) == e  # never twice in a bucket
            assert set(valid.tolist()) <= want[key]
            if len(want[key]) <= B:  # room for all: every block is there, no overflow
                assert set(valid.tolist()) == want[key] and tabs.overflows[t, key] == 0
            else:
                assert e == B and tabs.overflows[t, key] >= len(want[key]) - B
            refcount[valid] += 1
    np.testing.assert_array_equal(tabs.block_buckets, refcount)
    assert tabs.orphans == int(np.sum(refcount == 0))


def test_priority_is_distance_from_full_plus_overflows():
    keys, starts = table_inputs("caustic", 3000, (4, 1, 4), 2)
    tabs = insert_blocks(keys, starts, buckets=16, B=4)
    np.testing.assert_array_equal(tabs.priority, np.abs(4 - tabs.entries - tabs.overflows))
    assert tabs.priority.min() >= 0


def test_full_bucket_bumps_the_block_that_sits_in_most_buckets():
    # Block 0 has photons in buckets 0 and 1; block 1 only in bucket 0, which holds one ref.
    keys = np.array([[0, 1, 0]], dtype=np.int64)
    starts = np.array([0, 2, 3])
    tabs = insert_blocks(keys, starts, buckets=2, B=1)
    assert tabs.refs[0, 0, 0] == 1 and tabs.refs[0, 1, 0] == 0
    assert tabs.bumps == 1 and tabs.overflows[0, 0] == 1
    np.testing.assert_array_equal(tabs.block_buckets, [1, 1])
    assert tabs.orphans == 0


def test_full_bucket_keeps_a_resident_that_is_its_only_home():
    # Both blocks hash only to bucket 0 of one table with room for one: the second is refused.
    keys = np.array([[0, 0]], dtype=np.int64)
    tabs = insert_blocks(keys, np.array([0, 1, 2]), buckets=1, B=1)
    assert tabs.refs[0, 0, 0] == 0 and tabs.bumps == 0 and tabs.overflows[0, 0] == 1
    assert tabs.orphans == 1


@pytest.mark.parametrize("L", [2, 3, 5])
def test_striping_starts_each_table_at_a_different_block(L):
    # One bucket of one slot per table and single-photon blocks: nobody can be bumped
    # (every count stays 1), so each table keeps the first block striping gave it.
    nblocks = 10
    keys = np.zeros((L, nblocks), dtype=np.int64)
    tabs = insert_blocks(keys, np.arange(nblocks + 1), buckets=1, B=1)
    np.testing.assert_array_equal(tabs.refs[:, 0, 0], [(t * nblocks) // L for t in range(L)])


def test_block_is_inserted_once_per_distinct_key_not_per_photon():
    keys = np.array([[2, 2, 2, 0]], dtype=np.int64)
    tabs = insert_blocks(keys, np.array([0, 4]), buckets=3, B=2)
    assert tabs.entries[0].tolist() == [1, 0, 1]
    assert tabs.block_buckets.tolist() == [2]


def plain_insert(keys, starts, buckets, B):
    """Section 4.3 written out in Python: the reference for the compiled insertion."""
    L, nblocks = keys.shape[0], len(starts) - 1
    refs = np.full((L, buckets, B), NO_BLOCK, dtype=np.int32)
    entries = np.zeros((L, buckets), dtype=np.int32)
    overflows = np.zeros((L, buckets), dtype=np.int32)
    counts = np.zeros(nblocks, dtype=np.int32)
    bumps = 0
    for i in range(nblocks):
        for t in range(L):
            b = (i + (t * nblocks) // L) % nblocks
            done = set()
            for s in range(starts[b], starts[b + 1]):
                key = int(keys[t, s])
                if key in done:
                    continue
                done.add(key)
                e = entries[t, key]
                if e < B:
                    refs[t, key, e] = b
                    entries[t, key] += 1
                    counts[b] += 1
                    continue
                overflows[t, key] += 1
                j = int(np.argmax(counts[refs[t, key]]))  # the first of the most referenced
                if counts[refs[t, key, j]] > 1 and counts[refs[t, key, j]] > counts[b]:
                    counts[refs[t, key, j]] -= 1
                    refs[t, key, j] = b
                    counts[b] += 1
                    bumps += 1
    return refs, entries, overflows, counts, bumps


@pytest.mark.parametrize("L, buckets, B", [(1, 7, 2), (3, 40, 3), (5, 200, 8)])
def test_compiled_insertion_equals_the_plain_one(L, buckets, B):
    rng = np.random.default_rng(L * B)
    n = 3000
    starts = np.unique(np.concatenate([[0, n], rng.choice(np.arange(1, n), 500, replace=False)]))
    keys = rng.integers(0, buckets, size=(L, n))
    keys[:, ::3] = keys[:, 1::3][:, :keys[:, ::3].shape[1]]  # repeated keys inside blocks
    t = insert_blocks(keys, starts, buckets=buckets, B=B)
    refs, entries, overflows, counts, bumps = plain_insert(keys, starts, buckets, B)
    np.testing.assert_array_equal(t.refs, refs)
    np.testing.assert_array_equal(t.entries, entries)
    np.testing.assert_array_equal(t.overflows, overflows)
    np.testing.assert_array_equal(t.block_buckets, counts)
    assert t.bumps == bumps
