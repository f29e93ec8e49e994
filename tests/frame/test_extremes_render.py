"""The renderer at the extremes of its scenes and images (docs/extremes.md): tiny images,
few photons, every case either a finite non-negative image or a clear error."""

from pathlib import Path

import numpy as np
import pytest
from conftest import context_or_skip
from conftest import small_ring_scene as scene

from blockhash import CapacityError, InputError
from blockhash.frame.gbuffer import rasterize
from blockhash.passes.pipeline import NoCausticWarning, render_scene

RING = Path(__file__).resolve().parents[2] / "scenes" / "ring.toml"

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

def assert_sane(result, *, caustic=True):
    for name, layer in result.layers().items():
        assert np.isfinite(layer).all(), name
        assert (layer >= 0).all(), name
    assert result.direct.max() > 0
    if caustic:
        assert result.caustic.max() > 0


@pytest.mark.parametrize("case", ["camera-inside-ring", "light-inside-ring"])
def test_extreme_placements_render_finite_images(case, gl_mode):
    context_or_skip("egl")
    kw = {"camera-inside-ring": dict(eye="[0.0, 0.15, 0.1]", target="[0.3, 0.0, -0.3]"),
          "light-inside-ring": dict(light="[0.1, 0.2, 0.0]")}[case]
    result = render_scene(scene(**kw), photons=2000, size=(16, 16))
    assert_sane(result)
    assert result.info["photons_stored"] == 2000


def test_light_on_the_floor_reaches_the_ring_and_gets_a_clear_error():
    # Emission starts off the light's own surface, so the photons reach the ring rather
    # than all hitting the floor at t = 0; a vertical mirror cannot send light from the
    # floor's plane back down to it, so there is no caustic, and the error says so.
    from blockhash.photons.tracing import trace_caustic_photons

    with pytest.raises(InputError, match=r"no caustic photon stored of [\d,]+ shot toward the "
                                         r"mirrors \['ring'\] \((?![^)]*direct diffuse)[^)]*"
                                         r"escaped [1-9].*move the light"):
        trace_caustic_photons(scene(light="[-1.0, 0.0, 0.0]"), 100, max_emitted=20_000)


def test_scene_without_a_mirror_renders_direct_light_only():
    context_or_skip("egl")
    with pytest.warns(NoCausticWarning, match="rendering direct light only: the scene has no specular object"):
        result = render_scene(scene(ring=""), size=(8, 8))
    assert_sane(result, caustic=False)
    assert np.all(result.caustic == 0) and result.index is None
    assert result.info["photons_stored"] == 0


def test_a_mirror_no_photon_reaches_is_a_clear_error():
    # The light is under the floor, which hides the ring from it.
    with pytest.raises(InputError, match=r"no .*photon|reach"):
        from blockhash.photons.tracing import trace_caustic_photons

        trace_caustic_photons(scene(light="[0.0, -1.0, 0.0]"), 100, max_emitted=20_000)


def test_k_above_the_shader_limit_is_refused_before_tracing(monkeypatch):
    import blockhash.photons.tracing as tracing

    monkeypatch.setattr(tracing, "trace_caustic_photons", lambda *a, **k: pytest.fail("traced anyway"))
    with pytest.raises(InputError, match=r"k=129 is above the lookup shader's limit MAX_K=128; "
                                         r"use k <= 128, or method='cpu' or 'kdtree'"):
        render_scene(scene(), k=129, size=(4, 4), method="bh")


def test_fewer_photons_than_k_is_a_clear_error():
    context_or_skip("egl")
    with pytest.raises(InputError, match=r"only 5 caustic photons were stored, fewer than k=8; "
                                         r"trace more photons"):
        render_scene(scene(), photons=5, size=(4, 4))


def test_a_later_pass_storing_fewer_photons_than_k_renders_or_says_why(gl_mode):
    """Pass 0 stores k photons; a later pass emits as many and may store fewer.  The
    conserving estimate takes any count (its radii reach the farthest photon); a k-nearest
    estimate cannot, and says which pass."""
    import blockhash

    context_or_skip("egl")
    ring = blockhash.load_scene(RING).with_size(8, 8)
    # seed 6 on the host's streams: pass 1 stores 45 of the 50 photons pass 0 stored (the
    # index refused k=50)
    image = blockhash.render(ring, photons=50, seed=6,
                             plan=blockhash.RenderPlan(passes=2, device="host"))
    assert image.info["passes"] == 2 and image.info["photons_stored"] == 95
    assert np.isfinite(image.caustic).all() and image.caustic.sum() > 0
    with pytest.raises(InputError, match=r"pass 1 stored only 45 caustic photons, fewer than "
                                         r"the k=50 neighbours the k-nearest estimate reads"):
        blockhash.render(ring, photons=50, seed=6, plan=blockhash.RenderPlan(passes=2, device="host"),
                         estimate=blockhash.EstimateOptions(estimate="paper"))


@pytest.mark.parametrize("size", [(1, 1), (256, 2), (1, 64)])
def test_tiny_and_very_wide_images(size):
    context_or_skip("egl")
    result = render_scene(scene(), photons=1000, size=size)
    assert result.direct.shape == (size[1], size[0], 3)
    for layer in result.layers().values():
        assert np.isfinite(layer).all() and (layer >= 0).all()


def test_images_at_the_largest_viewport_and_one_pixel_more():
    ctx = context_or_skip("egl")
    limit = min(ctx.info["GL_MAX_TEXTURE_SIZE"], *ctx.info["GL_MAX_VIEWPORT_DIMS"])
    s = scene()
    gbuf = rasterize(s.camera, s.objects, size=(limit, 1), backend="egl")
    assert gbuf.position.shape[:2] == (1, limit)
    with pytest.raises(CapacityError, match=rf"image size {limit + 1} x 1 is outside 1..{limit:,} per "
                                            r"side .*render a smaller image"):
        rasterize(s.camera, s.objects, size=(limit + 1, 1), backend="egl")
    with pytest.raises(CapacityError, match=r"image size 0 x 4 is outside"):
        rasterize(s.camera, s.objects, size=(0, 4), backend="egl")


def test_a_scene_whose_light_reaches_no_mirror_renders_its_direct_light_with_one_warning(tmp_path,
                                                                                       capsys):
    """The ring's light under the floor: no caustic path, a well-defined (dark) image.  The
    render goes on with direct light and caustic 0, warns once with what pass 0 found, and
    counts the photons it shot; the command exits 0."""
    from blockhash.cli import main

    context_or_skip("egl")
    dark = scene(light="[-2.0, -1.0, 0.0]")
    with pytest.warns(NoCausticWarning) as caught:
        result = render_scene(dark, size=(12, 12), photons=1000)
    notes = [str(w.message) for w in caught if issubclass(w.category, NoCausticWarning)]
    assert len(notes) == 1 and "no caustic photon stored of" in notes[0], notes
    assert "missed" in notes[0] or "direct diffuse" in notes[0]
    # dark, as Mitsuba renders it: the floor hides the light from everything the camera sees
    for name, layer in result.layers().items():
        assert np.isfinite(layer).all() and np.all(layer == 0), name
    assert result.info["photons_emitted"] > 0
    from conftest import RING_OBJECT, RING_TEMPLATE

    path = tmp_path / "dark.toml"
    path.write_text(RING_TEMPLATE.format(eye="[0.0, 1.9, 1.6]", target="[0.0, 0.0, 0.05]",
                                         light="[-2.0, -1.0, 0.0]", ring=RING_OBJECT))
    assert main(["render", str(path), "--size", "12x12", "--photons", "1000", "--passes", "2",
                 "-o", str(tmp_path / "dark.exr")]) == 0
    err = capsys.readouterr().err
    assert err.count("rendering direct light only") == 1, err


def test_vertex_normals_that_cancel_give_the_face_normal_in_the_gbuffer_as_in_the_ray_caster():
    """A floor whose vertex normals are zero (they cancel, or a file gave none of length):
    normalize(0) is NaN in GLSL; the rasterised G-buffer takes the face's normal, as the ray
    caster does, and the render stays finite."""
    from dataclasses import replace

    from blockhash.frame.scene_rays import SceneRays
    from blockhash.frame.subpixel import raycast_gbuffer
    from blockhash.scene import meshes

    context_or_skip("egl")
    s = scene().with_size(24, 24)
    floor = s.objects[0]
    flat = meshes.with_normals(floor.mesh.vertices, floor.mesh.faces, np.zeros_like(floor.mesh.vertices))
    s = replace(s, objects=(replace(floor, mesh=flat), *s.objects[1:]))
    g = rasterize(s.camera, s.objects, backend="egl")
    cast = raycast_gbuffer(s.camera, SceneRays(s.objects), samples=1)
    on_floor = g.object == 0
    assert on_floor.any() and np.isfinite(g.normal).all()
    np.testing.assert_allclose(g.normal[on_floor], np.tile([0, 1.0, 0], (on_floor.sum(), 1)), atol=1e-5)
    np.testing.assert_allclose(cast.normal[cast.object == 0], np.tile([0, 1.0, 0], ((cast.object == 0).sum(), 1)),
                               atol=1e-5)
    assert_sane(render_scene(s, photons=5_000, spp=1))
