"""Caustic photons as one Dr.Jit kernel: emitted (:mod:`.emission`), traced through mirrors
and glass to their first diffuse hit and stored there, the rules of
:func:`blockhash.photons.paths.trace_batch` and :func:`blockhash.photons.bounce.bounce` (the
host's, which the tests hold these to): a miss escapes (missed on the light's own ray); a
diffuse first hit is direct light; a one-sided receiver's back face absorbs; a mirror
reflects about the shading normal (the geometric one where that sends the photon in, counted
as a fallback); glass reflects or refracts by the Fresnel probability of the shading normal
(the geometric one where the refraction leaves on the wrong side), its tint on what passes;
a specular hit past ``max_bounces`` ends the photon; a weight fallen to 0 is absorbed.  New
rays start :data:`~blockhash.scene.raycast.RAY_OFFSET` times the scene's size off the surface,
on the side the photon leaves by.

Streams: photon ``i`` of a seed draws every number from its own PCG32 stream, seeded by a hash
of ``(seed, i)`` (:func:`photon_streams`): the same photons whatever the batch, the process or
the launch size, on one device.  The loop is symbolic (one kernel with the bounces inside,
the photons' state in registers): on the CPU it ran faster than a kernel per bounce.
"""

from __future__ import annotations

import numpy as np

from blockhash.device.geometry import DIFFUSE, GLASS, MIRROR, DeviceGeometry
from blockhash.photons.paths import (
    ABSORBED,
    DIRECT,
    ESCAPED,
    MAX_BOUNCES,
    MISSED,
    OUTSIDE_SPOT,
    STORED,
    STORED_FLOAT,
    STORED_OBJECT,
    Batch,
)

#: Photons a launch traces at most (the kernels' arrays: about 70 bytes a photon, freed
#: before the next): 131,072 keeps them small beside a pass's map, at the
#: speed of larger launches.
LAUNCH = 1 << 17
#: The fate of a photon still travelling.
TRAVELLING = 255

_M1, _M2, _GOLD = 0xBF58476D1CE4E5B9, 0x94D049BB133111EB, 0x9E3779B97F4A7C15
_PCG_MULT = 0x5851F42D4C957F2D


def _mix(dr, x):
    """splitmix64's finaliser on a UInt64 array."""
    x = (x ^ (x >> 30)) * _M1
    x = (x ^ (x >> 27)) * _M2
    return x ^ (x >> 31)


def photon_streams(mi, dr, seed: int, start: int, count: int):
    """A PCG32 of ``count`` lanes, lane ``i`` photon ``start + i``'s stream under ``seed`` (the
    seed and start as opaque values, so that a new one compiles nothing).  The state and the
    increment are set here, PCG32's seeding written out: Dr.Jit's own seeding adds each
    lane's position to its sequence, which would tie a photon's numbers to its launch."""
    s = int(seed)
    key = dr.opaque(mi.UInt64, (s ^ (s >> 64) ^ (s >> 128) * _GOLD) % 2**64)
    index = dr.arange(mi.UInt64, count) + dr.opaque(mi.UInt64, int(start) % 2**64)
    rng = mi.PCG32(size=count)
    inc = (_mix(dr, index + key * _GOLD) << 1) | 1
    state = (inc + _mix(dr, index ^ key)) * _PCG_MULT + inc  # from 0: one step, add, one step
    rng.state, rng.inc = state, inc
    return rng


def fresnel(dr, cos_i, eta):
    """The host's unpolarised Fresnel reflectance (:func:`blockhash.scene.microfacet.fresnel`):
    ``eta`` the incident over the transmitted index."""
    cos_i = dr.clip(cos_i, 0.0, 1.0)
    sin2_t = eta * eta * (1.0 - cos_i * cos_i)
    cos_t = dr.safe_sqrt(1.0 - sin2_t)
    a = eta * cos_i + cos_t
    b = cos_i + eta * cos_t
    rs = (eta * cos_i - cos_t) / dr.select(a == 0.0, 1.0, a)
    rp = (cos_i - eta * cos_t) / dr.select(b == 0.0, 1.0, b)
    return dr.select((sin2_t >= 1.0) | (a == 0.0) | (b == 0.0), 1.0, 0.5 * (rs * rs + rp * rp))


def _conductor(dr, cos_i, eta, k):
    """The host's conductor Fresnel reflectance (:func:`blockhash.scene.optics.conductor_fresnel`)
    of each channel of ``eta`` and ``k`` (Color3f) at ``cos_i``."""
    c = dr.clip(cos_i, 0.0, 1.0)
    c2 = c * c
    s2 = 1.0 - c2
    t0 = eta * eta - k * k - s2
    a2b2 = dr.sqrt(t0 * t0 + 4.0 * eta * eta * k * k)
    a = dr.safe_sqrt(0.5 * (a2b2 + t0))
    t1 = a2b2 + c2
    t2 = 2.0 * c * a
    rs = (t1 - t2) / (t1 + t2)
    t3 = c2 * a2b2 + s2 * s2
    t4 = t2 * s2
    rp = dr.select(t3 + t4 > 0.0, rs * (t3 - t4) / dr.maximum(t3 + t4, 1e-30), rs)
    return 0.5 * (rs + rp)


def _refract(dr, d, n, eta):
    """(unit refracted direction, total internal reflection) of ``d`` at normal ``n`` facing
    it (:func:`blockhash.photons.bounce._refract`)."""
    cos_i = dr.clip(-dr.dot(d, n), 0.0, 1.0)
    sin2_t = eta * eta * (1.0 - cos_i * cos_i)
    cos_t = dr.safe_sqrt(1.0 - sin2_t)
    t = eta * d + (eta * cos_i - cos_t) * n
    return t / dr.maximum(dr.norm(t), 1e-30), sin2_t >= 1.0


def _reflect(dr, d, n):
    return d - 2.0 * dr.dot(d, n) * n


def specular_event(geo, d, ns, ng, outer, obj, kind, rng, active):
    """A photon's event on a mirror or glass (``active``), along ``d`` with shading and
    geometric normals ``ns``, ``ng`` facing it (met from the ``outer`` side): (the new
    direction, unnormalised; the factor on its weight; +1 leaving on the incoming side or -1
    passing through; a mirror's fallback to the geometric normal), the rules of
    :func:`blockhash.photons.bounce._event`.  Glass draws its choice from ``rng``, and a
    rough mirror or glass its microfacet (:mod:`.microfacet`)."""
    mi, dr = geo.mi, geo.dr
    rough = (active & (dr.gather(mi.Float, geo.alpha, obj, active) > 0.0) if geo.any_rough
             else dr.zeros(mi.Bool, dr.width(active)))
    mirror = active & (kind == MIRROR) & ~rough
    r = _reflect(dr, d, ns)
    wrong = dr.dot(r, ng) <= 0.0
    r = dr.select(wrong, _reflect(dr, d, ng), r)
    factor = dr.select(mirror, _mirror_factor(geo, obj, -dr.dot(d, ns), mirror), 1.0)
    side = dr.ones(mi.Float, dr.width(active))
    if geo.any_glass:
        glass = active & (kind == GLASS) & ~rough
        ior = dr.gather(mi.Float, geo.ior, obj, glass)
        eta = dr.select(outer, 1.0 / ior, ior)
        uc = rng.next_float32(glass)
        through = glass & (uc >= fresnel(dr, -dr.dot(d, ns), eta))
        t, tir = _refract(dr, d, ns, eta)
        t_g, tir_g = _refract(dr, d, ng, eta)
        off = dr.dot(t, ng) >= 0.0  # leaves on the wrong side: about the geometric normal
        t, tir = dr.select(off, t_g, t), dr.select(off, tir_g, tir)
        through &= ~tir
        r_glass = _reflect(dr, d, ns)
        r_glass = dr.select(~through & (dr.dot(r_glass, ng) <= 0.0), _reflect(dr, d, ng), r_glass)
        r = dr.select(glass, dr.select(through, t, r_glass), r)
        factor = dr.select(through, dr.gather(mi.Color3f, geo.tint, obj, through), factor)
        side = dr.select(through, -1.0, side)
    if geo.any_rough:  # rough mirrors and glass: about a sampled microfacet, as the host's
        from blockhash.device.microfacet import rough_event

        r_r, f_r, t_r, i_m = rough_event(geo, d, ns, ng, outer, obj, rough & (kind == GLASS),
                                         rng, rough, fresnel)
        on_mirror = rough & (kind != GLASS)  # a rough coat's reflection is a rough mirror's
        f_m = dr.select(on_mirror, _mirror_factor(geo, obj, i_m, on_mirror),
                        dr.select(t_r, dr.gather(mi.Color3f, geo.tint, obj, t_r), 1.0))
        r = dr.select(rough, r_r, r)
        factor = dr.select(rough, f_m * f_r, factor)
        side = dr.select(rough, dr.select(t_r, -1.0, 1.0), side)
    return r, factor, side, mirror & wrong


def _mirror_factor(geo, obj, cos_i, on):
    """A mirror's factor at ``cos_i`` to its (micro)facet, for the photons ``on``
    (:func:`blockhash.scene.microfacet.mirror_factor`): its reflectance, times a conductor's
    Fresnel reflectance."""
    mi, dr = geo.mi, geo.dr
    factor = dr.gather(mi.Color3f, geo.reflectance, obj, on)
    if not geo.any_conductor:
        return factor
    metal = on & (dr.gather(mi.UInt32, geo.conductor, obj, on) != 0)
    return dr.select(metal, factor * _conductor(dr, cos_i, dr.gather(mi.Color3f, geo.eta, obj, metal),
                                                dr.gather(mi.Color3f, geo.k, obj, metal)), factor)


def coat_glint(geo, d, ns, outer, obj, diffuse, rng):
    """The photons on ``diffuse`` hits that a coated receiver's coat reflects
    (:mod:`blockhash.scene.coat`, the host's rule): each on a coat met from a side it covers
    draws a choice, and reflects with probability 1 - T (Fresnel's F for a smooth coat).
    :func:`specular_event` reflects them as a mirror of reflectance 1 would (a rough coat as
    a rough conductor of the coat's index), and :func:`coat_factor` gives their weight's
    factor.  Returns (those reflected, their 1 - T)."""
    mi, dr = geo.mi, geo.dr
    coat = dr.gather(mi.Float, geo.coat, obj, diffuse)
    sided = dr.gather(mi.UInt32, geo.one_sided, obj, diffuse) != 0
    coated = diffuse & (coat > 0.0) & (outer | ~sided)
    uc = rng.next_float32(coated)
    odds = 1.0 - coat_transmittance(geo, -dr.dot(d, ns), obj, coated)
    return coated & (uc < odds), odds


def coat_transmittance(geo, cos, obj, on):
    """T: what the coats of objects ``obj`` let through of light arriving at ``cos`` from
    outside (:func:`blockhash.scene.coat.through`; ``on`` the coated ones)."""
    from blockhash.scene.coat_tables import NODES

    mi, dr = geo.mi, geo.dr
    coat = dr.gather(mi.Float, geo.coat, obj, on)
    smooth = 1.0 - fresnel(dr, cos, 1.0 / dr.select(on, coat, 1.0))
    if not geo.any_rough_coat:
        return smooth
    rough = on & (dr.gather(mi.Float, geo.alpha, obj, on) > 0.0)
    x = dr.clip(cos, 0.0, 1.0) * (NODES - 1)
    i = dr.minimum(mi.UInt32(x), NODES - 2)
    f = x - mi.Float(i)
    at = obj * NODES + i
    table = ((1.0 - f) * dr.gather(mi.Float, geo.coat_table, at, rough)
             + f * dr.gather(mi.Float, geo.coat_table, at + 1, rough))
    return dr.select(rough, table, smooth)


def coat_factor(geo, obj, glint, odds, factor):
    """The weight's factor of the photons that a coat reflected (``glint``, with the
    probability ``odds``; ``factor`` :func:`specular_event`'s): the coat's reflectance on a
    smooth coat, the rough conductor's factor over the odds on a rough one."""
    mi, dr = geo.mi, geo.dr
    smooth = dr.gather(mi.Color3f, geo.coat_reflectance, obj, glint)
    if not geo.any_rough_coat:
        return dr.select(glint, smooth, factor)
    rough = glint & (dr.gather(mi.Float, geo.alpha, obj, glint) > 0.0)
    return dr.select(glint, dr.select(rough, factor / dr.select(rough, odds, 1.0), smooth), factor)


def _trace(geo, max_bounces, o, d, w, rng):
    """The bounce loop (module docstring): per photon its fate, fallbacks, rays and, for
    those stored, the hit point, arriving direction, normals, weight, object and depth."""
    mi, dr = geo.mi, geo.dr
    n = dr.width(o)
    fate = dr.select(dr.any(w > 0.0), TRAVELLING, OUTSIDE_SPOT) + dr.zeros(mi.UInt32, n)
    o = o + d * geo.offset
    active = fate == TRAVELLING
    depth = dr.zeros(mi.UInt32, n)
    fallbacks = dr.zeros(mi.UInt32, n)
    rays = dr.zeros(mi.UInt32, n)
    p_out, n_out = dr.zeros(mi.Point3f, n), dr.zeros(mi.Vector3f, n)
    obj_out = dr.zeros(mi.UInt32, n)
    while active:
        rays += 1
        hit, face, u, v = geo.intersect(o, d, active)
        miss = active & ~hit
        fate = dr.select(miss, dr.select(depth == 0, MISSED, ESCAPED), fate)
        obj = dr.gather(mi.UInt32, geo.face_object, face, hit)
        kind = dr.gather(mi.UInt32, geo.kind, obj, hit)
        diffuse = hit & (kind == DIFFUSE)
        p, ns, ng, outer = geo.hit_frame(face, u, v, d, hit)
        glint, odds = coat_glint(geo, d, ns, outer, obj, diffuse, rng) if geo.any_coat else (None, None)
        if glint is not None:
            diffuse &= ~glint
        fate = dr.select(diffuse & (depth == 0), DIRECT, fate)
        back = diffuse & (depth > 0) & ~outer & (dr.gather(mi.UInt32, geo.one_sided, obj, diffuse) != 0)
        fate = dr.select(back, ABSORBED, fate)
        store = diffuse & (depth > 0) & ~back
        fate = dr.select(store, STORED, fate)
        p_out, n_out = dr.select(store, p, p_out), dr.select(store, ns, n_out)
        obj_out = dr.select(store, obj, obj_out)
        spec = hit & (kind != DIFFUSE)
        if glint is not None:
            spec |= glint
        fate = dr.select(spec & (depth >= max_bounces), MAX_BOUNCES, fate)
        event = spec & (depth < max_bounces)
        r, factor, side, fell_back = specular_event(geo, d, ns, ng, outer, obj, kind, rng, event)
        if glint is not None:
            factor = coat_factor(geo, obj, glint, odds, factor)
        fallbacks += dr.select(fell_back, 1, 0)
        w = dr.select(event, w * factor, w)
        dead = event & ~dr.any(w > 0.0)
        fate = dr.select(dead, ABSORBED, fate)
        go = event & ~dead
        o = dr.select(go, p + ng * (side * geo.offset), o)
        # the direction arriving at a stored photon's receiver is kept: d changes on go only
        d = dr.select(go, dr.normalize(r), d)
        depth += dr.select(go, 1, 0)
        active = go
    return fate, fallbacks, rays, depth, p_out, d, n_out, w, obj_out


class DeviceCausticTracer:
    """The caustic photons of a scene's :class:`~blockhash.photons.tracing.PhotonSource` as
    device kernels: :meth:`batch` gives what the host's emitter and
    :func:`~blockhash.photons.paths.trace_batch` give for the same photon numbers."""

    def __init__(self, source, device):
        from blockhash.device.emission import DeviceEmitter

        self.device = device
        self.geometry = DeviceGeometry.of(source.geometry, device)
        self.emitter = DeviceEmitter(source.emitter, source.lights, source.scene.bounds, device)
        self.max_bounces = int(source.max_bounces)
        self.mi, self.dr = device.modules()
        self._kernel = self.dr.syntax(_trace)

    def batch(self, seed: int, start: int, count: int) -> tuple[Batch, np.ndarray]:
        """Photons ``start .. start + count - 1`` of ``seed``: (their :class:`Batch`, each
        photon's light)."""
        mi, dr = self.device.modules()
        rng = photon_streams(mi, dr, seed, start, count)
        o, d, w, light = self.emitter.sample(rng)
        out = self._kernel(self.geometry, self.max_bounces, o, d, w, rng)
        dr.eval(out, light)  # one launch: each array read before would run the loop again
        fate, fallbacks, rays, depth, p, d, n, w, obj = out
        del out
        idx = dr.compress(fate == STORED)
        m = dr.width(idx)
        vectors = [dr.ravel(dr.gather(type(v), v, idx)) for v in (p, d, n, w)]
        scalars = [dr.gather(mi.UInt32, a, idx) for a in (depth, obj)]
        total = dr.sum(rays)
        dr.eval(vectors, scalars, total)
        del p, d, n, w, obj, depth, rays  # the launch's arrays, before the host's copies
        columns = []
        while vectors:  # each column's device array let go once copied
            columns.append(np.asarray(vectors.pop(0)).reshape(m, 3).astype(STORED_FLOAT, copy=False))
        pos, dirs, nrm, wts = columns
        # The geometric normals are the light tracer's (the host's batches); a map keeps none.
        batch = Batch(fate=np.asarray(fate).astype(np.int8),
                      fallbacks=np.asarray(fallbacks).astype(np.uint16),
                      stored=np.asarray(idx).astype(np.int64), positions=pos, directions=dirs,
                      normals=nrm, weights=wts, depth=np.asarray(scalars[0]).astype(np.uint8),
                      rays=int(total[0]), objects=np.asarray(scalars[1]).astype(STORED_OBJECT),
                      geo_normals=np.zeros((0, 3), dtype=STORED_FLOAT))
        light = np.asarray(light).astype(np.int64)
        del fate, fallbacks, idx, scalars
        # Dr.Jit keeps freed arrays for reuse: given back here, they would stay in the
        # process's memory beside the pass's index and radii
        dr.flush_malloc_cache()
        return batch, light
