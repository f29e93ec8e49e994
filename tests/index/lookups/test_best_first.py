"""The default preset's nearest-box-first walk: node boxes, far queries, the queue's rule."""

from dataclasses import replace

import numpy as np
import pytest
from conftest import photon_set, two_patches_and_far_points

from blockhash import BlockHashIndex, InputError
from blockhash.evaluate.metrics import exact_knn, false_negatives
from blockhash.index.lookups.walk import QUEUE_CAPACITY, bf_query, walk_cull
from blockhash.index.tables.params import DEFAULT_WALK_FLOOR, candidate_cap
from blockhash.index.tables.thresholds import LEAF, THRESHOLD_PAD

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)


@pytest.mark.slow
def test_node_boxes_are_tight_around_their_photons():
    index = BlockHashIndex(photon_set("clustered", 20_000), k=8, A=8)
    boxes, rows = index.node_boxes, index.thresholds
    pos = index._positions
    from blockhash.index.tables.adaptive import build_adaptive

    _, keys, _ = build_adaptive(index.records.records[:, :3], L=index.params.L,
                                photons_per_bucket=index.params.bucket_photons,
                                scale=index.quantizer.step)
    for t in range(index.params.L):
        nn = rows.shape[1] // 2
        np.testing.assert_array_equal(boxes[t, 0, :3], pos.min(axis=0))  # the root: every photon
        np.testing.assert_array_equal(boxes[t, 0, 3:], pos.max(axis=0))
        for i in range(nn):
            meta = rows[t, 2 * i + 1]
            if meta == THRESHOLD_PAD:
                assert boxes[t, i, 0] > boxes[t, i, 3]  # padding: empty
            elif meta & LEAF:
                mine = pos[keys[t] == meta >> 3]  # the bucket's photons, tight
                np.testing.assert_array_equal(boxes[t, i, :3], mine.min(axis=0))
                np.testing.assert_array_equal(boxes[t, i, 3:], mine.max(axis=0))
            else:
                c = int(meta >> 3)
                np.testing.assert_array_equal(boxes[t, i, :3], boxes[t, c:c + 2, :3].min(axis=0))
                np.testing.assert_array_equal(boxes[t, i, 3:], boxes[t, c:c + 2, 3:].max(axis=0))


def test_far_queries_find_their_exact_neighbours_where_hashing_did_not():
    pts, q = two_patches_and_far_points()
    index = BlockHashIndex(pts, k=20, A=32)
    _, ei = exact_knn(index.positions, q, 20)
    _, walked = index.query(q)
    _, hashed = index.reference_query(q, best_first=False)
    fn_walk = false_negatives(walked, ei, len(pts)).mean() / 20
    fn_hash = false_negatives(hashed, ei, len(pts)).mean() / 20
    assert fn_walk <= 0.005, f"the walk missed {fn_walk:.1%}"   # measured 0.1%
    assert fn_hash >= 0.10, f"hashing now misses only {fn_hash:.1%}: make the case harder"  # 14.7%


def test_the_walk_stops_at_the_candidate_cap_and_without_k_neighbours_prunes_nothing():
    index = BlockHashIndex(photon_set("uniform", 20_000), k=8, A=2)
    q = photon_set("uniform", 200, seed=4).astype(np.float32)
    index.query(q)
    # k = 8 is below the walk's floor: the cap is A * walk_floor, not A * k
    assert candidate_cap(index.params, 8, 2) == 2 * index.params.walk_floor == 40
    assert index.counters["query.candidates.mean"] <= 40 + 9
    d, i = index.query(q, k=1, A=1)  # one candidate block is enough
    assert np.isfinite(d).all()


def test_below_its_floor_the_walk_takes_more_candidates_over_every_table():
    """k = 1 at A = 8: the A k cap alone takes 8 candidates, less than one block, and walks
    one table whose buckets lost some of their blocks; the floor fixes both."""
    pts = photon_set("uniform", 50_000)
    q = photon_set("uniform", 2_000, seed=6).astype(np.float32)
    index = BlockHashIndex(pts, k=1, A=8)
    prm = index.params
    assert prm.walk_floor == DEFAULT_WALK_FLOOR and prm.walk_tables(1) == prm.L
    assert prm.walk_tables(DEFAULT_WALK_FLOOR) == prm.trees_walked == 1
    _, exact = exact_knn(index.positions, q, 1)
    _, found = index.query(q, k=1)
    floored = false_negatives(found.reshape(-1, 1), exact, len(pts)).mean()
    index.params = replace(prm, walk_floor=0)
    _, found = index.query(q, k=1)
    capped = false_negatives(found.reshape(-1, 1), exact, len(pts)).mean()
    assert capped > 0.5 and floored < 0.05, (capped, floored)
    # at and above the floor nothing changes
    assert candidate_cap(prm, 50, 8) == 400 and candidate_cap(prm, 1, 8, "hash") == 8


def test_a_full_queue_drops_its_farthest_entries_and_counts_them():
    pts, q = two_patches_and_far_points()
    index = BlockHashIndex(pts, k=20, A=8)
    args = (q, index.thresholds, index.node_boxes, index.tables.refs, index.starts,
            index._positions, 20, 160, 0)
    # Walking all L tables fills the queue (one table's walk held at most 20 entries here).
    full = bf_query(*args, QUEUE_CAPACITY, trees=index.params.L, cull=walk_cull(index))
    small = bf_query(*args, 32, trees=index.params.L, cull=walk_cull(index))
    assert full[5].sum() == 0 and small[5].sum() > 0  # drops
    assert small[6].max() == 32 and full[6].max() > 32  # longest queue
    # Dropping the farthest entries costs little: the walk rarely reaches them.
    _, ei = exact_knn(index.positions, q, 20)
    to_idx = lambda slots: np.where(slots >= 0, index.order[np.maximum(slots, 0)], len(pts))
    fn = [false_negatives(to_idx(r[1]), ei, len(pts)).mean() / 20 for r in (full, small)]
    assert fn[1] <= fn[0] + 0.01, f"queue of {QUEUE_CAPACITY}: {fn[0]:.2%}, of 32: {fn[1]:.2%}"


def test_best_first_on_a_grid_layout_is_refused_with_the_way_out():
    index = BlockHashIndex(photon_set("uniform", 3000), k=8, A=4, preset="paper")
    assert not index.params.best_first and index.node_boxes is None
    with pytest.raises(InputError, match=r"best_first=True needs the adaptive layout's node boxes; "
                                         r"this index has the marginal layout.*best_first=False"):
        index.reference_query(np.zeros((2, 3)), best_first=True)


@pytest.mark.slow
def test_stats_count_the_node_boxes():
    index = BlockHashIndex(photon_set("uniform", 5000), k=8, A=4)
    assert index.stats.cell_bytes == 0  # the cells are built on first use only
    index.cells
    s = index.stats
    assert s.box_bytes == index.node_boxes.nbytes > 0
    assert s.cell_bytes == index.cells.nbytes > 0
    assert s.index_bytes == (s.reference_bytes + s.threshold_bytes + s.priority_bytes
                             + s.box_bytes + s.cell_bytes)
    assert "nearest-box-first" in repr(index.params)


def test_a_queue_capacity_the_shader_cannot_scan_is_refused_before_compiling(monkeypatch):
    import blockhash.gl.lookup as lookup_module
    from blockhash.gl.shaderlib import Variant

    index = BlockHashIndex(photon_set("uniform", 3000), k=8, A=4)
    lookup = object.__new__(lookup_module.GLLookup)  # defines() needs no context
    lookup.index, lookup.packed = index, type("P", (), {"widths": {}})()
    assert lookup.defines(Variant(), 8, 32)["BH_QUEUE"] == QUEUE_CAPACITY
    monkeypatch.setattr(lookup_module, "QUEUE_CAPACITY", 100)
    with pytest.raises(InputError, match=r"QUEUE_CAPACITY=100 must be a positive multiple of 32.*"
                                         r"round it up"):
        lookup.defines(Variant(), 8, 32)


def test_the_walk_has_no_block_cap_and_its_bound_is_tight():
    from blockhash.index.lookups.walk import walk_taken_bound

    index = BlockHashIndex(photon_set("clustered", 6000), k=8, A=2)
    prm = index.params
    q = photon_set("clustered", 300, seed=4).astype(np.float32)
    for A in (2, 16, 64):
        cap = A * 8
        *_, fetched, _, _, _ = bf_query(q, index.thresholds, index.node_boxes, index.tables.refs,
                                        index.starts, index._positions, 8, cap, 0,
                                        cull=walk_cull(index))
        assert fetched.max() <= walk_taken_bound(prm.B, cap)
        if A < 64:  # at A = 64 the walk prunes and culls its way to an end before the cap
            assert fetched.max() >= walk_taken_bound(prm.B, cap) - 1  # the bound is tight
    # k = 16 (culled blocks are not taken: at k = 8 a walk here ends within L * B blocks).
    *_, fetched, _, _, _ = bf_query(q, index.thresholds, index.node_boxes, index.tables.refs,
                                    index.starts, index._positions, 16, 16 * 16, 0,
                                    cull=walk_cull(index))
    assert fetched.max() > prm.L * prm.B  # the hash query's block cap would have stopped it


def test_walk_trees_seeds_the_walk_with_that_many_tables():
    index = BlockHashIndex(photon_set("clustered", 6000), k=8, A=8)
    prm = index.params
    assert prm.walk_trees == 1 and prm.trees_walked == 1 and "nearest-box-first over 1" in repr(prm)
    assert replace(prm, walk_trees=99).trees_walked == prm.L
    q = photon_set("clustered", 200, seed=4).astype(np.float32)
    pops = []
    for trees in (1, 3, prm.L, 99):
        index.reference_query(q, walk_trees=trees)
        pops.append(index.counters["query.pops.mean"])
    assert pops[0] < pops[1] < pops[2] == pops[3]
    # The params' tables: one at or above the walk's floor, all L below it (k = 8 here).
    np.testing.assert_array_equal(index.query(q, k=32)[1], index.reference_query(q, k=32, walk_trees=1)[1])
    np.testing.assert_array_equal(index.query(q)[1], index.reference_query(q, walk_trees=prm.L)[1])
    with pytest.raises(InputError, match=r"walk_trees=0 must be >= 1"):
        replace(prm, walk_trees=0)
    with pytest.raises(InputError, match=r"walk_trees"):
        index.reference_query(q, walk_trees=0)
