"""The exact kd-tree baseline (paper section 2): a balanced heap-ordered tree built on the CPU,
searched in a fragment shader, equal to the float32 brute force and to scipy's cKDTree."""

import numpy as np
import pytest
from conftest import context_or_skip, photon_set
from scipy.spatial import cKDTree

from blockhash.errors import CapacityError, InputError
from blockhash.gl.context import home_framebuffer
from blockhash.gl.kdtree import LOOP_LIMIT, MAX_K, GLKdTree, build_kdtree, query_order
from blockhash.gl.shaderlib import FULLSCREEN_VS, define_block, preprocess

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

BACKENDS = ["egl", "osmesa"]
N = 3000
#: cKDTree works in float64 on the float32 points, the shader in float32: a squared distance
#: differs by at most a few float32 roundings (4 ulp ~ 2.4e-7 relative), a distance by half that.
DIST_RTOL = 1e-6


def queries_for(name, m=400, seed=21):
    """Fresh samples of the distribution, some outside the photon box, and NaN / inf rows."""
    q = photon_set(name, m, seed=seed).astype(np.float32)
    q[::40] += np.float32(0.7)
    q[5::40] -= np.float32(3.0)
    q[7] = np.nan
    q[8, 2] = np.inf
    q[9, 0] = -np.inf
    return q


def brute_force(points, q, k):
    """The float32 oracle: keys (d2, index) with d2 = (dx*dx + dy*dy) + dz*dz in float32."""
    n = len(points)
    d = np.full((len(q), k), np.inf)
    idx = np.full((len(q), k), n, dtype=np.int64)
    for r, x in enumerate(q):
        if not np.isfinite(x).all():
            continue
        diff = points - x
        d2 = (diff[:, 0] * diff[:, 0] + diff[:, 1] * diff[:, 1]) + diff[:, 2] * diff[:, 2]
        order = np.lexsort((np.arange(n), d2))[:k]
        d[r, :len(order)] = np.sqrt(d2[order].astype(np.float64))
        idx[r, :len(order)] = order
    return d, idx


def assert_same_as_ckdtree(points, q, d, i, k):
    """Same neighbour sets as cKDTree on the float32 points in float64, except near-ties.

    The sorted distances agree within DIST_RTOL.  A neighbour may differ only if its
    distance is within DIST_RTOL of the k-th distance: there the float32 and float64
    orders of (nearly) tied points may disagree, and cKDTree orders exact ties arbitrarily.
    cKDTree refuses NaN and inf queries: those rows must have no neighbours.
    """
    n = len(points)
    finite = np.isfinite(q).all(axis=1)
    assert np.isinf(d[~finite]).all() and (i[~finite] == n).all()
    q, d, i = q[finite], d[finite], i[finite]
    dc, ic = cKDTree(points.astype(np.float64)).query(q.astype(np.float64), k)
    dc, ic = dc.reshape(len(q), k), ic.reshape(len(q), k)
    np.testing.assert_allclose(d, dc, rtol=DIST_RTOL, atol=0)
    assert np.array_equal(np.isinf(d), np.isinf(dc)) and (i[np.isinf(d)] == n).all()
    kth = np.where(np.isfinite(dc[:, -1]), dc[:, -1], np.inf)
    clear = dc < kth[:, None] * (1 - DIST_RTOL)  # cKDTree's neighbours not near-tied with the k-th
    for r in range(len(q)):
        sure = set(ic[r][clear[r]].tolist())
        assert sure <= set(i[r].tolist()), f"row {r}: {sorted(sure - set(i[r].tolist()))} missing"
        mine_clear = set(i[r][d[r] < kth[r] * (1 - DIST_RTOL)].tolist())
        extra = mine_clear - set(ic[r].tolist())
        assert not extra, f"row {r}: {sorted(extra)} not among cKDTree's neighbours"


# --- build ------------------------------------------------------------------------------

def assert_kdtree_invariants(points, tree):
    """N nodes in heap order; every photon lies on its ancestors' split sides."""
    p = points.astype(np.float32)
    n = len(p)
    assert len(tree) == n and tree.height == n.bit_length()
    assert np.array_equal(np.sort(tree.index), np.arange(n))
    np.testing.assert_array_equal(tree.positions, p[tree.index])
    nodes = np.arange(n)
    child = nodes.copy()
    while (child > 0).any():
        live = child > 0
        parent = (child[live] - 1) // 2
        ax = tree.axis[parent].astype(np.int64)
        mine = tree.positions[nodes[live], ax]
        split = tree.positions[parent, ax]
        left = child[live] % 2 == 1
        assert (mine[left] <= split[left]).all() and (mine[~left] >= split[~left]).all()
        child[live] = parent


@pytest.mark.slow
@pytest.mark.parametrize("n", [1, 2, 3, 7, 8, 100, N])
def test_build_kdtree_is_a_complete_heap_with_median_splits(distribution, n):
    points = photon_set(distribution, n)
    tree = build_kdtree(points)
    assert_kdtree_invariants(points, tree)


def test_build_kdtree_splits_the_axis_of_largest_extent():
    rng = np.random.default_rng(3)
    points = rng.random((1000, 3)) * [1.0, 3.0, 2.0]
    tree = build_kdtree(points)
    assert tree.axis[0] == 1  # y spans 3, z 2, x 1
    # planar photons: y never splits while x or z has any extent
    flat = build_kdtree(photon_set("planar", N))
    internal = np.arange(N) < N // 2
    assert not (flat.axis[internal] == 1).any()


def test_build_kdtree_keeps_duplicates_and_reports_itself():
    points = np.zeros((50, 3))
    tree = build_kdtree(points)
    assert_kdtree_invariants(points, tree)
    assert "KdTree(n=50, height=6" in repr(tree)


def test_build_kdtree_rejects_bad_positions():
    with pytest.raises(InputError, match=r"positions must have shape \(n, 3\); got shape \(5, 2\)"):
        build_kdtree(np.zeros((5, 2)))
    with pytest.raises(InputError, match="positions is empty"):
        build_kdtree(np.zeros((0, 3)))
    bad = np.zeros((4, 3))
    bad[2, 1] = np.nan
    with pytest.raises(InputError, match=r"positions\[2\].*is not finite"):
        build_kdtree(bad)


# --- search -----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def trees():
    """One GLKdTree per (backend, distribution), built once for the module."""
    cache = {}

    def get(backend, name):
        if (backend, name) not in cache:
            context_or_skip(backend)
            points = photon_set(name, N).astype(np.float32)
            cache[backend, name] = (points, GLKdTree(points, backend=backend))
        return cache[backend, name]
    yield get
    for _, tree in cache.values():
        tree.release()


@pytest.mark.slow
@pytest.mark.parametrize("k", [1, 8, 50])
@pytest.mark.parametrize("backend", BACKENDS)
def test_gl_kdtree_equals_float32_brute_force_and_ckdtree(trees, backend, distribution, k):
    points, kd = trees(backend, distribution)
    q = queries_for(distribution)
    d, i = kd.query(q, k)
    assert d.shape == i.shape == (len(q), k) and d.dtype == np.float64 and i.dtype == np.int64
    db, ib = brute_force(points, q, k)
    np.testing.assert_array_equal(i, ib)
    np.testing.assert_array_equal(d, db)
    assert_same_as_ckdtree(points, q, d, i, k)
    assert kd.counters["query.passes"] == 1 and kd.counters["query.nodes.mean"] > 0


@pytest.mark.parametrize("backend", BACKENDS)
def test_nan_and_inf_rows_get_no_neighbours(trees, backend):
    points, kd = trees(backend, "uniform")
    q = queries_for("uniform", m=64)
    d, i = kd.query(q, 8)
    bad = ~np.isfinite(q).all(axis=1)
    assert bad.sum() == 3
    assert np.isinf(d[bad]).all() and (i[bad] == N).all()
    assert np.isfinite(d[~bad]).all() and (i[~bad] < N).all()


def test_k_above_n_pads_with_inf_and_n_like_ckdtree():
    context_or_skip("egl")
    points = photon_set("clustered", 20).astype(np.float32)
    q = queries_for("clustered", m=30)
    q = q[np.isfinite(q).all(axis=1)]
    d, i = GLKdTree(points, backend="egl").query(q, 50)
    dc, ic = cKDTree(points.astype(np.float64)).query(q.astype(np.float64), 50)
    assert np.isinf(d[:, 20:]).all() and (i[:, 20:] == 20).all()
    np.testing.assert_allclose(d, dc, rtol=DIST_RTOL)
    np.testing.assert_array_equal(np.sort(i, axis=1), np.sort(ic, axis=1))


def test_exact_ties_are_ordered_by_index():
    context_or_skip("egl")
    grid = np.stack(np.meshgrid(*[np.arange(6.0)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    points = np.concatenate([grid, grid[::7]]).astype(np.float32)  # duplicates too
    q = np.array([[2.5, 2.5, 2.5], [0, 0, 0], [3, 2, 1], [2.5, 0, 0], [-1, 2, 2]], np.float32)
    d, i = GLKdTree(points, backend="egl").query(q, 27)
    db, ib = brute_force(points, q, 27)
    np.testing.assert_array_equal(i, ib)
    np.testing.assert_array_equal(d, db)


@pytest.mark.slow
@pytest.mark.parametrize("budget", [1, 40])
def test_searches_cut_by_the_step_budget_resume_to_the_same_result(budget):
    context_or_skip("egl")
    points = photon_set("caustic", N).astype(np.float32)
    q = queries_for("caustic", m=24)
    whole = GLKdTree(points, backend="egl")
    cut = GLKdTree(points, backend="egl", step_budget=budget)
    for k in (1, 50):
        d, i = cut.query(q, k)
        assert cut.counters["query.passes"] > 1 and cut.counters["query.resumed"] > 0
        dw, iw = whole.query(q, k)
        np.testing.assert_array_equal(i, iw)
        np.testing.assert_array_equal(d, dw)
        assert cut.counters["query.nodes.mean"] == whole.counters["query.nodes.mean"]


def test_a_search_longer_than_llvmpipes_loop_limit_is_complete():
    """Identical photons are all tied, so each query visits every node: more steps than the
    65,535 loop iterations llvmpipe allows a shader invocation.  The search must stop
    within its budget and resume, never be cut short silently."""
    context_or_skip("egl")
    n = 70_000
    points = np.ones((n, 3), np.float32)
    q = np.full((20, 3), 1.5, np.float32)
    kd = GLKdTree(points, backend="egl")
    d, i = kd.query(q, 50)
    assert kd.counters["query.nodes.max"] == n > LOOP_LIMIT
    assert kd.counters["query.passes"] == 2
    np.testing.assert_array_equal(i, np.broadcast_to(np.arange(50), (20, 50)))
    np.testing.assert_allclose(d, np.sqrt(0.75), rtol=DIST_RTOL)


def test_results_do_not_depend_on_the_query_order(trees):
    points, kd = trees("egl", "caustic")
    q = queries_for("caustic")
    d, i = kd.query(q, 8)
    dg, ig = kd.query(q, 8, spatial_order=False)
    np.testing.assert_array_equal(i, ig)
    np.testing.assert_array_equal(d, dg)
    order = query_order(q)
    assert np.array_equal(np.sort(order), np.arange(len(q)))
    assert not np.isfinite(q[order[-3:]]).all(axis=1).any()  # NaN / inf rows last


@pytest.mark.parametrize("points, k, error, match", [
    (np.zeros((5, 2)), 1, InputError, r"points must have shape \(n, 3\); got shape \(5, 2\)"),
    (np.zeros(3), 1, InputError, r"points must have shape \(n, 3\); got shape \(3,\)"),
    (np.zeros((5, 3)), 0, InputError, r"k=0 is out of range; allowed 1 <= k <= 512"),
    (np.zeros((5, 3)), MAX_K + 1, InputError, r"k=513 is out of range.*MAX_K=512"),
])
def test_bad_queries_raise_input_error(trees, points, k, error, match):
    _, kd = trees("egl", "uniform")
    with pytest.raises(error, match=match):
        kd.query(points, k)


def test_bad_step_budget_raises_input_error():
    with pytest.raises(InputError, match=r"step_budget=0 is out of range; allowed 1 <= "):
        GLKdTree(np.zeros((4, 3)), step_budget=0)


def test_too_many_photons_for_the_index_bits(monkeypatch):
    import blockhash.gl.kdtree_build as kdtree_build
    monkeypatch.setattr(kdtree_build, "MAX_PHOTONS", 16)
    with pytest.raises(CapacityError, match="positions has 20 photons.*use fewer photons"):
        build_kdtree(np.zeros((20, 3)))


@pytest.mark.parametrize("k", [50, MAX_K])
def test_heap_sift_spends_none_of_llvmpipes_loop_budget(k):
    """The step budget assumes kd_sift is unrolled (a loop of floor(log2 k) constant
    iterations): 60,000 full-depth sifts in one invocation must leave the loop budget for
    a k-iteration loop after them.  Were the sift rolled, llvmpipe would cut both loops."""
    ctx = context_or_skip("egl")
    defines = {"KD_K": k, "KD_LEVELS": k.bit_length() - 1, "KD_N": 1, "KD_DEPTH": 1,
               "KD_NODE_W": 0}
    probe = """
layout(std430, binding = 0) buffer Probe { uint probe[]; };
out vec4 frag_color;
void main() {
    kd_init(vec3(0.0), true);
    uint sifts = 0u;
    for (uint s = 0u; s < 60000u; ++s) {  // ever smaller keys: each sinks to a leaf
        kd_sift(uvec2(60000u - s, 0u), KD_K);
        sifts += 1u;
    }
    uint after = 0u;
    for (int j = 0; j < KD_K; ++j) {
        after += 1u;
    }
    probe[0] = sifts;
    probe[1] = after;
    probe[2] = kd_heap[0].x;
    frag_color = vec4(0.0);
}
"""
    source = preprocess("kd_tree.glsl", define_block(defines)).text + probe
    with ctx:
        prog = ctx.program(vertex_shader=FULLSCREEN_VS, fragment_shader=source)
        out = ctx.buffer(reserve=12)
        color = ctx.renderbuffer((1, 1), 4, dtype="f1")
        home = home_framebuffer(ctx)
        fbo = ctx.framebuffer(color_attachments=[color])
        out.bind_to_storage_buffer(0)
        fbo.use()
        fbo.viewport = (0, 0, 1, 1)
        vao = ctx.vertex_array(prog, [])
        vao.render(vertices=3)
        ctx.finish()
        sifts, after, top = np.frombuffer(out.read(), dtype=np.uint32)
        home.use()
        for obj in (vao, prog, out, fbo, color):
            obj.release()
    assert (sifts, after, top) == (60000, k, k)  # the heap keeps the k smallest: 1 .. k


def test_no_queries_give_empty_results(trees):
    _, kd = trees("egl", "planar")
    d, i = kd.query(np.zeros((0, 3), np.float32), 8)
    assert d.shape == i.shape == (0, 8)
