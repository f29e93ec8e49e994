"""The CPU index at the extremes: correct within the stated bounds, or a clear error.

Each case is listed in docs/extremes.md with the bound or the error it gets.
"""

import warnings

import numpy as np
import pytest
from scipy.spatial import cKDTree

from blockhash import BlockHashIndex, CapacityError, InputError, OrphanWarning
from blockhash.index.records.codec import decode_powers, encode_powers
from blockhash.index.records.fixedpoint import MIN_RESOLVED_EXTENT, Quantizer
from blockhash.index.tables.params import MAX_B, MAX_L, candidate_cap

EPS32 = 2.0**-24  # one float32 rounding, relative


def exhaustive(positions, k, **kw):
    """An index whose single bucket holds every block: the query examines all photons."""
    n = len(positions)
    blocks = -(-n // 10)
    with warnings.catch_warnings():
        warnings.simplefilter("error", OrphanWarning)
        return BlockHashIndex(positions, k=k, A=-(-n // k) + 1, preset="paper", L=1, P=1,
                              B=blocks, **kw)


def distance_tolerance(index, q):
    """Bound on |BH distance - exact float64 distance| of one neighbour: the decode
    error of the photon and of the float32 query, plus the float32 distance rounding."""
    eps = np.linalg.norm(index.quantizer.decode_error)
    return eps + np.sqrt(3) * EPS32 * np.abs(q).max() * 2


def assert_valid_result(index, q, d, i, k):
    """cKDTree-shaped, sorted, no photon twice, missing slots inf and N."""
    n = len(index)
    assert d.shape == i.shape == ((len(q), k) if k > 1 else (len(q),))
    d, i = d.reshape(len(q), k), i.reshape(len(q), k)
    assert np.all(d[:, 1:] >= d[:, :-1])
    assert np.all((i == n) == np.isinf(d))
    assert not np.isnan(d).any()
    for row in i:
        found = row[row < n]
        assert len(np.unique(found)) == len(found)


def assert_within_bound_of_exact(index, positions, q, d, i, k):
    """Every returned distance is the true distance of that photon within the bound, and
    the distance at rank r is never below the exact distance at rank r minus the bound."""
    tol = distance_tolerance(index, q)
    exact, _ = cKDTree(positions).query(q, k=k)
    exact = exact.reshape(len(q), k)
    d, i = d.reshape(len(q), k), i.reshape(len(q), k)
    found = i < len(positions)
    true = np.linalg.norm(positions[np.minimum(i, len(positions) - 1)] - q[:, None, :], axis=2)
    assert np.all(np.abs(true - d)[found] <= tol)
    assert np.all(d[found] >= exact[found] - tol)


# --------------------------------------------------------------------------- k, N and A

@pytest.mark.parametrize("n", [1, 2, 10, 11])
def test_tiny_maps_return_the_exact_neighbours(n):
    pts = np.random.default_rng(n).random((n, 3))
    index = BlockHashIndex(pts, k=n, A=8)
    q = np.random.default_rng(99).random((20, 3))
    d, i = index.query(q, k=n)
    assert_valid_result(index, q, d, i, n)
    de, ie = cKDTree(pts).query(q, k=n)
    np.testing.assert_array_equal(np.sort(np.reshape(i, (20, n)), 1), np.sort(np.reshape(ie, (20, n)), 1))


def test_k_equal_to_n_returns_every_photon():
    pts = np.random.default_rng(0).random((300, 3))
    index = exhaustive(pts, 300)
    d, i = index.query(pts[:5], k=300)
    assert np.all(np.sort(i, axis=1) == np.arange(300))


def test_k_1_returns_the_nearest_photon_squeezed_like_ckdtree():
    pts = np.random.default_rng(0).random((1000, 3))
    index = exhaustive(pts, 1)
    d, i = index.query(pts[:50], k=1)
    assert d.shape == i.shape == (50,)
    np.testing.assert_array_equal(i, np.arange(50))
    assert np.all(d <= np.linalg.norm(index.quantizer.decode_error))


def test_k_above_n_is_an_error_not_padding():
    index = BlockHashIndex(np.random.default_rng(0).random((10, 3)), k=10)
    with pytest.raises(InputError, match=r"k=11 is out of range; allowed 1 <= k <= 10; use k <= N=10"):
        index.query(np.zeros((1, 3)), k=11)
    with pytest.raises(InputError, match=r"k=11 is out of range.*add photons"):
        BlockHashIndex(np.zeros((10, 3)), k=11)


def test_A_1_examines_at_most_k_plus_one_block():
    pts = np.random.default_rng(0).random((5000, 3))
    index = BlockHashIndex(pts, k=8, A=1)
    d, i = index.query(pts[:200])
    assert_valid_result(index, pts[:200], d, i, 8)
    # below the walk's floor the cap is A * walk_floor candidates (20 here), not A * k
    cap = candidate_cap(index.params, 8, 1)
    assert cap == index.params.walk_floor
    assert index.counters["query.candidates.mean"] <= cap + 10


def test_huge_A_examines_everything_it_reaches_and_is_exact_on_a_small_map():
    pts = np.random.default_rng(1).random((1000, 3))
    index = BlockHashIndex(pts, k=8, A=10**6)  # one bucket: every block is a candidate
    q = np.random.default_rng(2).random((100, 3))
    d, i = index.query(q)
    np.testing.assert_array_equal(i, cKDTree(pts).query(q, k=8)[1])


@pytest.mark.parametrize("bad, match", [(0, r"A=0 is out of range; allowed 1 <= A"),
                                        (-3, r"A=-3 is out of range")])
def test_A_below_1_is_an_error(bad, match):
    with pytest.raises(InputError, match=match):
        BlockHashIndex(np.zeros((20, 3)), k=2, A=bad)


# --------------------------------------------------------------------------- degenerate sets

def _line(rng, n):
    t = rng.random(n)
    return np.stack([t, 0.5 * t + 0.1, -2 * t], axis=1)


def _axis_plane(rng, n):
    p = rng.random((n, 3))
    p[:, 1] = 0.25
    return p


def _tilted_plane(rng, n):
    u, v = rng.random(n), rng.random(n)
    a, b = np.array([1.0, 0.3, 0.2]), np.array([-0.2, 0.4, 1.0])
    return u[:, None] * a + v[:, None] * b


def _duplicates(rng, n):
    return np.repeat(rng.random((n // 25, 3)), 25, axis=0)


def _contrast(rng, n):
    """A 10^6 : 1 density contrast: a cusp 10^-2 m across holding half the photons
    inside a 1 m background: (0.5 / 1e-6) / (0.5 / 1) = 10^6."""
    cusp = 0.5 + 0.01 * rng.random((n // 2, 3))
    return np.concatenate([cusp, rng.random((n - n // 2, 3))])


SHAPES = {"line": _line, "axis-plane": _axis_plane, "tilted-plane": _tilted_plane,
          "duplicates": _duplicates, "contrast-1e6": _contrast}


@pytest.mark.parametrize("shape", sorted(SHAPES))
def test_degenerate_sets_stay_within_the_bound_and_find_most_neighbours(shape):
    rng = np.random.default_rng(5)
    pts = SHAPES[shape](rng, 20_000)
    index = BlockHashIndex(pts, k=16, A=8)
    q = pts[rng.choice(len(pts), 300, replace=False)] + rng.normal(0, 1e-3, (300, 3))
    d, i = index.query(q)
    assert_valid_result(index, q, d, i, 16)
    assert_within_bound_of_exact(index, pts, q, d, i, 16)
    assert index.stats.orphans == 0
    # Recall (share of the exact k nearest found, distance ties counted as found).
    exact = cKDTree(pts).query(q, k=16)[0]
    found = (d <= exact[:, -1:] + distance_tolerance(index, q)).sum(axis=1)
    assert found.mean() / 16 >= 0.75


def test_all_photons_at_one_point():
    pts = np.full((5000, 3), [0.3, -1.0, 2.0])
    with pytest.warns(OrphanWarning, match=r"one bucket that no cut splits\): raise A"):
        index = BlockHashIndex(pts, k=50, A=8)
    q = np.array([[0.3, -1.0, 2.0], [0.3, -1.0, 2.5], [1e6, 0, 0]])
    d, i = index.query(q)
    assert_valid_result(index, q, d, i, 50)
    assert np.all(i < 5000)
    np.testing.assert_allclose(d[:, 0], [0.0, 0.5, np.linalg.norm(q[2] - pts[0])], rtol=1e-6, atol=1e-6)


# --------------------------------------------------------------------------- scale and offset

@pytest.mark.parametrize("scale, offset", [(1e-3, 0.0), (1.0, 0.0), (1e4, 0.0), (1.0, 1e4), (1e4, 1e4), (0.1, 1e4),
                                           (10.0, -1e4), (1e-3, 1.0)])
def test_decode_error_and_neighbours_within_the_stated_bound(scale, offset):
    rng = np.random.default_rng(3)
    pts = rng.random((2500, 3)) * scale + offset
    index = exhaustive(pts, 8)
    bound = index.quantizer.decode_error
    err = np.abs(index.positions.astype(np.float64) - pts)
    assert np.all(err <= bound)
    # The bound is about 2.4e-7 of (box size + distance from the origin), not loose.
    assert np.all(bound <= 5e-7 * (scale + abs(offset)) + index.quantizer.step)
    q = pts[:300] + rng.normal(0, 0.01 * scale, (300, 3))
    d, i = index.query(q)
    assert_valid_result(index, q, d, i, 8)
    assert_within_bound_of_exact(index, pts, q, d, i, 8)


@pytest.mark.parametrize("span, offset", [(1e-39, 0.0), (1e-12, 0.0), (1e-3, 1e4)])
def test_boxes_float32_cannot_resolve_are_refused(span, offset):
    pts = np.random.default_rng(0).random((2000, 3)) * span + offset
    with pytest.raises(InputError, match=r"positions span only .* m \(photon box \[\[.*\]\]\), but "
                                         r"float32 fixed point there resolves positions to .* m; "
                                         r"the box must span at least 16 times that.*larger units"):
        BlockHashIndex(pts, k=8)


def test_the_smallest_resolvable_box_builds():
    q0 = Quantizer.for_points(np.array([[0.0, 0, 0], [1e-6, 0, 0]]))
    span = 2 * MIN_RESOLVED_EXTENT * q0.decode_error.max()
    pts = np.random.default_rng(0).random((500, 3)) * span
    index = BlockHashIndex(pts, k=4)
    assert len(index) == 500


# --------------------------------------------------------------------------- queries

def threshold_codes(index):
    """Codes that are thresholds of the first table (marginal grid, or the adaptive tree)."""
    row = index.thresholds[0]
    if index.params.layout.name == "ADAPTIVE":  # pairs (threshold, meta); meta bit 2: a leaf
        inner = (row[1::2] & 4) == 0
        return row[0::2][inner][:24].astype(np.uint32)
    return row[:24].astype(np.uint32)


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("layout", ["marginal", "adaptive"])
def test_queries_on_thresholds_outside_far_away_and_not_finite(layout):
    rng = np.random.default_rng(4)
    pts = rng.random((20_000, 3))
    grid = {"P": (8, 8, 8), "layout": "marginal"} if layout == "marginal" else {}
    index = BlockHashIndex(pts, k=8, A=8, **grid)
    assert index.params.layout.name == layout.upper()
    # Points whose hash codes equal threshold codes (the bucket borders), up to float32.
    thr = threshold_codes(index)
    assert len(thr) > 3
    on = index.quantizer.decode(np.stack([thr, thr, thr], axis=1))
    far = np.array([[1e30, 0, 0], [-1e30, 5, 5], [3.0, 3.0, 3.0], [-0.5, 0.5, 0.5]])
    bad = np.array([[np.nan, 0, 0], [np.inf, 0, 0], [0, -np.inf, 0]])
    q = np.concatenate([on, far, bad]).astype(np.float32)
    d, i = index.query(q)
    assert_valid_result(index, q, d, i, 8)
    m = len(on)
    assert np.all(i[:m] < len(pts)) and np.all(i[m + 2:m + 4] < len(pts))  # outside: found
    # 1e30 m away the float32 squared distance overflows: no neighbours, never (inf, a photon).
    assert np.all(np.isinf(d[m:m + 2])) and np.all(i[m:m + 2] == len(pts))
    assert np.all(np.isinf(d[-3:])) and np.all(i[-3:] == len(pts))
    assert_within_bound_of_exact(index, pts, q[:len(on)], d[:len(on)], i[:len(on)], 8)


# --------------------------------------------------------------------------- powers

@pytest.mark.parametrize("watts", [1e-9, 1e-3, 1.0, 1e3, 1e9])
def test_photon_powers_keep_float16_precision_at_any_magnitude(watts):
    p = np.random.default_rng(0).random((1000, 3)) * watts + watts
    bits, scale = encode_powers(p)
    back = decode_powers(bits, scale, dtype=np.float64)[:, :3]
    assert np.isfinite(back).all() and (back > 0).all()
    np.testing.assert_allclose(back, p, rtol=2.0**-11)


def test_powers_spanning_1e_9_to_1e9_in_one_map_have_the_stated_absolute_bound():
    p = np.array([[1e-9, 1.0, 1e9], [1e9, 1e9, 1e9]])
    bits, scale = encode_powers(p)
    back = decode_powers(bits, scale, dtype=np.float64)[:, :3]
    assert np.isfinite(back).all()
    assert np.all(np.abs(back - p) <= np.maximum(2.0**-11 * p, 2.0**-25 * scale))
    assert back[0, 2] == pytest.approx(1e9, rel=2.0**-11)


# --------------------------------------------------------------------------- L, P, B

@pytest.mark.filterwarnings("ignore::blockhash.OrphanWarning")
@pytest.mark.parametrize("L, B", [(1, 1), (MAX_L, 1), (1, MAX_B), (4, MAX_B)])
def test_L_and_B_at_their_limits_build_and_query(L, B):
    pts = np.random.default_rng(0).random((4000, 3))
    index = BlockHashIndex(pts, k=8, A=4, L=L, B=B)
    d, i = index.query(pts[:100])
    assert_valid_result(index, pts[:100], d, i, 8)
    assert index.params.L == L and index.params.B == B


@pytest.mark.parametrize("kw, match", [
    ({"L": 0}, r"L=0 is out of range; allowed 1 <= L <= 64"),
    ({"L": MAX_L + 1}, r"L=65 is out of range; allowed 1 <= L <= 64"),
    ({"B": 0}, r"B=0 is out of range; allowed 1 <= B <= 256"),
    ({"B": MAX_B + 1}, r"B=257 is out of range; allowed 1 <= B <= 256"),
    ({"P": 0}, r"P\[0\]=0 is out of range; allowed 1 <= P\[0\] <= 4,096"),
    ({"P": 4097}, r"P\[0\]=4,097 is out of range"),
])
def test_L_P_B_beyond_their_limits_are_errors(kw, match):
    with pytest.raises(InputError, match=match):
        BlockHashIndex(np.random.default_rng(0).random((100, 3)), k=4, **kw)


def test_largest_P_is_refused_by_the_reference_budget_before_allocating():
    with pytest.raises(CapacityError, match=r"needs [\d,]+ block references > 268,435,456; use smaller P, L or B"):
        BlockHashIndex(np.random.default_rng(0).random((100, 3)), k=4, P=4096, layout="marginal")


def test_tables_too_small_orphan_blocks_and_say_so():
    pts = np.random.default_rng(0).random((20_000, 3))
    with pytest.warns(OrphanWarning, match=r"[\d,]+ of 2,000 photon blocks \([\d,]+ photons\) are in no "
                                           r"hash table and can never be found.*raise B or L"):
        index = BlockHashIndex(pts, k=8, A=8, preset="paper", B=1, L=1)
    s = index.stats
    assert s.orphans > 0 and s.orphan_photons >= 10 * (s.orphans - 1)
    assert s.summary().startswith(f"WARNING: {s.orphans:,} orphaned blocks")
