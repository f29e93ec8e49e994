"""The CPU reference query against a literal transcription of section 4.4 and against cKDTree."""

from dataclasses import replace

import numpy as np
import pytest
from conftest import photon_set
from scipy.spatial import cKDTree
from transcription import transcribed_query, walked_query

from blockhash import BlockHashIndex
from blockhash.index.tables.thresholds import ThresholdLayout, hash_codes


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::blockhash.OrphanWarning")  # the paper preset orphans blocks
@pytest.mark.parametrize("k,A", [(1, 1), (8, 1), (8, 8), (50, 8), (50, 16)])
@pytest.mark.parametrize("preset", ["default", "paper"])
def test_reference_query_follows_section_4_4(distribution, k, A, preset):
    pts = photon_set(distribution, 6000)
    index = BlockHashIndex(pts, k=k, A=A, preset=preset)
    queries = photon_set(distribution, 40, seed=99)
    d, i = index.query(queries, k=[k] and k)
    d = d.reshape(len(queries), k)
    i = i.reshape(len(queries), k)
    slot_of = np.empty(len(index), dtype=np.int64)
    slot_of[index.order] = np.arange(len(index))
    for qi, q in enumerate(queries):
        slots, d2 = transcribed_query(index, q, k, A)
        found = i[qi] < len(index)
        assert slot_of[i[qi][found]].tolist() == slots
        np.testing.assert_array_equal(d[qi][found], np.sqrt(np.float64(np.float32(d2))))
        assert np.isinf(d[qi][~found]).all()


@pytest.mark.slow
@pytest.mark.parametrize("k,A", [(8, 8), (50, 16)])
@pytest.mark.parametrize("trees", [1, 2, 5])
def test_the_walk_follows_its_transcription_over_any_number_of_tables(k, A, trees):
    pts = photon_set("clustered", 6000)
    index = BlockHashIndex(pts, k=k, A=A)
    assert index.params.best_first and index.params.L == 5
    queries = photon_set("clustered", 40, seed=99)
    queries[::4] += 0.5  # some far from the photons: the walk prunes
    d, i = index.reference_query(queries, k=[k] and k, walk_trees=trees)
    slot_of = np.empty(len(index), dtype=np.int64)
    slot_of[index.order] = np.arange(len(index))
    for qi, q in enumerate(queries):
        slots, d2 = walked_query(index, q, k, A, trees)
        found = i[qi] < len(index)
        assert slot_of[i[qi][found]].tolist() == slots
        np.testing.assert_array_equal(d[qi][found], np.sqrt(np.float64(np.float32(d2))))


def test_one_bucket_holding_every_block_gives_the_exact_neighbours(distribution):
    pts = photon_set(distribution, 2500)  # 250 blocks, all in one bucket of 256 slots
    index = BlockHashIndex(pts, k=20, A=1000, L=1, P=1, B=256)
    queries = photon_set(distribution, 200, seed=5)
    d, i = index.query(queries)
    ed, ei = cKDTree(index.positions.astype(np.float64)).query(queries.astype(np.float32), k=20)
    np.testing.assert_allclose(d, ed, rtol=1e-6, atol=1e-9)
    assert (np.sort(i, axis=1) == np.sort(ei, axis=1)).mean() > 0.999  # float ties only


def test_builders_give_identical_answers():
    pts = photon_set("caustic", 20000)
    q = photon_set("caustic", 500, seed=3)
    a = BlockHashIndex(pts, k=16, A=4, builder="bulk").query(q)
    b = BlockHashIndex(pts, k=16, A=4, builder="btree").query(q)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])


def test_examined_candidates_stop_after_A_k_plus_one_block():
    index = BlockHashIndex(photon_set("uniform", 20000), k=10, A=2)
    index.params = replace(index.params, walk_floor=0)  # the A k cap alone
    index.query(photon_set("uniform", 300, seed=4))
    assert index.counters["query.candidates.mean"] <= 2 * 10 + 9


@pytest.mark.parametrize("layout", ["marginal"])
def test_query_hashes_a_photon_to_the_buckets_that_hold_its_block(layout):
    pts = photon_set("clustered", 5000)
    index = BlockHashIndex(pts, k=10, A=8, layout=layout, B=64)
    prm = index.params
    codes = index.records.records[:, :3]
    keys = hash_codes(codes, index.thresholds, prm.P, ThresholdLayout[layout.upper()])
    block = np.repeat(np.arange(len(index.starts) - 1), np.diff(index.starts))
    # With room to spare nothing overflows, so each photon's block is in each of its buckets.
    assert index.stats.overflowing_buckets == 0
    for t in range(prm.L):
        assert all(block[s] in index.tables.refs[t, keys[t, s]] for s in range(0, len(block), 97))


@pytest.mark.filterwarnings("ignore::blockhash.OrphanWarning")  # the paper's grid at N = 20,000
@pytest.mark.parametrize("preset,layout_rounds", [("default", None), ("paper", 1)])
def test_the_hash_query_counts_its_dependent_fetch_rounds(preset, layout_rounds):
    """Rounds = the deepest table's threshold chain + the bucket + the blocks: an adaptive
    row's depth (followed here node by node), or one for the marginal layout's thresholds."""
    from blockhash.index.tables.thresholds import LEAF

    pts = photon_set("clustered", 20_000)
    index = BlockHashIndex(pts, k=8, A=8, preset=preset)
    q = photon_set("clustered", 200, seed=5)
    index.query(q, lookup="hash")
    if layout_rounds is None:
        codes = index.quantizer.quantize_query(q.astype(np.float32))
        deepest = []
        for c in codes:
            depths = []
            for row in index.thresholds:
                i, depth = 0, 1
                while not row[2 * i + 1] & LEAF:
                    meta = int(row[2 * i + 1])
                    i = (meta >> 3) + int(c[meta & 3] >= row[2 * i])
                    depth += 1
                depths.append(depth)
            deepest.append(max(depths))
        expect = np.array(deepest) + 2
    else:
        expect = np.full(len(q), layout_rounds + 2)
    assert index.counters["query.rounds.mean"] == pytest.approx(expect.mean())
    assert index.counters["query.rounds.max"] == expect.max()


def test_query_keeps_the_ckdtree_contract_and_the_oracle_switches_warn():
    import warnings

    from blockhash import BlockHashIndex

    pts = np.random.default_rng(4).random((3000, 3))
    index = BlockHashIndex(pts, k=8)
    q = pts[:50] + 0.001
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d, i = index.query(q, 8, A=4)
    d2, i2 = index.reference_query(q, 8, A=4)
    np.testing.assert_array_equal(i, i2)
    with pytest.warns(DeprecationWarning, match="reference_query"):
        _, old = index.query(q, 8, best_first=False)
    np.testing.assert_array_equal(old, index.reference_query(q, 8, best_first=False)[1])
    with pytest.raises(TypeError, match="unexpected keyword"):
        index.query(q, 8, eps=0.1)
