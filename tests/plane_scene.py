"""The analytic plane the render in passes is held to: a point light over a rectangular
mirror casts its image onto a ceiling, whose caustic radiance is known in closed form
(:func:`analytic_caustic`)."""

import numpy as np
import pytest
import trimesh

from blockhash.scene.model import (
    Camera,
    MirrorMaterial,
    PhongMaterial,
    PhotonSettings,
    PointLight,
    Scene,
    SceneObject,
)

KD, RHO, POWER = 0.6, 0.9, 40.0
#: Mirror at y = 0 (half sides MX x MZ) under a point light at height D; the caustic (the
#: light's mirror image through the mirror's rectangle) falls on a ceiling at height H.
MX, MZ, D, H = 0.4, 0.25, 1.0, 2.0
SIZE = 32


def _quad(y, hx, hz, normal):
    v = np.array([[-hx, y, -hz], [hx, y, -hz], [hx, y, hz], [-hx, y, hz]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    if np.cross(v[1] - v[0], v[2] - v[0]) @ normal < 0:
        f = f[:, ::-1]
    return trimesh.Trimesh(v, f, vertex_normals=np.tile(normal, (4, 1)), process=False)


@pytest.fixture(scope="module")
def plane():
    """The mirror, the ceiling and a camera under the ceiling looking up at the caustic."""
    ceiling = PhongMaterial(kd=np.full(3, KD), ks=np.zeros(3), n=1.0)
    mirror = MirrorMaterial(reflectance=np.full(3, RHO))
    objects = (SceneObject("mirror", _quad(0.0, MX, MZ, np.array([0.0, 1.0, 0.0])), mirror),
               SceneObject("ceiling", _quad(H, 3.0, 3.0, np.array([0.0, -1.0, 0.0])), ceiling))
    cam = Camera(eye=(0.0, 1.3, 0.0), target=(0.0, H, 0.0), up=(0.0, 0.0, -1.0), fov_y_deg=100.0,
                 width=SIZE, height=SIZE)
    return Scene(camera=cam, lights=(PointLight(position=(0.0, D, 0.0), power=(POWER,) * 3),),
                 objects=objects, photons=PhotonSettings(count=4000, k=50, A=8, seed=2,
                                                         max_bounces=2))


def analytic_caustic(scene, sub: int = 8) -> np.ndarray:
    """(h, w) pixel means of the caustic radiance on the ceiling: kd / pi * rho I cos / r^2
    from the light's mirror image, where its ray crosses the mirror; ``sub`` x ``sub`` points
    per pixel."""
    from blockhash.scene.camera import Pinhole

    pin = Pinhole.of(scene.camera)
    off = (np.arange(sub) + 0.5) / sub
    x = (np.arange(SIZE)[None, :, None, None] + off[None, None, None, :])
    y = (np.arange(SIZE)[:, None, None, None] + off[None, None, :, None])
    x, y = np.broadcast_arrays(x, y)
    d = pin.film_rays(x, y)
    t = (H - pin.eye[1]) / d[:, 1]
    p = pin.eye + t[:, None] * d
    v = p - np.array([0.0, -D, 0.0])
    r2 = np.sum(v * v, axis=1)
    cos = v[:, 1] / np.sqrt(r2)
    cross = v * (D / v[:, 1])[:, None] + np.array([0.0, -D, 0.0])
    inside = (np.abs(cross[:, 0]) <= MX) & (np.abs(cross[:, 2]) <= MZ)
    L = KD / np.pi * RHO * POWER / (4 * np.pi) * cos / r2 * inside
    return L.reshape(SIZE, SIZE, sub * sub).mean(axis=2)


def error_against(img, truth):
    return float(np.sqrt(np.mean((img[..., 0] - truth) ** 2)) / np.sqrt(np.mean(truth ** 2)))

