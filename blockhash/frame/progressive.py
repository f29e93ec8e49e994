"""The render as a sequence of passes: stochastic progressive photon mapping.

A :class:`Renderer` builds what does not change once (the photon source with its embree
geometry and emitter, the camera's rays, the materials; the GL context and its compiled
programs are shared process-wide by :mod:`blockhash.gl`), then each :meth:`Renderer.step`
runs one pass:

1. photons: pass 0 shoots until the requested count is stored (exactly the one-pass render);
   pass p >= 1 shoots as many photons as pass 0 emitted, from photon ``p * PASS_STRIDE`` of
   the streams (:class:`blockhash.photons.tracing.PhotonSource`), so passes are independent
   and reproducible per (seed, pass);
2. the index of that batch and, for the conserving estimate, the photons' own radii scaled by
   the pass's shrink (:class:`PassRadii`);
3. a fresh camera sample per pixel (:func:`camera_samples`): pass 0 the one-pass layout,
   later passes the R2 sequence under a per-pixel shift (or stratified S x S jitter with a
   seed of the pass's own);
4. direct light and the caustic estimate of those samples, box-filtered into pixels and added
   to the :class:`~.film.Film`.

Radii shrink as Knaus and Zwicker's probabilistic progressive photon mapping (2011): the
squared radius of pass i (1-based) is ``r_1^2 prod_{j=2..i} (j - 1 + alpha) / j``, so the
variance of a pass grows as ``i^(1 - alpha)`` while the bias falls as ``r_i^2``, and the mean
of the passes converges to the unbiased image (MSE about ``N^-(2/3)`` passes at
``alpha = 2/3``).  Here ``r_1`` is each photon's own radius (its j-th nearest other photon in
its own pass, :mod:`.photon_radius`).  A photon whose disc is under ``footprint`` pixel
footprints across (the bound shrinking with the radii) and that the camera sees directly is
splatted into its pixel instead (:mod:`.pixel_splat`): a focus smaller than a pixel gives the
pixel's mean, not a point sample of it (the cover gather and its CPU reference; the other
searches gather every photon).  The k-nearest estimates
(``paper``, ``unbiased``) take their radius from the k-th neighbour: their passes average
noise away, their bias stays that of one pass.

Memory is one pass's: a pass's photons, index, gather and GL textures are released before
the next pass traces (the last pass's index stays on the image for callers that query it).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from blockhash.errors import InputError
from blockhash.frame.caustic import CausticPass, estimate_cpu, estimate_exact
from blockhash.frame.cover_estimate import cover_gather, estimate_cover_cpu
from blockhash.frame.estimate import EstimateOptions
from blockhash.frame.film import Film
from blockhash.frame.gbuffer import rasterize
from blockhash.frame.options import LookupOptions, resolve_method
from blockhash.frame.photon_radius import exact_radii2, own_radii2
from blockhash.frame.result import RenderResult
from blockhash.frame.shading import SceneRays, direct_light, shading_points
from blockhash.frame.subpixel import box_filter, film_gbuffer, pass_offsets, raycast_gbuffer
from blockhash.gl.limits import MAX_K
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.index.records.fixedpoint import min_r2
from blockhash.scene.camera import SPP_SEED, Pinhole, jitter_seed
from blockhash.validate import as_int

#: Knaus and Zwicker's alpha: the share of a pass's photons kept in the next radius.
DEFAULT_ALPHA = 2.0 / 3.0
#: Photons whose discs are under this many pixel footprints across (at pass 1; the bound
#: shrinks with the radii) and that the camera sees directly are splatted into their pixel
#: (:mod:`.pixel_splat`).
DEFAULT_FOOTPRINT = 1.0
#: A warning follows this many passes in a row that store no photon.
EMPTY_PASSES_WARNING = 10


class NoCausticWarning(UserWarning):
    """The scene has no specular object or no photon reached a receiver."""


class EmptyPassesWarning(UserWarning):
    """Many passes in a row stored no caustic photon."""


def shrink(pass_index: int, alpha: float) -> float:
    """The factor on the squared radii of pass ``pass_index`` (0-based):
    ``prod_{j=2..p+1} (j - 1 + alpha) / j`` (1 for the first pass)."""
    return math.exp(sum(math.log((j - 1 + alpha) / j) for j in range(2, pass_index + 2)))


@dataclass(frozen=True)
class PassRadii:
    """The squared radii of one pass of the conserving estimate: ``base(index, k)`` (each
    photon's own, :mod:`.photon_radius`) times ``scale``, at least the map's position error;
    float32 steps as the shader reads them.  Hashable and holding no index, so the caches
    keyed by the index let it go with the pass."""

    base: object
    scale: float = 1.0

    def __call__(self, index, k: int) -> np.ndarray:
        r2 = self.base(index, k)
        if self.scale == 1.0:
            return r2
        return np.maximum(r2 * self.scale, min_r2(index)).astype(np.float32).astype(np.float64)


@dataclass(eq=False)
class FixedRadii:
    """Squared radii computed before (on the pass's whole map, for the photons the gather
    keeps after the pixel splat took the rest): ``r2`` whatever the index.  Hashed by
    identity: one per pass."""

    r2: np.ndarray

    def __call__(self, index, k: int) -> np.ndarray:
        if len(index) != len(self.r2):
            raise InputError(f"these radii belong to a map of {len(self.r2):,} photons, not "
                             f"{len(index):,}; estimate on the render's own index")
        return self.r2


@dataclass(frozen=True)
class Schedule:
    """How a progressive render's passes shrink their radii.

    alpha : float in (0, 1)      Knaus and Zwicker's alpha (module docstring)
    footprint : float >= 0       photons whose discs are under this many pixel footprints
                                 across where the camera sees them directly are splatted
                                 into their pixel (:mod:`.pixel_splat`); 0: none is
    """

    alpha: float = DEFAULT_ALPHA
    footprint: float = DEFAULT_FOOTPRINT

    def __post_init__(self):
        if not (isinstance(self.alpha, (int, float)) and 0.0 < self.alpha < 1.0):
            raise InputError(f"alpha={self.alpha!r} is outside (0, 1): the share of a pass's "
                             f"photons kept in the next radius; use e.g. {DEFAULT_ALPHA:.3g}")
        if not (isinstance(self.footprint, (int, float)) and 0.0 <= self.footprint < math.inf):
            raise InputError(f"footprint={self.footprint!r}: the disc size in pixel footprints "
                             "under which photons are splatted into their pixel must be a finite "
                             f"number >= 0 (0 turns the splat off); use e.g. {DEFAULT_FOOTPRINT}")


@dataclass
class PassStats:
    """What one :meth:`Renderer.step` did."""

    index: int
    stored: int
    emitted: int
    scale: float
    timings: dict = field(default_factory=dict)


def camera_points(scene, rays: SceneRays, side: int, *, size=None, backend=None,
                  both_branches: bool = True, seed: int = SPP_SEED):
    """The camera's shading points at ``side`` x ``side`` samples per pixel: the rasterised
    pixel centres for one, else stratified jitter cast with ``rays`` (``seed``); mirrors and
    glass followed, glass on both branches unless ``both_branches`` is False
    (:func:`.shading.shading_points`)."""
    if side == 1:
        gbuf = rasterize(scene.camera, scene.objects, size=size, backend=backend)
    else:
        gbuf = raycast_gbuffer(scene.camera, rays, size=size, samples=side, seed=seed)
    return _shade(scene, rays, gbuf, both_branches)


def camera_samples(scene, rays: SceneRays, side: int, pass_index: int, *, backend=None):
    """The shading points of pass ``pass_index`` at ``side`` x ``side`` samples per pixel,
    and a bool array of their shape: the camera saw the point directly (its first hit is not
    a mirror or glass).

    Pass 0 is :func:`camera_points`' layout (the one-pass render's).  Later passes take one
    sample per pixel from :func:`.subpixel.pass_offsets`, or S x S stratified jitter under a
    seed of their own (:func:`blockhash.scene.camera.jitter_seed`).
    """
    if side == 1 and pass_index == 0:
        gbuf = rasterize(scene.camera, scene.objects, backend=backend)
    elif side == 1:
        pin = Pinhole.of(scene.camera)
        u, v = pass_offsets(pin.width, pin.height, pass_index, SPP_SEED)
        gbuf = film_gbuffer(pin, rays, np.arange(pin.width)[None, :] + u,
                            np.arange(pin.height)[:, None] + v)
    else:
        gbuf = raycast_gbuffer(scene.camera, rays, samples=side, seed=jitter_seed(pass_index))
    points = _shade(scene, rays, gbuf, True)
    specular = np.array([o.is_specular for o in scene.objects] + [False])
    seen = ~specular[gbuf.object.reshape(-1)]  # object -1 (nothing hit): the last entry
    if points.owner is not None:
        seen = seen[points.owner]
    return points, seen.reshape(points.shape)


def _shade(scene, rays, gbuf, both_branches: bool):
    from blockhash.scene.model import MirrorMaterial

    return shading_points(scene.camera, gbuf, scene.objects, rays, (MirrorMaterial,),
                          both_branches=both_branches)


def _only(points, keep):
    """``points`` with every point outside ``keep`` shading nothing (material -1)."""
    from dataclasses import replace

    return replace(points, material=np.where(keep, points.material, -1).astype(np.int32))


class Renderer:
    """A progressive render of ``scene``: :meth:`step` runs one pass, :attr:`image` is the
    image so far (:class:`.result.RenderResult`); see the module docstring.

    ``photons``: caustic photons stored in the first pass (every later pass emits as many as
    the first did), or a traced map (``CausticPhotons``) for a one-pass render.  ``side``:
    S for S x S samples per pixel per pass.  The rest as :func:`.pipeline.render`.
    """

    def __init__(self, scene, *, photons=None, side: int = 1, seed=None,
                 estimate: EstimateOptions = EstimateOptions(), lookup: LookupOptions = LookupOptions(),
                 backend=None, schedule: Schedule = Schedule()):
        from blockhash.photons.tracing import PhotonSource

        self.scene = scene
        self.side = as_int(side, "side", minimum=1)
        settings = scene.photons
        self.k = settings.k if lookup.k is None else lookup.k
        self.A = settings.A if lookup.A is None else lookup.A
        self.variant = lookup.variant
        self.estimate = estimate
        self.method = resolve_method(lookup.method, estimate.estimate)
        if self.method == "bh" and self.k > MAX_K:  # refused before hours of tracing, not after
            raise InputError(f"k={self.k} is above the lookup shader's limit MAX_K={MAX_K}; use "
                             f"k <= {MAX_K}, or method='cpu' or 'kdtree', or the conserving "
                             "estimate's cover gather (method='auto'), which has no such limit")
        self.backend = backend
        self.schedule = schedule
        self.seed = settings.seed if seed is None else seed
        if photons is None or isinstance(photons, (int, np.integer)):
            self.count, self.traced = photons or settings.count, None
        else:
            self.count, self.traced = None, photons
        self.rays = SceneRays(scene.objects)
        self.source = PhotonSource(scene, geometry=self.rays.geometry)
        from blockhash.scene.materials import receiver_materials

        self.materials = receiver_materials(scene.objects)
        pin = Pinhole.of(scene.camera)
        self.pin = pin
        self.film = Film(pin.height, pin.width)
        self.timings: dict = {}
        self.info: dict = {"estimate": estimate.label, "spp": self.side ** 2}
        self.first_emitted = None
        self.stored = self.emitted = 0
        self.empty_run = 0
        self.index = self.radii = None

    @property
    def passes(self) -> int:
        return self.film.passes

    def step(self) -> PassStats:
        """Run one pass and add it to the film."""
        p = self.passes
        self.index = self.radii = None  # the last pass's go before this pass's photons come
        timings: dict = {}
        t0 = time.perf_counter()
        photons = self._photons(p)
        timings["trace"] = time.perf_counter() - t0
        stored = len(photons.positions) if photons is not None else 0
        emitted = photons.emitted if photons is not None else 0
        scale = shrink(p, self.schedule.alpha)
        index, radii, splat, whole = self._index(photons, scale, timings)
        t = time.perf_counter()
        points, seen = camera_samples(self.scene, self.rays, self.side, p, backend=self.backend)
        timings["gbuffer"] = time.perf_counter() - t
        t = time.perf_counter()
        direct = direct_light(points, self.scene.objects, self.scene.lights, self.rays)
        timings["direct"] = time.perf_counter() - t
        caustic = np.zeros_like(direct, dtype=np.float32)
        t = time.perf_counter()
        if splat is not None and not seen.all():
            # Points seen in a mirror or through glass gather every photon: the splat reached
            # only the pixels that see its photons directly.
            caustic = self._caustic(whole[0], _only(points, ~seen), whole[1])
            if index is not None:
                caustic += self._caustic(index, _only(points, seen), radii)
        elif index is not None:
            caustic = self._caustic(index, points, radii)
        timings["caustic"] = time.perf_counter() - t
        caustic = box_filter(points.gather(caustic), self.side)
        if splat is not None:
            caustic = caustic + splat
        self.film.add(box_filter(points.gather(direct), self.side), caustic, emitted)
        timings["total"] = time.perf_counter() - t0
        for name, sec in timings.items():
            self.timings[name] = self.timings.get(name, 0.0) + sec
        self.index, self.radii = index, radii
        self._count(p, stored, emitted)
        return PassStats(p, stored, emitted, scale, timings)

    def _photons(self, p: int):
        from blockhash.photons.tracing import PASS_STRIDE

        if self.traced is not None:
            if p:
                raise InputError("a traced photon map (photons=CausticPhotons) is one pass; give "
                                 "photons=N (photons per pass) to render more passes")
            return self.traced
        if self.source.emitter is None:
            return None
        if p == 0:
            photons = self.source.until_stored(self.count, seed=self.seed)
            self.first_emitted = photons.emitted
            return photons
        return self.source.emit(self.first_emitted, seed=self.seed, start=p * PASS_STRIDE)

    def _index(self, photons, scale: float, timings: dict):
        """The pass's index and the conserving estimate's radii (None, None: no photons)."""
        stored = 0 if photons is None else len(photons.positions)
        if stored == 0:
            return None, None, None, None
        if self.passes == 0 and stored < self.k:
            raise InputError(f"only {stored} caustic photons were stored, fewer than k={self.k}; "
                             "trace more photons (--photons) or lower --k")
        t = time.perf_counter()
        # The cover gather reads the records in Hilbert order only: the hash tables are built
        # on first use (a caller's k-nearest query), not here.
        cover = self.method in ("cover", "cpu") and self.estimate.estimate == "conserving"
        index = BlockHashIndex(photons.positions, k=self.k, A=self.A,
                               directions=photons.directions, normals=photons.normals,
                               powers=photons.powers, tables=not cover)
        timings["index"] = time.perf_counter() - t
        if self.passes == 0:
            self.info["index"] = (
                index.stats.summary() if index.tables_built else
                f"photons {len(index):,} in Hilbert order (the cover gather's records; the "
                "Block Hashing tables are built on first use)")
        radii = splat = whole = None
        if self.estimate.estimate == "conserving":
            base = exact_radii2 if self.method == "kdtree" else own_radii2
            radii = PassRadii(base, scale)
            t = time.perf_counter()
            r2 = radii(index, self.k)  # cached for the pass (the base radii per index)
            timings["photon radii"] = time.perf_counter() - t
            if self.schedule.footprint > 0 and self.method in ("cover", "cpu"):
                t = time.perf_counter()
                whole = (index, FixedRadii(r2))
                index, radii, splat = self._split(photons, index, r2, scale, timings)
                timings["pixel splat"] = time.perf_counter() - t
            if self.method in ("cover", "cpu") and index is not None:
                t = time.perf_counter()
                cover_gather(index, self.k, radii)  # cached for the pass
                timings["cover gather"] = time.perf_counter() - t
        return index, radii, splat, whole

    def _split(self, photons, index, r2, scale, timings):
        """The pixel splat of the photons whose discs are under ``footprint`` pixel footprints
        (:mod:`.pixel_splat`), and the index and radii of the rest."""
        from blockhash.frame.pixel_splat import splat_subpixel

        image, keep = splat_subpixel(photons, r2, self.pin, self.rays, self.materials,
                                     footprint=self.schedule.footprint * math.sqrt(scale))
        if keep.all():
            return index, FixedRadii(r2), None
        rest = np.flatnonzero(keep)
        if not rest.size:  # every photon splatted: nothing left to gather
            return None, None, image
        t = time.perf_counter()
        index = BlockHashIndex(photons.positions[rest], k=self.k, A=self.A,
                               directions=photons.directions[rest], normals=photons.normals[rest],
                               powers=photons.powers[rest], tables=False)
        timings["index"] += time.perf_counter() - t
        return index, FixedRadii(r2[rest]), image

    def _caustic(self, index, points, radii) -> np.ndarray:
        options, method = self.estimate, self.method
        if method in ("bh", "cover"):
            cp = CausticPass(index, backend=self.backend, radii=radii,
                             gather="cover" if method == "cover" else "knn")
            try:
                return cp.render(points, self.materials, variant=self.variant, options=options)
            finally:
                cp.release()
        if method == "cpu" and options.estimate == "conserving":
            return estimate_cover_cpu(cover_gather(index, self.k, radii), points, self.materials,
                                      options).astype(np.float32)
        if method == "cpu":
            return estimate_cpu(index, points, self.materials, variant=self.variant,
                                options=options, radii=radii).astype(np.float32)
        return estimate_exact(index, points, self.materials, backend=self.backend,
                              options=options, radii=radii or exact_radii2).astype(np.float32)

    def _count(self, p: int, stored: int, emitted: int) -> None:
        self.stored += stored
        self.emitted += emitted
        if p == 0 and stored == 0:
            why = ("the scene has no specular object" if not self.scene.specular_objects
                   else "no caustic photon reached a receiver")
            warnings.warn(f"rendering direct light only: {why}", NoCausticWarning, stacklevel=3)
        if self.scene.specular_objects:
            self.empty_run = self.empty_run + 1 if stored == 0 else 0
            if self.empty_run == EMPTY_PASSES_WARNING:
                warnings.warn(
                    f"{EMPTY_PASSES_WARNING} passes in a row stored no caustic photon (each "
                    f"emitted {emitted:,}); they count, so the image stays unbiased, but it "
                    "refines slowly: raise --photons (photons per pass)", EmptyPassesWarning,
                    stacklevel=3)

    @property
    def image(self):
        """The image so far (:class:`.result.RenderResult`, float32 pixel means)."""
        info = {**self.info, "passes": self.passes, "photons_stored": self.stored,
                "photons_emitted": self.emitted, "estimated_error": self.film.estimated_error(),
                "radius_scale": shrink(max(self.passes - 1, 0), self.schedule.alpha)}
        return RenderResult(direct=self.film.direct.astype(np.float32),
                            caustic=self.film.caustic.astype(np.float32),
                            timings=dict(self.timings), info=info, index=self.index,
                            spp=self.side ** 2 * self.passes, passes=self.passes,
                            radii=self.radii)
