"""The GL side at its limits: the shader's k and loop limits, textures, viewports,
allocations and compile failures (docs/extremes.md).  Shaders compile slowly on
llvmpipe, so the GL cases are few and tiny; most limits are checked without drawing."""

import numpy as np
import pytest
from conftest import context_or_skip

from blockhash import BlockHashIndex, CapacityError, InputError
from blockhash.errors import ShaderCompileError
from blockhash.frame.caustic import CausticPass, estimate_cpu
from blockhash.frame.estimate import EstimateOptions
from blockhash.frame.shading_points import ShadingPoints
from blockhash.gl import limits
from blockhash.gl.context import check_gl
from blockhash.gl.limits import LOOP_LIMIT, MAX_K, check_lookup, largest_A, loop_iterations
from blockhash.gl.lookup import GLLookup, query_slot_bits
from blockhash.gl.packing import pack_index, texture_shape, upload
from blockhash.gl.shaderlib import Variant, compile_program
from blockhash.index.records.fixedpoint import min_radius

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)


def same_as_cpu(lookup, index, q, k, A, variant="default"):
    v = Variant.parse(variant)
    bits = query_slot_bits(index.params, k, A) if v.select == "packed" else 0
    d, i = lookup.query(q, k=k, A=A, variant=variant)
    dc, ic = index.reference_query(q, k=[k] and k, A=A, by_priority=v.priority == "on", slot_bits=bits)
    np.testing.assert_array_equal(i, ic.reshape(len(q), k))
    np.testing.assert_array_equal(d, dc.reshape(len(q), k))
    return d, i


@pytest.fixture
def no_compile(monkeypatch):
    """Fail the test if a shader is compiled: the checks must come first."""
    import blockhash.gl.lookup as lookup_module

    def refuse(*args, **kwargs):
        raise AssertionError("a shader was compiled before the limit was checked")

    monkeypatch.setattr(lookup_module, "compile_program", refuse)


@pytest.fixture(scope="module")
def small_index():
    return BlockHashIndex(np.random.default_rng(0).random((3000, 3)), k=8, A=4)


# --------------------------------------------------------------------------- k and A

def test_k_above_the_shader_limit_is_refused_before_compiling(no_compile):
    context_or_skip("egl")
    index = BlockHashIndex(np.random.default_rng(0).random((2000, 3)), k=MAX_K + 1, A=1)
    lookup = GLLookup(index, backend="egl")
    with pytest.raises(InputError, match=r"k=129 is above the lookup shader's limit MAX_K=128 .*"
                                         r"use k <= 128, or the CPU query"):
        lookup.query(np.zeros((2, 3)))


def test_k_at_the_shader_limit_passes_the_check(small_index):
    # k = 128 compiles in about a minute under llvmpipe (measured: 53 s) and returns the
    # CPU reference's neighbours; here only the check, which must let it through.
    check_lookup(None, small_index.params, Variant(), MAX_K, 1)


def test_a_failed_compile_names_the_file_line_and_variant():
    ctx = context_or_skip("egl")
    index = BlockHashIndex(np.random.default_rng(0).random((2000, 3)), k=MAX_K + 1, A=1)
    lookup = GLLookup(index, backend="egl")
    defines = {**lookup.defines(Variant(), MAX_K + 1, MAX_K + 1), "BH_QUERY_W": 1, "BH_QUERIES": 1}
    with pytest.raises(ShaderCompileError, match=r"(?s)bh_query\.frag failed to compile \(variant "
                                                 r"binary-set-on-packed-box\): .*bh_select_packed\.glsl:\d+.*"
                                                 r"BH_K above 128") as info:
        with ctx:
            compile_program(ctx, "bh_query.frag", defines)
    assert "active defines: " in str(info.value) and "BH_K=129" in str(info.value)
    assert "no OpenGL" not in str(info.value)


def test_loop_bound_grows_with_the_budget_and_allows_the_default_settings():
    pts = np.random.default_rng(1).random((20_000, 3))
    index = BlockHashIndex(pts, k=50, A=8)
    bounds = [loop_iterations(index.params, Variant(), 50, A * 50) for A in (1, 4, 8, 16)]
    assert bounds == sorted(bounds) and bounds[2] <= LOOP_LIMIT
    assert loop_iterations(index.params, Variant.parse("paper"), 50, 400) > bounds[2]


@pytest.mark.parametrize("k,A", [(8, 64), (50, 16)])
def test_the_largest_allowed_A_at_k_equals_the_cpu_reference(k, A):
    context_or_skip("egl")
    pts = np.random.default_rng(1).random((20_000, 3))
    index = BlockHashIndex(pts, k=k, A=A)
    best = largest_A(index.params, Variant(), k)
    assert best >= A
    same_as_cpu(GLLookup(index, backend="egl"), index, pts[:64].astype(np.float32), k, best)


def test_A_beyond_the_loop_limit_is_refused_on_llvmpipe_with_the_largest_A(no_compile):
    ctx = context_or_skip("egl")
    if not limits.is_llvmpipe(ctx):
        pytest.skip("the loop limit is llvmpipe's")
    index = BlockHashIndex(np.random.default_rng(1).random((20_000, 3)), k=8, A=8200)
    best = largest_A(index.params, Variant(), 8)
    lookup = GLLookup(index, backend="egl")
    with pytest.raises(CapacityError, match=rf"k=8, A=8200 \(A\*k=65,600 candidates\).*above "
                                            rf"llvmpipe's 65,535.*use A <= {best}, or the CPU query"):
        lookup.query(np.zeros((2, 3)))


@pytest.mark.slow
@pytest.mark.parametrize("n", [1, 10, 11])
def test_k_equal_to_n_and_tiny_maps_equal_the_cpu_reference(n, gl_mode):
    context_or_skip("egl")
    pts = np.random.default_rng(n).random((n, 3))
    index = BlockHashIndex(pts, k=1, A=1)
    q = np.concatenate([pts, [[5.0, 5, 5], [np.nan, 0, 0], [1e30, 0, 0]]]).astype(np.float32)
    lookup = GLLookup(index, backend="egl")
    same_as_cpu(lookup, index, q, 1, 1)
    d, i = same_as_cpu(lookup, index, q, n, 8)
    assert np.all(i[:n] < n) and np.all(i[-2:] == n)   # NaN and 1e30 m: no neighbours


# --------------------------------------------------------------------------- textures and viewports

class SmallLimitContext:
    """A context whose GL_MAX_TEXTURE_SIZE is small; everything else is the real one's."""

    def __init__(self, ctx, max_size):
        self._ctx, self.info = ctx, {**ctx.info, "GL_MAX_TEXTURE_SIZE": max_size}

    def __getattr__(self, name):
        return getattr(self._ctx, name)


def test_photon_map_one_block_under_and_over_the_largest_texture():
    ctx = context_or_skip("egl")
    max_size = 16  # blocks texture: 16 texels a block, 16 x 16 texels = 16 blocks = 160 photons
    limited = SmallLimitContext(ctx, max_size)
    one_table = dict(k=4, A=2, preset="paper", L=1, P=1, B=17)  # the blocks are the largest texture
    fits = BlockHashIndex(np.random.default_rng(0).random((160, 3)), **one_table)
    too_big = BlockHashIndex(np.random.default_rng(0).random((161, 3)), **one_table)
    with ctx:
        packed = pack_index(limited, fits)
        assert packed.blocks.size == (16, 16)
        packed.release()
        with pytest.raises(CapacityError, match=r"272 texels need 16 x 17 > GL_MAX_TEXTURE_SIZE=16 rows; "
                                                r"use fewer photons"):
            pack_index(limited, too_big)


def test_texture_shape_at_the_real_limit():
    assert texture_shape(16384 * 16384, 16384) == (16384, 16384, 14)
    with pytest.raises(CapacityError, match=r"16,384 x 16,385 > GL_MAX_TEXTURE_SIZE=16,384"):
        texture_shape(16384 * 16384 + 1, 16384)


def test_a_failed_allocation_in_upload_is_a_capacity_error():
    ctx = context_or_skip("egl")

    class FailingContext(SmallLimitContext):
        error = "GL_OUT_OF_MEMORY"

    with ctx, pytest.raises(CapacityError, match=r"OpenGL reported GL_OUT_OF_MEMORY after allocating "
                                                 r"the photon block texture \(8 x 1 x 4 x 4 bytes\).*"
                                                 r"use fewer photons"):
        upload(FailingContext(ctx, 16384), np.zeros((8, 4), np.uint32), 4, "photon block")


def test_invalid_value_from_an_oversized_allocation_is_a_capacity_error():
    ctx = context_or_skip("egl")
    with ctx:
        assert ctx.error == "GL_NO_ERROR"
        ctx.texture((40000, 1), 4, dtype="f4")  # beyond GL_MAX_TEXTURE_SIZE: GL_INVALID_VALUE
        with pytest.raises(CapacityError, match=r"GL_INVALID_VALUE after a 40,000-wide texture"):
            check_gl(ctx, "a 40,000-wide texture")
        assert ctx.error == "GL_NO_ERROR"


# --------------------------------------------------------------------------- the caustic estimate

def shading_points(positions):
    p = np.asarray(positions, np.float32).reshape(1, -1, 3)
    w = p.shape[1]
    return ShadingPoints(position=p, normal=np.tile(np.float32([0, 1, 0]), (1, w, 1)),
                         view=np.tile(np.float32([0, 1, 0]), (1, w, 1)),
                         material=np.zeros((1, w), np.int32), weight=np.ones((1, w, 3), np.float32))


@pytest.mark.parametrize("watts", [1e-9, 1e9])
def test_tiny_radius_and_missing_photons_give_finite_pixels(watts, gl_mode):
    context_or_skip("egl")
    rng = np.random.default_rng(0)
    pos = np.concatenate([np.full((20, 3), 0.5), rng.random((180, 3))])
    pos[:, 1] = 0.0
    index = BlockHashIndex(pos, k=8, A=4, directions=np.tile([0, -1.0, 0], (200, 1)),
                           powers=np.full((200, 3), watts))
    # On the 20 coincident photons (r = 0), 1e-9 m from them, in the open, 1e30 m away, NaN.
    pts = shading_points([[0.5, 0, 0.5], [0.5, 0, 0.5 + 1e-9], [0.3, 0, 0.7], [1e30, 0, 0],
                          [np.nan, 0, 0]])
    mats = [((0.5,) * 3, (0.3,) * 3, 100.0)]
    default_gl = CausticPass(index, backend="egl").render(pts, mats)
    assert np.isfinite(default_gl).all() and np.all(default_gl[0, 3:] == 0)
    # The paper's estimate (all k photons over pi r^2, no filter) has the analytic peak.
    paper = EstimateOptions(estimate="paper", filter="none")
    cpu = estimate_cpu(index, pts, mats, options=paper)
    gl = CausticPass(index, backend="egl").render(pts, mats, options=paper)
    assert np.isfinite(cpu).all() and np.isfinite(gl).all()
    assert np.all(cpu[0, 3:] == 0) and np.all(gl[0, 3:] == 0)
    # r is floored at the decode error bound: 8 photons within it give the same finite peak.
    peak = 8 * watts * (0.5 / np.pi + 0.3 * 102 / (2 * np.pi)) / (np.pi * min_radius(index) ** 2)
    np.testing.assert_allclose(cpu[0, :2, 0], peak, rtol=1e-2)  # polar-coded direction, float16 power
    np.testing.assert_allclose(gl, cpu, rtol=1e-4, atol=0)


@pytest.mark.parametrize("gather", [None, 0, 7])
def test_the_caustic_pass_refuses_to_compile_without_a_known_gather(gather):
    """caustic_pass.frag picks its gather by CP_GATHER; an unknown value (or none) stops the
    compile with the values it knows, not a silent fall into one of them."""
    ctx = context_or_skip("egl")
    defines = {} if gather is None else {"CP_GATHER": gather}
    with pytest.raises(ShaderCompileError, match=r"(?s)caustic_pass\.frag.*CP_GATHER must be "
                                                 r"CP_COVER \(1\), CP_CELLS \(2\) or CP_KNN \(3\)"):
        with ctx:
            compile_program(ctx, "caustic_pass.frag", defines)
