"""Direct light against a numpy oracle: phong_brdf, the light's cone, and shadow rays cast
with first hits (not the occlusion query the renderer uses)."""

from dataclasses import replace
from pathlib import Path

import numpy as np

from blockhash.frame.direct_light import direct_light
from blockhash.frame.scene_rays import SceneRays
from blockhash.frame.shading import shading_points
from blockhash.frame.subpixel import raycast_gbuffer
from blockhash.scene.loader import load_scene
from blockhash.scene.materials import phong_brdf
from blockhash.scene.model import MirrorMaterial, SpotLight
from blockhash.scene.raycast import RAY_OFFSET

SCENES = Path(__file__).resolve().parents[2] / "scenes"


def oracle(points, objects, lights, rays):
    mat = points.material.reshape(-1)
    live = np.flatnonzero(mat >= 0)
    p = points.position.reshape(-1, 3)[live].astype(np.float64)
    n = points.normal.reshape(-1, 3)[live].astype(np.float64)
    wo = points.view.reshape(-1, 3)[live].astype(np.float64)
    table = [o.material for o in objects]
    kd = np.array([getattr(m, "kd", np.zeros(3)) for m in table])[mat[live]]
    ks = np.array([getattr(m, "ks", np.zeros(3)) for m in table])[mat[live]]
    e = np.array([getattr(m, "n", 1.0) for m in table])[mat[live]]
    out = np.zeros((len(mat), 3))
    for light in lights:
        d = np.asarray(light.position) - p
        dist = np.linalg.norm(d, axis=1)
        wi = d / dist[:, None]
        cos = np.sum(wi * n, axis=1)
        hit, q, _, _, _ = rays.first_hit(p + n * RAY_OFFSET * rays.scale, wi)
        blocked = hit & (np.linalg.norm(q - p, axis=1) < dist * (1 - 1e-6))
        power = np.asarray(light.power, dtype=np.float64)
        if isinstance(light, SpotLight):
            cos_c = np.cos(np.radians(light.cone_deg))
            inside = -wi @ np.asarray(light.direction) >= cos_c
            intensity = np.where(inside[:, None], power / (2 * np.pi * (1 - cos_c)), 0.0)
        else:
            intensity = np.broadcast_to(power / (4 * np.pi), (len(p), 3))
        term = phong_brdf(wi, wo, n, kd, ks, e) * intensity * (np.maximum(cos, 0) / dist ** 2)[:, None]
        out[live] += np.where(((cos > 0) & ~blocked)[:, None], term, 0.0)
    return (out * points.weight.reshape(-1, 3)).reshape(*points.shape, 3)


def test_direct_light_equals_the_numpy_oracle_with_point_and_spot_lights():
    scene = load_scene(SCENES / "corner.toml")
    spot = SpotLight(position=[0.0, 1.5, 0.5], direction=[0.1, -1.0, -0.2], power=30.0, cone_deg=20.0)
    scene = replace(scene, lights=scene.lights + (spot,))
    rays = SceneRays(scene.objects)
    g = raycast_gbuffer(scene.camera, rays, size=(64, 64), samples=2, seed=3)
    pts = shading_points(scene.camera, g, scene.objects, rays, (MirrorMaterial,))
    got = direct_light(pts, scene.objects, scene.lights, rays)
    want = oracle(pts, scene.objects, scene.lights, rays)
    lit_by_spot = direct_light(pts, scene.objects, (spot,), rays)
    assert (lit_by_spot > 0).any() and (lit_by_spot == 0).any()  # the cone edge is inside the view
    assert (got == 0).any()  # shadows
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-12)
