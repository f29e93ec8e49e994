"""64-word photon blocks and the block builders (paper sections 3.2 and 4.1, Figures 5, 7a)."""

from __future__ import annotations

import numpy as np
import pytest

from blockhash import BlockHashError, InputError
from blockhash.evaluate.datasets import caustic_like, uniform
from blockhash.index.records.blocks import (
    BLOCK_WORDS,
    BUILDERS,
    COUNT_WORD,
    PHOTONS_PER_BLOCK,
    make_blocks,
    pack_blocks,
    unpack_blocks,
)
from blockhash.index.records.btree import btree_blocks
from blockhash.index.records.codec import WORDS_PER_PHOTON
from blockhash.index.records.fixedpoint import Quantizer
from blockhash.index.records.hilbert import hilbert_keys


def _hilbert_keys_of(points: np.ndarray) -> np.ndarray:
    return hilbert_keys(Quantizer.for_points(points).encode(points))


def _keys(scenario: str, n: int, rng: np.random.Generator) -> np.ndarray:
    if scenario == "caustic":
        return _hilbert_keys_of(caustic_like(n, rng))
    if scenario == "uniform":
        return _hilbert_keys_of(uniform(n, rng))
    if scenario == "duplicates":  # many photons sharing a key (coincident photons)
        return rng.integers(0, max(2, n // 7), n).astype(np.uint64)
    raise ValueError(scenario)


def _records(n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 6) uint32 records over the full word range, so truncation or mixing shows."""
    return rng.integers(0, 2**32, size=(n, WORDS_PER_PHOTON), dtype=np.uint32)


def _expected_words(records: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Oracle block layout written out record by record (section 3.2)."""
    words = np.zeros((len(starts) - 1, 64), dtype=np.uint32)
    for b in range(len(starts) - 1):
        for slot, r in enumerate(range(starts[b], starts[b + 1])):
            words[b, 6 * slot:6 * slot + 6] = records[r]
        words[b, 60] = starts[b + 1] - starts[b]
    return words


def _mean_block_diagonal(points: np.ndarray, order: np.ndarray, starts: np.ndarray) -> float:
    """Mean bounding-box diagonal of the blocks ``order[starts[b]:starts[b + 1]]``."""
    nblocks = len(starts) - 1
    block = np.repeat(np.arange(nblocks), np.diff(starts))
    lo = np.full((nblocks, 3), np.inf)
    hi = np.full((nblocks, 3), -np.inf)
    np.minimum.at(lo, block, points[order])
    np.maximum.at(hi, block, points[order])
    return float(np.linalg.norm(hi - lo, axis=1).mean())


def _starts(scenario: str) -> np.ndarray:
    """Block boundaries for a packing scenario."""
    fixed = {"full-then-partial": [0, 10, 20, 23], "single-photon": [0, 1], "one-full-block": [0, 10],
             "hand-made-uneven": [0, 3, 4, 14, 21], "no-blocks": [0]}
    if scenario in fixed:
        return np.array(fixed[scenario], dtype=np.int64)
    # Uncompacted B+-tree leaves (Figure 5a): sizes 5..10, not all equal.
    n = {"btree-uncompacted": 777, "btree-uncompacted-large": 5000}[scenario]
    keys = np.random.default_rng(n).integers(0, 2**63, n, dtype=np.uint64)
    starts = btree_blocks(keys, leaf_capacity=PHOTONS_PER_BLOCK, compact=False).starts
    assert len(np.unique(np.diff(starts))) > 1  # otherwise the scenario tests nothing uneven
    return starts


def test_block_geometry_follows_the_paper():
    # 64-word burst; ten 6-word records fill words 0-59; the count lives in a spare word.
    assert (BLOCK_WORDS, PHOTONS_PER_BLOCK, COUNT_WORD) == (64, 10, 60)
    assert BUILDERS == ("bulk", "btree")


def test_unknown_builder_is_rejected_with_the_valid_names():
    with pytest.raises(InputError, match=r"builder='octree' is not known; choose one of bulk, btree"):
        make_blocks(np.arange(20, dtype=np.uint64), builder="octree")


@pytest.mark.slow
@pytest.mark.parametrize("builder", BUILDERS)
@pytest.mark.parametrize("scenario", ["caustic", "uniform", "duplicates"])
@pytest.mark.parametrize("n", [1, 10, 11, 2345])
def test_builders_give_disjoint_blocks_covering_every_photon_once(builder, scenario, n):
    keys = _keys(scenario, n, np.random.default_rng(n))
    blocks = make_blocks(keys, builder=builder)
    np.testing.assert_array_equal(np.bincount(blocks.order, minlength=n), np.ones(n, dtype=np.int64))
    assert blocks.starts[0] == 0 and blocks.starts[-1] == n
    sizes = np.diff(blocks.starts)
    assert sizes.min() >= 1 and sizes.max() <= PHOTONS_PER_BLOCK
    # Each block is an interval of the curve: keys never decrease along the blocks.
    in_order = keys[blocks.order]
    assert (in_order[1:] >= in_order[:-1]).all()


@pytest.mark.parametrize("builder", BUILDERS)
def test_hilbert_blocks_on_caustic_data_are_far_tighter_than_random_blocks(builder):
    # Figure 7a: a block covers a compact region.  Random blocking of the same photons with
    # the same block sizes spans the whole scene.  Measured ratio (seeds 0-2, n = 20,000):
    # 30-32x for both builders; require 10x.
    points = caustic_like(20_000, np.random.default_rng(5))
    blocks = make_blocks(_hilbert_keys_of(points), builder=builder)
    hilbert = _mean_block_diagonal(points, blocks.order, blocks.starts)
    shuffled = _mean_block_diagonal(points, np.random.default_rng(6).permutation(len(points)),
                                    blocks.starts)
    assert hilbert * 10 < shuffled


def test_both_builders_give_the_same_blocks():
    keys = _keys("duplicates", 3000, np.random.default_rng(8))
    bulk, tree = make_blocks(keys, builder="bulk"), make_blocks(keys, builder="btree")
    np.testing.assert_array_equal(bulk.order, tree.order)
    np.testing.assert_array_equal(bulk.starts, tree.starts)


@pytest.mark.parametrize("scenario", ["full-then-partial", "single-photon", "one-full-block",
                                      "hand-made-uneven", "btree-uncompacted"])
def test_pack_lays_records_six_words_each_from_word_zero_with_count_in_word_60(scenario):
    starts = _starts(scenario)
    records = _records(int(starts[-1]), np.random.default_rng(len(starts)))
    words = pack_blocks(records, starts)
    assert words.shape == (len(starts) - 1, BLOCK_WORDS) and words.dtype == np.uint32
    np.testing.assert_array_equal(words, _expected_words(records, starts))
    np.testing.assert_array_equal(words[:, COUNT_WORD], np.diff(starts))
    np.testing.assert_array_equal(words[:, COUNT_WORD + 1:], 0)


@pytest.mark.parametrize("scenario", ["full-then-partial", "single-photon", "no-blocks",
                                      "btree-uncompacted", "btree-uncompacted-large"])
def test_unpack_recovers_packed_records_and_starts_exactly(scenario):
    starts = _starts(scenario)
    records = _records(int(starts[-1]), np.random.default_rng(len(starts) + 1))
    back, back_starts = unpack_blocks(pack_blocks(records, starts))
    np.testing.assert_array_equal(back, records)
    assert back.dtype == np.uint32 and back.shape == records.shape
    np.testing.assert_array_equal(back_starts, starts)


@pytest.mark.parametrize("n, starts, sizes", [
    pytest.param(11, [0, 11], "11..11", id="eleven"),
    pytest.param(3, [0, 0, 3], "0..3", id="empty-block"),
    pytest.param(3, [0, 3, 2, 3], "-1..3", id="decreasing-starts"),
    pytest.param(40, [0, 10, 25, 40], "10..15", id="one-oversized"),
])
def test_block_sizes_outside_1_to_10_are_rejected(n, starts, sizes):
    records = _records(n, np.random.default_rng(0))
    with pytest.raises(InputError, match=rf"block sizes must be 1\.\.10; got {sizes}"):
        pack_blocks(records, np.array(starts))


@pytest.mark.parametrize("n, starts", [
    pytest.param(5, [2, 7], id="offset-starts"),
    pytest.param(10, [0, 5], id="records-left-over"),
])
def test_starts_that_do_not_span_the_records_are_rejected(n, starts):
    with pytest.raises(BlockHashError, match="starts"):
        pack_blocks(_records(n, np.random.default_rng(0)), np.array(starts))


def test_unpack_rejects_a_count_word_above_10():
    words = np.zeros((1, BLOCK_WORDS), dtype=np.uint32)
    words[0, COUNT_WORD] = 11
    with pytest.raises(BlockHashError, match="count"):
        unpack_blocks(words)
