"""Caustic photon tracing: Jensen's caustic photon map (paper sections 1 and 6).

Photons leave each light only toward the specular objects (mirrors and glass), bounce
off perfect mirrors, reflect or refract at glass with the Fresnel probabilities
(:mod:`blockhash.scene.optics`), and are stored at the first non-specular (modified Phong) hit, so the
map holds the caustic paths L S+ D and nothing else.  ``max_bounces`` counts every
specular event.  Direct light is the renderer's
job (shadow rays), so photons whose first hit is diffuse are dropped.

Emission (importance sampling toward the mirrors, still unbiased):

* For every light and every specular object there is a *bounding cone*: apex at
  the light, axis toward the centre of the object's bounding sphere, half-angle
  the largest angle to any vertex (at most the bounding sphere's cone, usually
  tighter; a half-angle below 90 degrees makes the cone convex, so it contains
  every triangle).  A spot light's cone replaces the object's cone where it is
  the smaller one; where the two cones only overlap, the smaller one is sampled
  and photons outside the spot cone carry nothing.
* A photon picks a light and one of its cones with probability proportional to
  the light's power falling into the cone (``pmf``), then a direction uniform in
  solid angle inside that cone.  Its weight is ``I(w) / q(w)`` where ``I`` is
  the light's intensity (power / emission solid angle, zero outside a spot cone)
  and ``q`` the full mixture density of the direction (overlapping cones of one
  light are counted together), and its power is ``weight / emitted``.  With one
  light and one cone this is ``power * cone_solid_angle / emission_solid_angle /
  photons_shot`` (one-sample MIS over lights and cones; the light's share of
  photons is its share of the power into the cones).
* Photons that miss the mirrors inside the cone, or hit a diffuse surface first,
  carry no caustic: they are dropped but count as emitted.

Determinism: photon ``i`` draws its four uniforms from
``Philox(key=seed, counter=i)`` (one counter step = four 64-bit words), so every
result is the same whatever ``batch_size`` (pbrt-v4 SPPM's per-index streams).

Stopping: photons are shot in index order until the ``n+1``-th caustic photon
appears at index ``g``; the map keeps the first ``n`` and ``emitted = g``.  That
is the unbiased negative-binomial estimator ``(k-1)/(N-1)`` (keeping the ``n``-th
photon and ``emitted = g+1`` would bias the flux by about ``1/n``), and it does
not depend on the batch size.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from blockhash.errors import InputError
from blockhash.photons.emission import Emitter
from blockhash.photons.paths import (  # noqa: F401 (the map and its fates, importable from here)
    ABSORBED,
    DIRECT,
    ESCAPED,
    FATE_NAMES,
    MAX_BOUNCES,
    MISSED,
    OUTSIDE_SPOT,
    RAY_OFFSET,
    STORED,
    STORED_FLOAT,
    STORED_OBJECT,
    Batch,
    CausticPhotons,
    trace_batch,
)
from blockhash.scene.raycast import EmbreeGeometry
from blockhash.validate import as_int

#: Default safety cap on emitted photons, as a multiple of the stored target
#: (with at least DEFAULT_MIN_CAP).  The ring scene stores ~30% of the photons
#: shot into its cone; 1% efficiency would still finish well under the cap.
DEFAULT_CAP_FACTOR = 100
DEFAULT_MIN_CAP = 1_000_000
#: With nothing stored after this many photons the mirror is taken as unreachable.
ZERO_STORED_ABORT = 1_000_000
#: Batches are sized from the fraction stored so far, with this margin, so that the
#: photons traced past the target (discarded) stay few.
OVERSHOOT = 1.1

class TracingWarning(UserWarning):
    """Fewer caustic photons than asked for: the safety cap on emitted photons was reached."""


def _scene_name(scene) -> str:
    path = getattr(scene, "path", None)
    return f"scene {str(path)!r}" if path else "scene (built in code, no path)"


def trace_caustic_photons(scene, n_stored_target: int | None = None, *, seed: int | None = None,
                          batch_size: int = 65536, max_emitted: int | None = None,
                          progress: bool = False) -> CausticPhotons:
    """Trace the caustic photon map of ``scene`` (paths light -> mirror(s) -> diffuse).

    Parameters
    ----------
    scene : blockhash.scene.model.Scene
        Lights (point: ``position``, ``power``; spot: also ``direction``, ``cone_deg``),
        objects (trimesh meshes; ``scene.specular_objects`` are perfect mirrors with
        ``material.reflectance``), ``photons`` (``count``, ``seed``, ``max_bounces``).
    n_stored_target : int, optional
        Caustic photons to store; default ``scene.photons.count``.  Exactly this many
        are kept unless the cap is reached first.
    seed : int, optional
        Non-negative random seed; default ``scene.photons.seed``.
    batch_size : int
        Photons traced per vectorised batch; results do not depend on it.
    max_emitted : int, optional
        Safety cap on emitted photons; default ``max(100 * n_stored_target, 1,000,000)``.
        Reaching it with some photons stored warns (:class:`TracingWarning`); with none
        stored (or none after 1,000,000 emitted) raises :class:`InputError`.
    progress : bool
        Show a tqdm bar of stored photons.

    Returns
    -------
    CausticPhotons
        Empty (``stats['stopped_by'] == 'no_specular_objects'``) when the scene has no
        mirror: there is no caustic, and the renderer shows direct light only.

    Raises
    ------
    InputError
        No lights; ``max_bounces`` < 1; lights with no power toward the mirrors; no
        light reaching any mirror (spot cones miss, occluders, wrong side), or no photon
        stored within the cap (the message says why, :func:`no_caustic_reason`).  Its
        callers (the studies, the tools, the accuracy runs) ask for a map to index and
        measure, which an empty one cannot give; a render, which goes on without a caustic,
        calls :meth:`PhotonSource.until_stored` instead.
    """
    source = PhotonSource(scene)
    photons = source.until_stored(n_stored_target, seed=seed, batch_size=batch_size,
                                  max_emitted=max_emitted, progress=progress)
    if photons.stats.get("stopped_by") in ("nothing_stored", "unreachable"):  # a map was asked for
        raise InputError(
            f"{source.name}: {no_caustic_reason(photons.stats)}; the mirrors are not reachable "
            "from the lights, or nothing diffuse receives their reflection: move the light, "
            "remove the occluder or add a receiver (a render goes on with direct light only)")
    return photons


def no_caustic_reason(stats: dict) -> str:
    """What a trace that stored no caustic photon found, in one sentence for a warning, from
    its map's ``stats`` (:class:`CausticPhotons`): the photons shot, toward which specular
    objects, and the fates of those shot (those that occurred), e.g. ``no caustic photon
    stored of 1,048,576 shot toward the mirrors ['ring'] (missed 1,016,250, direct diffuse
    32,326)``.  A scene without a specular object says so instead."""
    if stats.get("stopped_by") == "no_specular_objects":
        return "the scene has no specular (mirror or glass) object, so it has no caustic"
    if stats.get("stopped_by") == "direct_only":
        return "the scene asks for direct light only (photons.direct_only)"
    if stats.get("stopped_by") == "unreachable":
        return str(stats.get("reason"))
    toward = list(stats.get("specular_objects") or
                  dict.fromkeys(c["object"] for c in stats.get("cones", ())))
    fates = ", ".join(f"{name.replace('_', ' ')} {stats[name]:,}" for name in FATE_NAMES
                      if name != "stored" and stats.get(name))
    shot = stats.get("emitted") or 0
    return (f"no caustic photon stored of {shot:,} shot toward the mirrors {toward}"
            + (f" ({fates})" if fates else ""))


#: Photon indices between the streams of consecutive passes of a progressive render
#: (:meth:`PhotonSource.emit`): pass p shoots photons p * PASS_STRIDE onward.
PASS_STRIDE = 1 << 44


class PhotonSource:
    """A scene's lights, emitter and embree geometry, checked and built once: caustic
    photons from any stretch ``start ..`` of the per-photon streams (the module docstring's
    determinism), so that the passes of a progressive render share one geometry."""

    def __init__(self, scene, *, geometry: EmbreeGeometry | None = None, device: str | None = None):
        from blockhash.device.choice import resolve

        self.scene = scene
        #: Where the photons are traced (:mod:`blockhash.device.choice`) and, on a Dr.Jit
        #: device, its kernels (:class:`blockhash.device.caustic.DeviceCausticTracer`).
        self.device = resolve(device)
        self.kernels = None
        self.name = name = _scene_name(scene)
        self.max_bounces = as_int(scene.photons.max_bounces, "photons.max_bounces", minimum=1,
                                  hint=f"{name}: caustic paths need at least one mirror bounce")
        self.lights = lights = tuple(scene.lights)
        if not lights:
            raise InputError(f"{name} has no lights; caustic photons need at least one light: "
                             "add a [[lights]] entry or an object with emission")
        self.specular = specular = tuple(scene.specular_objects)
        self.emitter = self.geometry = None
        self.unreachable = ""
        if not specular or scene.photons.direct_only:
            return
        self.geometry = geometry or EmbreeGeometry(tuple(scene.objects))
        emitter = Emitter(lights, specular, geometry=self.geometry, bounds=scene.bounds)
        if not emitter.sources and not all(hasattr(li, "position") for li in lights):
            # an area light facing away from every mirror: a render goes on with direct light
            self.unreachable = (f"no light reaches the specular objects {[o.name for o in specular]} "
                                "(each area light faces away from them, or is behind them)")
            return
        if not emitter.sources:
            raise InputError(
                f"{name}: no light reaches a specular object (every spot light's cone misses "
                f"the mirrors {[o.name for o in specular]}); aim a spot light at a mirror or widen "
                "its cone_deg")
        if emitter.total_brightness <= 0.0:
            raise InputError(f"{name}: the lights that face the mirrors have zero power; "
                             "give a light a positive power")
        self.emitter = emitter
        if self.device.jit:
            from blockhash.device.caustic import DeviceCausticTracer

            self.kernels = DeviceCausticTracer(self, self.device)

    def _seed(self, seed):
        return as_int(self.scene.photons.seed if seed is None else seed, "seed", minimum=0,
                      maximum=2**128 - 1, hint="use a non-negative integer seed")

    def _no_specular(self, t0) -> CausticPhotons:
        if self.scene.photons.direct_only:
            return CausticPhotons.empty({
                "emitted": 0, "hit_specular": 0, "stored": 0, "stopped_by": "direct_only",
                "reason": f"{self.name} renders direct light only (photons.direct_only)",
                "seconds": time.perf_counter() - t0})
        if self.unreachable:
            return CausticPhotons.empty({
                "emitted": 0, "hit_specular": 0, "stored": 0, "stopped_by": "unreachable",
                "reason": f"{self.name}: {self.unreachable}", "seconds": time.perf_counter() - t0})
        return CausticPhotons.empty({
            "emitted": 0, "hit_specular": 0, "stored": 0, "stopped_by": "no_specular_objects",
            "reason": f"{self.name} has no specular (mirror) object, so it has no caustic",
            "seconds": time.perf_counter() - t0})

    def until_stored(self, n_stored_target: int | None = None, *, seed: int | None = None,
                     batch_size: int = 65536, max_emitted: int | None = None,
                     progress: bool = False) -> CausticPhotons:
        """Photons 0, 1, ... shot until ``n_stored_target`` are stored
        (:func:`trace_caustic_photons`, which documents the parameters).  None stored within
        the cap is an empty map whose ``stats['stopped_by']`` is ``'nothing_stored'`` (with the
        photons shot and their fates, and ``emitted`` the photons shot), not an error and not
        a warning: a render goes on with direct light and warns once, with
        :func:`no_caustic_reason`."""
        t0 = time.perf_counter()
        target = as_int(self.scene.photons.count if n_stored_target is None else n_stored_target,
                        "n_stored_target", minimum=1)
        seed = self._seed(seed)
        batch_size = as_int(batch_size, "batch_size", minimum=1)
        cap = as_int(max(DEFAULT_CAP_FACTOR * target, DEFAULT_MIN_CAP) if max_emitted is None
                     else max_emitted, "max_emitted", minimum=1)
        if self.emitter is None:
            return self._no_specular(t0)
        run = self._shoot(seed, 0, target, cap, batch_size, progress)
        if run.stored == 0:  # an answer, not an error: a render goes on with direct light
            run.stopped_by = "nothing_stored"
            return run.photons(self, t0)
        if run.stored < target:
            warnings.warn(
                f"{self.name}: only {run.stored:,} of n_stored_target={target:,} caustic photons "
                f"after max_emitted={cap:,} photons; the mirrors catch little of the light. Raise "
                "max_emitted or lower n_stored_target", TracingWarning, stacklevel=3)
        return run.photons(self, t0)

    def emit(self, count: int, *, seed: int | None = None, start: int = 0,
             batch_size: int = 65536) -> CausticPhotons:
        """Exactly ``count`` photons shot, photons ``start .. start + count - 1`` of the
        streams, keeping those that are stored (none is an answer, not an error: the pass of
        a progressive render that catches no caustic still counts its emitted photons)."""
        t0 = time.perf_counter()
        count = as_int(count, "count", minimum=1)
        start = as_int(start, "start", minimum=0)
        if self.emitter is None:
            return self._no_specular(t0)
        run = self._shoot(self._seed(seed), start, None, count, as_int(batch_size, "batch_size",
                                                                     minimum=1), False)
        return run.photons(self, t0)

    def _shoot(self, seed, first, target, cap, batch_size, progress) -> "_Run":
        """Shoot photons ``first`` onward until ``target`` are stored (None: until ``cap``
        photons are shot) or ``cap`` are shot."""
        run = _Run(len(self.lights), cap if target is None else target)
        start = 0
        # After the first batch (a pilot of the fraction stored, on a device), a launch's
        # photons: as many as the device's arrays hold
        launch = batch_size
        if self.kernels is not None:
            from blockhash.device.caustic import LAUNCH

            launch = max(batch_size, LAUNCH)
        bar = None
        if progress:
            from tqdm.auto import tqdm
            bar = tqdm(total=target, unit="photon", desc="caustic photons")
        try:
            while start < cap:
                # size the batch to what is still needed (results do not depend on it)
                if target is None:
                    need, guess = cap + 1, launch
                else:
                    need = target + 1 - run.stored
                    if run.stored:
                        guess = int(need * start / run.stored * OVERSHOOT) + 256
                    else:
                        guess = 4 * need + 1024 if start == 0 else launch
                count = min(batch_size if start == 0 and target else launch, cap - start, guess)
                batch, light = self._batch(seed, first + start, count)
                run.batches += 1
                run.traced += count
                run.rays += batch.rays
                done = len(batch.stored) >= need
                if done:
                    end = int(batch.stored[need - 1])  # the (target+1)-th photon: not kept
                    batch = batch.cut(end)
                    light = light[:end]
                    count = end
                    run.stopped_by = "target"
                run.add(batch, light)
                start += count
                if bar is not None:
                    bar.update(min(len(batch.stored), target - bar.n))
                if done:
                    break
                if target is not None and run.stored == 0 and start >= ZERO_STORED_ABORT:
                    break
        finally:
            if bar is not None:
                bar.close()
        if target is None:
            run.stopped_by = "emitted"
        run.emitted = start
        return run

    def _batch(self, seed: int, start: int, count: int):
        """Photons ``start .. start + count - 1`` of ``seed``: (their
        :class:`~blockhash.photons.paths.Batch`, each one's light), on the source's device."""
        if self.kernels is not None:
            return self.kernels.batch(seed, start, count)
        u = self.emitter.uniforms(seed, start, count)
        origins, dirs, weights, light = self.emitter.sample(u)
        return trace_batch(self.geometry, origins, dirs, weights, self.max_bounces, seed=seed,
                           start=start), light


class _Run:
    """The batches of one :meth:`PhotonSource._shoot` and their counters."""

    def __init__(self, lights: int, capacity: int):
        self.fates = np.zeros(len(FATE_NAMES), dtype=np.int64)
        self.light_counts = np.zeros(lights, dtype=np.int64)
        # The map's columns at the most photons the run can store, filled batch by batch and
        # cut to those stored (pages never written are never resident): no batch's chunk is
        # left behind in the tracing thread's heap (STORED_FLOAT: 52 bytes a photon).
        self.columns = [np.empty((capacity, 3), dtype=STORED_FLOAT) for _ in range(4)]
        self.columns.append(np.empty(capacity, dtype=STORED_OBJECT))
        self.stored = self.fallbacks = self.rays = self.batches = self.traced = self.emitted = 0
        self.max_depth = 0
        self.stopped_by = "cap"

    def add(self, batch: Batch, light: np.ndarray) -> None:
        self.fates += np.bincount(batch.fate, minlength=len(FATE_NAMES))
        self.light_counts += np.bincount(light, minlength=len(self.light_counts))
        self.fallbacks += int(batch.fallbacks.sum())
        rows = slice(self.stored, self.stored + len(batch.stored))
        for column, values in zip(self.columns, (batch.positions, batch.directions,
                                                 batch.normals, batch.weights, batch.objects)):
            column[rows] = values
        if len(batch.depth):
            self.max_depth = max(self.max_depth, int(batch.depth.max()))
        self.stored += len(batch.stored)

    def photons(self, source: PhotonSource, t0: float) -> CausticPhotons:
        """The stored photons, powers divided by the photons emitted (the columns cut to
        them in place: a run makes its map once)."""
        if self.stored == 0:
            z = np.zeros((0, 3), dtype=np.float32)
            return CausticPhotons(z, z.copy(), z.copy(), z.copy(), self.emitted,
                                  self._stats(source, 0, t0))
        for column in self.columns:  # realloc: shrinks a mapped block where it lies
            column.resize((self.stored,) + column.shape[1:], refcheck=False)
        positions, directions, normals, powers, objects = self.columns
        self.columns = []
        powers /= np.float32(self.emitted)
        return CausticPhotons(positions=positions, directions=directions, normals=normals,
                              powers=powers, emitted=self.emitted,
                              stats=self._stats(source, self.max_depth, t0), objects=objects)

    def _stats(self, source: PhotonSource, max_depth: int, t0: float) -> dict:
        fates = self.fates
        return {
            "emitted": self.emitted,
            "hit_specular": int(self.emitted - fates[[OUTSIDE_SPOT, MISSED, DIRECT]].sum()),
            **{k: int(v) for k, v in zip(FATE_NAMES, fates)},
            "max_depth_reached": max_depth,
            "shading_normal_fallbacks": self.fallbacks,
            "emitted_per_light": tuple(int(c) for c in self.light_counts),
            "cones": tuple({"light": c.light, "object": c.object_name, "sampled": c.sampled,
                            "half_angle_deg": float(np.degrees(np.arccos(c.cos_half))),
                            "solid_angle": c.solid_angle, "pmf": float(p)}
                           for c, p in zip(source.emitter.cones, source.emitter.pmf))
                     + tuple({"light": t.light, "object": t.object_name, "sampled": t.kind,
                              "pmf": float(p)}
                             for t, p in zip(source.emitter.targets,
                                             source.emitter.pmf[len(source.emitter.cones):])),
            "specular_objects": tuple(o.name for o in source.specular),
            "stopped_by": self.stopped_by,
            "traced": self.traced, "rays_cast": self.rays, "batches": self.batches,
            "seconds": time.perf_counter() - t0,
        }
