"""Render a scene: caustic photons, Block Hashing index, G-buffer, direct light, caustic pass.

``render_scene`` returns the three layers (direct, caustic, combined) and a
summary of every phase; ``blockhash render`` writes them to a multi-layer EXR
and a tone-mapped PNG.  ``method='kdtree'`` replaces the Block Hashing lookup
by the exact k nearest photons from the kd-tree shader (the estimate itself in
numpy) for comparison; ``method='cpu'`` computes the caustic with the CPU
reference of the Block Hashing lookup.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from blockhash.render.caustic import CausticPass, estimate_cpu, estimate_exact
from blockhash.render.estimate import EstimateOptions
from blockhash.scene.materials import receiver_materials
from blockhash.errors import InputError
from blockhash.gl.limits import MAX_K
from blockhash.render.gbuffer import rasterize
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.render.photon_radius import exact_radii2, own_radii2
from blockhash.render.shading import SceneRays, direct_light, shading_points
from blockhash.render.subpixel import box_filter, raycast_gbuffer
from blockhash.scene.camera import DEFAULT_SPP, SPP_SEED, spp_side

METHODS = ("bh", "kdtree", "cpu")


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


def render_scene(scene, *, photons=None, k=None, A=None, method="bh", variant="default",
                 size=None, seed=None, backend=None, progress=False, photon_map=None,
                 estimate=None, filter=None, normal_cos=None, normal_test=True, disc=None,
                 options=None, spp=None) -> RenderResult:
    """Render ``scene`` (see :mod:`blockhash.scene.model`).

    Parameters
    ----------
    photons, k, A, seed : optional
        Override the scene's ``[photons]`` settings.
    method : {'bh', 'kdtree', 'cpu'}
    variant : str
        Shader variant of the Block Hashing lookup (``blockhash.gl.shaderlib.variants()``).
    size : (width, height), optional
        Override the camera's image size.
    photon_map : CausticPhotons, optional
        Reuse traced photons (for comparing methods on the same map).
    estimate : {'conserving', 'unbiased', 'paper'}, optional
    filter : {'none', 'cone', 'epanechnikov', 'silverman'}, optional
    normal_cos : float in [-1, 1], optional
        Threshold of the photon normal test, ``dot(n_photon, n) >= normal_cos``.
    normal_test : bool
        False turns the photon normal test off.
    disc : float >= 0, optional
        Flattened neighbourhood: photons within ``disc * r`` of the tangent plane.
    options : EstimateOptions, optional
        The density estimate's options (:mod:`blockhash.render.estimate`); the keywords
        above change single fields of it (default: ``EstimateOptions()``).
    spp : int, optional
        Samples per pixel, a square number S * S (default: the scene's ``[camera] spp``,
        else :data:`blockhash.scene.camera.DEFAULT_SPP`).  1 shades the pixel centres the rasteriser
        gives; S * S > 1 casts one ray per cell of an S x S stratified, jittered grid in
        each pixel (a fixed pattern, :data:`blockhash.scene.camera.SPP_SEED`), and every sample gets
        its own hit, direct light and caustic estimate (one caustic pass over all of
        them) before the box filter averages them into pixels.
    """
    from blockhash.scene.model import MirrorMaterial
    from blockhash.photons.tracing import trace_caustic_photons

    if method not in METHODS:
        raise InputError(f"method={method!r} is not known; choose one of {', '.join(METHODS)}")
    settings = scene.photons
    k = settings.k if k is None else k
    A = settings.A if A is None else A
    if method == "bh" and k > MAX_K:  # refused before hours of tracing, not after
        raise InputError(f"k={k} is above the lookup shader's limit MAX_K={MAX_K}; use k <= "
                         f"{MAX_K}, or method='cpu' or 'kdtree'")
    options = EstimateOptions.of(options, estimate=estimate, filter=filter, normal_cos=normal_cos,
                                 disc=disc)
    if not normal_test:
        options = replace(options, normal_cos=None)
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
        index = BlockHashIndex(photon_map.positions, k=k, A=A, directions=photon_map.directions,
                               normals=photon_map.normals, powers=photon_map.powers)
        timings["index"] = time.perf_counter() - t
        info["index"] = index.stats.summary()
        if options.estimate == "conserving":
            t = time.perf_counter()
            (exact_radii2 if method == "kdtree" else own_radii2)(index, k)  # cached for the pass
            timings["photon radii"] = time.perf_counter() - t
    t = time.perf_counter()
    rays = SceneRays(scene.objects)
    if side == 1:
        gbuf = rasterize(scene.camera, scene.objects, size=size, backend=backend)
    else:
        gbuf = raycast_gbuffer(scene.camera, rays, size=size, samples=side, seed=SPP_SEED)
    points = shading_points(scene.camera, gbuf, scene.objects, rays, (MirrorMaterial,))
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
        if method == "bh":
            caustic = CausticPass(index, backend=backend).render(points, materials, variant=variant,
                                                                 options=options)
        elif method == "cpu":
            caustic = estimate_cpu(index, points, materials, variant=variant,
                                   options=options).astype(np.float32)
        else:
            caustic = estimate_exact(index, points, materials, backend=backend,
                                     options=options).astype(np.float32)
        timings["caustic"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t0
    return RenderResult(direct=box_filter(direct, side), caustic=box_filter(caustic, side),
                        timings=timings, info=info, index=index, spp=side * side)
