"""Property-based tests (hypothesis) of the Block Hashing query over random photon sets,
queries, k and A: the invariants hold for every input, and the shader equals the CPU
reference (a few small examples: every new index compiles a new program)."""

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree
from transcription import examined_blocks

from blockhash import BlockHashIndex, OrphanWarning

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

SHAPES = ("uniform", "clustered", "plane", "line", "duplicates")


def photons(shape, n, seed):
    rng = np.random.default_rng(seed)
    if shape == "uniform":
        return rng.random((n, 3)) * 4 - 2
    if shape == "clustered":
        centres = rng.random((3, 3))
        return centres[rng.integers(0, 3, n)] + rng.normal(0, 0.01, (n, 3))
    if shape == "plane":
        p = rng.random((n, 3))
        p[:, 1] = 0.0
        return p
    if shape == "line":
        t = rng.random(n)
        return np.stack([t, 2 * t, -t], axis=1)
    return np.repeat(rng.random((-(-n // 7), 3)), 7, axis=0)[:n]


def candidate_slots(index, q, k, A):
    """The photons (slots in block order) the reference examines for one query, rebuilt
    from the tables by the plain-Python transcription of query.py's steps 1-4."""
    taken = examined_blocks(index, q, k, A)
    return np.concatenate([np.arange(index.starts[b], index.starts[b + 1]) for b in taken])


problem = st.tuples(st.sampled_from(SHAPES), st.integers(1, 400), st.integers(0, 2**32 - 1),
                    st.integers(1, 24), st.integers(1, 16), st.integers(0, 2**32 - 1))


def build(shape, n, seed, k, A):
    pts = photons(shape, n, seed)
    k = min(k, n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OrphanWarning)
        return pts, k, BlockHashIndex(pts, k=k, A=A)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problem)
def test_query_invariants(args):
    shape, n, seed, k, A, qseed = args
    pts, k, index = build(shape, n, seed, k, A)
    rng = np.random.default_rng(qseed)
    q = np.concatenate([pts[rng.integers(0, n, 4)] + rng.normal(0, 0.05, (4, 3)),
                        rng.random((2, 3)) * 6 - 3]).astype(np.float32)
    d, i = index.query(q, k=[k] and k)
    d, i = d.reshape(len(q), k), i.reshape(len(q), k)
    decoded = index.positions.astype(np.float64)
    exact = np.sort(cKDTree(decoded).query(q.astype(np.float64), k=k)[0].reshape(len(q), k), axis=1)
    for row in range(len(q)):
        dr, ir = d[row], i[row]
        assert np.all(dr[1:] >= dr[:-1])                         # sorted
        found = ir < n
        assert np.all(np.isinf(dr) == ~found)                   # inf exactly where missing
        assert len(np.unique(ir[found])) == found.sum()          # no photon twice, at most k
        cands = candidate_slots(index, q[row], k, A)
        slots = index.slot_of[ir[found]]
        assert np.isin(slots, cands).all()                       # only examined photons
        assert found.sum() == min(k, len(cands))                # k found when k were examined
        # The k nearest of the candidates, by float32 distance (ties by slot).
        diff = index._positions[cands] - q[row]
        dd = (diff[:, 0] * diff[:, 0] + diff[:, 1] * diff[:, 1]) + diff[:, 2] * diff[:, 2]
        best = cands[np.lexsort((cands, dd))][:k]
        np.testing.assert_array_equal(slots, best)
        # Never nearer than exact at the same rank (float32 distance rounding aside).
        assert np.all(dr[found] >= exact[row][found] * (1 - 1e-6) - 1e-7 * (1 + np.abs(q[row]).max()))


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["default", "paper"])
@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problem)
def test_shader_equals_the_cpu_reference(variant, args):
    from conftest import context_or_skip

    from blockhash.gl.lookup import GLLookup, query_slot_bits
    from blockhash.gl.shaderlib import Variant

    context_or_skip("egl")
    shape, n, seed, k, A, qseed = args
    pts, k, index = build(shape, n, seed, k, A)
    q = (pts[np.random.default_rng(qseed).integers(0, n, 16)] + 0.01).astype(np.float32)
    v = Variant.parse(variant)
    bits = query_slot_bits(index.params, k, index.params.A) if v.select == "packed" else 0
    d, i = GLLookup(index, backend="egl").query(q, k=k, variant=variant)
    dc, ic = index.reference_query(q, k=[k] and k, slot_bits=bits)
    np.testing.assert_array_equal(i, ic.reshape(len(q), k))
    np.testing.assert_array_equal(d, dc.reshape(len(q), k))
