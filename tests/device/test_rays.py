"""The camera side's ray casts on the device (blockhash.device.rays) against their oracle,
embree's host casts: first hits (hit, object, face side, point, both normals, face and
barycentrics) and shadow rays agree ray by ray within float32's tolerance; a render's camera
casts where its photons run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from blockhash.device.choice import resolve
from blockhash.errors import InputError
from blockhash.frame.scene_rays import SceneRays
from blockhash.scene.camera import Pinhole
from blockhash.scene.loader import load_scene

SCENES = Path(__file__).resolve().parents[2] / "scenes"


@pytest.fixture(scope="module")
def cpu():
    try:
        return resolve("cpu")
    except InputError as exc:
        pytest.skip(f"no Dr.Jit CPU device here: {exc}")


def _rays(scene, n: int, seed: int):
    """Camera rays through the film, and rays from random points in the scene's box in random
    directions (some start inside objects, some graze them)."""
    rng = np.random.default_rng(seed)
    pin = Pinhole.of(scene.camera, (64, 64))
    x, y = rng.random(n) * pin.width, rng.random(n) * pin.height
    o1, d1 = pin.lens_rays(x, y, 7)
    lo, hi = (np.asarray(b, dtype=np.float64) for b in scene.bounds)
    o2 = lo + rng.random((n, 3)) * (hi - lo)
    d2 = rng.normal(size=(n, 3))
    d2 /= np.linalg.norm(d2, axis=1, keepdims=True)
    return np.concatenate([o1, o2]), np.concatenate([d1, d2])


@pytest.mark.parametrize("name", ["ring", "glass", "cbox", "venus"])
def test_first_hits_agree_with_embree(cpu, name):
    scene = load_scene(SCENES / f"{name}.toml")
    host = SceneRays(scene.objects)
    device = SceneRays(scene.objects).on_device(cpu)
    o, d = _rays(scene, 4000, 1)
    h = host.first_hit(o, d, sides=True, faces=True)
    g = device.first_hit(o, d, sides=True, faces=True)
    hit = h[0]
    assert hit.sum() > 1000
    # A ray that grazes an edge or a silhouette may hit on one side and miss on the other.
    assert (g[0] == hit).mean() > 0.998
    both = hit & g[0]
    same = both & (g[3] == h[3])
    assert same.sum() > 0.995 * both.sum()
    tol = 1e-5 * host.scale
    close = np.linalg.norm(g[1] - h[1], axis=1) < tol
    assert close[same].mean() > 0.995  # the rest: the same object met at another surface
    s = same & close
    assert (g[6][s] == h[6][s]).mean() > 0.99  # faces (a point on an edge: either face)
    s &= g[6] == h[6]
    assert np.abs(g[2][s] - h[2][s]).max() < 1e-4  # shading normals
    assert np.abs(g[4][s] - h[4][s]).max() < 1e-5  # geometric normals
    assert (g[5][s] == h[5][s]).all()  # the face's side
    assert np.abs(g[7][s] - h[7][s]).max() < 1e-3  # barycentrics
    miss = ~g[0]
    assert (g[3][miss] == -1).all() and (g[6][miss] == -1).all()
    assert not g[1][miss].any() and not g[2][miss].any()


@pytest.mark.parametrize("name", ["ring", "cbox"])
def test_shadow_rays_agree_with_embree(cpu, name):
    scene = load_scene(SCENES / f"{name}.toml")
    host = SceneRays(scene.objects)
    device = SceneRays(scene.objects).on_device(cpu)
    o, d = _rays(scene, 3000, 2)
    hit, p, _, _, ng = host.first_hit(o, d)
    points, normals = p[hit], ng[hit]
    rng = np.random.default_rng(3)
    lo, hi = (np.asarray(b, dtype=np.float64) for b in scene.bounds)
    targets = lo + rng.random((len(points), 3)) * (hi - lo)
    seen_host = host.visible(points, normals, targets)
    seen_device = device.visible(points, normals, targets)
    assert 0.05 < seen_host.mean() < 0.95
    assert (seen_host == seen_device).mean() > 0.998
    far = np.full(len(points), np.inf)
    dirs = targets - points
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    lifted = points + normals * 1e-4 * host.scale
    assert (host.occluded(lifted, dirs, far) == device.occluded(lifted, dirs, far)).mean() > 0.998


def test_empty_batches(cpu):
    rays = SceneRays(load_scene(SCENES / "ring.toml").objects).on_device(cpu)
    hit, p, ns, obj, ng, outer, face, bary = rays.first_hit(np.zeros((0, 3)), np.zeros((0, 3)),
                                                            sides=True, faces=True)
    assert len(hit) == len(obj) == len(face) == 0 and p.shape == bary.shape[:1] + (3,)
    assert rays.occluded(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)).shape == (0,)


def test_a_render_casts_its_camera_rays_where_its_photons_run(cpu):
    from blockhash.passes.task import PassSettings, RenderSetup

    scene = load_scene(SCENES / "ring.toml")
    on_cpu = RenderSetup(scene, PassSettings.of(scene, photons=1000, device="cpu"))
    assert on_cpu.rays.device is not None and on_cpu.rays.device.device.name == "cpu"
    on_host = RenderSetup(scene, PassSettings.of(scene, photons=1000, device="host"))
    assert on_host.rays.device is None


@pytest.mark.parametrize("name,both", [("ring", True), ("glass", False), ("venus", True)])
def test_shading_points_and_direct_light_agree_with_embree(cpu, name, both):
    """The camera's shading points, mirrors and glass followed, and their direct light: the
    same numpy stages over the device's casts and over embree's."""
    from blockhash.frame.camera_samples import camera_points
    from blockhash.frame.direct_light import direct_light

    scene = load_scene(SCENES / f"{name}.toml")
    out = []
    for rays in (SceneRays(scene.objects), SceneRays(scene.objects).on_device(cpu)):
        points, _ = camera_points(scene, rays, 2, size=(48, 48), both_branches=both)
        out.append((points, direct_light(points, scene.objects, scene.lights, rays, 0)))
    (h, h_direct), (g, g_direct) = out
    assert h.shape == g.shape
    same = h.material == g.material
    assert same.mean() > 0.995 and (h.material >= 0).mean() > 0.3
    s = same & (h.material >= 0)
    assert np.abs(g.position[s] - h.position[s]).max() < 1e-4 * np.ptp(scene.bounds)
    assert np.percentile(np.abs(g.weight[s] - h.weight[s]), 99) < 1e-5
    lit = np.abs(g_direct[s] - h_direct[s]) <= 1e-4 * np.maximum(h_direct[s], 1e-3)
    assert lit.mean() > 0.99  # a shadow's edge: a sample lit on one side only


@pytest.mark.parametrize("aperture", [0.0, 0.05])
def test_the_films_gbuffer_made_on_the_device_is_embrees(cpu, aperture):
    """The camera's rays made and cast on the device (a pinhole and a thin lens, launches of
    :data:`CHUNK` rays) against the host's rays cast by embree."""
    from dataclasses import replace

    import blockhash.device.rays as device_rays
    from blockhash.frame.subpixel import film_gbuffer, pass_points

    scene = load_scene(SCENES / "ring.toml")
    camera = replace(scene.camera, aperture_radius=aperture, focus_distance=3.0)
    pin = Pinhole.of(camera, (40, 30))
    x, y = pass_points(40, 30, 3, 1)
    host = film_gbuffer(pin, SceneRays(scene.objects), x, y, lens_seed=11)
    chunk, device_rays.CHUNK = device_rays.CHUNK, 1000
    try:
        dev = film_gbuffer(pin, SceneRays(scene.objects).on_device(cpu), x, y, lens_seed=11)
    finally:
        device_rays.CHUNK = chunk
    assert dev.object.shape == host.object.shape == x.shape
    same = dev.object == host.object
    assert same.mean() > 0.998 and (host.object < 0).any() and (host.object >= 0).mean() > 0.5
    scale = np.ptp(scene.bounds)
    assert np.percentile(np.abs(dev.position[same] - host.position[same]), 99.9) < 1e-5 * scale
    assert np.percentile(np.abs(dev.normal[same] - host.normal[same]), 99.9) < 1e-4
    assert (dev.front[same] == host.front[same]).mean() > 0.999
    if aperture:
        assert np.abs(dev.origin - host.origin).max() < 1e-6 * scale
    else:
        assert dev.origin is None and host.origin is None


def test_one_film_kernel_serves_every_camera(cpu):
    """The camera's numbers reach the film's kernel as values, not literals, and the film
    points as arrays at one alignment: every frame of a moving camera, whatever its film's
    size, launches the one kernel (Dr.Jit's kernel history), where literals would compile a
    kernel a frame, and numpy's own alignment one of several."""
    from dataclasses import replace

    from blockhash.frame.subpixel import film_gbuffer, pass_points

    mi, dr = cpu.modules()
    scene = load_scene(SCENES / "ring.toml")
    rays = SceneRays(scene.objects).on_device(cpu)
    kernels = []
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    try:
        dr.kernel_history()  # what ran before: cleared by reading it
        for k in range(8):
            eye = np.asarray(scene.camera.eye) + [0.1 * k, 0.05 * k, 0.0]
            x, y = pass_points(16 + k % 3, 16, 1, k)
            film_gbuffer(Pinhole.of(replace(scene.camera, eye=tuple(eye)), (16 + k % 3, 16)),
                         rays, x, y)
            kernels.append([e["hash"] for e in dr.kernel_history()
                            if e["type"] == dr.KernelType.JIT])
    finally:
        dr.set_flag(dr.JitFlag.KernelHistory, False)
    later = [h for frame in kernels[1:] for h in frame]
    assert len(later) == 7 and len(set(later)) == 1, kernels
