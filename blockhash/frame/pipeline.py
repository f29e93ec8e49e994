"""Render a scene: caustic photons, Block Hashing index, G-buffer, direct light, caustic pass.

``render`` (``blockhash.render``) and ``render_scene`` (every setting a keyword) return
the three layers (direct, caustic, combined) and a
summary of every phase; ``blockhash render`` writes them to a multi-layer EXR
and a tone-mapped PNG.  The default ``method='auto'`` gathers, for the conserving estimate,
every photon whose own disc covers the shading point (the cover gather, in the shader) and
for the k-nearest estimates the Block Hashing walk; ``method='bh'`` the walk with every
estimate; ``method='kdtree'`` the exact k nearest photons from the kd-tree shader (the
estimate itself in numpy) for comparison; ``method='cpu'`` the CPU reference of what
``auto`` picks.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from blockhash.errors import InputError
from blockhash.frame.caustic import CausticPass, estimate_cpu, estimate_exact
from blockhash.frame.cover_estimate import cover_gather, estimate_cover_cpu
from blockhash.frame.estimate import EstimateOptions
from blockhash.frame.gbuffer import rasterize
from blockhash.frame.options import LookupOptions, resolve_method
from blockhash.frame.photon_radius import exact_radii2, own_radii2
from blockhash.frame.shading import SceneRays, direct_light, shading_points
from blockhash.frame.subpixel import box_filter, raycast_gbuffer
from blockhash.gl.limits import MAX_K
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.scene.camera import DEFAULT_SPP, SPP_SEED, spp_side
from blockhash.scene.materials import receiver_materials
from blockhash.validate import old_keywords


class NoCausticWarning(UserWarning):
    """The scene has no specular object or no photon reached a receiver."""


@dataclass
class RenderResult:
    """The layers of a render, (h, w, 3) float32 pixel means of ``spp`` samples each."""

    direct: np.ndarray
    caustic: np.ndarray
    timings: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)
    index: BlockHashIndex | None = None
    spp: int = 1

    @property
    def samples(self) -> np.ndarray:
        """(h, w) int32 samples averaged into each pixel."""
        return np.full(self.direct.shape[:2], self.spp, dtype=np.int32)

    @property
    def combined(self) -> np.ndarray:
        return self.direct + self.caustic

    def layers(self) -> dict:
        return {"direct": self.direct, "caustic": self.caustic, "combined": self.combined}


def render(scene, *, photons=None, spp=None, seed=None, estimate=EstimateOptions(),
           lookup=LookupOptions(), backend=None, progress=False) -> RenderResult:
    """Render ``scene`` (:func:`blockhash.load_scene`): its direct and caustic layers.

    Parameters
    ----------
    photons : int or CausticPhotons, optional
        Photons to trace (default: the scene's ``[photons] count``), or photons already
        traced (``blockhash.photons.tracing.trace_caustic_photons``), to compare lookups
        on one photon map.
    spp : int, optional
        Samples per pixel, a square number (default: the scene's ``[camera] spp``, else
        :data:`blockhash.scene.camera.DEFAULT_SPP`).
    seed : int, optional
        The photons' seed (default: the scene's ``[photons] seed``).
    estimate : EstimateOptions
        The density estimate (:mod:`blockhash.frame.estimate`).
    lookup : LookupOptions
        The photon search: method, k, A, shader variant.
    backend : {'auto', 'egl', 'osmesa'}, optional
    progress : bool
        Print the photon tracing's progress.

    Returns
    -------
    RenderResult
        ``direct``, ``caustic``, ``combined`` and ``layers()``, ``timings`` per stage,
        ``info``, the ``index``, and ``spp``.  The image size is the camera's
        (``Scene.with_size`` for another).
    """
    if not isinstance(estimate, EstimateOptions):
        raise InputError(f"estimate must be an EstimateOptions; got {type(estimate).__name__} "
                         "(e.g. estimate=EstimateOptions(estimate='unbiased'))")
    if not isinstance(lookup, LookupOptions):
        raise InputError(f"lookup must be a LookupOptions; got {type(lookup).__name__} "
                         "(e.g. lookup=LookupOptions(method='kdtree', k=50))")
    count, traced = ((photons, None) if photons is None or isinstance(photons, (int, np.integer))
                     else (None, photons))
    return render_scene(scene, photons=count, photon_map=traced, k=lookup.k, A=lookup.A,
                        method=lookup.method, variant=lookup.variant, seed=seed, backend=backend,
                        progress=progress, options=estimate, spp=spp)


#: render_scene's keywords that repeat fields of EstimateOptions.
_ESTIMATE_KEYWORDS = ("estimate", "filter", "normal_cos", "normal_test", "disc")


def render_scene(scene, *, photons=None, k=None, A=None, method="auto", variant="default",
                 size=None, seed=None, backend=None, progress=False, photon_map=None,
                 options=None, spp=None, **deprecated) -> RenderResult:
    """Render ``scene`` with every setting a keyword: the form :func:`render` is made
    from, which also takes an image ``size``.  The keywords ``estimate``, ``filter``,
    ``normal_cos``, ``normal_test`` and ``disc`` still work and warn
    (DeprecationWarning): give ``options=EstimateOptions(...)``, or call
    ``blockhash.render(scene, estimate=EstimateOptions(...))``.

    Parameters
    ----------
    photons, k, A, seed : optional
        Override the scene's ``[photons]`` settings.
    method : {'auto', 'cover', 'bh', 'kdtree', 'cpu'}
        :class:`~.options.LookupOptions`' method: 'auto' is the cover gather with the
        conserving estimate, the Block Hashing walk with the others.
    variant : str
        Shader variant of the Block Hashing lookup (``blockhash.gl.shaderlib.variants()``).
    size : (width, height), optional
        Override the camera's image size.
    photon_map : CausticPhotons, optional
        Reuse traced photons (for comparing methods on the same map).
    options : EstimateOptions, optional
        The density estimate's options (:mod:`blockhash.frame.estimate`; default:
        ``EstimateOptions()``).
    spp : int, optional
        Samples per pixel, a square number S * S (default: the scene's ``[camera] spp``,
        else :data:`blockhash.scene.camera.DEFAULT_SPP`).  1 shades the pixel centres the rasteriser
        gives; S * S > 1 casts one ray per cell of an S x S stratified, jittered grid in
        each pixel (a fixed pattern, :data:`blockhash.scene.camera.SPP_SEED`), and every sample gets
        its own hit, direct light and caustic estimate (one caustic pass over all of
        them) before the box filter averages them into pixels.
    """
    old_keywords("render_scene", deprecated, _ESTIMATE_KEYWORDS,
                 "give options=EstimateOptions(...), or call "
                 "blockhash.render(scene, estimate=EstimateOptions(...))")
    if deprecated:
        normal_test = deprecated.pop("normal_test", True)
        options = EstimateOptions.of(options, **deprecated)
        if not normal_test:
            options = replace(options, normal_cos=None)
    LookupOptions(method=method, k=k, A=A, variant=variant)  # checks them, as render's
    from blockhash.photons.tracing import trace_caustic_photons

    settings = scene.photons
    k = settings.k if k is None else k
    A = settings.A if A is None else A
    method = resolve_method(method, EstimateOptions.of(options).estimate)
    if method == "bh" and k > MAX_K:  # refused before hours of tracing, not after
        raise InputError(f"k={k} is above the lookup shader's limit MAX_K={MAX_K}; use k <= "
                         f"{MAX_K}, or method='cpu' or 'kdtree', or the conserving estimate's "
                         "cover gather (method='auto'), which has no such limit")
    options = EstimateOptions.of(options)
    side = spp_side((scene.camera.spp or DEFAULT_SPP) if spp is None else spp)
    timings, info = {}, {}
    info["estimate"] = options.label
    info["spp"] = side * side
    t0 = time.perf_counter()
    if photon_map is None and scene.specular_objects:
        photon_map = trace_caustic_photons(scene, photons or settings.count,
                                           seed=settings.seed if seed is None else seed,
                                           progress=progress)
    timings["trace"] = time.perf_counter() - t0
    stored = 0 if photon_map is None else len(photon_map.positions)
    info["photons_stored"] = stored
    if photon_map is not None:
        info["photons_emitted"] = photon_map.emitted
    index = None
    if stored >= k:
        t = time.perf_counter()
        # The cover gather reads the records in Hilbert order only: the hash tables are built
        # on first use (a caller's k-nearest query), not here.
        cover = method in ("cover", "cpu") and options.estimate == "conserving"
        index = BlockHashIndex(photon_map.positions, k=k, A=A, directions=photon_map.directions,
                               normals=photon_map.normals, powers=photon_map.powers,
                               tables=not cover)
        timings["index"] = time.perf_counter() - t
        info["index"] = (index.stats.summary() if index.tables_built else
                         f"photons {len(index):,} in Hilbert order (the cover gather's records; "
                         "the Block Hashing tables are built on first use)")
        if options.estimate == "conserving":
            t = time.perf_counter()
            (exact_radii2 if method == "kdtree" else own_radii2)(index, k)  # cached for the pass
            timings["photon radii"] = time.perf_counter() - t
            if method in ("cover", "cpu"):
                t = time.perf_counter()
                cover_gather(index, k)  # cached for the pass
                timings["cover gather"] = time.perf_counter() - t
    t = time.perf_counter()
    rays = SceneRays(scene.objects)
    points = camera_points(scene, rays, side, size=size, backend=backend)
    timings["gbuffer"] = time.perf_counter() - t
    t = time.perf_counter()
    direct = direct_light(points, scene.objects, scene.lights, rays)
    timings["direct"] = time.perf_counter() - t
    caustic = np.zeros_like(direct, dtype=np.float32)
    if stored == 0:
        why = ("the scene has no specular object" if not scene.specular_objects
               else "no caustic photon reached a receiver")
        warnings.warn(f"rendering direct light only: {why}", NoCausticWarning, stacklevel=2)
    elif stored < k:
        raise InputError(f"only {stored} caustic photons were stored, fewer than k={k}; "
                         "trace more photons (--photons) or lower --k")
    else:
        materials = receiver_materials(scene.objects)
        t = time.perf_counter()
        if method in ("bh", "cover"):
            cp = CausticPass(index, backend=backend, gather="cover" if method == "cover" else "knn")
            caustic = cp.render(points, materials, variant=variant, options=options)
        elif method == "cpu" and options.estimate == "conserving":
            caustic = estimate_cover_cpu(cover_gather(index, k), points, materials,
                                         options).astype(np.float32)
        elif method == "cpu":
            caustic = estimate_cpu(index, points, materials, variant=variant,
                                   options=options).astype(np.float32)
        else:
            caustic = estimate_exact(index, points, materials, backend=backend,
                                     options=options).astype(np.float32)
        timings["caustic"] = time.perf_counter() - t
    direct, caustic = points.gather(direct), points.gather(caustic)
    timings["total"] = time.perf_counter() - t0
    return RenderResult(direct=box_filter(direct, side), caustic=box_filter(caustic, side),
                        timings=timings, info=info, index=index, spp=side * side)


def camera_points(scene, rays: SceneRays, side: int, *, size=None, backend=None,
                  both_branches: bool = True, seed: int = SPP_SEED):
    """The camera's shading points at ``side`` x ``side`` samples per pixel: the rasterised
    pixel centres for one, else stratified jitter cast with ``rays`` (``seed``); mirrors and
    glass followed, glass on both branches unless ``both_branches`` is False
    (:func:`.shading.shading_points`)."""
    from blockhash.scene.model import MirrorMaterial

    if side == 1:
        gbuf = rasterize(scene.camera, scene.objects, size=size, backend=backend)
    else:
        gbuf = raycast_gbuffer(scene.camera, rays, size=size, samples=side, seed=seed)
    return shading_points(scene.camera, gbuf, scene.objects, rays, (MirrorMaterial,),
                          both_branches=both_branches)


def direct_layer(scene, spp=None, *, size=None, backend=None, both_branches: bool = True,
                 seed: int = SPP_SEED) -> np.ndarray:
    """(h, w, 3) float32 pixel means of the direct layer alone, as :func:`render_scene`
    computes it (no photons are traced): ``spp`` samples per pixel (default the scene's)."""
    side = spp_side((scene.camera.spp or DEFAULT_SPP) if spp is None else spp)
    rays = SceneRays(scene.objects)
    points = camera_points(scene, rays, side, size=size, backend=backend,
                           both_branches=both_branches, seed=seed)
    return box_filter(points.gather(direct_light(points, scene.objects, scene.lights, rays)), side)
