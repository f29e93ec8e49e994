"""Strict GL (blockhash/gl/strict.py) shows here what a GPU's driver does with reads past what
a pass wrote and with GLSL's undefined operations: the instrument itself, and every canonical
scene rendered with it, finite and equal to the ordinary render.  (On an NVIDIA H200 the Cornell
box's caustic and indirect layers were NaN: pow(0, 0) in the Phong lobe of its diffuse walls,
whose exponent is 0; llvmpipe gives 1 there, strict GL NaN, as NVIDIA.)"""

from pathlib import Path

import moderngl
import numpy as np
import pytest
from conftest import context_or_skip

import blockhash
from blockhash import EstimateOptions, LookupOptions, RenderPlan
from blockhash.gl import strict
from blockhash.gl.pool import give_back, pooled_texture
from blockhash.gl.shaderlib import FULLSCREEN_VS

pytestmark = pytest.mark.gl

SCENES = Path(__file__).resolve().parents[2] / "scenes"
PROBE = """
uniform float zero;
uniform float two;
out vec4 frag_color;
void main() {
    frag_color = vec4(pow(zero, zero), length(normalize(vec3(zero))), sqrt(-two), pow(two, 3.0));
}
"""


def probe(ctx, prologue: str) -> np.ndarray:
    prog = ctx.program(vertex_shader=FULLSCREEN_VS,
                       fragment_shader="#version 450 core\n" + prologue + PROBE)
    prog["zero"].value, prog["two"].value = 0.0, 2.0
    out = ctx.texture((1, 1), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[out])
    vao = ctx.vertex_array(prog, [])
    try:
        fbo.use()
        fbo.viewport = (0, 0, 1, 1)
        vao.render(moderngl.TRIANGLES, vertices=3)
        return np.frombuffer(out.read(), dtype=np.float32)
    finally:
        from blockhash.gl.context import home_framebuffer

        home_framebuffer(ctx).use()
        for obj in (vao, fbo, out, prog):
            obj.release()


def test_strict_glsl_makes_the_undefined_operations_nan():
    ctx = context_or_skip("egl")
    with ctx:
        values = probe(ctx, strict.PROLOGUE)
    assert np.isnan(values[:3]).all() and values[3] == pytest.approx(8.0)


def test_strict_mode_poisons_textures_before_they_are_written():
    ctx = context_or_skip("egl")
    with ctx, strict.strict():
        tex = pooled_texture(ctx, "strict test", 8, 4, 4, "f4")
        bits = np.frombuffer(tex.read(), dtype=np.uint32)
        give_back(tex)
        assert (bits == strict.POISON).all()
        again = pooled_texture(ctx, "strict test", 8, 4, 4, "f4")  # from the pool: stale rows too
        again.write(np.zeros((4, 8, 4), np.float32))
        give_back(again)
        tex = pooled_texture(ctx, "strict test", 8, 4, 4, "f4")
        assert (np.frombuffer(tex.read(), dtype=np.uint32) == strict.POISON).all()
        give_back(tex)
    assert not strict.enabled()


def render(name, on, **kw):
    scene = blockhash.load_scene(SCENES / f"{name}.toml").with_size(32, 32)
    with strict.strict(on):
        return blockhash.render(scene, photons=6_000, seed=5, plan=RenderPlan(passes=2), **kw)


def assert_finite_and_equal(name, **kw):
    plain, poisoned = render(name, False, **kw), render(name, True, **kw)
    for layer, values in poisoned.layers().items():
        assert np.isfinite(values).all(), f"{name}: {layer} has non-finite pixels in strict GL"
        want = plain.layers()[layer]
        np.testing.assert_allclose(values, want, rtol=1e-5, atol=1e-6 * max(want.max(), 1e-30),
                                   err_msg=f"{name}: {layer}")


@pytest.mark.slow
@pytest.mark.parametrize("name", ["ring", "venus", "glass", "corner", "mirror", "cbox", "sun"])
def test_every_scene_renders_finite_and_the_same_in_strict_gl(name):
    assert_finite_and_equal(name)


@pytest.mark.parametrize("method,estimate", [("bh", "unbiased"), ("bh", "paper"),
                                             ("kdtree", "conserving")])
def test_the_k_nearest_gathers_render_the_box_finite_in_strict_gl(method, estimate):
    assert_finite_and_equal("cbox", estimate=EstimateOptions(estimate=estimate),
                            lookup=LookupOptions(method=method))
