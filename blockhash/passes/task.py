"""A pass as a task: :func:`run_pass` is a function of what a process builds once for a render
(:class:`RenderSetup`, from the scene and its :class:`PassSettings`) and the pass number; it
returns what the pass adds to the film (:class:`PassContribution`).

1. photons: pass 0 shoots until the requested count is stored; pass p >= 1 shoots the count
   that pass 0 emitted (given to it), from photon ``p * PASS_STRIDE`` of the streams
   (:class:`blockhash.photons.tracing.PhotonSource`): the same (seed, p) gives the same photons
   in any process;
2. the index of that batch and, for the conserving estimate, the photons' own radii scaled by
   the pass's shrink (:mod:`.schedule`), and the pixel splat of the photons under the footprint;
3. a fresh camera sample per pixel (:func:`blockhash.frame.camera_samples.camera_samples`),
   cast on the photons' device (:meth:`blockhash.frame.scene_rays.SceneRays.on_device`);
4. direct light and the caustic estimate of those samples, box-filtered into pixel means.

Which search and estimate a pass runs is chosen once, when the setup is built
(:func:`blockhash.passes.stages.caustic_stage`), not by names inside the pass."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from blockhash.errors import InputError
from blockhash.frame.camera_samples import camera_samples, only
from blockhash.frame.cover_estimate import cover_gather, drop_gather, forget_gathers
from blockhash.frame.direct_light import direct_light
from blockhash.frame.estimate import EstimateOptions
from blockhash.frame.film_filter import PassFilm
from blockhash.frame.options import LookupOptions, resolve_method
from blockhash.frame.scene_rays import SceneRays
from blockhash.gl.limits import MAX_K
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.passes.schedule import FixedRadii, PassRadii, Schedule, shrink
from blockhash.passes.stages import caustic_stage  # noqa: F401 (importable from here)
from blockhash.scene.camera import Pinhole, spp_grid
from blockhash.validate import INDIRECT, as_flag, as_int

#: The most indirect photons a pass stores, in caustic counts (a lamp over a plastic floor,
#: whose coat reflects few of the caustic's photons, shot 354 million a pass without it).
INDIRECT_STORED = 8


@dataclass(frozen=True)
class PassSettings:
    """What every pass of a render shares besides the scene: photons stored in pass 0
    (``count``; None with a traced map), the samples a pixel as ``(rows, cols)`` of stratified
    cells (``grid``, :func:`blockhash.scene.camera.spp_grid`), the photons' seed, the estimate,
    the resolved search (``method``, ``k``, ``A``, ``variant``), the GL backend and the radius
    schedule."""

    count: int | None
    grid: tuple[int, int]
    seed: int
    estimate: EstimateOptions
    method: str
    k: int
    A: int
    variant: str = "default"
    backend: str | None = None
    schedule: Schedule = field(default_factory=Schedule)
    indirect: bool = True
    device: str | None = None

    @classmethod
    def of(cls, scene, *, photons=None, spp: int = 1, seed=None,
           estimate: EstimateOptions = EstimateOptions(), lookup: LookupOptions = LookupOptions(),
           backend=None, schedule: Schedule = Schedule(), indirect: bool = True,
           device: str | None = None) -> "PassSettings":
        """The settings of ``scene`` with these overrides (``photons``: photons stored per
        pass, or None for the scene's; ``spp``: samples a pixel per pass; a traced map is given
        to :class:`RenderSetup`;
        ``indirect``: trace the indirect photons where the scene has diffuse interreflection;
        ``device``: where the caustic photons are traced, :mod:`blockhash.device.choice`)."""
        as_flag(indirect, "indirect", INDIRECT)
        settings = scene.photons
        k = settings.k if lookup.k is None else lookup.k
        method = resolve_method(lookup.method, estimate.estimate)
        if method == "bh" and k > MAX_K:  # refused before hours of tracing, not after
            raise InputError(f"k={k} is above the lookup shader's limit MAX_K={MAX_K}; use "
                             f"k <= {MAX_K}, or method='cpu' or 'kdtree', or the conserving "
                             "estimate's cover gather (method='auto'), which has no such limit")
        count = photons if photons is not None else settings.count
        return cls(count=count, grid=spp_grid(spp),
                   seed=settings.seed if seed is None else seed, estimate=estimate,
                   method=method, k=k, A=settings.A if lookup.A is None else lookup.A,
                   variant=lookup.variant, backend=backend, schedule=schedule,
                   indirect=indirect, device=device)


class RenderSetup:
    """What a process builds once for a render and reuses for every pass it runs: the photon
    source (embree geometry, emitter), the camera's rays, the receivers' materials and the
    chosen :class:`~blockhash.passes.stages.CausticStage` (the GL context and compiled programs are kept per process by
    :mod:`blockhash.gl`).  ``traced``: a traced photon map, rendered as pass 0 (one pass).

    ``kept``: the setup of the last frame (:class:`blockhash.passes.session.FrameSession`),
    whose objects are ``scene``'s: its geometry and materials serve this one; with
    ``objects_moved`` (objects placed elsewhere, the same meshes' triangles) embree's scene is
    built again and the device's updated in place."""

    def __init__(self, scene, settings: PassSettings, traced=None, *, kept=None,
                 objects_moved: bool = False):
        from blockhash.passes.heap import return_large_blocks
        from blockhash.photons.tracing import PhotonSource
        from blockhash.scene.materials import receiver_materials

        return_large_blocks()  # a pass's arrays unmapped when freed, not kept by the heap
        self.scene, self.settings, self.traced = scene, settings, traced
        if traced is None:
            as_int(settings.count, "photons", minimum=1)
        if kept is None or objects_moved:
            self.rays = SceneRays(scene.objects)
            self.materials = receiver_materials(scene.objects)
            if kept is not None:
                from blockhash.device.geometry import DeviceGeometry

                DeviceGeometry.move(kept.rays.geometry, self.rays.geometry)
        else:
            self.rays, self.materials = kept.rays, kept.materials
        self.source = PhotonSource(scene, geometry=self.rays.geometry, device=settings.device)
        self.rays.on_device(self.source.device)
        self.pin = Pinhole.of(scene.camera)
        self.caustic = caustic_stage(settings)
        self.indirect, self.indirect_emitted, self.indirect_note = self._indirect(scene, settings)
        #: Passes' photons, indices and radii kept for the next frames of an animation whose
        #: camera alone moves (:class:`blockhash.passes.session.FrameCache`; None: none kept).
        self.cache = None
        #: The camera's pixel filter over each pass's samples (a :class:`PassFilm`).
        self.pixel_filter = PassFilm(self.pin, scene.camera.filter, settings.grid)

    def _indirect(self, scene, settings: PassSettings):
        """(the :class:`blockhash.photons.indirect.IndirectSource`, the photons it shoots per
        pass, a note saying why none) of the render: None and 0 when ``settings`` leaves the
        indirect light out, for a traced photon map, or when the scene's diffuse surfaces
        cannot light one another (the pilot, :func:`blockhash.photons.indirect.needs_indirect`).

        The photons of a pass are shared by the flux each map carries (the rule): the indirect
        photons shot a pass are the caustic's shot (pass 0's, estimated from a pilot of
        :data:`~blockhash.photons.indirect.PILOT` caustic photons) times the ratio of the
        indirect flux to the caustic flux (from pilots of as many photons of each), within
        [1/4, 4]; the caustic's count where the scene has no caustic.  So a watt of either
        layer costs about the same tracing, however rarely a map's photons are stored; but
        no more are shot than store :data:`INDIRECT_STORED` times the caustic's count."""
        from blockhash.photons.indirect import PILOT, IndirectSource, needs_indirect

        if not settings.indirect or self.traced is not None:
            return None, 0, "left out" if not settings.indirect else "a traced map: one pass"
        if scene.photons.direct_only:
            return None, 0, "left out: the scene asks for direct light only"
        source = IndirectSource(scene, self.rays.geometry, device=settings.device)
        sample, _ = needs_indirect(source, settings.seed)
        if sample is None:
            return None, 0, (f"none: no photon of a {PILOT:,}-photon pilot met a diffuse surface "
                             "after leaving one (the scene's diffuse surfaces cannot light one "
                             "another)")
        emitted = float(settings.count)
        if self.source.emitter is not None:
            caustic = self.source.emit(PILOT, seed=settings.seed)
            stored = max(len(caustic.positions), 1)
            c_flux = float(caustic.powers.sum(axis=0).mean())  # watts: powers are per shot
            i_flux = float(sample.powers.sum(axis=0).mean())
            emitted *= PILOT / stored  # the caustic's photons shot a pass
            if c_flux > 0:
                emitted *= min(max(i_flux / c_flux, 0.25), 4.0)
        emitted = min(emitted, INDIRECT_STORED * settings.count * PILOT / len(sample.positions))
        emitted = max(int(np.ceil(emitted)), 1)
        target = emitted * len(sample.positions) / PILOT
        return source, emitted, (f"{emitted:,} photons shot a pass over the whole scene, about "
                                 f"{int(target):,} stored at second or later diffuse vertices")

    def photons(self, p: int, emitted: int | None):
        """Pass ``p``'s photons (None: the scene has no specular object): pass 0 until
        ``count`` are stored, pass p >= 1 ``emitted`` photons from ``p * PASS_STRIDE``."""
        from blockhash.photons.tracing import PASS_STRIDE

        if self.traced is not None:
            if p:
                raise InputError("a traced photon map (photons=CausticPhotons) is one pass; give "
                                 "photons=N (photons per pass) to render more passes")
            return self.traced
        if self.source.emitter is None:  # no mirror; or none a light reaches: say why once
            return self.source.until_stored(1) if self.source.unreachable and p == 0 else None
        if p == 0:
            return self.source.until_stored(self.settings.count, seed=self.settings.seed)
        if emitted is None:
            raise InputError(f"pass {p} needs the photons emitted per pass, which pass 0 fixes; "
                             "run pass 0 first and give its emitted count")
        return self.source.emit(emitted, seed=self.settings.seed, start=p * PASS_STRIDE)


@dataclass
class PassContribution:
    """What pass ``index`` adds to the film: pixel means of its samples (``direct``, and
    ``caustic`` with powers divided by the photons it emitted), its photons emitted and stored,
    its stage timings (seconds) and notes (``info``).  ``photon_index`` and ``radii`` are the
    pass's index and conserving radii, kept only where the pass ran in the caller's process."""

    index: int
    direct: np.ndarray
    caustic: np.ndarray
    emitted: int
    stored: int
    scale: float
    timings: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)
    photon_index: object = None
    radii: object = None
    #: The indirect layer's pixel means (None: the render has no indirect photons) and the
    #: indirect photons shot (:mod:`blockhash.photons.indirect`).
    indirect: np.ndarray | None = None
    indirect_emitted: int = 0

    def portable(self) -> "PassContribution":
        """The contribution without what stays in its process (the index and radii)."""
        from dataclasses import replace

        return replace(self, photon_index=None, radii=None)


def trace_pass(setup: RenderSetup, p: int, emitted: int | None = None):
    """Pass ``p``'s photons and the seconds they took (:meth:`RenderSetup.photons`): the first
    stage of :func:`run_pass`, which a caller may run ahead, on another thread."""
    t0 = time.perf_counter()
    photons = _kept(setup, ("caustic photons", p), lambda: setup.photons(p, emitted))
    return photons, time.perf_counter() - t0


def _kept(setup: RenderSetup, key, make):
    """``make()``, or what the setup's frame cache keeps under ``key`` (kept when made)."""
    if setup.cache is None:
        return make()
    if key not in setup.cache:
        value = make()
        setup.cache.keep(key, (value,))
        return value
    return setup.cache[key][0]


def run_pass(setup: RenderSetup, p: int, emitted: int | None = None, *,
             traced=None) -> PassContribution:
    """Pass ``p`` of the render ``setup`` was built for (module docstring); ``emitted``: the
    photons every pass after the first emits (pass 0's emitted count; None for pass 0);
    ``traced``: the pass's :func:`trace_pass`, when it ran ahead."""
    s = setup.settings
    timings: dict = {}
    t0 = time.perf_counter()
    photons, timings["trace"] = traced or trace_pass(setup, p, emitted)
    traced = None  # the photons are held here alone, and freed once indexed and splatted
    stored = len(photons.positions) if photons is not None else 0
    shot = photons.emitted if photons is not None else 0
    scale = shrink(p, s.schedule.alpha)
    info: dict = {"device": setup.source.device.name}
    if p == 0 and photons is not None:
        info["photon_stats"] = {k: v for k, v in photons.stats.items()
                                if isinstance(v, (int, float, str))
                                or k == "specular_objects"}
    built = _index(setup, photons, p, scale, timings, info)
    photons = None
    t = time.perf_counter()
    points, seen = camera_samples(setup.scene, setup.rays, s.grid, p, backend=s.backend)
    timings["gbuffer"] = time.perf_counter() - t
    t = time.perf_counter()
    direct = direct_light(points, setup.scene.objects, setup.scene.lights, setup.rays, p)
    timings["direct"] = time.perf_counter() - t
    t = time.perf_counter()
    caustic = _layer(setup, built, points, seen, p, timings)
    timings["caustic"] = time.perf_counter() - t - _gathers(timings)
    indirect, indirect_emitted = _indirect_layer(setup, p, scale, points, seen, timings, info)
    direct = setup.pixel_filter.develop(points.gather_direct(direct), p)
    timings["total"] = time.perf_counter() - t0
    return PassContribution(p, direct, caustic, shot, stored, scale, timings, info, *built[:2],
                            indirect, indirect_emitted)


def _layer(setup: RenderSetup, built, points, seen, p: int, timings: dict) -> np.ndarray:
    """The pixel means of one photon map's estimate at the pass's camera points, from its
    :func:`_index` (``built``: index, radii, pixel splat, every photon's index, radii and
    whether the frame cache keeps them).  Its gathers are photon stages, built here after the
    camera's samples (never held with them), timed apart from the estimate: ``timings["cover
    gather"]``, and ``["mirror cover gather"]`` for every photon's where a point sees a mirror
    or glass, which a kept index keeps for the next frames (it does not depend on the camera)."""
    index, radii, splat, whole = built
    estimate = setup.caustic.estimate
    if index is not None and radii is not None and setup.caustic.cover:
        t = time.perf_counter()
        cover_gather(index, setup.settings.k, radii)
        timings["cover gather"] = time.perf_counter() - t
    image = np.zeros(points.shape + (3,), dtype=np.float32)
    if splat is not None and not seen.all():
        # Points seen in a mirror or through glass gather every photon (the splat reached only
        # the pixels that see its photons directly); each gather is let go before the next.
        if index is not None:
            image = estimate(setup, index, only(points, seen), radii)
            drop_gather(index, setup.settings.k, radii)
        t = time.perf_counter()
        cover_gather(whole[0], setup.settings.k, whole[1])
        timings["mirror cover gather"] = time.perf_counter() - t
        image += estimate(setup, whole[0], only(points, ~seen), whole[1])
        if not whole[2]:  # kept for the next frames with its index, else let go
            drop_gather(whole[0], setup.settings.k, whole[1])
    elif index is not None:
        image = estimate(setup, index, points, radii)
    image = setup.pixel_filter.develop(points.gather(image), p)
    return image + splat if splat is not None else image


def _gathers(timings: dict) -> float:
    """Seconds of :func:`_layer`'s gather builds, photon stages timed apart from its estimate."""
    return timings.get("cover gather", 0.0) + timings.get("mirror cover gather", 0.0)


def _indirect_layer(setup: RenderSetup, p: int, scale: float, points, seen, timings: dict,
                    info: dict):
    """Pass ``p``'s indirect layer and its photons shot (None, 0 without indirect photons):
    the indirect photons from photon ``p * PASS_STRIDE`` of their streams, indexed and
    estimated as the caustic's are, their radii on the same schedule."""
    from blockhash.photons.tracing import PASS_STRIDE

    if setup.indirect is None:
        if p == 0:
            info["indirect"] = setup.indirect_note
        return None, 0
    t = time.perf_counter()
    photons = _kept(setup, ("indirect photons", p),
                    lambda: setup.indirect.emit(setup.indirect_emitted, seed=setup.settings.seed,
                                                start=p * PASS_STRIDE))
    stages: dict = {"trace": time.perf_counter() - t}
    if p == 0:
        info["indirect"] = setup.indirect_note
        info["indirect_stats"] = {k: v for k, v in photons.stats.items()
                                  if isinstance(v, (int, float, str))}
    built = _index(setup, photons, p, scale, stages, {}, name="indirect")
    t = time.perf_counter()
    image = _layer(setup, built, points, seen, p, stages)
    stages["estimate"] = time.perf_counter() - t - _gathers(stages)
    for name, sec in stages.items():
        timings[f"indirect {name}"] = sec
    return image, photons.emitted


def _index(setup: RenderSetup, photons, p: int, scale: float, timings: dict, info: dict,
           name: str = "caustic"):
    """The pass's index, radii, pixel splat and (index, radii, kept in the frame cache) of every
    photon, for the points seen in mirrors; all None without photons.  The index and radii of map
    ``name`` (not the splat: it depends on the camera) come from the frame cache where it keeps
    them."""
    s, stage = setup.settings, setup.caustic
    stored = 0 if photons is None else len(photons.positions)
    if stored == 0:
        return None, None, None, None
    if p == 0 and name == "caustic" and stored < s.k:
        raise InputError.about("only {stored} caustic photons were stored, fewer than {k}{value}; "
                               "trace more photons ({photons}) or lower {k}", stored=stored,
                               value=s.k)
    if stored < s.k and not stage.cover:  # the conserving estimate takes any count
        raise InputError.about(
            "pass {p} stored only {stored} {name} photons, fewer than the {k}{value} neighbours "
            "the k-nearest estimate reads; trace more photons a pass ({photons}), lower {k}, or "
            "use the conserving estimate", p=p, stored=stored, name=name, value=s.k)
    kept = setup.cache.get((name, p)) if setup.cache is not None else None
    t = time.perf_counter()
    if kept is not None:
        index, r2, every = kept
        forget_gathers(index, keep=every)  # the last frame's splat's gathers go
    else:
        # The cover gather reads the records in Hilbert order only: the hash tables are
        # built on first use (a caller's k-nearest query), not here.
        index = BlockHashIndex(photons.positions, k=min(s.k, stored), A=s.A,
                               directions=photons.directions,
                               normals=photons.normals, powers=photons.powers,
                               tables=not stage.cover)
    timings["index"] = time.perf_counter() - t
    if p == 0:
        info["index"] = (
            index.stats.summary() if index.tables_built else
            f"photons {len(index):,} in Hilbert order (the cover gather's records; the "
            "Block Hashing tables are built on first use)")
    if stage.radii is None:
        return index, None, None, None
    radii = PassRadii(stage.radii, scale)
    t = time.perf_counter()
    if kept is None:
        r2 = radii(index, s.k)
        every = FixedRadii(r2)  # one object a pass: the key of its gather of every photon
        if setup.cache is not None:
            setup.cache.keep((name, p), (index, r2, every))
    else:
        radii = FixedRadii(r2)
    timings["photon radii"] = time.perf_counter() - t
    if not stage.cover:
        return index, radii, None, None
    splat = whole = None
    if s.schedule.footprint > 0 and not setup.pin.aperture:  # a lens blurs what it splats
        t = time.perf_counter()
        whole = (index, every, setup.cache is not None and (name, p) in setup.cache)
        index, radii, splat = _split(setup, photons, index, r2, scale, p)
        timings["pixel splat"] = time.perf_counter() - t
    return index, radii, splat, whole


def _split(setup: RenderSetup, photons, index, r2, scale, p: int):
    """The pixel splat of the photons whose discs are under the footprint
    (:mod:`blockhash.frame.pixel_splat`), and the index and radii the gather keeps for the
    rest: the same index, the splatted photons' radii infinite (the cover gather leaves out a
    photon of infinite radius, :meth:`blockhash.index.lookups.cover.CoverGather.build`)."""
    from blockhash.frame.pixel_splat import splat_subpixel

    s = setup.settings
    image, keep = splat_subpixel(photons, r2, setup.pin, setup.rays, setup.materials,
                                 footprint=s.schedule.footprint * math.sqrt(scale),
                                 spread=setup.pixel_filter.spread(p))
    if keep.all():
        return index, FixedRadii(r2), None
    if not keep.any():  # every photon splatted: nothing left to gather
        return None, None, image
    return index, FixedRadii(np.where(keep, r2, np.inf)), image

