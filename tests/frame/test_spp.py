"""Samples per pixel: stratified jitter, box-filtered; spp = 1 is the pixel-centre render."""

import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import context_or_skip

from blockhash.errors import InputError
from blockhash.frame.subpixel import box_filter
from blockhash.passes.pipeline import NoCausticWarning, render_scene
from blockhash.scene.camera import Pinhole, spp_grid
from blockhash.scene.loader import load_scene

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

ROOT = Path(__file__).resolve().parents[2]

#: A floor seen from straight above whose edge x = EDGE_X runs through the image at a slant
#: (rotated 20 degrees about y), lit by a point light above; nothing else, so no caustic.
STEP_EDGE = """
[camera]
eye = [0.0, 2.0, 0.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
fov_y_deg = 20.0
width = 24
height = 24
{spp}
[materials.floor]
kind = "phong"
kd = 0.5
[[lights]]
kind = "point"
position = [0.0, 1.0, 0.0]
power = 10.0
[[objects]]
name = "floor"
material = "floor"
rotate_deg = [0.0, 20.0, 0.0]
[objects.shape]
kind = "rectangle"
x = [-2.0, 0.0]
z = [-2.0, 2.0]
"""


def step_edge(tmp_path, spp_line=""):
    path = tmp_path / "edge.toml"
    path.write_text(STEP_EDGE.format(spp=spp_line))
    return load_scene(path)


def render_quiet(scene, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NoCausticWarning)
        return render_scene(scene, **kw)


def coverage(scene, s=64):
    """Share of each pixel's footprint on the floor, from a regular s x s grid of rays
    intersected with the floor's plane analytically (y = 0, inside the rotated half-plane)."""
    pin = Pinhole.of(scene.camera)
    ys, xs = np.mgrid[0:pin.height * s, 0:pin.width * s]
    d = pin.film_rays((xs.ravel() + 0.5) / s, (ys.ravel() + 0.5) / s)
    t = -pin.eye[1] / d[:, 1]
    p = pin.eye + t[:, None] * d
    a = np.radians(20.0)  # the floor's x axis after rotate_deg y = 20: (cos a, 0, -sin a)
    u = p[:, 0] * np.cos(a) - p[:, 2] * np.sin(a)
    on = (u <= 0.0).reshape(pin.height * s, pin.width * s).astype(float)
    return box_filter(on[..., None], s)[..., 0]


def test_any_spp_is_stratified_as_near_square_as_it_divides(tmp_path):
    assert [spp_grid(n) for n in (1, 9, 32, 128, 512, 7, 6)] == [
        (1, 1), (3, 3), (4, 8), (8, 16), (16, 32), (1, 7), (2, 3)]
    for bad in (0, 1025):
        with pytest.raises(InputError, match="spp"):
            spp_grid(bad)
    with pytest.raises(InputError, match=r"camera\.spp.*1 to 1024"):
        step_edge(tmp_path, "spp = 2000")
    assert step_edge(tmp_path, "spp = 6").camera.spp == 6


def test_box_filter_averages_each_pixels_samples():
    x = np.arange(36, dtype=float).reshape(6, 6, 1)
    out = box_filter(x, 3)
    assert out.shape == (2, 2, 1) and out[0, 0, 0] == pytest.approx(x[:3, :3].mean())


def test_spp_1_shades_pixel_centres_so_edges_alias(tmp_path):
    context_or_skip("egl")
    scene = step_edge(tmp_path)
    r = render_quiet(scene, spp=1)
    lit = r.direct[..., 0] > 0
    cover = coverage(scene)
    edge = (cover > 0.1) & (cover < 0.9)
    assert edge.sum() >= 10
    # Each edge pixel is all floor or all background: its centre decides.
    interior = r.direct[..., 0][cover == 1.0].min()
    assert np.all((r.direct[..., 0][edge] == 0) | (r.direct[..., 0][edge] >= 0.9 * interior))
    assert r.spp == 1 and (r.samples == 1).all() and lit.any()


def test_spp_16_antialiases_the_step_edge(tmp_path):
    """Each edge pixel's mean is its footprint's share of floor times the floor's radiance
    there (the neighbouring interior pixel's, which varies slowly), within the stratified
    estimate's error: 4 x 4 cells, one jittered sample each, so at most 4 cells are cut."""
    context_or_skip("egl")
    scene = step_edge(tmp_path, "spp = 16")
    r = render_quiet(scene)
    assert r.spp == 16 and r.samples.shape == (24, 24) and (r.samples == 16).all()
    cover = coverage(scene)
    value = r.direct[..., 0]
    rows, cols = np.nonzero((cover > 0.1) & (cover < 0.9))
    assert len(rows) >= 10
    for i, j in zip(rows, cols):
        # the floor is at u <= 0, to the image's left; the nearest fully covered pixel in the row
        full = [c for c in range(j - 1, -1, -1) if cover[i, c] == 1.0][0]
        share = value[i, j] / value[i, full]
        assert abs(share - cover[i, j]) <= 4 / 16 + 0.05, (i, j, share, cover[i, j])
    # Stratification: over the edge pixels, the error of the shares averages out.
    shares = np.array([value[i, j] / value[i, [c for c in range(j - 1, -1, -1)
                                                if cover[i, c] == 1.0][0]]
                       for i, j in zip(rows, cols)])
    assert abs(np.mean(shares - cover[rows, cols])) < 0.03


@pytest.mark.slow
def test_spp_images_are_the_same_in_every_run(tmp_path):
    context_or_skip("egl")
    scene = load_scene(ROOT / "scenes" / "ring.toml")
    a = render_scene(scene, photons=5000, size=(16, 16), spp=4)
    b = render_scene(scene, photons=5000, size=(16, 16), spp=4)
    assert np.array_equal(a.caustic, b.caustic) and np.array_equal(a.direct, b.direct)
    assert a.caustic.shape == (16, 16, 3) and a.caustic.max() > 0


def test_render_command_records_spp_in_the_exr(tmp_path, capsys):
    context_or_skip("egl")
    from blockhash.cli import main
    from blockhash.evaluate.images import read_attribute

    out = tmp_path / "ring.exr"
    assert main(["render", str(ROOT / "scenes" / "ring.toml"), "--size", "16x16", "--photons",
                 "3000", "--spp", "4", "--passes", "1", "-o", str(out)]) == 0
    assert read_attribute(out, "blockhash:spp") == 4
    assert "4 samples per pixel" in capsys.readouterr().out
    assert main(["render", str(ROOT / "scenes" / "ring.toml"), "--spp", "2000",
                 "-o", str(out)]) == 2
    assert "spp=2,000 is out of range" in capsys.readouterr().err


@pytest.mark.slow
def test_spp_1_is_the_pixel_centre_render_of_the_rasteriser():
    """spp = 1 takes the renderer's single-sample path unchanged: the rasterised G-buffer's
    shading points, their direct light and one caustic pass, with no filter."""
    context_or_skip("egl")
    from blockhash import BlockHashIndex
    from blockhash.device.choice import resolve
    from blockhash.frame.caustic import CausticPass
    from blockhash.frame.direct_light import direct_light
    from blockhash.frame.gbuffer import rasterize
    from blockhash.frame.scene_rays import SceneRays
    from blockhash.frame.shading import shading_points
    from blockhash.photons.tracing import trace_caustic_photons
    from blockhash.scene.materials import receiver_materials
    from blockhash.scene.model import MirrorMaterial

    scene = load_scene(ROOT / "scenes" / "ring.toml")
    pm = trace_caustic_photons(scene, 5000, seed=1)
    r = render_scene(scene, photon_map=pm, size=(24, 24), spp=1)
    rays = SceneRays(scene.objects).on_device(resolve())  # where the render casts
    pts = shading_points(scene.camera, rasterize(scene.camera, scene.objects, size=(24, 24)),
                         scene.objects, rays, (MirrorMaterial,))
    index = BlockHashIndex(pm.positions, k=scene.photons.k, A=scene.photons.A,
                           directions=pm.directions, normals=pm.normals, powers=pm.powers)
    caustic = CausticPass(index, gather="cover", radii=r.radii).render(pts, receiver_materials(scene.objects))
    np.testing.assert_array_equal(r.caustic, caustic)
    np.testing.assert_array_equal(r.direct, direct_light(pts, scene.objects, scene.lights,
                                                         rays).astype(np.float32))
