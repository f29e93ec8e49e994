"""The camera's pixel filter (:mod:`blockhash.scene.pixel_filter`) and a pass's pixels under it
(:mod:`blockhash.frame.film_filter`): Mitsuba's filter functions, a weighted mean that blurs
and never scales, the scene file's ``filter``, and a render under a tent against the light
tracer's reference under the same tent."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from conftest import context_or_skip

from blockhash.errors import InputError
from blockhash.frame.film_filter import continuous_share, filtered, spread, weights
from blockhash.frame.subpixel import box_filter, subpixel_points
from blockhash.scene.loader import load_scene
from blockhash.scene.pixel_filter import PixelFilter, pixel_filter

ROOT = Path(__file__).resolve().parents[2]
FILTERS = [PixelFilter("tent"), PixelFilter("tent", 2.5), PixelFilter("gaussian"),
           PixelFilter("gaussian", 1.2)]


@pytest.mark.parametrize("pf", FILTERS, ids=str)
def test_the_filter_functions_are_mitsubas(pf):
    from conftest import mitsuba_or_skip

    mitsuba_or_skip()
    from blockhash.reference.mitsuba import load_mitsuba_module

    mi, _ = load_mitsuba_module()
    name = "radius" if pf.kind == "tent" else "stddev"
    theirs = mi.load_dict({"type": pf.kind, name: pf.width})
    assert theirs.radius() == pytest.approx(pf.radius, rel=1e-6)
    d = np.linspace(-pf.radius - 0.5, pf.radius + 0.5, 41)
    np.testing.assert_allclose(pf.weight(d), np.ravel([theirs.eval(float(x)) for x in d]),
                               atol=1e-3)


@pytest.mark.parametrize("pf", FILTERS, ids=str)
@pytest.mark.parametrize("grid", [(1, 1), (2, 3), (4, 4)])
def test_a_flat_image_stays_flat_to_the_borders(pf, grid):
    x, y = subpixel_points(9, 7, grid, seed=4)
    out = filtered(np.full(x.shape + (3,), 2.5), x, y, pf, 9, 7)
    assert out.shape == (7, 9, 3)
    np.testing.assert_allclose(out, 2.5, rtol=1e-6)
    values = np.random.default_rng(1).random(x.shape + (3,))  # a pass's layers share its weights
    np.testing.assert_array_equal(filtered(values, x, y, pf, 9, 7, total=weights(pf, x, y, 9, 7)),
                                  filtered(values, x, y, pf, 9, 7))


def test_the_box_is_the_pixel_mean_and_a_wide_filter_blurs_a_point():
    rng = np.random.default_rng(0)
    x, y = subpixel_points(6, 5, (2, 3), seed=1)
    v = rng.random(x.shape + (3,))
    np.testing.assert_array_equal(filtered(v, x, y, PixelFilter(), 6, 5, (2, 3)),
                                  box_filter(v, (2, 3)))
    spike = np.zeros(x.shape + (1,))
    spike[4, 7] = 1.0  # one sample in pixel (2, 2)
    tent = filtered(spike, x, y, PixelFilter("tent", 1.5), 6, 5)[..., 0]
    assert tent[2, 2] == tent.max() and tent[1, 2] > 0 and tent[2, 1] > 0 and tent[0, 0] == 0


def test_a_splat_weighs_as_a_sample_at_its_point():
    """spread() gives a photon at a film point what a sample there would give every pixel."""
    pf = PixelFilter("tent", 1.5)
    x, y = subpixel_points(6, 5, (2, 2), seed=3)
    share = 4.0 / weights(pf, x, y, 6, 5)
    v = np.zeros(x.shape + (3,))
    v[3, 5] = [1.0, 2.0, 3.0]
    by_sample = filtered(v, x, y, pf, 6, 5).reshape(-1, 3)
    # as a splat: the sample's value over the samples a pixel (a box pixel's mean of one)
    by_splat = spread(pf, [x[3, 5]], [y[3, 5]], v[3, 5][None] / 4.0, 6, 5, share)
    np.testing.assert_allclose(by_splat, by_sample, rtol=1e-6, atol=1e-12)


def test_a_uniform_density_of_splats_has_the_filters_integral_inside():
    pf = PixelFilter("tent", 2.0)  # integral over the plane: radius^2
    share = continuous_share(pf, 12, 10).reshape(10, 12)
    assert share[5, 6] == pytest.approx(1 / 4.0, rel=1e-3)
    assert share[0, 0] > share[5, 6]  # less of the filter inside the image at a corner
    assert continuous_share(PixelFilter(), 3, 2) == pytest.approx(1.0)


def test_the_scene_files_filter(tmp_path):
    assert pixel_filter("tent") == PixelFilter("tent", 1.0)
    assert pixel_filter({"kind": "gaussian", "stddev": 0.7}) == PixelFilter("gaussian", 0.7)
    text = (ROOT / "scenes" / "ring.toml").read_text()
    for line, match in (('filter = "lanczos"', r"camera\.filter\.kind.*'box', 'tent', 'gaussian'"),
                        ('filter = {kind = "tent", stddev = 1.0}', r"camera\.filter\.stddev.*radius"),
                        ('filter = {kind = "tent", radius = 0.1}', r"camera\.filter\.radius.*above 0.5")):
        path = tmp_path / "bad.toml"
        path.write_text(text.replace("[camera]", f"[camera]\n{line}", 1))
        with pytest.raises(InputError, match=match):
            load_scene(path)
    path = tmp_path / "tent.toml"
    path.write_text(text.replace("[camera]", '[camera]\nfilter = {kind = "tent", radius = 1.5}', 1))
    assert load_scene(path).camera.filter == PixelFilter("tent", 1.5)


@pytest.mark.gl
@pytest.mark.slow
def test_a_tent_render_agrees_with_the_light_tracer_under_the_same_tent():
    """The ring under a tent of radius 1.5 at 6 samples a pixel (2 x 3 cells): its caustic
    against the light tracer's under the tent, where the camera sees the floor.  Measured:
    flux 1.007,
    rel. RMS in the caustic 0.087 (the box render against the tent's reference: 0.219)."""
    context_or_skip("egl")
    import blockhash
    from blockhash.reference.lighttrace import light_trace

    scene = load_scene(ROOT / "scenes" / "ring.toml")
    tent = dataclasses.replace(scene, camera=dataclasses.replace(
        scene.camera, width=48, height=48, spp=6, filter=PixelFilter("tent", 1.5)))
    ref = light_trace(tent, 1_000_000, seed=2)
    m = ref.visible
    lum = ref.radiance.sum(-1)
    region = m & (lum > 0.1 * lum[m].max())  # the caustic, where its edges are
    errs = {}
    for name, pf in (("tent", PixelFilter("tent", 1.5)), ("box", PixelFilter())):
        sc = dataclasses.replace(tent, camera=dataclasses.replace(tent.camera, filter=pf))
        img = blockhash.render(sc, photons=100_000, seed=1).caustic.astype(np.float64)
        flux = img.sum(-1)[m].sum() / ref.radiance.sum(-1)[m].sum()
        diff = (img - ref.radiance)[region]
        errs[name] = float(np.sqrt((diff ** 2).mean() / (ref.radiance[region] ** 2).mean()))
        if name == "tent":
            assert abs(flux - 1) < 0.02, f"flux {flux:.4f}"
    assert errs["tent"] < 0.12 and errs["box"] > 1.8 * errs["tent"], errs
