"""What a caustic photon does at its hit, compiled: one pass over a bounce's rays after the
ray cast (:func:`bounce`), for :func:`blockhash.photons.paths.trace_batch`.

Per ray: a miss escapes; a diffuse hit is direct light on the first bounce, absorbed on a
one-sided receiver's back face, else stored; a mirror reflects (its reflectance on the
weight, times a conductor's Fresnel reflectance; about the geometric normal where the
shading normal sends the ray into the surface); glass reflects or refracts with the Fresnel
probability (:mod:`blockhash.scene.optics`, the same formulas, scalar); a rough mirror or glass
does the same about a sampled microfacet (:mod:`blockhash.scene.microfacet`); a coated
receiver's coat reflects with Fresnel's probability, as a mirror (a rough coat with its
table's, about a sampled microfacet: :mod:`blockhash.scene.coat`), and otherwise the hit is
diffuse; a ray whose weight falls to 0 is absorbed.  The rays that go on
are written, in order, to the front of the next bounce's arrays: no boolean mask, fancy
index or temporary array per step, which the numpy version spent as much time on as embree
on its rays (BENCHMARKS.md, "What a photon costs").
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.scene import microfacet
from blockhash.scene.coat import COAT, COAT_REFLECTANCE, through
from blockhash.scene.microfacet import ALPHA, DISTRIBUTION, UNIFORMS, mirror_factor
from blockhash.scene.microfacet import fresnel as _fresnel
from blockhash.scene.raycast import hit_frame

# Photon fates (blockhash.photons.paths)
STORED, OUTSIDE_SPOT, MISSED, DIRECT, ESCAPED, ABSORBED, MAX_BOUNCES = range(7)


@numba.njit(cache=True, nogil=True, inline="always")
def _reflect(d0, d1, d2, n0, n1, n2):
    k = 2.0 * ((d0 * n0 + d1 * n1) + d2 * n2)
    return d0 - k * n0, d1 - k * n1, d2 - k * n2


@numba.njit(cache=True, nogil=True, inline="always")
def _refract(d0, d1, d2, n0, n1, n2, eta):
    """(t0, t1, t2, total internal reflection)."""
    cos_i = min(max(-((d0 * n0 + d1 * n1) + d2 * n2), 0.0), 1.0)
    sin2_t = eta * eta * (1.0 - cos_i * cos_i)
    cos_t = np.sqrt(max(1.0 - sin2_t, 0.0))
    k = eta * cos_i - cos_t
    t0, t1, t2 = eta * d0 + k * n0, eta * d1 + k * n1, eta * d2 + k * n2
    length = max(np.sqrt((t0 * t0 + t1 * t1) + t2 * t2), 1e-300)
    return t0 / length, t1 / length, t2 / length, sin2_t >= 1.0


@numba.njit(cache=True, nogil=True, inline="always")
def _event(pid, obj, outer, d0, d1, d2, n0, n1, n2, g0, g1, g2, w0, w1, w2, dielectric,
           reflectance, ior, tint, choices, events, fallbacks):
    """Photon ``pid``'s specular event on object ``obj`` (met from its outer side or not),
    along (d0, d1, d2), shading and geometric normals facing it: (the new unit direction, the
    new weight, +1 leaving on the incoming side or -1 passing through).  ``reflectance``: the
    mirrors' table (:attr:`blockhash.scene.raycast.EmbreeGeometry.mirror`)."""
    side = 1.0
    alpha = reflectance[obj, ALPHA]
    if alpha > 0.0:  # a rough mirror or glass: about a sampled microfacet
        width = choices.shape[1]
        e = events[pid]
        events[pid] += UNIFORMS
        r0, r1, r2, f, through, c = microfacet.event(
            d0, d1, d2, n0, n1, n2, g0, g1, g2, outer, dielectric[obj], ior[obj], alpha,
            reflectance[obj, DISTRIBUTION] != 0.0, choices[pid, e % width],
            choices[pid, (e + 1) % width], choices[pid, (e + 2) % width])
        if through:
            return r0, r1, r2, w0 * f * tint[obj, 0], w1 * f * tint[obj, 1], \
                w2 * f * tint[obj, 2], -1.0
        if not dielectric[obj]:
            w0, w1, w2 = (w0 * mirror_factor(reflectance, obj, 0, c),
                          w1 * mirror_factor(reflectance, obj, 1, c),
                          w2 * mirror_factor(reflectance, obj, 2, c))
        return r0, r1, r2, w0 * f, w1 * f, w2 * f, 1.0
    if not dielectric[obj]:
        c = -((d0 * n0 + d1 * n1) + d2 * n2)
        w0, w1, w2 = (w0 * mirror_factor(reflectance, obj, 0, c),
                      w1 * mirror_factor(reflectance, obj, 1, c),
                      w2 * mirror_factor(reflectance, obj, 2, c))
        r0, r1, r2 = _reflect(d0, d1, d2, n0, n1, n2)
        if (r0 * g0 + r1 * g1) + r2 * g2 <= 0.0:  # the shading normal sent it in
            r0, r1, r2 = _reflect(d0, d1, d2, g0, g1, g2)
            fallbacks[pid] += 1
    else:
        uc = choices[pid, events[pid] % choices.shape[1]]
        events[pid] += 1
        eta = 1.0 / ior[obj] if outer else ior[obj]
        through = uc >= _fresnel(-((d0 * n0 + d1 * n1) + d2 * n2), eta)
        r0, r1, r2 = _reflect(d0, d1, d2, n0, n1, n2)
        if through:
            t0, t1, t2, tir = _refract(d0, d1, d2, n0, n1, n2, eta)
            if (t0 * g0 + t1 * g1) + t2 * g2 >= 0.0:  # wrong side: about the geometric one
                t0, t1, t2, tir = _refract(d0, d1, d2, g0, g1, g2, eta)
            if tir:
                through = False
            else:
                r0, r1, r2 = t0, t1, t2
        if not through and (r0 * g0 + r1 * g1) + r2 * g2 <= 0.0:
            r0, r1, r2 = _reflect(d0, d1, d2, g0, g1, g2)
        if through:
            w0, w1, w2 = w0 * tint[obj, 0], w1 * tint[obj, 1], w2 * tint[obj, 2]
            side = -1.0
    length = np.sqrt((r0 * r0 + r1 * r1) + r2 * r2)
    return r0 / length, r1 / length, r2 / length, w0, w1, w2, side


@numba.njit(cache=True, nogil=True, inline="always")
def _coat(obj, d0, d1, d2, n0, n1, n2, g0, g1, g2, w0, w1, w2, table):
    """A coated receiver's coat reflecting a photon (:mod:`blockhash.scene.coat`): about the
    shading normal (the geometric one where that sends it in), times the coat's
    reflectance; (new direction, weight, side +1)."""
    r0, r1, r2 = _reflect(d0, d1, d2, n0, n1, n2)
    if (r0 * g0 + r1 * g1) + r2 * g2 <= 0.0:
        r0, r1, r2 = _reflect(d0, d1, d2, g0, g1, g2)
    return (r0, r1, r2, w0 * table[obj, COAT_REFLECTANCE], w1 * table[obj, COAT_REFLECTANCE + 1],
            w2 * table[obj, COAT_REFLECTANCE + 2], 1.0)


@numba.njit(cache=True, nogil=True)
def specular_events(idx, d, w, face, u, v, tri, vn, fn, face_object, dielectric, reflectance,
                    ior, tint, choices, events, fallbacks, p, ng, side, absorbed):
    """One specular event for each ray ``idx`` (on mirrors and glass only: the hits ``face``,
    ``u``, ``v``): the rays that go on written over the front of ``idx``, ``d``, ``w``, their
    hit points, geometric normals (facing where they came from) and sides to ``p``, ``ng``,
    ``side``; those whose weight fell to 0 to ``absorbed``.  Returns (going on, absorbed)."""
    n_next = 0
    n_dead = 0
    for i in range(idx.shape[0]):
        pid = idx[i]
        f = face[i]
        d0, d1, d2 = d[i, 0], d[i, 1], d[i, 2]
        outer = (d0 * fn[f, 0] + d1 * fn[f, 1]) + d2 * fn[f, 2] < 0.0
        p0, p1, p2, n0, n1, n2, g0, g1, g2 = hit_frame(tri, vn, fn, f, u[i], v[i], d0, d1, d2)
        r0, r1, r2, w0, w1, w2, s = _event(
            pid, face_object[f], outer, d0, d1, d2, n0, n1, n2, g0, g1, g2, w[i, 0], w[i, 1],
            w[i, 2], dielectric, reflectance, ior, tint, choices, events, fallbacks)
        if not (w0 > 0.0 or w1 > 0.0 or w2 > 0.0):
            absorbed[n_dead] = pid
            n_dead += 1
            continue
        idx[n_next] = pid
        d[n_next, 0], d[n_next, 1], d[n_next, 2] = r0, r1, r2
        w[n_next, 0], w[n_next, 1], w[n_next, 2] = w0, w1, w2
        p[n_next, 0], p[n_next, 1], p[n_next, 2] = p0, p1, p2
        ng[n_next, 0], ng[n_next, 1], ng[n_next, 2] = g0, g1, g2
        side[n_next] = s
        n_next += 1
    return n_next, n_dead


@numba.njit(cache=True, nogil=True)
def bounce(first, last, idx, d, w, hit, face, u, v, tri, vn, fn, face_object, specular,
           dielectric, one_sided, reflectance, ior, tint, choices, events, fallbacks, fate,
           offset, o_next, s_idx, s_p, s_d, s_n, s_w, s_obj, s_ng):
    """One bounce of rays ``idx`` (photon numbers in the batch) along ``d`` with weights
    ``w``: ``hit`` (n,) their ray cast's hits, ``face``, ``u``, ``v`` those of the hit rays,
    in order.  ``first``: the light's own rays (a diffuse hit is direct light); ``last``: the
    last bounce (a specular hit exceeds max_bounces).  Writes ``fate``, ``fallbacks``,
    ``events``; the stored photons to ``s_*`` (from 0); the rays that go on over the front of
    ``idx``, ``d``, ``w`` and their new origins to ``o_next``.  Returns (rays going on,
    photons stored)."""
    n_next = 0
    n_stored = 0
    j = -1
    for i in range(idx.shape[0]):
        pid = idx[i]
        if not hit[i]:
            fate[pid] = MISSED if first else ESCAPED
            continue
        j += 1
        f = face[j]
        obj = face_object[f]
        d0, d1, d2 = d[i, 0], d[i, 1], d[i, 2]
        outer = (d0 * fn[f, 0] + d1 * fn[f, 1]) + d2 * fn[f, 2] < 0.0  # met from outside
        coated = False
        glint = 1.0
        if not specular[obj]:
            coat = reflectance[obj, COAT]
            if coat > 0.0 and (outer or not one_sided[obj]):  # the coat reflects by Fresnel
                p0, p1, p2, n0, n1, n2, g0, g1, g2 = hit_frame(tri, vn, fn, f, u[j], v[j], d0,
                                                               d1, d2)
                uc = choices[pid, events[pid] % choices.shape[1]]
                events[pid] += 1
                glint = 1.0 - through(-((d0 * n0 + d1 * n1) + d2 * n2), reflectance, obj)
                coated = uc < glint
            if not coated:
                if first:
                    fate[pid] = DIRECT  # direct light: the renderer's shadow rays do it
                    continue
                if one_sided[obj] and not outer:
                    fate[pid] = ABSORBED  # a one-sided receiver met from behind reflects nothing
                    continue
                p0, p1, p2, n0, n1, n2, g0, g1, g2 = hit_frame(tri, vn, fn, f, u[j], v[j], d0,
                                                               d1, d2)
                fate[pid] = STORED
                s_idx[n_stored] = pid
                s_p[n_stored, 0], s_p[n_stored, 1], s_p[n_stored, 2] = p0, p1, p2
                s_d[n_stored, 0], s_d[n_stored, 1], s_d[n_stored, 2] = d0, d1, d2
                s_n[n_stored, 0], s_n[n_stored, 1], s_n[n_stored, 2] = n0, n1, n2
                s_ng[n_stored, 0], s_ng[n_stored, 1], s_ng[n_stored, 2] = g0, g1, g2
                for c in range(3):
                    s_w[n_stored, c] = w[i, c]
                s_obj[n_stored] = obj
                n_stored += 1
                continue
        else:
            p0, p1, p2, n0, n1, n2, g0, g1, g2 = hit_frame(tri, vn, fn, f, u[j], v[j], d0, d1, d2)
        if last:
            fate[pid] = MAX_BOUNCES
            continue
        if coated and reflectance[obj, ALPHA] > 0.0:  # a rough coat: a rough conductor of
            # its index, over the probability of its choice
            r0, r1, r2, w0, w1, w2, side = _event(
                pid, obj, outer, d0, d1, d2, n0, n1, n2, g0, g1, g2, w[i, 0] / glint,
                w[i, 1] / glint, w[i, 2] / glint, dielectric, reflectance, ior, tint, choices,
                events, fallbacks)
        elif coated:
            r0, r1, r2, w0, w1, w2, side = _coat(obj, d0, d1, d2, n0, n1, n2, g0, g1, g2,
                                                 w[i, 0], w[i, 1], w[i, 2], reflectance)
        else:
            r0, r1, r2, w0, w1, w2, side = _event(
                pid, obj, outer, d0, d1, d2, n0, n1, n2, g0, g1, g2, w[i, 0], w[i, 1], w[i, 2],
                dielectric, reflectance, ior, tint, choices, events, fallbacks)
        if not (w0 > 0.0 or w1 > 0.0 or w2 > 0.0):
            fate[pid] = ABSORBED
            continue
        idx[n_next] = pid
        d[n_next, 0], d[n_next, 1], d[n_next, 2] = r0, r1, r2
        w[n_next, 0], w[n_next, 1], w[n_next, 2] = w0, w1, w2
        t = side * offset
        o_next[n_next, 0] = p0 + g0 * t
        o_next[n_next, 1] = p1 + g1 * t
        o_next[n_next, 2] = p2 + g2 * t
        n_next += 1
    return n_next, n_stored
