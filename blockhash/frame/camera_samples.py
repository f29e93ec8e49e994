"""The camera's shading points of a render or of one of its passes: :func:`camera_points`
(S x S or rows x cols samples per pixel) and :func:`camera_samples` (pass p's, with where the camera sees
the point directly), and :func:`only` (points outside a mask shading nothing)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from blockhash.frame.gbuffer import rasterize
from blockhash.frame.scene_rays import SceneRays
from blockhash.frame.shading import shading_points
from blockhash.frame.subpixel import LENS_KEY, film_gbuffer, pass_points, subpixel_points
from blockhash.scene.camera import SPP_SEED, Pinhole, grid_of, jitter_seed
from blockhash.scene.model import EnvironmentLight, MirrorMaterial


def camera_points(scene, rays: SceneRays, samples, *, size=None, backend=None,
                  both_branches: bool = True, seed: int = SPP_SEED):
    """The camera's shading points at ``samples`` per pixel (S for S x S, or ``(rows, cols)``)
    and the film points ``(x, y)`` of its samples: the rasterised pixel centres for one (a
    pinhole's), else stratified jitter cast with ``rays`` (``seed``); mirrors and glass
    followed, glass on both branches unless ``both_branches`` is False
    (:func:`.shading.shading_points`)."""
    pin = Pinhole.of(scene.camera, size)
    centres = grid_of(samples) == (1, 1) and not scene.camera.aperture_radius  # a lens: cast
    x, y = subpixel_points(pin.width, pin.height, samples, None if centres else seed)
    if centres:
        gbuf = rasterize(scene.camera, scene.objects, size=size, backend=backend)
    else:
        gbuf = film_gbuffer(pin, rays, x, y, lens_seed=LENS_KEY + seed)
    return _shade(scene, rays, gbuf, both_branches), (x, y)


def camera_samples(scene, rays: SceneRays, samples, pass_index: int, *, backend=None):
    """The shading points of pass ``pass_index`` at ``samples`` per pixel (S for S x S, or
    ``(rows, cols)``), and a bool array of their shape: the camera saw the point directly (its
    first hit is not a mirror or glass).

    Pass 0 is :func:`camera_points`' layout (the one-pass render's).  Later passes take one
    sample per pixel from :func:`.subpixel.pass_offsets`, or stratified jitter under a seed
    of their own (:func:`blockhash.scene.camera.jitter_seed`): :func:`.subpixel.pass_points`.
    """
    if grid_of(samples) == (1, 1) and pass_index == 0 and not scene.camera.aperture_radius:
        gbuf = rasterize(scene.camera, scene.objects, backend=backend)
    else:
        pin = Pinhole.of(scene.camera)
        gbuf = film_gbuffer(pin, rays, *pass_points(pin.width, pin.height, samples, pass_index),
                            lens_seed=LENS_KEY + jitter_seed(pass_index))
    points = _shade(scene, rays, gbuf, True, pass_index)
    specular = np.array([o.is_specular for o in scene.objects] + [False])
    seen = ~specular[gbuf.object.reshape(-1)]  # object -1 (nothing hit): the last entry
    if points.owner is not None:
        seen = seen[points.owner]
    if points.first_hit is not None:  # a coat's reflection is not seen directly
        seen = seen & points.first_hit.reshape(-1)
    return points, seen.reshape(points.shape)


def _shade(scene, rays, gbuf, both_branches: bool, pass_index: int = 0):
    return shading_points(scene.camera, gbuf, scene.objects, rays, (MirrorMaterial,),
                          both_branches=both_branches, events=scene.photons.camera_bounces,
                          environment=any(isinstance(li, EnvironmentLight)
                                          for li in scene.lights), pass_index=pass_index,
                          lights=scene.lights)


def only(points, keep):
    """``points`` with every point outside ``keep`` shading nothing (material -1)."""
    return replace(points, material=np.where(keep, points.material, -1).astype(np.int32))
