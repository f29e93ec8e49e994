import math

import numpy as np
import pytest
from conftest import photon_set

from blockhash import BlockHashIndex, CapacityError, InputError, InputTypeError, OrphanWarning
from blockhash.evaluate.metrics import accuracy, exact_knn


@pytest.fixture(scope="module")
def small_index():
    return BlockHashIndex(photon_set("uniform", 5000), k=8, A=4)


# --- cKDTree-shaped results -------------------------------------------------------------

def test_query_shapes_follow_ckdtree(small_index):
    q = photon_set("uniform", 7, seed=1)
    d, i = small_index.query(q)
    assert d.shape == i.shape == (7, 8) and d.dtype == np.float64 and i.dtype == np.int64
    assert (np.diff(d, axis=1) >= 0).all()
    d1, i1 = small_index.query(q, k=1)
    assert d1.shape == i1.shape == (7,)
    ds, is_ = small_index.query(q[0])
    assert ds.shape == is_.shape == (8,)
    np.testing.assert_array_equal(is_, i[0])


def test_nan_query_gets_no_neighbours(small_index):
    q = np.array([[0.5, 0.5, 0.5], [np.nan, 0.1, 0.1], [np.inf, 0, 0]])
    d, i = small_index.query(q)
    assert np.isfinite(d[0]).all() and (i[0] < 5000).all()
    assert np.isinf(d[1:]).all() and (i[1:] == 5000).all()


def test_fewer_than_k_found_pads_with_inf_and_n():
    # Three clusters of one block each, one bucket per cluster and one ref per bucket:
    # a query in cluster 0 can only see its 10 photons.
    rng = np.random.default_rng(0)
    pts = np.concatenate([c + 0.01 * rng.random((10, 3)) for c in ([0, 0, 0], [1, 0, 0], [2, 0, 0])])
    index = BlockHashIndex(pts, k=5, A=8, L=1, P=(3, 1, 1), B=1, layout="marginal")
    d, i = index.query([[0.005, 0.005, 0.005]], k=15)
    assert np.isfinite(d[0, :10]).all() and (i[0, :10] < 30).all()
    assert np.isinf(d[0, 10:]).all() and (i[0, 10:] == 30).all()


def test_query_is_deterministic():
    pts = photon_set("caustic", 20000)
    q = photon_set("caustic", 300, seed=2)
    a = BlockHashIndex(pts, k=10, A=8).query(q)
    b = BlockHashIndex(pts, k=10, A=8).query(q)
    np.testing.assert_array_equal(a[1], b[1])


def test_positions_round_trip_to_the_callers_order():
    pts = photon_set("clustered", 3000)
    index = BlockHashIndex(pts, k=4)
    np.testing.assert_allclose(index.positions, pts, atol=1e-6)


# --- accuracy on caustic-like data (the targets at a test-sized N) ----------------

def test_default_preset_on_caustic_data_is_accurate_without_orphans():
    pts = photon_set("caustic", 200_000)
    q = photon_set("caustic", 5000, seed=11)
    index = BlockHashIndex(pts, k=50, A=8)
    acc = accuracy(index.query(q), exact_knn(index.positions, q, 50), len(index))
    assert index.stats.orphans == 0
    assert index.stats.refs_per_photon <= 2.5
    assert acc.fn_fraction <= 0.10
    assert acc.avg_dilation["mean"] <= 1.05


def test_accuracy_improves_with_A():
    pts = photon_set("caustic", 50_000)
    q = photon_set("caustic", 2000, seed=12)
    index = BlockHashIndex(pts, k=20, A=1)
    exact = exact_knn(index.positions, q, 20)
    fn = [accuracy(index.query(q, A=A), exact, len(index)).fn_fraction for A in (1, 2, 8)]
    assert fn[0] > fn[1] > fn[2]


def test_paper_preset_orphans_blocks_on_a_planar_caustic_and_says_so():
    with pytest.warns(OrphanWarning, match=r"photon blocks .* are in no hash table"):
        index = BlockHashIndex(photon_set("caustic", 100_000), k=50, A=8, preset="paper")
    assert index.stats.orphans > 0.3 * index.stats.blocks
    assert index.stats.summary().startswith("WARNING:")


# --- memory accounting (section 5) --------------------------------------------------------

@pytest.mark.filterwarnings("ignore::blockhash.OrphanWarning")
@pytest.mark.parametrize("n", [100_000, 400_000])
def test_paper_preset_overhead_matches_equations_1_and_2(n):
    k, A = 50, 16
    index = BlockHashIndex(photon_set("uniform", n), k=k, A=A, preset="paper")
    s = index.stats
    L, P, B = s.params.L, s.params.P[0], s.params.B
    # Equation (1) with the index's own L = P = round(ln N) and B; blocks are N/10 exactly
    # here.  The index stores the P - 1 interior thresholds per axis (t_0 and t_P are the
    # box faces, implicit), where the paper counts P + 1: 12 L (P - 1) bytes, not 12 L P.
    eq1 = (4 * B * L * P**3 + 12 * L * (P - 1) + 25.6 * n - 24 * n) / (24 * n)
    assert s.overhead == pytest.approx(eq1, rel=1e-12)
    # Equation (2) uses ln N and B = Ak/(10 ln N) unrounded: the rounding of L and P and
    # the ceiling of B move the reference term by at most these factors.
    lnN = math.log(n)
    eq2 = (4 * (A * k / 10) * lnN**3 + 12 * lnN**2 + 1.6 * n) / (24 * n)
    ref_ratio = (B * L * P**3) / ((A * k / (10 * lnN)) * lnN**4)
    assert 0.5 < ref_ratio < 2.0
    rounding = ((ref_ratio - 1) * 4 * (A * k / 10) * lnN**3 + 12 * L * (P - 1) - 12 * lnN**2) / (24 * n)
    assert s.overhead == pytest.approx(eq2 + rounding, rel=1e-9)


def test_stats_count_bytes_of_the_real_structure(small_index):
    s = small_index.stats
    prm = s.params
    assert s.block_bytes == small_index.block_words.nbytes
    assert s.reference_bytes == small_index.tables.refs.nbytes
    assert s.threshold_bytes == small_index.thresholds.nbytes
    assert s.priority_bytes == prm.L * prm.buckets * 4
    assert s.photon_bytes == 24 * 5000
    assert "overhead (eq. 1)" in s.summary()


# --- bad input ----------------------------------------------------------------------------

@pytest.mark.parametrize("positions,error,match", [
    (np.zeros((0, 3)), InputError, "empty"),
    (np.array([[0.0, np.nan, 0.0]] * 20), InputError, r"positions\[0\].*not finite"),
    (np.array([[0.0, np.inf, 0.0]] * 20), InputError, "not finite"),
    (np.zeros((20, 2)), InputError, r"shape \(n, 3\)"),
    (np.array([["a", "b", "c"]] * 20), InputTypeError, "numeric"),
])
def test_bad_positions_are_rejected(positions, error, match):
    with pytest.raises(error, match=match):
        BlockHashIndex(positions, k=1)


@pytest.mark.parametrize("kwargs,match", [
    ({"k": 0}, r"k=0 is out of range"),
    ({"k": 101}, r"k=101 .*N=100"),
    ({"A": 0}, r"A=0 is out of range"),
    ({"L": 0}, r"L=0"),
    ({"L": 65}, r"L=65"),
    ({"P": 0}, r"P\[0\]=0"),
    ({"P": (2, 2)}, r"one int or three"),
    ({"B": 0}, r"B=0"),
    ({"B": 257}, r"B=257"),
    ({"preset": "fast"}, r"preset='fast' is not known; choose one of default, paper"),
    ({"builder": "tree"}, r"builder='tree' is not known"),
    ({"layout": "grid"}, r"layout='grid' is not known; choose one of marginal, adaptive"),
    ({"layout": "nested"}, r"layout='nested' was retired: .* use layout='adaptive' or, for the "
                           r"paper's grid, layout='marginal'"),
    ({"k": 2.5}, r"k must be an integer"),
])
def test_bad_parameters_are_rejected(kwargs, match):
    with pytest.raises(InputError if "k" not in kwargs or kwargs["k"] != 2.5 else InputTypeError,
                       match=match):
        BlockHashIndex(photon_set("uniform", 100), **{"k": 4, **kwargs})


def test_index_too_large_is_a_capacity_error():
    with pytest.raises(CapacityError, match="block references"):
        BlockHashIndex(photon_set("uniform", 100), k=4, L=64, P=4096, B=256)


def test_mismatched_payload_is_rejected():
    with pytest.raises(InputError, match="powers"):
        BlockHashIndex(photon_set("uniform", 100), k=4, powers=np.ones((99, 3)))


@pytest.mark.parametrize("k", [0, 5001])
def test_bad_query_k_is_rejected(small_index, k):
    with pytest.raises(InputError, match=f"k={k:,}"):
        small_index.query(np.zeros((1, 3)), k=k)


def test_bad_query_shape_is_rejected(small_index):
    with pytest.raises(InputError, match=r"points must have shape \(n, 3\)"):
        small_index.query(np.zeros((4, 2)))


def test_an_index_without_tables_builds_them_on_first_use():
    """tables=False (the cover gather's render) builds the records only; the first query or
    stats build the same tables an eager index has."""
    pts = np.random.default_rng(4).random((5_000, 3))
    eager = BlockHashIndex(pts, k=8)
    lazy = BlockHashIndex(pts, k=8, tables=False)
    assert eager.tables_built and not lazy.tables_built
    np.testing.assert_array_equal(lazy.records.records, eager.records.records)
    np.testing.assert_array_equal(lazy.order, eager.order)
    d0, i0 = eager.query(pts[:50])
    d1, i1 = lazy.query(pts[:50])
    assert lazy.tables_built
    np.testing.assert_array_equal(i0, i1)
    np.testing.assert_array_equal(lazy.block_words, eager.block_words)
    assert lazy.stats.summary() == eager.stats.summary()
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        lazy.nothing
