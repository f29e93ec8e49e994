"""B+-tree photon blocks (paper section 4.1, Figure 5)."""

from __future__ import annotations

import numpy as np
import pytest

from blockhash.errors import InputError, InputTypeError
from blockhash.index.records.btree import LeafBlocks, btree_blocks, btree_nodes, bulk_blocks


def _keys(scenario: str, n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    if scenario == "random":
        return rng.integers(0, 2**64 - 1, n, dtype=np.uint64, endpoint=True)
    if scenario == "duplicates":
        return rng.integers(0, max(2, n // 20), n).astype(np.uint64)
    if scenario == "sorted":
        return np.sort(rng.integers(0, 2**40, n).astype(np.uint64))
    if scenario == "reverse":
        return np.sort(rng.integers(0, 2**40, n).astype(np.uint64))[::-1].copy()
    if scenario == "equal":
        return np.full(n, 12345, np.uint64)
    raise ValueError(scenario)


SCENARIOS = ["random", "duplicates", "sorted", "reverse", "equal"]
SHAPES = [(1, 10, 16), (7, 10, 16), (10, 10, 16), (11, 10, 16), (3000, 10, 16),
          (3000, 2, 3), (3000, 3, 4), (5000, 7, 5)]


def _check_invariants(keys: np.ndarray, cap: int, fan: int) -> None:
    t = btree_nodes(keys, leaf_capacity=cap, fanout=fan)
    height = t.depth.max() + 1
    assert t.depth[0] == 0
    # every leaf at the same depth, every index node above it
    np.testing.assert_array_equal(t.is_leaf, t.depth == height - 1)
    # occupancy: non-root nodes between ceil(cap/2) and cap; root index node >= 2 children
    limit = np.where(t.is_leaf, cap, fan)
    assert (t.count <= limit).all()
    assert (t.count[1:] >= (limit[1:] + 1) // 2).all()
    assert t.count[0] >= (1 if t.is_leaf[0] else 2)
    # each index node has count children, one level deeper
    np.testing.assert_array_equal(np.bincount(t.parent[1:], minlength=len(t.count)),
                                  np.where(t.is_leaf, 0, t.count))
    np.testing.assert_array_equal(t.depth[1:], t.depth[t.parent[1:]] + 1)
    # separators enclose their subtrees
    assert (t.lo <= t.hi).all() and t.lo[0] == keys.min() and t.hi[0] == keys.max()
    assert (t.bound_lo <= t.lo).all() and (t.hi <= t.bound_hi).all()
    # leaf records in key order and a permutation of the input
    assert t.leaf_keys.size == t.count[t.is_leaf].sum() == keys.size
    assert (t.leaf_keys[1:] >= t.leaf_keys[:-1]).all()
    np.testing.assert_array_equal(t.leaf_keys, np.sort(keys))


@pytest.mark.slow
@pytest.mark.parametrize("scenario", SCENARIOS)
@pytest.mark.parametrize("n,cap,fan", SHAPES)
def test_uncompacted_tree_keeps_bplus_tree_invariants(scenario, n, cap, fan):
    _check_invariants(_keys(scenario, n), cap, fan)


@pytest.mark.parametrize("scenario", SCENARIOS)
@pytest.mark.parametrize("n,cap,fan", SHAPES)
def test_compacted_blocks_equal_bulk_blocks(scenario, n, cap, fan):
    keys = _keys(scenario, n, seed=1)
    tree = btree_blocks(keys, leaf_capacity=cap, fanout=fan)
    bulk = bulk_blocks(keys, leaf_capacity=cap, fanout=fan)
    np.testing.assert_array_equal(tree.order, bulk.order)
    np.testing.assert_array_equal(tree.starts, bulk.starts)
    assert tree.order.dtype == tree.starts.dtype == np.int64
    sizes = np.diff(tree.starts)
    assert (sizes[:-1] == cap).all() and 1 <= sizes[-1] <= cap


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_uncompacted_blocks_are_the_half_full_leaves_in_key_order(scenario):
    keys = _keys(scenario, 4000, seed=2)
    blocks = btree_blocks(keys, leaf_capacity=10, fanout=4, compact=False)
    sizes = np.diff(blocks.starts)
    assert len(sizes) == blocks.leaves_before_compaction
    assert ((sizes >= 5) & (sizes <= 10)).all()
    assert blocks.mean_leaf_fill == pytest.approx(keys.size / (10 * len(sizes)))
    np.testing.assert_array_equal(np.sort(blocks.order), np.arange(keys.size))
    np.testing.assert_array_equal(blocks.order, np.argsort(keys, kind="stable"))


def test_equal_keys_keep_insertion_order_across_leaf_splits():
    keys = np.array([5, 3, 5, 5, 1, 5, 3, 5, 5, 5, 5, 5, 5, 5, 0, 5, 5, 5, 5, 5], np.uint64)
    blocks = btree_blocks(keys, leaf_capacity=2, fanout=3, compact=False)
    np.testing.assert_array_equal(blocks.order, np.argsort(keys, kind="stable"))
    assert blocks.height >= 3


def test_fewer_photons_than_leaf_capacity_give_one_root_leaf():
    keys = np.array([9, 2, 7], np.uint64)
    blocks = btree_blocks(keys)
    assert blocks.height == 1 and blocks.leaves_before_compaction == 1
    np.testing.assert_array_equal(blocks.order, [1, 2, 0])
    np.testing.assert_array_equal(blocks.starts, [0, 3])
    assert blocks.mean_leaf_fill == pytest.approx(0.3)


def test_all_equal_keys_fill_leaves_in_insertion_order():
    keys = np.full(1000, 7, np.uint64)
    tree = btree_blocks(keys, compact=False)
    np.testing.assert_array_equal(tree.order, np.arange(1000))
    # every insertion lands in the rightmost leaf, so splits leave leaves 6/10 full
    assert np.diff(tree.starts)[:-1].tolist() == [6] * (len(tree.starts) - 2)


def test_reverse_sorted_insertion_leaves_half_full_leaves_and_compaction_fills_them():
    keys = _keys("reverse", 1000)
    tree = btree_blocks(keys, compact=False)
    assert (np.diff(tree.starts)[1:] == 5).all()
    compact = btree_blocks(keys)
    assert compact.leaves_before_compaction == len(tree.starts) - 1
    assert (np.diff(compact.starts) == 10).all()


def test_signed_keys_sort_like_their_values():
    keys = np.array([3, -1, 0, -(2**63), 2**63 - 1, -1], np.int64)
    blocks = btree_blocks(keys, leaf_capacity=2)
    np.testing.assert_array_equal(blocks.order, [3, 1, 5, 2, 0, 4])
    np.testing.assert_array_equal(blocks.order, bulk_blocks(keys, leaf_capacity=2).order)


def test_many_keys_with_small_fanout_build_a_tall_valid_tree():
    keys = _keys("random", 200_000, seed=3)
    _check_invariants(keys, 10, 3)
    tree = btree_blocks(keys, fanout=3)
    bulk = bulk_blocks(keys, fanout=3)
    assert tree.height >= 9
    assert 0.5 <= tree.mean_leaf_fill < 1.0
    np.testing.assert_array_equal(tree.order, bulk.order)
    np.testing.assert_array_equal(tree.starts, bulk.starts)


def test_bulk_blocks_reports_full_leaves_and_static_height():
    blocks = bulk_blocks(np.arange(1000, dtype=np.uint64)[::-1], leaf_capacity=10, fanout=4)
    assert blocks.leaves_before_compaction == blocks.nblocks == 100
    assert blocks.mean_leaf_fill == 1.0
    assert blocks.height == 1 + 4  # 100 leaves -> 25 -> 7 -> 2 -> 1 index nodes


def test_repr_is_short_and_names_the_counts():
    text = repr(btree_blocks(np.arange(25, dtype=np.uint64)))
    assert text.startswith("LeafBlocks(n=25, blocks=3, height=2")
    assert "\n" not in text and len(text) < 120
    assert isinstance(bulk_blocks([1, 2]), LeafBlocks)


@pytest.mark.parametrize("func", [btree_blocks, bulk_blocks])
@pytest.mark.parametrize("keys,kwargs,error,match", [
    (np.zeros((3, 2), np.uint64), {}, InputError, r"keys must be 1-D .*got shape \(3, 2\)"),
    (np.zeros(0, np.uint64), {}, InputError, r"keys is empty"),
    (np.zeros(4, np.float64), {}, InputTypeError, r"integer dtype; got dtype float64.*uint64"),
    (np.zeros(4, bool), {}, InputTypeError, r"got dtype bool"),
    (np.zeros(4, np.uint64), {"leaf_capacity": 1}, InputError, r"leaf_capacity=1 .*2 <= leaf_capacity"),
    (np.zeros(4, np.uint64), {"leaf_capacity": 2.5}, InputTypeError, r"leaf_capacity must be an integer"),
    (np.zeros(4, np.uint64), {"fanout": 2}, InputError, r"fanout=2 .*3 <= fanout.*3 children"),
])
def test_bad_input_is_rejected_with_a_message_naming_the_parameter(func, keys, kwargs, error, match):
    with pytest.raises(error, match=match):
        func(keys, **kwargs)


def test_errors_are_also_builtin_exceptions():
    with pytest.raises(ValueError):
        btree_blocks([], leaf_capacity=10)
    with pytest.raises(TypeError):
        btree_blocks(["a"])
