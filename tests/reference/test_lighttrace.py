"""The light tracer (blockhash.reference.lighttrace) against an analytic caustic.

A point light at height HL below a plane mirror (y = H, facing down) over a Lambertian
floor (y = 0): the caustic on the floor is the light's mirror image at y = 2H - HL, times
the reflectance, so the floor's radiance is exactly ``kd / pi * R * I cos(theta) / d^2``
from the image point.  Pixels are checked against it within their own standard errors.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from blockhash.errors import InputError
from blockhash.reference.lighttrace import cached_reference, lambertian, light_trace, scene_digest
from blockhash.scene.camera import Pinhole
from blockhash.scene.loader import load_scene
from blockhash.scene.model import (
    Camera,
    MirrorMaterial,
    PhongMaterial,
    PhotonSettings,
    PointLight,
    Scene,
    SceneObject,
)

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

H, HL, KD, POWER = 2.0, 0.5, 0.5, 100.0
REFL = np.array([0.9, 0.6, 0.3])
LIGHT_X = 0.3  # off the camera's symmetry plane, so a left-right flip would show
SIZE = 24


def quad(y, half, normal):
    v = np.array([[-half, y, -half], [half, y, -half], [half, y, half], [-half, y, half]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    if np.cross(v[1] - v[0], v[2] - v[0]) @ normal < 0:
        f = f[:, ::-1]
    return trimesh.Trimesh(v, f, vertex_normals=np.tile(normal, (4, 1)), process=False)


def mirror_scene(*, mirror=True, ks=0.0, fov=50.0):
    floor = SceneObject("floor", quad(0.0, 6.0, np.array([0, 1.0, 0])),
                        PhongMaterial(kd=np.full(3, KD), ks=np.full(3, ks), n=10.0))
    objects = [floor]
    if mirror:
        objects.append(SceneObject("mirror", quad(H, 1.5, np.array([0, -1.0, 0])), MirrorMaterial(REFL)))
    cam = Camera(eye=(0.0, 1.2, 1.5), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov_y_deg=fov,
                 width=SIZE, height=SIZE)
    return Scene(camera=cam, lights=(PointLight((LIGHT_X, HL, 0.0), (POWER,) * 3),),
                 objects=tuple(objects), photons=PhotonSettings(count=1000, k=50, A=8, seed=1,
                                                                max_bounces=2))


def analytic(scene) -> np.ndarray:
    """(h, w, 3) exact caustic radiance of the floor at the pixel centres."""
    pin = Pinhole.of(scene.camera)
    d = pin.pixel_rays()
    p = pin.eye + (-pin.eye[1] / d[:, 1])[:, None] * d
    v = p - [LIGHT_X, 2 * H - HL, 0.0]
    dist = np.linalg.norm(v, axis=1)
    irradiance = POWER / (4 * np.pi) * (2 * H - HL) / dist ** 3
    return ((KD / np.pi * irradiance)[:, None] * REFL).reshape(SIZE, SIZE, 3)


def rel_rms(image, exact):
    return float(np.sqrt(np.mean((image - exact) ** 2)) / np.sqrt(np.mean(exact ** 2)))


@pytest.fixture(scope="module")
def traced():
    scene = mirror_scene()
    return scene, light_trace(scene, 800_000, seed=5)


def test_pixels_match_the_mirror_image_of_the_light_within_their_noise(traced):
    scene, img = traced
    exact = analytic(scene)
    assert img.visible.all()
    z = (img.radiance - exact) / img.stderr
    # z-scores of independent pixels: mean square near 1, no outlier past 5 sigma
    assert 0.8 < np.mean(z ** 2) < 1.25, np.mean(z ** 2)
    assert np.abs(z).max() < 5.0


def test_total_flux_matches_within_the_summed_noise(traced):
    scene, img = traced
    exact = analytic(scene)
    sigma = np.sqrt(np.sum(img.stderr ** 2, axis=(0, 1)))
    assert np.all(np.abs(img.radiance.sum(axis=(0, 1)) - exact.sum(axis=(0, 1))) < 4 * sigma)
    assert img.radiance.sum() / exact.sum() == pytest.approx(1.0, abs=0.02)


@pytest.mark.slow
def test_error_falls_as_one_over_sqrt_photons():
    scene = mirror_scene()
    exact = analytic(scene)
    coarse = rel_rms(light_trace(scene, 100_000, seed=11).radiance, exact)
    fine = rel_rms(light_trace(scene, 1_600_000, seed=12).radiance, exact)
    assert 3.0 < coarse / fine < 5.4, (coarse, fine)  # sqrt(16) = 4


def test_image_does_not_depend_on_the_batch_size():
    scene = mirror_scene()
    a = light_trace(scene, 30_000, seed=2, batch_size=7_000)
    b = light_trace(scene, 30_000, seed=2)
    np.testing.assert_allclose(a.radiance, b.radiance, rtol=1e-12, atol=0)
    assert a.radiance.sum() > 0


def test_glossy_receiver_differs_and_a_scene_without_mirrors_is_black():
    glossy = light_trace(mirror_scene(ks=0.4), 50_000, seed=3)
    plain = light_trace(mirror_scene(), 50_000, seed=3)
    assert not np.allclose(glossy.radiance, plain.radiance)
    assert np.all(light_trace(mirror_scene(mirror=False), 1000).radiance == 0)


def test_reference_is_cached_by_scene_content(tmp_path):
    scene = mirror_scene()
    first, path = cached_reference(scene, 20_000, cache_dir=tmp_path)
    again, path2 = cached_reference(scene, 20_000, cache_dir=tmp_path)
    assert path == path2 and path.is_file()
    np.testing.assert_array_equal(first.radiance, again.radiance)
    assert scene_digest(scene) != scene_digest(mirror_scene(ks=0.4))
    assert scene_digest(lambertian(mirror_scene(ks=0.4))) == scene_digest(mirror_scene())


def test_photon_count_must_be_positive():
    with pytest.raises(InputError, match="photons=0"):
        light_trace(mirror_scene(), 0)


@pytest.mark.slow
def test_exact_knn_photon_map_agrees_with_the_light_tracer(traced):
    """The renderer's pixels (G-buffer rows, camera) line up with the light tracer's."""
    from conftest import context_or_skip

    context_or_skip("egl")
    from blockhash import BlockHashIndex
    from blockhash.frame.caustic import estimate_exact
    from blockhash.frame.gbuffer import rasterize
    from blockhash.frame.scene_rays import SceneRays
    from blockhash.frame.shading import shading_points
    from blockhash.photons.tracing import trace_caustic_photons
    from blockhash.scene.materials import receiver_materials

    scene, img = traced
    photons = trace_caustic_photons(scene, 200_000, seed=4)
    index = BlockHashIndex(photons.positions, k=50, A=1, directions=photons.directions,
                           normals=photons.normals, powers=photons.powers)
    g = rasterize(scene.camera, scene.objects, backend="egl")
    points = shading_points(scene.camera, g, scene.objects, SceneRays(scene.objects), (MirrorMaterial,))
    est = estimate_exact(index, points, receiver_materials(scene.objects), gpu=False)
    exact = analytic(scene)
    # The default (conserving) estimate's noise is about sqrt(1.5 / 36) = 0.2 per pixel
    # (each photon over the disc to its 36th neighbour, cone filter); both images must
    # match the truth
    assert rel_rms(est, exact) < 0.3
    assert rel_rms(img.radiance, exact) < 0.25
    assert rel_rms(est, img.radiance) < 0.35  # both noises: about sqrt(0.2^2 + 0.2^2)
    assert est.sum() / img.radiance.sum() == pytest.approx(1.0, abs=0.05)


def test_projection_inverts_the_pixel_rays():
    pin = Pinhole.of(mirror_scene().camera, (17, 11))
    rays = pin.pixel_rays()
    pix, cos_c = pin.project(pin.eye + 2.5 * rays)
    np.testing.assert_array_equal(pix, np.arange(17 * 11))
    np.testing.assert_allclose(cos_c, rays @ pin.forward, rtol=1e-12)
    assert pin.project(pin.eye - rays[:1])[0][0] == -1  # behind the camera


def test_visible_pixels_line_up_with_the_renderers_gbuffer():
    """A floor only on the camera's left-hand, near side: both must see it in the same pixels."""
    from conftest import context_or_skip

    context_or_skip("egl")
    from blockhash.frame.gbuffer import rasterize

    base = mirror_scene()
    v = np.array([[-3.0, 0, 0.2], [0.1, 0, 0.2], [0.1, 0, 3.0], [-3.0, 0, 3.0]])
    f = np.array([[0, 2, 1], [0, 3, 2]])
    part = trimesh.Trimesh(v, f, vertex_normals=np.tile([0, 1.0, 0], (4, 1)), process=False)
    floor = SceneObject("floor", part, base.objects[0].material)
    scene = Scene(camera=base.camera, lights=base.lights, objects=(floor, base.objects[1]),
                  photons=base.photons)
    img = light_trace(scene, 1000)
    seen = rasterize(scene.camera, scene.objects, backend="egl").object == 0
    assert 0.1 < seen.mean() < 0.6
    assert np.mean(img.visible != seen) < 0.05  # edge pixels may differ


FILL_CACHE = """
import sys
import numpy as np
from blockhash.reference.lighttrace import cached_reference
from blockhash.scene.loader import load_scene
img, path = cached_reference(load_scene(sys.argv[1]), 30_000, size=(24, 16), cache_dir=sys.argv[2])
np.save(sys.argv[3], img.radiance)
print(path)
"""


@pytest.mark.slow
def test_two_processes_fill_one_cache_entry_at_once(tmp_path):
    """Two renders that trace the same reference at the same time both get the whole
    image, and the cache holds one complete file and nothing half-written."""
    import subprocess
    import sys
    from pathlib import Path

    scene = Path(__file__).resolve().parents[2] / "scenes" / "ring.toml"
    cache = tmp_path / "cache"
    procs = [subprocess.Popen([sys.executable, "-c", FILL_CACHE, str(scene), str(cache),
                               str(tmp_path / f"out{i}.npy")], stdout=subprocess.PIPE, text=True)
             for i in range(2)]
    paths = [p.communicate(timeout=600)[0].strip() for p in procs]
    assert [p.returncode for p in procs] == [0, 0]
    assert paths[0] == paths[1]
    assert sorted(f.name for f in cache.iterdir()) == [Path(paths[0]).name]
    a, b = np.load(tmp_path / "out0.npy"), np.load(tmp_path / "out1.npy")
    np.testing.assert_array_equal(a, b)
    assert a.sum() > 0
    again, _ = cached_reference(load_scene(scene), 30_000, size=(24, 16), cache_dir=cache)
    np.testing.assert_array_equal(again.radiance, a)


def test_an_unreadable_cache_file_is_traced_again(tmp_path):
    scene = mirror_scene()
    first, path = cached_reference(scene, 5_000, cache_dir=tmp_path)
    path.write_bytes(path.read_bytes()[:100])  # cut short
    with pytest.warns(UserWarning, match="unreadable"):
        again, path2 = cached_reference(scene, 5_000, cache_dir=tmp_path)
    assert path2 == path
    np.testing.assert_array_equal(again.radiance, first.radiance)
    third, _ = cached_reference(scene, 5_000, cache_dir=tmp_path)  # whole again
    np.testing.assert_array_equal(third.radiance, first.radiance)


def test_the_cache_key_follows_the_code(tmp_path, monkeypatch):
    import blockhash.reference.lighttrace as lt
    scene = mirror_scene()
    _, path = cached_reference(scene, 5_000, cache_dir=tmp_path)
    monkeypatch.setattr(lt, "source_digest", lambda parts: "edited")
    _, moved = cached_reference(scene, 5_000, cache_dir=tmp_path)
    assert moved != path
