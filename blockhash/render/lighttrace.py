"""An unbiased reference for the caustic layer: light tracing (particle tracing) to the camera.

The photon map estimates caustic radiance by density estimation, which blurs and
biases (paper section 6 only compares approximate with exact neighbours).  This
module computes the same layer without any density estimate, so that both can be
measured against it:

1. Photons leave the lights exactly as the photon map's do (:mod:`.emission`, the
   same cone sampling and counter-based Philox streams, photon ``i`` of a seed has
   the same numbers whatever the batch size) and bounce off perfect mirrors and through
   glass (the same Fresnel choices) to their first diffuse hit
   (:func:`.tracing.trace_batch`); only paths L S+ D are kept.
   Unlike the map, a fixed number ``M`` of photons is shot, so each carries
   ``Phi_i = w_i / M`` (``w_i`` the emission weight times the mirror reflectances).
2. Every such hit ``x`` is connected to the pinhole at ``e``: the camera must lie on
   the side of the surface the photon arrived on (geometric and shading normal), in
   front of the camera and inside the image, and a shadow ray from ``x`` to ``e``
   through embree must be free.
3. The contribution to the pixel ``j`` that ``x`` projects into is

       Phi_i  f_r(w_i, w_o)  cos(theta_x) / d^2  W_e(theta_c)

   with ``f_r`` the modified Phong BRDF (:func:`.caustic.phong_brdf`, ``w_i`` toward
   where the photon came from, ``w_o`` toward the eye), ``theta_x`` the angle between
   the shading normal and ``w_o``, ``d = |x - e|`` and ``theta_c`` the angle between
   the view ray and the camera's forward axis.

The pinhole's importance.  A pixel's value is the mean radiance over its footprint
on the image plane at distance 1: ``I_j = (1/a) integral_pixel L dA_film`` with
``a = (2 tan(fov_x/2) / W) (2 tan(fov_y/2) / H)`` the pixel's area on that plane.
A film point at angle ``theta_c`` lies ``1/cos(theta_c)`` from the pinhole and its
plane is tilted by ``theta_c``, so ``dA_film = d_omega / cos^3(theta_c)`` and
``I_j = integral L W_e d_omega`` with ``W_e = 1 / (a cos^3(theta_c))`` per solid angle
(pbrt's ``1 / (A cos^4)`` per *projected* solid angle, times the ``cos`` it carries
at the lens).  The solid angle the camera sees of ``dA_x`` is
``cos(theta_x) dA_x / d^2``, which gives the factor in step 3.  Check: a uniform
Lambertian plane of radiance ``L`` gives ``I_j = (1/a) L a = L`` in every pixel.

What the image holds, and what not.  It is the caustic radiance *seen directly*:
pixels whose view ray meets a diffuse surface first.  The renderer's caustic layer
also shows caustics *in mirrors* (:func:`.shading.shading_points` moves a mirror
pixel's shading point to what the mirror reflects); the light tracer would need a
specular connection through the mirror for those and leaves them out.  So compare
only on :attr:`LightTraceImage.visible` (:meth:`LightTraceImage.comparison_mask`
also drops pixels next to a mirror or the background, which the pixel-area average
here and the renderer's one sample at the pixel centre see differently).  Direct
light and multiple diffuse bounces are in neither layer.

Noise.  Each pixel is a mean of ``M`` independent contributions ``X_i``; the
second moment ``sum X_i^2`` is kept, so :attr:`LightTraceImage.stderr` is the
standard error of every pixel and tests can use noise-derived tolerances.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .caustic import phong_brdf
from .emission import Emitter, photon_uniforms
from .raycast import EmbreeGeometry
from .shading import SceneRays
from .tracing import trace_batch
from ..errors import InputError
from ..validate import as_int

#: Default photons per batch (memory ~ 1 KB per photon in flight).
BATCH = 1 << 18
#: The reference's default Philox key is the scene's seed plus this offset, so its
#: photons are independent of any photon map traced with the scene's own seed.
REFERENCE_SEED_OFFSET = 1 << 64
#: Bump when the estimator changes, so that cached references are recomputed.
CACHE_VERSION = 1


@dataclass(frozen=True)
class LightTraceImage:
    """A light-traced caustic layer.

    radiance : (h, w, 3) float64      mean caustic radiance per pixel (W / (m^2 sr))
    sum_squares : (h, w, 3) float64   sum over photons of ``X_i^2``, ``X_i`` the pixel's
                                      value from photon i alone times M (so that
                                      ``radiance`` is the mean of the ``X_i``)
    visible : (h, w) bool             the view ray through the pixel centre meets a
                                      diffuse surface first (where the image is complete)
    emitted : int                     photons shot (M)
    stats : dict                      counters and settings
    """

    radiance: np.ndarray
    sum_squares: np.ndarray
    visible: np.ndarray
    emitted: int
    stats: dict = field(default_factory=dict)

    @property
    def stderr(self) -> np.ndarray:
        """(h, w, 3) standard error of each pixel: sqrt((E[X^2] - E[X]^2) / (M - 1))."""
        m = float(self.emitted)
        var = (self.sum_squares / m - self.radiance ** 2) / max(m - 1.0, 1.0)
        return np.sqrt(np.maximum(var, 0.0))

    def comparison_mask(self, erode: int = 1) -> np.ndarray:
        """(h, w) bool: visible pixels whose neighbours within ``erode`` pixels are visible too."""
        m = self.visible.copy()
        h, w = m.shape
        for dy in range(-erode, erode + 1):
            for dx in range(-erode, erode + 1):
                shifted = np.zeros_like(m)
                shifted[max(dy, 0):h + min(dy, 0), max(dx, 0):w + min(dx, 0)] = \
                    self.visible[max(-dy, 0):h + min(-dy, 0), max(-dx, 0):w + min(-dx, 0)]
                m &= shifted
        return m

    def __repr__(self) -> str:
        h, w = self.visible.shape
        return (f"LightTraceImage({w} x {h}, emitted={self.emitted:,}, "
                f"connected={self.stats.get('connected', 0):,}, "
                f"mean={self.radiance[self.visible].mean() if self.visible.any() else 0.0:.4g})")


# --------------------------------------------------------------------------- camera

@dataclass(frozen=True)
class Pinhole:
    """The scene camera at a given image size: projection and importance (see module docstring)."""

    eye: np.ndarray
    right: np.ndarray
    up: np.ndarray
    forward: np.ndarray
    tan_x: float
    tan_y: float
    width: int
    height: int

    @classmethod
    def of(cls, camera, size=None) -> "Pinhole":
        width, height = size or (camera.width, camera.height)
        cam = replace(camera, width=width, height=height)
        right, up, forward = cam.basis()
        tan_y = math.tan(math.radians(cam.fov_y_deg) / 2.0)
        return cls(np.asarray(cam.eye, np.float64), right, up, forward, tan_y * cam.aspect, tan_y,
                   int(width), int(height))

    @property
    def pixel_area(self) -> float:
        """Area of one pixel on the image plane at distance 1 from the pinhole."""
        return (2.0 * self.tan_x / self.width) * (2.0 * self.tan_y / self.height)

    def project(self, points):
        """(pixel index (m,) int64, -1 outside the image; cos(theta_c) (m,)) of world points."""
        v = points - self.eye
        z = v @ self.forward
        with np.errstate(divide="ignore", invalid="ignore"):
            sx = (v @ self.right) / (z * self.tan_x)
            sy = (v @ self.up) / (z * self.tan_y)
        col = np.floor((sx + 1.0) * 0.5 * self.width)
        row = np.floor((1.0 - sy) * 0.5 * self.height)  # row 0 at the top, like the renderer
        inside = (z > 0) & (col >= 0) & (col < self.width) & (row >= 0) & (row < self.height)
        pix = np.where(inside, row * self.width + col, -1)
        cos_c = np.where(inside, z / np.linalg.norm(v, axis=1), 0.0)
        return np.nan_to_num(pix, nan=-1).astype(np.int64), cos_c

    def film_rays(self, x, y) -> np.ndarray:
        """(m, 3) unit view directions through film points (x, y) in pixels, x from the left
        edge and y from the top (pixel (row, col) covers [col, col + 1) x [row, row + 1),
        the footprint :meth:`project` assigns to it)."""
        sx = (2.0 * np.ravel(x) / self.width - 1.0) * self.tan_x
        sy = (1.0 - 2.0 * np.ravel(y) / self.height) * self.tan_y
        d = self.forward + sx[:, None] * self.right + sy[:, None] * self.up
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    def pixel_rays(self) -> np.ndarray:
        """(h * w, 3) unit view directions through the pixel centres, row by row from the top."""
        gx, gy = np.meshgrid(np.arange(self.width) + 0.5, np.arange(self.height) + 0.5)
        return self.film_rays(gx, gy)


def directly_visible(scene, pinhole: Pinhole, rays: SceneRays) -> np.ndarray:
    """(h, w) bool: the view ray through each pixel centre first meets a diffuse object."""
    d = pinhole.pixel_rays()
    hit, _, _, obj, _ = rays.first_hit(np.broadcast_to(pinhole.eye, d.shape).copy(), d)
    diffuse = np.array([not o.is_specular for o in scene.objects] + [False])
    return (hit & diffuse[obj]).reshape(pinhole.height, pinhole.width)


# --------------------------------------------------------------------------- tracing

def _materials(objects):
    kd = np.array([getattr(o.material, "kd", np.zeros(3)) for o in objects], np.float64)
    ks = np.array([getattr(o.material, "ks", np.zeros(3)) for o in objects], np.float64)
    e = np.array([float(getattr(o.material, "n", 1.0)) for o in objects], np.float64)
    return kd, ks, e


def light_trace(scene, photons: int, *, size=None, seed: int | None = None,
                batch_size: int = BATCH, progress: bool = False) -> LightTraceImage:
    """Light-trace the caustic layer of ``scene`` with ``photons`` photons shot.

    Parameters
    ----------
    scene : blockhash.render.scene.Scene
    photons : int
        Photons shot toward the mirrors (M); the error falls as 1/sqrt(M).
    size : (width, height), optional
        Image size; default the camera's.
    seed : int, optional
        Philox key; default ``scene.photons.seed + REFERENCE_SEED_OFFSET`` (independent
        of the photon map's stream).
    batch_size : int
        Photons per vectorised batch; the image does not depend on it.

    Returns
    -------
    LightTraceImage
        All zeros when the scene has no mirror (no caustic).
    """
    t0 = time.perf_counter()
    m_total = as_int(photons, "photons", minimum=1, hint="shoot at least one photon")
    seed = as_int(scene.photons.seed + REFERENCE_SEED_OFFSET if seed is None else seed, "seed",
                  minimum=0, maximum=2**128 - 1, hint="use a non-negative integer seed")
    batch_size = as_int(batch_size, "batch_size", minimum=1)
    pin = Pinhole.of(scene.camera, size)
    rays = SceneRays(scene.objects)
    geom: EmbreeGeometry = rays.geometry
    visible = directly_visible(scene, pin, rays)
    npix = pin.width * pin.height
    sum1 = np.zeros((npix, 3))
    sum2 = np.zeros((npix, 3))
    stats = {"photons": m_total, "seed": seed, "size": [pin.width, pin.height],
             "stored": 0, "connected": 0}
    specular = tuple(scene.specular_objects)
    if specular:
        emitter = Emitter(tuple(scene.lights), specular)
        if not emitter.cones:
            raise InputError("light_trace: no light reaches a specular object; aim a spot light "
                             "at a mirror or widen its cone_deg")
        kd, ks, e = _materials(scene.objects)
        max_bounces = scene.photons.max_bounces
        bar = None
        if progress:
            from tqdm.auto import tqdm
            bar = tqdm(total=m_total, unit="photon", desc="light tracing")
        for start in range(0, m_total, batch_size):
            count = min(batch_size, m_total - start)
            origins, dirs, weights, _ = emitter.sample(photon_uniforms(seed, start, count))
            b = trace_batch(geom, origins, dirs, weights, max_bounces, seed=seed, start=start)
            stats["stored"] += len(b.stored)
            _connect(b, pin, rays, kd, ks, e, sum1, sum2, stats)
            if bar is not None:
                bar.update(count)
        if bar is not None:
            bar.close()
    shape = (pin.height, pin.width, 3)
    stats["seconds"] = time.perf_counter() - t0
    return LightTraceImage(radiance=(sum1 / m_total).reshape(shape),
                           sum_squares=sum2.reshape(shape),
                           visible=visible, emitted=m_total, stats=stats)


def _connect(b, pin: Pinhole, rays: SceneRays, kd, ks, e, sum1, sum2, stats) -> None:
    """Splat every stored photon of batch ``b`` into its pixel (step 3 of the module docstring)."""
    if not len(b.stored):
        return
    x, ns, ng = b.positions, b.normals, b.geo_normals
    to_eye = pin.eye - x
    d2 = np.einsum("ij,ij->i", to_eye, to_eye)
    wo = to_eye / np.sqrt(d2)[:, None]
    cos_x = np.einsum("ij,ij->i", ns, wo)
    pix, cos_c = pin.project(x)
    ok = (cos_x > 0) & (np.einsum("ij,ij->i", ng, wo) > 0) & (pix >= 0)
    idx = np.flatnonzero(ok)
    if not idx.size:
        return
    vis = rays.visible(x[idx], ng[idx], np.broadcast_to(pin.eye, (idx.size, 3)))
    idx = idx[vis]
    if not idx.size:
        return
    obj = b.objects[idx]
    f = phong_brdf(-b.directions[idx], wo[idx], ns[idx], kd[obj], ks[obj], e[obj])
    we = 1.0 / (pin.pixel_area * cos_c[idx] ** 3)
    contrib = b.weights[idx] * f * (cos_x[idx] * we / d2[idx])[:, None]
    for c in range(3):
        sum1[:, c] += np.bincount(pix[idx], contrib[:, c], minlength=len(sum1))
        sum2[:, c] += np.bincount(pix[idx], contrib[:, c] ** 2, minlength=len(sum2))
    stats["connected"] += int(idx.size)


# --------------------------------------------------------------------------- scenes and cache

def lambertian(scene):
    """A copy of ``scene`` with every Phong material's ``ks`` set to 0 (Lambertian receivers)."""
    from .scene import PhongMaterial

    objects = []
    for o in scene.objects:
        m = o.material
        if isinstance(m, PhongMaterial):
            o = replace(o, material=PhongMaterial(kd=m.kd, ks=np.zeros(3), n=m.n))
        objects.append(o)
    return replace(scene, objects=tuple(objects))


def scene_digest(scene) -> str:
    """sha256 of what the light tracer sees: camera, lights, geometry, materials, photon settings."""
    h = hashlib.sha256()
    c = scene.camera
    h.update(repr((c.eye.tolist(), c.target.tolist(), c.up.tolist(), c.fov_y_deg,
                   c.width, c.height)).encode())
    for light in scene.lights:
        h.update(repr((type(light).__name__, np.asarray(light.position).tolist(),
                       np.asarray(light.power).tolist(),
                       None if getattr(light, "direction", None) is None
                       else np.asarray(light.direction).tolist(),
                       getattr(light, "cone_deg", None))).encode())
    for o in scene.objects:
        m = o.material
        h.update(repr((o.name, type(m).__name__,
                       *(np.asarray(getattr(m, a)).tolist()
                         for a in ("kd", "ks", "n", "reflectance", "ior", "tint")
                         if hasattr(m, a)))).encode())
        for arr in (o.mesh.vertices, o.mesh.faces, o.mesh.vertex_normals):
            h.update(np.ascontiguousarray(arr).tobytes())
    h.update(repr((scene.photons.seed, scene.photons.max_bounces)).encode())
    return h.hexdigest()


def cached_reference(scene, photons: int, *, size=None, seed: int | None = None,
                     cache_dir=None, progress: bool = False) -> tuple[LightTraceImage, Path | None]:
    """:func:`light_trace`, cached as ``.npz`` under ``cache_dir`` by content hash of the
    scene (:func:`scene_digest`) and the settings.  Returns (image, cache file or None)."""
    if cache_dir is None:
        return light_trace(scene, photons, size=size, seed=seed, progress=progress), None
    pin = Pinhole.of(scene.camera, size)
    key = hashlib.sha256(json.dumps({"scene": scene_digest(scene), "photons": int(photons),
                                     "size": [pin.width, pin.height], "seed": seed,
                                     "version": CACHE_VERSION}).encode()).hexdigest()[:24]
    path = Path(cache_dir) / f"lighttrace-{key}.npz"
    if path.is_file():
        z = np.load(path, allow_pickle=False)
        return LightTraceImage(z["radiance"], z["sum_squares"], z["visible"], int(z["emitted"]),
                               json.loads(str(z["stats"]))), path
    img = light_trace(scene, photons, size=size, seed=seed, progress=progress)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, radiance=img.radiance, sum_squares=img.sum_squares,
                        visible=img.visible, emitted=img.emitted,
                        stats=json.dumps(img.stats, default=str))
    tmp.replace(path)
    return img, path
