"""Indirect photons as Dr.Jit kernels: :class:`blockhash.photons.indirect.IndirectSource`'s
photons (emitted over the whole scene, through mirrors and glass, bounced at diffuse surfaces
with Russian roulette, stored at every diffuse vertex after the first), the rules of its
module docstring on the device.

One symbolic kernel with the surface events inside (:func:`_paths`): a photon stored at an
event takes the next slot of an atomic counter, with a key (its lane times the events plus the
event) by which the host orders the launch's stored photons afterwards, so they come out by
photon and then event, the same in any process whatever order the threads wrote them in.  The
buffers are sized from the most stored photons a photon shot seen so far; a launch that
overflows them runs again with room for all (the same photons).  It ran 1.65x the speed of a
launch per event (the live photons compacted between launches) on the Cornell box's 8 x 10^5
photons, the same photons stored.  Each photon's numbers come from its own stream
(:func:`blockhash.device.caustic.photon_streams`, offset by the source's ``counter``,
:data:`~blockhash.photons.indirect.INDIRECT_COUNTER`, from the caustic photons').
"""

from __future__ import annotations

import numpy as np

from blockhash.device.arrays import floats, uints
from blockhash.device.caustic import (
    coat_factor,
    coat_glint,
    coat_transmittance,
    photon_streams,
    specular_event,
)
from blockhash.device.emission import cone_frame, in_cone
from blockhash.device.geometry import DIFFUSE, DeviceGeometry
from blockhash.device.light_tables import LightTables
from blockhash.photons.directions import orthonormal_basis
from blockhash.photons.paths import CausticPhotons

#: Light kinds of the indirect emission.
CONE, DISC, SURFACE, ENVIRONMENT = 0, 1, 2, 3


class DeviceIndirectTracer:
    """The indirect photons of ``source`` (an :class:`~blockhash.photons.indirect.IndirectSource`)
    on ``device``: :meth:`emit` gives what the source's host ``emit`` gives, in distribution."""

    def __init__(self, source, device):
        from blockhash.scene.model import AreaLight, DirectionalLight, EnvironmentLight

        self.device = device
        self.mi, self.dr = mi, dr = device.modules()
        self.geometry = DeviceGeometry.of(source.geometry, device)
        self.max_events = int(source.max_events)
        self.counter = int(source.counter)
        #: Photons a launch traces at most (the host's batch: its buffers a few tens of bytes a
        #: stored photon, given back after each launch).
        self.launch = int(source.batch_size)
        lights = source.lights
        self.lights = LightTables(lights, source.scene.bounds, device)
        n = len(lights)
        kind = np.zeros(n, np.uint32)
        axis, t1, t2, omc = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n)
        disc = np.zeros((n, 3))  # a directional light's disc centre, upstream of the scene
        disc_over_pmf = 0.0  # an environment's disc's area over its light's probability
        for li, (light, cone) in enumerate(zip(lights, source.cones)):
            if isinstance(light, DirectionalLight):
                kind[li] = DISC
                D = np.asarray(light.direction, dtype=np.float64)
                D = D / np.linalg.norm(D)
                axis[li] = D
                t1[li], t2[li] = orthonormal_basis(D)
                disc[li] = source.center - 2.0 * source.radius * D
            elif isinstance(light, AreaLight):
                kind[li] = SURFACE
            elif isinstance(light, EnvironmentLight):
                kind[li] = ENVIRONMENT
                disc_over_pmf = np.pi * source.radius ** 2 / source.pmf[li]
            else:
                a, cos_c, _ = cone
                axis[li] = a
                t1[li], t2[li] = orthonormal_basis(np.asarray(a, dtype=np.float64))
                omc[li] = 2.0 if cos_c <= -1.0 else 1.0 - cos_c
        f32 = lambda a: floats(mi, a)  # noqa: E731
        self.kind, self.axis, self.t1, self.t2 = uints(mi, kind), f32(axis), f32(t1), f32(t2)
        self.omc, self.disc = f32(omc), f32(disc)
        self.radius = float(source.radius)
        self.weight = f32(source.power / source.pmf[:, None])
        self.cdf = f32(source.cdf)
        self.center, self.disc_over_pmf = f32(source.center), f32([disc_over_pmf])
        self.n_lights = n
        self.kinds = set(kind.tolist())
        self.kd, self.ks, self.e = f32(source.kd), f32(source.ks), f32(source.e)
        #: The textured receivers' reflectance (None: the scene has none).
        self.textures = None
        if source.geometry.textures:
            from blockhash.device.textures import SurfaceTextures

            self.textures = SurfaceTextures(source.geometry, device)
        #: Stored photons a photon shot, the most seen so far (sizes the output buffers).
        self.stores_per_photon = 1.0
        self._kernel = dr.syntax(_paths)

    def _emission(self, rng):
        mi, dr = self.mi, self.dr
        u = [rng.next_float32() for _ in range(6)]
        cdf = self.cdf
        k = dr.binary_search(0, self.n_lights - 1, lambda i: dr.gather(mi.Float, cdf, i) <= u[0])
        k = dr.minimum(mi.UInt32(k), self.n_lights - 1)
        kind = dr.gather(mi.UInt32, self.kind, k)
        gv = lambda table: dr.gather(mi.Vector3f, table, k)  # noqa: E731
        axis, t1, t2 = gv(self.axis), gv(self.t1), gv(self.t2)
        w = dr.gather(mi.Color3f, self.weight, k)
        lt = self.lights
        # point and spot lights: uniform inside their cone
        d = in_cone(dr, axis, t1, t2, dr.gather(mi.Float, self.omc, k), u[1], u[2])
        o = mi.Point3f(dr.gather(mi.Point3f, lt.position, k))
        if lt.any_spot:
            w = lt.spot_weight(k, d, w, kind == CONE)
        if DISC in self.kinds:
            sun = kind == DISC
            rho = self.radius * dr.sqrt(u[1])
            sin_p, cos_p = dr.sincos(2.0 * dr.pi * u[2])
            o = dr.select(sun, gv(self.disc) + (rho * cos_p) * t1 + (rho * sin_p) * t2, o)
            d = dr.select(sun, axis, d)
        if ENVIRONMENT in self.kinds:  # a direction by the map, a disc across it
            env = kind == ENVIRONMENT
            toward, p = lt.environment.sample(u[3], u[4], u[5], env)
            D = -toward
            e1, e2 = cone_frame(mi, dr, D)
            rho = self.radius * dr.sqrt(u[1])
            sin_p, cos_p = dr.sincos(2.0 * dr.pi * u[2])
            c = dr.gather(mi.Point3f, self.center, mi.UInt32(0), env)
            o = dr.select(env, c - (2.0 * self.radius) * D + (rho * cos_p) * e1
                          + (rho * sin_p) * e2, o)
            d = dr.select(env, D, d)
            scale = dr.gather(mi.Float, self.disc_over_pmf, mi.UInt32(0), env)
            w = dr.select(env, lt.environment.emitted(toward, env) * (scale / dr.maximum(p, 1e-30)),
                          w)
        if SURFACE in self.kinds:
            area = kind == SURFACE
            y, ny, radiance = lt.area_point(k, u[3], u[1], u[2], area)
            if lt.area_textures is not None:  # the radiance there over its mean
                mean = dr.gather(mi.Color3f, lt.radiance, k, area)
                w = dr.select(area, w * dr.select(mean > 0.0, radiance / mean, 0.0), w)
            o = dr.select(area, y, o)
            d = dr.select(area, _cosine(mi, dr, ny, u[4], u[5]), d)
        return o, d, w

    def emit(self, count: int, *, seed: int, start: int = 0) -> CausticPhotons:
        """Photons ``start .. start + count - 1`` shot (as the host's
        :meth:`~blockhash.photons.indirect.IndirectSource.emit`)."""
        import time

        t0 = time.perf_counter()
        parts, counts = [], {"escaped": 0, "absorbed": 0, "roulette": 0, "max_events": 0,
                             "rays_cast": 0}
        for first in range(start, start + count, self.launch):
            n = min(self.launch, start + count - first)
            parts += self._trace(seed, first, n, counts)
        if parts:
            pos, dirs, nrm, powers, obj = (np.concatenate(c) for c in zip(*parts))
            powers /= np.float32(count)
        else:
            pos = dirs = nrm = powers = np.zeros((0, 3), dtype=np.float32)
            obj = np.zeros(0, dtype=np.int32)
        stats = {"emitted": count, "stored": len(pos), **counts,
                 "seconds": time.perf_counter() - t0}
        return CausticPhotons(pos, dirs, nrm, powers, count, stats, obj)

    def _trace(self, seed: int, start: int, n: int, counts: dict) -> list:
        """The stored photons of photons ``start .. start + n - 1`` (one launch), ordered by
        photon and then event, the counts of how their paths ended added to ``counts``."""
        mi, dr = self.device.modules()
        while True:
            capacity = int(n * self.stores_per_photon * 1.25) + 1024
            rng = photon_streams(mi, dr, seed, self.counter + start, n)
            o, d, w = self._emission(rng)
            out = (dr.zeros(mi.UInt32, 1), dr.zeros(mi.UInt32, capacity),
                   dr.zeros(mi.Float, 3 * capacity), dr.zeros(mi.Float, 3 * capacity),
                   dr.zeros(mi.Float, 3 * capacity), dr.zeros(mi.Float, 3 * capacity),
                   dr.zeros(mi.UInt32, capacity))
            end, rays = self._kernel(self, o, d, w, rng, capacity, out)
            total = dr.sum(rays)
            dr.eval(end, total, out)
            m = int(out[0][0])
            self.stores_per_photon = max(self.stores_per_photon, m / max(n, 1))
            if m <= capacity:  # else again with room for them all: the same photons
                break
        ends = np.bincount(np.asarray(end), minlength=5)
        for name, code in (("escaped", ESCAPED_), ("absorbed", ABSORBED_),
                           ("roulette", ROULETTE_), ("max_events", MAX_EVENTS_)):
            counts[name] += int(ends[code])
        counts["rays_cast"] += int(total[0])
        if m == 0:
            return []
        order = np.argsort(np.asarray(out[1])[:m], kind="stable")
        cols = [np.asarray(b).reshape(-1, 3)[:m][order] for b in out[2:6]]
        objects = np.asarray(out[6])[:m][order].astype(np.int32)
        del out, end, rays, rng, o, d, w
        dr.flush_malloc_cache()  # Dr.Jit's freed buffers back to the system, not kept for reuse
        return [(*cols, objects)]


#: How a photon's path ended (per photon, counted after the loop).
GOING, ESCAPED_, ABSORBED_, ROULETTE_, MAX_EVENTS_ = range(5)


def _paths(tr, o, d, w, rng, capacity, out):
    """The indirect photons' events in one symbolic loop: each stored photon written at the
    slot an atomic counter hands it (``out``: the counter and the buffers of ``capacity``
    photons), with its key (lane x events + event) for the order afterwards."""
    geo = tr.geometry
    mi, dr = geo.mi, geo.dr
    n = dr.width(o)
    count, keys, pos, dirs, nrm, wts, objs = out
    lane = dr.arange(mi.UInt32, n)
    o = o + d * geo.offset
    seen = dr.zeros(mi.UInt32, n)
    event = dr.zeros(mi.UInt32, n)
    end = dr.zeros(mi.UInt32, n)
    rays = dr.zeros(mi.UInt32, n)
    active = dr.full(mi.Bool, True, n)
    while active:
        rays += 1
        hit, face, u, v = geo.intersect(o, d, active)
        end = dr.select(active & ~hit, ESCAPED_, end)
        obj = dr.gather(mi.UInt32, geo.face_object, face, hit)
        kind = dr.gather(mi.UInt32, geo.kind, obj, hit)
        p, ns, ng, outer = geo.hit_frame(face, u, v, d, hit)
        diffuse = hit & (kind == DIFFUSE)
        back = diffuse & ~outer & (dr.gather(mi.UInt32, geo.one_sided, obj, diffuse) != 0)
        end = dr.select(back, ABSORBED_, end)
        diffuse &= ~back
        glint, odds = coat_glint(geo, d, ns, outer, obj, diffuse, rng) if geo.any_coat else (None, None)
        if glint is not None:  # the coat's reflection: a specular event, not a vertex
            diffuse &= ~glint
        store = diffuse & (seen >= 1)
        slot = dr.scatter_inc(count, mi.UInt32(0), store)
        fits = store & (slot < capacity)
        dr.scatter(keys, lane * tr.max_events + event, slot, fits)
        dr.scatter(pos, p, slot, fits)
        dr.scatter(dirs, d, slot, fits)
        dr.scatter(nrm, ns, slot, fits)
        dr.scatter(wts, w, slot, fits)
        dr.scatter(objs, obj, slot, fits)
        seen += dr.select(diffuse, 1, 0)
        last = event == tr.max_events - 1
        spec = hit & (kind != DIFFUSE)
        if glint is not None:
            spec |= glint
        end = dr.select(last & (diffuse | spec), MAX_EVENTS_, end)
        up = dr.select(dr.dot(ns, ng) > 0.0, ns, ng)
        bounce = diffuse & ~last
        wo = _cosine(mi, dr, up, rng.next_float32(bounce), rng.next_float32(bounce))
        ur = rng.next_float32(bounce)
        cos_n = dr.dot(wo, up)
        refl = 2.0 * dr.dot(-d, up) * up + d
        c_alpha = dr.maximum(dr.dot(refl, wo), 0.0)
        e = dr.gather(mi.Float, tr.e, obj, bounce)
        lobe = (e + 2.0) * 0.5 * dr.select(e == 0.0, 1.0, dr.power(c_alpha, e))
        kd = dr.gather(mi.Color3f, tr.kd, obj, bounce)
        if tr.textures is not None:
            textured, albedo = tr.textures.albedo(obj, face, u, v, bounce)
            kd = dr.select(textured, albedo, kd)
        factor = kd + dr.gather(mi.Color3f, tr.ks, obj, bounce) * lobe
        if geo.any_coat:  # what leaves a coated base passes its coat: T on the way out
            coated = bounce & (dr.gather(mi.Float, geo.coat, obj, bounce) > 0.0)
            factor = dr.select(coated, factor * coat_transmittance(geo, cos_n, obj, coated), factor)
        factor = dr.select((dr.dot(wo, ng) <= 0.0) | (cos_n <= 0.0), 0.0, factor)
        q = dr.minimum(dr.max(factor), 1.0)
        survive = bounce & (ur < q)
        end = dr.select(bounce & ~survive, ROULETTE_, end)
        turn = spec & ~last
        r, s_factor, side, _ = specular_event(geo, d, ns, ng, outer, obj, kind, rng, turn)
        if glint is not None:
            s_factor = coat_factor(geo, obj, glint, odds, s_factor)
        w_spec = w * s_factor
        spec_go = turn & dr.any(w_spec > 0.0)
        end = dr.select(turn & ~spec_go, ABSORBED_, end)
        go = survive | spec_go
        w = dr.select(survive, w * factor / dr.select(q > 0.0, q, 1.0), w_spec)
        o = dr.select(survive, p + ng * geo.offset, p + ng * (side * geo.offset))
        d = dr.select(survive, wo, dr.normalize(r))
        event += 1
        active = go
    return end, rays


def _cosine(mi, dr, normal, u1, u2):
    """Directions cosine-distributed about unit ``normal`` (Malley's method)."""
    frame = mi.Frame3f(normal)
    r = dr.sqrt(u1)
    sin_p, cos_p = dr.sincos(2.0 * dr.pi * u2)
    return (r * cos_p) * frame.s + (r * sin_p) * frame.t + dr.safe_sqrt(1.0 - u1) * normal
