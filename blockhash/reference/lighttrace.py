"""An unbiased reference for the caustic layer: light tracing (particle tracing) to the camera.

The photon map estimates caustic radiance by density estimation, which blurs and
biases (paper section 6 only compares approximate with exact neighbours).  This
module computes the same layer without any density estimate, so that both can be
measured against it:

1. Photons leave the lights exactly as the photon map's do (:mod:`blockhash.photons.emission`, the
   same cone sampling and counter-based Philox streams, photon ``i`` of a seed has
   the same numbers whatever the batch size) and bounce off perfect mirrors and through
   glass (the same Fresnel choices) to their first diffuse hit
   (:func:`blockhash.photons.paths.trace_batch`); only paths L S+ D are kept.
   Unlike the map, a fixed number ``M`` of photons is shot, so each carries
   ``Phi_i = w_i / M`` (``w_i`` the emission weight times the mirror reflectances).
2. Every such hit ``x`` is connected to the pinhole at ``e``: the camera must lie on
   the side of the surface the photon arrived on (geometric and shading normal), in
   front of the camera and inside the image, and a shadow ray from ``x`` to ``e``
   through embree must be free.
3. The contribution to the pixel ``j`` that ``x`` projects into is

       Phi_i  f_r(w_i, w_o)  cos(theta_x) / d^2  W_e(theta_c)

   with ``f_r`` the modified Phong BRDF (:func:`blockhash.scene.materials.phong_brdf`, ``w_i`` toward
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
also shows caustics *in mirrors* (:func:`blockhash.frame.shading.shading_points` moves a mirror
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
import os
import tempfile
import time
import warnings
import zipfile
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from blockhash import __version__
from blockhash.code_version import source_digest
from blockhash.errors import InputError
from blockhash.frame.film_filter import continuous_share, spread
from blockhash.frame.scene_rays import SceneRays
from blockhash.photons.emission import Emitter
from blockhash.photons.paths import trace_batch
from blockhash.scene.camera import Pinhole
from blockhash.scene.materials import material_arrays, phong_brdf, receiver_materials
from blockhash.scene.raycast import EmbreeGeometry
from blockhash.validate import as_int

#: Default photons per batch (memory ~ 1 KB per photon in flight).
BATCH = 1 << 18
#: The reference's default Philox key is the scene's seed plus this offset, so its
#: photons are independent of any photon map traced with the scene's own seed.
REFERENCE_SEED_OFFSET = 1 << 64
#: The code a reference image depends on: a cached image is keyed by the source of these
#: parts of the package (and the version), so an edit to the tracer or the scene model
#: never reads an image the old code traced.
CODE_PARTS = ("reference", "photons", "scene", "frame/shading.py")


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
        """(h, w) bool: visible pixels whose neighbours within ``erode`` pixels are visible too.

        Pixels seen through a mirror or glass are left out: this tracer (and Mitsuba's
        ``ptracer``) connects each caustic hit to the pinhole by a straight shadow ray, which
        cannot pass a delta surface, so its caustic there is 0 while the renderer's (which
        follows camera rays through mirrors and glass) is not.  Those pixels are checked by
        the mirror identity instead (``tools/mirror_identity.py``)."""
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


def directly_visible(scene, pinhole: Pinhole, rays: SceneRays) -> np.ndarray:
    """(h, w) bool: the view ray through each pixel centre first meets a diffuse object."""
    d = pinhole.pixel_rays()
    hit, _, _, obj, _ = rays.first_hit(np.broadcast_to(pinhole.eye, d.shape).copy(), d)
    diffuse = np.array([not o.is_specular for o in scene.objects] + [False])
    return (hit & diffuse[obj]).reshape(pinhole.height, pinhole.width)


# --------------------------------------------------------------------------- tracing

@dataclass(frozen=True)
class FilmWeights:
    """A camera filter other than the box and each pixel's share of a connection under it
    (:func:`blockhash.frame.film_filter.continuous_share`)."""

    filter: object
    share: np.ndarray


def light_trace(scene, photons: int, *, size=None, seed: int | None = None,
                batch_size: int = BATCH, progress: bool = False,
                layer: str = "caustic") -> LightTraceImage:
    """Light-trace the caustic layer of ``scene`` with ``photons`` photons shot; with
    ``layer="indirect"``, the indirect layer: photons over the whole scene
    (:class:`blockhash.photons.indirect.IndirectSource`), every diffuse vertex after a path's
    first connected to the camera.

    Parameters
    ----------
    scene : blockhash.scene.model.Scene
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
    textured = [o.name for o in scene.objects if getattr(o.material, "texture", None) is not None]
    if textured:
        raise InputError(f"objects {textured} have textured reflectances, which the light tracer "
                         "does not model (its camera connections read one kd an object); take "
                         "the reference with Mitsuba (engine 'mitsuba')")
    coated = [o.name for o in scene.objects if getattr(o.material, "coat", 0.0)]
    if coated:
        raise InputError(f"objects {coated} are coated (plastic), whose coats the light "
                         "tracer's camera connections do not model; take the reference with "
                         "Mitsuba (engine 'mitsuba')")
    m_total = as_int(photons, "photons", minimum=1, hint="shoot at least one photon")
    seed = as_int(scene.photons.seed + REFERENCE_SEED_OFFSET if seed is None else seed, "seed",
                  minimum=0, maximum=2**128 - 1, hint="use a non-negative integer seed")
    batch_size = as_int(batch_size, "batch_size", minimum=1)
    pin = Pinhole.of(scene.camera, size)
    if pin.aperture > 0:
        raise InputError(f"the light tracer connects photons to a pinhole; this camera has a thin "
                         f"lens (aperture_radius {pin.aperture:g}): render its reference with "
                         "Mitsuba (engine 'mitsuba'), or set aperture_radius 0")
    rays = SceneRays(scene.objects)
    geom: EmbreeGeometry = rays.geometry
    visible = directly_visible(scene, pin, rays)
    npix = pin.width * pin.height
    sum1 = np.zeros((npix, 3))
    sum2 = np.zeros((npix, 3))
    pf = scene.camera.filter
    film = None if pf.is_box else FilmWeights(pf, continuous_share(pf, pin.width, pin.height))
    stats = {"photons": m_total, "seed": seed, "size": [pin.width, pin.height],
             "stored": 0, "connected": 0}
    specular = tuple(scene.specular_objects)
    if layer not in ("caustic", "indirect"):
        raise InputError(f"layer={layer!r}: the light tracer renders the 'caustic' or the "
                         "'indirect' layer; give one of those")
    if layer == "indirect":
        _trace_indirect(scene, rays, pin, m_total, seed, batch_size, sum1, sum2, stats, film)
    elif specular:
        emitter = Emitter(tuple(scene.lights), specular, bounds=scene.bounds)
        if not emitter.sources:
            raise InputError("light_trace: no light reaches a specular object; aim a spot light "
                             "at a mirror or widen its cone_deg, or turn an area light to face one")
        kd, ks, e = material_arrays(receiver_materials(scene.objects))
        max_bounces = scene.photons.max_bounces
        bar = None
        if progress:
            from tqdm.auto import tqdm
            bar = tqdm(total=m_total, unit="photon", desc="light tracing")
        for start in range(0, m_total, batch_size):
            count = min(batch_size, m_total - start)
            origins, dirs, weights, _ = emitter.sample(emitter.uniforms(seed, start, count))
            b = trace_batch(geom, origins, dirs, weights, max_bounces, seed=seed, start=start)
            stats["stored"] += len(b.stored)
            _connect(b, pin, rays, kd, ks, e, sum1, sum2, stats, film)
            if bar is not None:
                bar.update(count)
        if bar is not None:
            bar.close()
    shape = (pin.height, pin.width, 3)
    stats["seconds"] = time.perf_counter() - t0
    return LightTraceImage(radiance=(sum1 / m_total).reshape(shape),
                           sum_squares=sum2.reshape(shape),
                           visible=visible, emitted=m_total, stats=stats)


def _trace_indirect(scene, rays: SceneRays, pin: Pinhole, m_total: int, seed: int,
                    batch_size: int, sum1, sum2, stats, film) -> None:
    """The indirect layer's photons, batch by batch, each stored vertex splatted (``_connect``)."""
    from blockhash.photons.indirect import IndirectSource

    source = IndirectSource(scene, rays.geometry, device="host")  # batch(): the host's paths
    kd, ks, e = material_arrays(receiver_materials(scene.objects))
    for start in range(0, m_total, batch_size):
        count = min(batch_size, m_total - start)
        b = source.batch(count, seed=seed, start=start)
        stats["stored"] += len(b.positions)
        _connect(b, pin, rays, kd, ks, e, sum1, sum2, stats, film)


def _connect(b, pin: Pinhole, rays: SceneRays, kd, ks, e, sum1, sum2, stats, film=None) -> None:
    """Splat every stored photon of batch ``b`` into its pixel (step 3 of the module docstring),
    or with ``film`` (:class:`FilmWeights`, a camera filter other than the box) into the pixels
    its filter reaches."""
    if not len(b.stored):
        return
    x, ns, ng = b.positions, b.normals, b.geo_normals
    to_eye = pin.eye - x
    d2 = np.einsum("ij,ij->i", to_eye, to_eye)
    wo = to_eye / np.sqrt(d2)[:, None]
    cos_x = np.einsum("ij,ij->i", ns, wo)
    pf = film.filter if film is not None else None
    if pf is None:
        pix, cos_c = pin.project(x)
        reaches = pix >= 0
    else:  # a photon just outside the image still weighs in the pixels its filter reaches
        fx, fy, z = pin.film_coords(x)
        r = pf.radius
        reaches = (z > 0) & (fx > -r) & (fx < pin.width + r) & (fy > -r) & (fy < pin.height + r)
        cos_c = np.where(reaches, z / np.sqrt(d2), 0.0)
    ok = (cos_x > 0) & (np.einsum("ij,ij->i", ng, wo) > 0) & reaches
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
    if pf is not None:
        for out, squared in ((sum1, False), (sum2, True)):
            out += spread(pf, fx[idx], fy[idx], contrib ** (2 if squared else 1), pin.width,
                          pin.height, film.share, squared=squared)
    else:
        for c in range(3):
            sum1[:, c] += np.bincount(pix[idx], contrib[:, c], minlength=len(sum1))
            sum2[:, c] += np.bincount(pix[idx], contrib[:, c] ** 2, minlength=len(sum2))
    stats["connected"] += int(idx.size)


# --------------------------------------------------------------------------- scenes and cache

def lambertian(scene):
    """A copy of ``scene`` with every Phong material's ``ks`` set to 0 (Lambertian receivers)."""
    from blockhash.scene.model import PhongMaterial

    objects = []
    for o in scene.objects:
        m = o.material
        if isinstance(m, PhongMaterial):
            o = replace(o, material=replace(m, ks=np.zeros(3)))
        objects.append(o)
    return replace(scene, objects=tuple(objects))


def scene_digest(scene) -> str:
    """sha256 of what the light tracer sees: camera, lights, geometry, materials, photon
    settings (a camera field past the pinhole's, such as a crop or a lens, only where it is
    not its default: the digests of scenes without them stay as they were)."""
    h = hashlib.sha256()
    c = scene.camera
    h.update(repr((c.eye.tolist(), c.target.tolist(), c.up.tolist(), c.fov_y_deg,
                   c.width, c.height) + (() if c.filter.is_box else (c.filter,))
                  + (() if c.crop is None else (c.crop,))
                  + (() if not c.aperture_radius else
                     (c.aperture_radius, c.focus_distance))).encode())
    for light in scene.lights:
        h.update(repr((type(light).__name__, *(np.asarray(getattr(light, a)).tolist()
                                               for a in ("position", "power", "direction",
                                                         "cone_deg", "object", "radiance",
                                                         "irradiance")
                                               if hasattr(light, a)))).encode())
        if hasattr(light, "image"):  # an environment light: its map and its turn
            h.update(np.ascontiguousarray(light.image).tobytes())
            h.update(np.ascontiguousarray(light.to_world).tobytes())
    for o in scene.objects:
        m = o.material
        h.update(repr((o.name, type(m).__name__,
                       *(np.asarray(getattr(m, a)).tolist()
                         for a in ("kd", "ks", "n", "sided", "reflectance", "ior", "tint")
                         if hasattr(m, a)))).encode())
        for arr in (o.mesh.vertices, o.mesh.faces, o.mesh.vertex_normals):
            h.update(np.ascontiguousarray(arr).tobytes())
    h.update(repr((scene.photons.seed, scene.photons.max_bounces)).encode())
    return h.hexdigest()


def cached_reference(scene, photons: int, *, size=None, seed: int | None = None,
                     cache_dir=None, progress: bool = False) -> tuple[LightTraceImage, Path | None]:
    """:func:`light_trace`, cached as ``.npz`` under ``cache_dir`` by content hash of the
    scene (:func:`scene_digest`), the settings and the code (:data:`CODE_PARTS`); written
    atomically, so concurrent renders may share a cache.  Returns (image, cache file or None)."""
    if cache_dir is None:
        return light_trace(scene, photons, size=size, seed=seed, progress=progress), None
    pin = Pinhole.of(scene.camera, size)
    key = hashlib.sha256(json.dumps({"scene": scene_digest(scene), "photons": int(photons),
                                     "size": [pin.width, pin.height], "seed": seed,
                                     "package": __version__,
                                     "code": source_digest(parts=CODE_PARTS)}).encode()).hexdigest()[:24]
    path = Path(cache_dir) / f"lighttrace-{key}.npz"
    if path.is_file():
        try:
            with np.load(path, allow_pickle=False) as z:
                return LightTraceImage(z["radiance"], z["sum_squares"], z["visible"],
                                       int(z["emitted"]), json.loads(str(z["stats"]))), path
        except (OSError, ValueError, KeyError, zipfile.BadZipFile) as e:
            # Not an image this code wrote (a copy cut short by a full disk, say): trace
            # again and replace it.
            warnings.warn(f"the reference cache {path} is unreadable ({e}); tracing it again",
                          stacklevel=2)
    img = light_trace(scene, photons, size=size, seed=seed, progress=progress)
    path.parent.mkdir(parents=True, exist_ok=True)
    # Written under a name of its own, then renamed over the cache file in one step: a
    # reader sees the old file or the whole new one, and two renders filling the same
    # entry at once each rename a complete file (the same image: tracing is deterministic).
    fd, tmp = tempfile.mkstemp(prefix=path.stem + ".", suffix=".tmp.npz", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez_compressed(f, radiance=img.radiance, sum_squares=img.sum_squares,
                                visible=img.visible, emitted=img.emitted,
                                stats=json.dumps(img.stats, default=str))
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return img, path
