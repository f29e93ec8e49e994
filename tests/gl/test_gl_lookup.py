"""The GLSL lookup returns exactly the CPU reference's neighbours (the oracle)."""

import copy
from dataclasses import replace

import numpy as np
import pytest
from conftest import context_or_skip, photon_set

from blockhash import BlockHashIndex, CapacityError, InputError
from blockhash.errors import GLUnavailableError
from blockhash.gl.context import check_gl, get_context, gl_info
from blockhash.gl.lookup import GLLookup, query_slot_bits
from blockhash.gl.packing import texture_shape
from blockhash.gl.shaderlib import Variant, variants
from blockhash.index.tables.params import candidate_cap

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

BACKENDS = ["egl", "osmesa"]


def queries_for(name, m=300, seed=21):
    q = photon_set(name, m, seed=seed).astype(np.float32)
    q[::50] += np.float32(0.7)  # some points outside the photon box
    q[7] = np.nan
    q[8, 2] = np.inf
    return q


def assert_same_as_cpu(lookup, index, q, k, A, variant="default"):
    """The variant's neighbours equal the CPU reference run in the same mode."""
    v = Variant.parse(variant)
    bits = query_slot_bits(index.params, k, A) if v.packed_keys else 0
    d, i = lookup.query(q, k=k, A=A, variant=variant)
    dc, ic = index.reference_query(q, k=[k] and k, A=A, by_priority=v.priority == "on", slot_bits=bits)
    dc, ic = dc.reshape(len(q), k), ic.reshape(len(q), k)
    np.testing.assert_array_equal(i, ic)
    np.testing.assert_array_equal(d, dc)
    assert np.isinf(d[7]).all() and (i[8] == len(index)).all()


@pytest.fixture(scope="module")
def caustic_index():
    return BlockHashIndex(photon_set("caustic", 8000), k=8, A=4)


#: Every combination of the paper's four stages (cull off), and culling beside each
#: duplicate removal and selection (the full product with culling would double the compiles).
TESTED_VARIANTS = [v for v in variants() if not v.endswith("-box")] + [
    f"binary-{d}-on-{s}-box" for d in ("branch", "zero", "set")
    for s in ("insertion", "network", "packed", "merge")] + ["linear-set-off-packed-box"]


@pytest.mark.slow
@pytest.mark.parametrize("variant", TESTED_VARIANTS)
def test_every_variant_equals_the_cpu_reference(caustic_index, variant):
    context_or_skip("egl")
    lookup = GLLookup(caustic_index, backend="egl")
    assert_same_as_cpu(lookup, caustic_index, queries_for("caustic"), 8, 4, variant=variant)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("variant", ["default", "paper"])
def test_both_backends_equal_the_cpu_reference(caustic_index, backend, variant):
    context_or_skip(backend)
    lookup = GLLookup(caustic_index, backend=backend)
    assert_same_as_cpu(lookup, caustic_index, queries_for("caustic"), 8, 4, variant=variant)
    assert gl_info(lookup.ctx)["backend"] == backend


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::blockhash.OrphanWarning")
@pytest.mark.parametrize("preset", ["default", "paper"])
@pytest.mark.parametrize("k", [1, 8, 50])
def test_distributions_k_and_A_equal_the_cpu_reference(distribution, preset, k):
    context_or_skip("egl")
    index = BlockHashIndex(photon_set(distribution, 5000), k=k, A=8, preset=preset)
    lookup = GLLookup(index, backend="egl")
    q = queries_for(distribution, m=200)
    for A in (1, 8, 16):
        assert_same_as_cpu(lookup, index, q, k, A)


@pytest.mark.slow
def test_queries_are_split_into_passes_without_changing_results(caustic_index, monkeypatch):
    context_or_skip("egl")
    import blockhash.gl.lookup as lookup_module

    lookup = GLLookup(caustic_index, backend="egl")
    q = queries_for("caustic", m=500)
    whole = lookup.query(q)
    monkeypatch.setattr(lookup_module, "MAX_QUERIES_PER_PASS", 128)
    parts = lookup.query(q)
    np.testing.assert_array_equal(whole[1], parts[1])


def test_bad_queries_are_rejected(caustic_index):
    context_or_skip("egl")
    lookup = GLLookup(caustic_index, backend="egl")
    with pytest.raises(InputError, match=r"points must have shape \(n, 3\)"):
        lookup.query(np.zeros((3, 4)))
    with pytest.raises(InputError, match="k=9,000 is out of range"):
        lookup.query(np.zeros((3, 3)), k=9000)
    with pytest.raises(InputError, match="shader variant 'fastest' is not known"):
        lookup.query(np.zeros((3, 3)), variant="fastest")


def test_maps_beyond_the_texture_limit_are_refused_before_allocating():
    assert texture_shape(16384 * 3 + 1, 16384) == (16384, 4, 14)
    assert texture_shape(5, 16384) == (8, 1, 3)
    with pytest.raises(CapacityError, match=r"GL_MAX_TEXTURE_SIZE=1,024.*use fewer photons"):
        texture_shape(1024 * 1024 + 1, 1024)


def test_failed_allocation_is_an_error_not_junk():
    class FakeContext:
        error = "GL_OUT_OF_MEMORY"

    with pytest.raises(CapacityError, match="GL_OUT_OF_MEMORY after allocating the photon block texture"):
        check_gl(FakeContext(), "allocating the photon block texture")


def test_unknown_backend_is_named():
    with pytest.raises(GLUnavailableError, match="backend 'vulkan' is not known; choose one of auto, egl, osmesa"):
        get_context("vulkan")


def test_gl_lookup_of_an_index_matches_its_cpu_query(caustic_index):
    context_or_skip("egl")
    q = queries_for("caustic", m=100)
    lookup = GLLookup(caustic_index, backend="egl")
    d, i = lookup.query(q, variant="binary-branch-on-network")
    np.testing.assert_array_equal(i, caustic_index.query(q)[1])

def test_one_program_serves_every_query_count(caustic_index):
    """The query count and viewport width are uniforms: a new image size compiles nothing."""
    context_or_skip("egl")
    from blockhash.gl import shaderlib

    lookup = GLLookup(caustic_index, backend="egl")
    q = queries_for("caustic", m=300)
    assert_same_as_cpu(lookup, caustic_index, q, 8, 4)
    compiled = len(shaderlib._PROGRAMS)
    assert_same_as_cpu(lookup, caustic_index, q[:37], 8, 4)
    assert len(shaderlib._PROGRAMS) == compiled
    assert len(lookup._programs) == 1


def test_timed_draws_report_wall_and_gpu_time_per_draw(caustic_index):
    context_or_skip("egl")
    lookup = GLLookup(caustic_index, backend="egl")
    times = lookup.time_draws(queries_for("caustic", m=64), 8, A=4, repeat=3, warmup=1)
    assert len(times["wall"]) == len(times["gpu"]) == 3
    assert all(t > 0 for t in times["wall"]) and all(t > 0 for t in times["gpu"])
    with pytest.raises(InputError, match="repeat=0 is out of range"):
        lookup.time_draws(queries_for("caustic", m=64), 8, A=4, repeat=0)


@pytest.mark.filterwarnings("ignore::blockhash.OrphanWarning")
@pytest.mark.parametrize("variant, k, A", [
    ("binary-set-on-merge", 50, 16), ("binary-set-off-packed", 50, 16), ("linear-zero-on-merge", 50, 16),
    ("binary-branch-on-merge", 50, 8), ("binary-set-on-merge", 100, 2), ("binary-set-on-merge", 1, 16),
    ("binary-set-on-merge-box", 100, 2)])
@pytest.mark.slow
def test_register_variants_equal_the_cpu_reference_up_to_the_largest_state(variant, k, A):
    """The taken-block set at its bound (A * k = 800 candidates: 81 blocks) and the merge
    network at k = 100 (128 slots) still equal the CPU reference."""
    context_or_skip("egl")
    index = BlockHashIndex(photon_set("clustered", 4000), k=k, A=A)
    lookup = GLLookup(index, backend="egl")
    assert_same_as_cpu(lookup, index, queries_for("clustered", m=150), k, A, variant=variant)


def test_taken_bound_covers_the_most_blocks_a_query_takes():
    from blockhash.gl.lookup import taken_bound

    # Full blocks of 10, cap checked before each block: 40 blocks reach 400 candidates,
    # a partial last block can add one more.
    assert taken_bound(7, 23, 400) == 41
    assert taken_bound(2, 5, 400) == 10
    from blockhash.index.lookups.hash import bh_query
    index = BlockHashIndex(photon_set("clustered", 3000), k=20, A=16)
    q = queries_for("clustered", m=300)[10:]
    prm = index.params
    for A in (1, 3, 16):
        cap = A * 20
        *_, fetched = bh_query(index.quantizer.quantize_query(q), q, index.thresholds,
                               np.asarray(prm.P, dtype=np.int64), int(prm.layout),
                               index.tables.refs, index.priority, index.starts, index._positions,
                               20, cap, True, 0, prm.probe, index.quantizer.step.astype(np.float32))
        assert fetched.max() <= taken_bound(prm.L, prm.B, cap)
        assert fetched.max() >= taken_bound(prm.L, prm.B, cap) - 1  # the bound is tight


@pytest.mark.slow
def test_query_width_changes_the_tile_shape_not_the_results(caustic_index):
    context_or_skip("egl")
    lookup = GLLookup(caustic_index, backend="egl")
    q = queries_for("caustic", m=300)
    d, i = lookup.query(q)
    for width in (7, 16):
        d2, i2 = lookup.query(q, width=width)
        np.testing.assert_array_equal(i, i2)
        np.testing.assert_array_equal(d, d2)
    limit = lookup.ctx.info["GL_MAX_TEXTURE_SIZE"]
    with pytest.raises(InputError, match=r"width=.* is out of range"):
        lookup.query(q, width=limit + 1)
    with pytest.raises(CapacityError, match=r"queries at width=1 need .* rows > GL_MAX_TEXTURE_SIZE"):
        lookup.query(np.zeros((limit + 1, 3), np.float32), width=1)


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["default", "binary-branch-on-network-box"])
def test_culling_skips_blocks_and_keeps_the_neighbours(variant):
    """Culled blocks (not fetched, not offered) leave every neighbour as the CPU reference
    has it, and some blocks are culled: a lookup that never culls fails here.  The walk
    (the default preset) culls whatever the variant's cull field; hashing with cull 'off'
    culls nothing."""
    context_or_skip("egl")
    index = BlockHashIndex(photon_set("caustic", 20000), k=8, A=8)
    lookup = GLLookup(index, backend="egl")
    q = queries_for("caustic", m=400)
    assert_same_as_cpu(lookup, index, q, 8, 8, variant=variant)
    culled = lookup.counters["query.blocks_culled.mean"]
    assert culled > 1.0
    off = Variant.parse(variant).name.rsplit("-", 1)[0] + "-off"
    assert_same_as_cpu(lookup, index, q, 8, 8, variant=off)
    assert lookup.counters["query.blocks_culled.mean"] == culled
    hashing = copy.copy(index)
    hashing.params = replace(index.params, best_first=False)
    lookup = GLLookup(hashing, backend="egl")
    lookup.query(q, 8, A=8, variant=off)
    assert lookup.counters["query.blocks_culled.mean"] == 0.0
    lookup.query(q, 8, A=8, variant=variant)
    assert lookup.counters["query.blocks_culled.mean"] > 0.0


def test_block_boxes_bound_every_photon_code():
    from blockhash.gl.packing import block_boxes

    index = BlockHashIndex(photon_set("clustered", 3007), k=8, A=4)
    words = index.block_words
    boxes = block_boxes(words)
    for b in (0, 5, len(words) - 1):
        n = words[b, 60]
        codes = words[b, :60].reshape(10, 6)[:n, :3].astype(np.int64)
        lo = (boxes[b] & 0xFFFF).astype(np.int64) << 16
        hi = ((boxes[b] >> 16).astype(np.int64) << 16) | 0xFFFF
        assert (codes >= lo).all() and (codes <= hi).all()
        assert (codes.min(axis=0) >> 16 == lo >> 16).all()  # tight to 16 bits


@pytest.mark.slow
@pytest.mark.parametrize("offset", [0.0, 1000.0])
def test_culling_is_exact_far_from_the_origin(offset):
    """The culling bound's margin scales with the box's magnitude: a map far from the
    origin (coarser float32 positions) still gives the CPU reference's neighbours."""
    context_or_skip("egl")
    pts = photon_set("clustered", 6000) + np.float32(offset)
    index = BlockHashIndex(pts, k=16, A=8)
    lookup = GLLookup(index, backend="egl")
    q = queries_for("clustered", m=300) + np.float32(offset)
    q[7] = np.nan
    assert_same_as_cpu(lookup, index, q, 16, 8)
    assert lookup.counters["query.blocks_culled.mean"] > 0.0


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::blockhash.OrphanWarning")
def test_a_candidate_cap_beyond_the_register_set_is_refused_with_the_way_out():
    """An explicit dedup=set variant is refused beyond its register set; the default falls
    back to dedup=branch there, with the same neighbours."""
    context_or_skip("egl")
    index = BlockHashIndex(photon_set("clustered", 4000), k=100, A=32)
    prm = index.params
    lookup = GLLookup(index, backend="egl")
    q = queries_for("clustered", m=20)
    assert prm.L * prm.B > 128
    taken = min(prm.L * prm.B, 1600 // 10 + 1)
    with pytest.raises(InputError, match=rf"A \* k = 1,600 candidates can take up to {taken} "
                                         r"blocks.*dedup=branch"):
        lookup.query(q, k=100, A=16, variant="binary-set-on-packed")
    assert_same_as_cpu(lookup, index, q, 100, 16, variant="default")




def two_patches_and_far_points():
    """tests/index/lookups/test_best_first.py's two patches and far shading points, smaller, with a NaN and
    an infinite point: the walk prunes, pops many nodes and fills its queue."""
    from conftest import two_patches_and_far_points as patches

    pts, q = patches(6000, 200)
    q[7] = np.nan
    q[8, 2] = np.inf
    return pts, q


@pytest.fixture(scope="module")
def far_index():
    return BlockHashIndex(two_patches_and_far_points()[0], k=16, A=8)


@pytest.mark.parametrize("variant", ["default", "binary-branch-on-insertion", "binary-zero-off-network-box",
                                     "binary-set-on-merge", "binary-branch-on-packed"])
@pytest.mark.slow
def test_the_nearest_box_first_walk_equals_the_cpu_reference_on_far_queries(far_index, variant):
    context_or_skip("egl")
    assert far_index.params.best_first
    lookup = GLLookup(far_index, backend="egl")
    assert_same_as_cpu(lookup, far_index, two_patches_and_far_points()[1], 16, 8, variant=variant)


@pytest.mark.slow
def test_a_full_walk_queue_drops_the_same_entries_on_both_sides(far_index, monkeypatch):
    """A queue of 32 entries overflows on these queries; the shader drops exactly the entries
    that the CPU reference drops (the largest (distance, node id))."""
    context_or_skip("egl")
    import blockhash.gl.lookup as lookup_module
    from blockhash.index.lookups.walk import bf_query, walk_cull

    monkeypatch.setattr(lookup_module, "QUEUE_CAPACITY", 32)
    q = two_patches_and_far_points()[1]
    qf = np.where(np.isfinite(q).all(axis=1)[:, None], q, np.float32(0))
    ix = copy.copy(far_index)  # walking all L tables fills the queue (one table's walk: 20)
    ix.params = replace(far_index.params, walk_trees=far_index.params.L)
    d2, slots, *_, drops, longest = bf_query(qf, ix.thresholds, ix.node_boxes, ix.tables.refs,
                                             ix.starts, ix._positions, 16,
                                             candidate_cap(ix.params, 16, 8), 0, 32,
                                             trees=ix.params.L, cull=walk_cull(ix))
    assert drops.sum() > 0 and longest.max() == 32
    d, i = GLLookup(ix, backend="egl").query(q, k=16, A=8, variant="binary-branch-on-insertion")
    ok = np.isfinite(q).all(axis=1)
    expect = np.where(slots >= 0, ix.order[np.maximum(slots, 0)], len(ix))
    np.testing.assert_array_equal(i[ok], expect[ok])


def walking(index, trees):
    """``index`` with its walk seeded with ``trees`` tables (the same tables and boxes)."""
    ix = copy.copy(index)
    ix.params = replace(index.params, walk_trees=trees)
    return ix


@pytest.mark.parametrize("trees", [2, 5])
@pytest.mark.parametrize("variant", ["default", "binary-branch-on-insertion", "binary-set-on-merge"])
def test_the_walk_over_more_tables_equals_the_cpu_reference(far_index, trees, variant):
    context_or_skip("egl")
    assert far_index.params.walk_trees == 1 and far_index.params.L == 5
    ix = walking(far_index, trees)
    assert_same_as_cpu(GLLookup(ix, backend="egl"), ix, two_patches_and_far_points()[1], 16, 8,
                       variant=variant)


@pytest.mark.slow
@pytest.mark.parametrize("trees", [1, 5])
@pytest.mark.parametrize("variant", ["default", "binary-branch-on-packed", "binary-zero-off-network"])
def test_the_walk_takes_more_than_L_B_blocks_the_same_on_both_sides(caustic_index, trees, variant):
    """The walk has no L * B block cap: queried at 16x the A k it was built for, it takes more
    than L B blocks and up to ceil(A k / 10) + 1 (the candidates numbered in the packed keys'
    slot bits)."""
    context_or_skip("egl")
    from blockhash.index.lookups.walk import bf_query, walk_cull, walk_taken_bound

    ix = walking(caustic_index, trees)
    prm, q, k, A = ix.params, queries_for("caustic"), 64, 8
    qf = np.where(np.isfinite(q).all(axis=1)[:, None], q, np.float32(0))
    *_, fetched, _, _, _ = bf_query(qf, ix.thresholds, ix.node_boxes, ix.tables.refs, ix.starts,
                                    ix._positions, k, A * k, 0, trees=trees,
                                    cull=walk_cull(ix))
    assert prm.L * prm.B < fetched.max() <= walk_taken_bound(prm.B, A * k)
    assert_same_as_cpu(GLLookup(ix, backend="egl"), ix, q, k, A, variant=variant)


@pytest.mark.parametrize("name,k,A", [("caustic", 20, 8), ("clustered", 8, 4), ("uniform", 1, 8),
                                      ("room", 50, 2)])
@pytest.mark.slow
def test_cell_shader_returns_what_the_cpu_cells_return(name, k, A):
    from dataclasses import replace as _replace

    from blockhash.evaluate.photon_maps import MAPS, queries

    pm = MAPS[name]
    pts = pm.photons(8_000, np.random.default_rng(3))
    q = queries(pm, 700, np.random.default_rng(4)).astype(np.float32)
    q[0] = np.nan
    index = BlockHashIndex(pts, k=k, A=A)
    index.params = _replace(index.params, cells=True)
    d, i = index.query(q, k=[k] and k)
    if k == 1:
        d, i = d[:, None], i[:, None]
    gd, gi = GLLookup(index).query(q)
    assert np.array_equal(gi, i) and np.array_equal(gd, d)


@pytest.mark.slow
def test_the_stages_the_default_index_ignores_change_nothing_there(caustic_index):
    """shaderlib.IGNORED_BY_DEFAULT_INDEX: on the default preset's index, a variant that
    differs from the default only in those stages returns exactly the default's neighbours."""
    from blockhash.gl.shaderlib import CHOICES, IGNORED_BY_DEFAULT_INDEX, NAMED, Variant

    context_or_skip("egl")
    assert caustic_index.params.preset == "default"
    lookup = GLLookup(caustic_index, backend="egl")
    q = queries_for("caustic")
    d0, i0 = lookup.query(q, 8, A=4, variant="default")
    default = NAMED["default"]
    for stage in IGNORED_BY_DEFAULT_INDEX:
        other = next(c for c in CHOICES[stage][1] if c != getattr(default, stage))
        v = Variant(**{**{f: getattr(default, f) for f in CHOICES}, stage: other})
        d, i = lookup.query(q, 8, A=4, variant=v.name)
        np.testing.assert_array_equal(i, i0, err_msg=f"{stage}={other} changed the neighbours")
        np.testing.assert_array_equal(d, d0)
