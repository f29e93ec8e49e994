"""The cover gather (blockhash/index/lookups/cover.py) finds exactly the photons whose own discs cover a
point: its CPU reference against cKDTree.query_ball_point per octave, on every synthetic map,
near the photons and far from them, and on radii that span many octaves."""

import numpy as np
import pytest
from conftest import photon_set
from scipy.spatial import cKDTree

from blockhash.errors import InputError
from blockhash.frame.photon_radius import exact_radii2
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.index.lookups.cover import CoverGather, octave_sides

#: Distances within this relative margin of a radius may fall either way between the
#: float32 test of the reference and the float64 oracle.
BORDER = 1e-5


def oracle(positions, r2, octave, q):
    """Per point, the set of photons with |p - q| < h, from one cKDTree per octave."""
    pos = np.asarray(positions, dtype=np.float64)
    h = np.sqrt(r2)
    found = [set() for _ in range(len(q))]
    border = [set() for _ in range(len(q))]
    for level in np.unique(octave):
        members = np.flatnonzero(octave == level)
        tree = cKDTree(pos[members])
        for i, hits in enumerate(tree.query_ball_point(q, r=h[members].max() * (1 + BORDER))):
            hits = members[np.asarray(hits, dtype=np.int64)]
            d = np.linalg.norm(pos[hits] - q[i], axis=1)
            found[i] |= set(hits[d < h[hits] * (1 - BORDER)].tolist())
            border[i] |= set(hits[np.abs(d - h[hits]) <= h[hits] * BORDER].tolist())
    return found, border


def assert_matches_oracle(index, r2, q):
    gather = CoverGather.build(index, r2)
    cov = gather.query(q)
    octave = np.empty(len(index), dtype=np.int64)
    octave[gather.photon] = gather.octave
    keep = np.isfinite(r2)
    truth, border = oracle(index.positions[keep], r2[keep], octave[keep],
                           q.astype(np.float32).astype(np.float64))
    ids = np.flatnonzero(keep)
    for i in range(len(q)):
        got = set(gather.photon[cov.records[cov.offsets[i]:cov.offsets[i + 1]]].tolist())
        want = {int(ids[j]) for j in truth[i]}
        maybe = {int(ids[j]) for j in border[i]}
        assert want <= got <= want | maybe, (i, sorted(want ^ got)[:10])
    return gather, cov


def queries(index, rng, m=400):
    """Points near the photons (jittered photon positions) and far from them (uniform in a box
    twice the photons' span)."""
    pos = index.positions.astype(np.float64)
    lo, hi = pos.min(0), pos.max(0)
    span = np.maximum(hi - lo, 1e-3)
    near = pos[rng.integers(0, len(pos), m // 2)] + rng.normal(0, 0.002, (m // 2, 3)) * span
    far = rng.uniform(lo - span / 2, hi + span / 2, (m // 2, 3))
    return np.vstack([near, far]).astype(np.float32)


@pytest.mark.parametrize("k", [10, 50])
def test_the_reference_equals_the_oracle_on_every_map(distribution, k, rng):
    index = BlockHashIndex(photon_set(distribution, 20_000), k=k)
    r2 = exact_radii2(index, k)
    gather, cov = assert_matches_oracle(index, r2, queries(index, rng))
    assert cov.counts[:200].mean() > 1  # the near points are covered
    assert (cov.candidates >= cov.counts).all()
    assert len(gather.octaves) >= 2


@pytest.mark.filterwarnings("ignore::blockhash.index.block_hash_index.OrphanWarning")
def test_radii_that_span_many_octaves(rng):
    """A far photon with a huge radius and photons piled at one point (their radius floors at
    the position error) are found like every other; none is left out."""
    base = photon_set("caustic", 5_000)
    piled = np.repeat(base[:1], 300, axis=0)
    far = base.mean(0, keepdims=True) + 50.0
    pos = np.vstack([base, piled, far])
    index = BlockHashIndex(pos, k=16)
    r2 = exact_radii2(index, 16)
    assert r2[-1] > 100.0 and r2[5_000] == r2.min()
    q = np.vstack([queries(index, rng), pos[:1], pos[-1:] + 1.0]).astype(np.float32)
    gather, cov = assert_matches_oracle(index, r2, q)
    assert gather.left_out == 0 and len(gather) == len(pos)
    assert len(gather.octaves) >= 8
    assert gather.octaves[-1] == len(octave_sides()) - 1  # the far photon: the top octave
    assert cov.counts[-1] >= 1  # beside the far photon, still under its disc
    assert cov.counts[-2] >= 300  # the pile covers its own point


def test_an_empty_octave_costs_nothing_and_an_uncovered_point_reads_nothing():
    """Two clusters of very different density: only their octaves are probed, and a point
    far from both reads no record."""
    rng = np.random.default_rng(3)
    dense = rng.normal(0, 0.001, (4_000, 3))
    sparse = rng.normal(0, 1.0, (400, 3)) + 20.0
    index = BlockHashIndex(np.vstack([dense, sparse]), k=8)
    gather = CoverGather.build(index, exact_radii2(index, 8))
    between = set(range(gather.octaves[0], gather.octaves[-1])) - set(gather.octaves.tolist())
    assert between  # octaves between the clusters' hold nothing, and are not probed
    assert gather.octave_uniforms().shape == (len(gather.octaves), 4)
    cov = gather.query(np.array([[10.0, -10.0, 10.0]], dtype=np.float32))
    assert cov.counts[0] == 0 and cov.candidates[0] == 0
    assert 1 <= cov.probes[0] <= 4 * len(gather.octaves)  # at most 2 x 2 windows an octave


def test_one_photon_has_no_radius_and_adds_nothing():
    index = BlockHashIndex(np.zeros((1, 3)), k=1)
    gather = CoverGather.build(index, np.array([np.inf]))
    assert len(gather) == 0 and gather.left_out == 1
    cov = gather.query(np.zeros((2, 3), dtype=np.float32))
    assert cov.counts.tolist() == [0, 0]


@pytest.mark.parametrize("bad", [np.nan, 0.0, -1.0])
def test_a_radius_that_is_not_positive_is_refused(bad):
    index = BlockHashIndex(photon_set("uniform", 200), k=8)
    r2 = exact_radii2(index, 8).copy()
    r2[7] = bad
    with pytest.raises(InputError, match=r"photon radius\^2 \[7\]"):
        CoverGather.build(index, r2)
    with pytest.raises(InputError, match="one per photon"):
        CoverGather.build(index, r2[:-1])


def test_octave_steps_are_checked():
    with pytest.raises(InputError, match="octave steps"):
        octave_sides(4)
    assert (np.diff(octave_sides(2)) > 0).all() and octave_sides(1)[-1] == 1 << 31


@pytest.mark.parametrize("kwargs, match", [({"fine": 5}, r"fine=5 must be 1, 2, 3 or 4"),
                                           ({"fine": 0}, r"fine=0 must be"),
                                           ({"axis": 3}, r"axis=3 must be 0, 1 or 2")])
def test_the_window_layout_is_checked(kwargs, match):
    index = BlockHashIndex(photon_set("uniform", 200), k=8)
    with pytest.raises(InputError, match=match):
        CoverGather.build(index, exact_radii2(index, 8), **kwargs)


def test_octahedral_directions_round_trip_within_a_ten_thousandth_of_a_radian():
    from blockhash.index.records.octahedral import octahedral_decode, octahedral_encode

    rng = np.random.default_rng(5)
    v = rng.normal(size=(20_000, 3))
    v = np.vstack([v, np.eye(3), -np.eye(3)])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    back = octahedral_decode(octahedral_encode(v)).astype(np.float64)
    angle = np.linalg.norm(back - v, axis=1)  # the chord: the angle, for small angles
    assert angle.max() < 1e-4
    assert np.allclose(np.linalg.norm(back, axis=1), 1, atol=1e-6)


@pytest.mark.parametrize("normal, fine", [((0, 1, 0), 0), ((1, 0, 0), 1), ((0, 0, 1), 0),
                                          ((0.6, 0.8, 0), 2)])
def test_the_fine_axis_runs_along_the_surface(normal, fine):
    from blockhash.index.lookups.cover import fine_axis

    n = np.tile(np.asarray(normal, np.float64), (50, 1))
    assert fine_axis(n) == fine
    assert fine_axis(np.zeros((0, 3))) == 0
    # a table of normals with counts (the gather's histogram of codes) is the same mean
    table = np.vstack([n[0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    assert fine_axis(table, np.array([50, 0, 0])) == fine
    assert fine_axis(table, np.zeros(3, int)) == 0


def test_the_gathers_fine_axis_from_codes_is_that_of_the_decoded_normals(rng):
    """The build reads the fine axis from a histogram of the records' normal codes: the axis
    of every photon's decoded normal."""
    from blockhash.index.lookups.cover import CoverGather, fine_axis
    from blockhash.index.records.codec import decode_directions

    for normal in ((0.2, 0.9, 0.1), (0.9, 0.1, 0.3), (0.1, 0.3, 0.9)):
        n = np.asarray(normal) + 0.3 * rng.standard_normal((3000, 3))
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        index = BlockHashIndex(rng.random((3000, 3)), normals=n, tables=False)
        want = fine_axis(decode_directions((index.records.records[:, 3] >> 16).astype(np.uint16)))
        assert CoverGather.build(index, np.full(3000, 1e-4)).axis == want


@pytest.mark.parametrize("plane", ["xz", "xy", "yz"])
def test_windows_along_a_surface_read_few_candidates(plane, rng):
    """Photons on a plane, whichever axes it spans: the fine axis lies in the plane, the gather
    finds what the oracle finds, and reads under 6 times the covering photons (2 x 2 x 2 cubic
    cells of the same side read about 7.3 times, windows across the plane as many)."""
    n = 40_000
    flat = {"xz": 1, "xy": 2, "yz": 0}[plane]
    pos = rng.random((n, 3))
    pos[:, flat] = 0.5
    normals = np.zeros((n, 3))
    normals[:, flat] = 1.0
    index = BlockHashIndex(pos, k=50, normals=normals)
    r2 = exact_radii2(index, 50)
    q = np.full((2_000, 3), 0.5)
    q[:, [a for a in range(3) if a != flat]] = rng.uniform(0.1, 0.9, (2_000, 2))
    gather, cov = assert_matches_oracle(index, r2, q.astype(np.float32))
    assert gather.axis != flat
    assert cov.candidates.mean() < 6.0 * cov.counts.mean()
