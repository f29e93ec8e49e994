"""Rough mirrors and glass: a microfacet event, compiled, shared by the photons
(:func:`blockhash.photons.bounce._event`) and the camera's rays (:func:`rough_scatter`).

A rough surface (``alpha > 0`` on :class:`blockhash.scene.materials.MirrorMaterial` or
:class:`~blockhash.scene.materials.DielectricMaterial`, Mitsuba's ``roughconductor`` and
``roughdielectric``) is Walter et al.'s microfacet BSDF (EGSR 2007), as Mitsuba 3 evaluates
it: the ``beckmann`` or ``ggx`` distribution D of isotropic roughness ``alpha``, Smith's
shadowing-masking G = G1(w_i, m) G1(w_o, m) (Beckmann's G1 by Walter's rational fit, as
Mitsuba's), and the Fresnel term of the microfacet normal m: a conductor's of its complex
index (or 1 for a perfect mirror), a dielectric's of its index, which reflects or refracts.

An event samples m from D(m) cos(theta_m) (two uniforms), reflects or refracts the ray about
it (a dielectric chooses by F(w_i . m) with a third uniform, as smooth glass does with one), and
multiplies the weight by f cos(theta_o) / pdf, which for both reflection and refraction is

    G(w_i, w_o, m) |w_i . m| / (cos(theta_i) cos(theta_m))

(the dielectric's F and 1 - F cancel against the choice; a conductor's F stays on the
weight).  The factor is the same for a photon and for a camera ray: blockhash's glass carries
no eta^2 on a refraction, as its smooth glass does not (it cancels through a closed object).
A direction that the microfacet sends below the surface (a reflection behind it, a
refraction back out), or a microfacet that faces away from the ray, ends the ray: its weight
is 0, as Mitsuba's BSDF gives nothing there.
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: Columns of a specular object's row in the ray caster's table
#: (:attr:`blockhash.scene.raycast.EmbreeGeometry.mirror`) that hold its roughness and its
#: distribution (0 Beckmann, 1 GGX).
ALPHA, DISTRIBUTION = 10, 11
#: Uniforms a rough event draws (the microfacet's two and a dielectric's choice).
UNIFORMS = 3


@numba.njit(cache=True, nogil=True, inline="always")
def normal(n0, n1, n2, alpha, ggx, u1, u2):
    """A microfacet normal about the unit normal (n0, n1, n2), drawn from D(m) cos(theta_m)
    of ``alpha`` (Beckmann, or GGX where ``ggx``) by the uniforms ``u1``, ``u2``:
    (m0, m1, m2, cos(theta_m))."""
    a2 = alpha * alpha
    u1 = min(u1, 1.0 - 1e-12)
    tan2 = a2 * u1 / (1.0 - u1) if ggx else -a2 * math.log(1.0 - u1)
    cos_m = 1.0 / math.sqrt(1.0 + tan2)
    sin_m = math.sqrt(max(1.0 - cos_m * cos_m, 0.0))
    phi = 2.0 * math.pi * u2
    x, y = sin_m * math.cos(phi), sin_m * math.sin(phi)
    # An orthonormal frame about n (Duff et al. 2017)
    s = 1.0 if n2 >= 0.0 else -1.0
    a = -1.0 / (s + n2)
    b = n0 * n1 * a
    t0, t1, t2 = 1.0 + s * n0 * n0 * a, s * b, -s * n0
    b0, b1, b2 = b, s + n1 * n1 * a, -n1
    return (x * t0 + y * b0 + cos_m * n0, x * t1 + y * b1 + cos_m * n1,
            x * t2 + y * b2 + cos_m * n2, cos_m)


@numba.njit(cache=True, nogil=True, inline="always")
def smith_g1(cos_v, v_dot_m, alpha, ggx):
    """Smith's G1 of a direction at ``cos_v`` to the surface normal and ``v_dot_m`` to the
    microfacet's: 0 where the two disagree in sign (a facet seen from behind)."""
    if v_dot_m * cos_v <= 0.0:
        return 0.0
    c2 = cos_v * cos_v
    if c2 >= 1.0:
        return 1.0
    tan2 = alpha * alpha * (1.0 - c2) / c2
    if ggx:
        return 2.0 / (1.0 + math.sqrt(1.0 + tan2))
    a = 1.0 / math.sqrt(tan2)
    if a >= 1.6:
        return 1.0
    return (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)


@numba.njit(cache=True, nogil=True)
def smith_g1_rays(cos_v, v_dot_m, alpha, ggx):
    """:func:`smith_g1` of each ray (all (m,) arrays), for the host's vectorised callers."""
    out = np.empty(cos_v.shape[0])
    for i in range(cos_v.shape[0]):
        out[i] = smith_g1(cos_v[i], v_dot_m[i], alpha[i], ggx[i])
    return out


@numba.njit(cache=True, nogil=True, inline="always")
def weight(cos_i, i_m, cos_o, o_m, cos_m, alpha, ggx):
    """The factor on the weight of a ray sent about a microfacet (module docstring; the
    Fresnel term aside): ``cos_i``, ``cos_o`` the incoming (reversed) and outgoing
    directions' cosines to the surface normal, ``i_m``, ``o_m`` to the microfacet's,
    ``cos_m`` the microfacet's to the surface's."""
    if cos_i <= 0.0 or i_m <= 0.0 or cos_m <= 0.0:
        return 0.0
    g = smith_g1(cos_i, i_m, alpha, ggx) * smith_g1(cos_o, o_m, alpha, ggx)
    return g * i_m / (cos_i * cos_m)


@numba.njit(cache=True, nogil=True, parallel=True)
def rough_scatter(d, n, g, outer, obj, table, dielectric, ior, u):
    """Rough events of the camera's rays ``d`` (unit, (m, 3)) on objects ``obj`` (m,) with
    shading and geometric normals ``n``, ``g`` facing the ray; ``outer`` (m,) bool the ray
    met the surface's outer side; ``table`` the ray caster's per-object table (reflectance,
    eta, k, conductor, :data:`ALPHA`, :data:`DISTRIBUTION`), ``dielectric`` (objects,) bool,
    ``ior`` (objects,), ``u`` (m, :data:`UNIFORMS`).  The rules of the photons' event
    (:func:`blockhash.photons.bounce._event`): returns (new unit directions (m, 3), weight
    factors (m, 3) before a refraction's tint, passed through (m,) bool)."""
    m = d.shape[0]
    out = np.zeros((m, 3))
    factor = np.zeros((m, 3))
    through = np.zeros(m, dtype=np.bool_)
    for i in numba.prange(m):
        o = obj[i]
        r0, r1, r2, w, t, c = event(d[i, 0], d[i, 1], d[i, 2], n[i, 0], n[i, 1], n[i, 2],
                                    g[i, 0], g[i, 1], g[i, 2], outer[i], dielectric[o],
                                    ior[o], table[o, ALPHA], table[o, DISTRIBUTION] != 0.0,
                                    u[i, 0], u[i, 1], u[i, 2])
        out[i, 0], out[i, 1], out[i, 2] = r0, r1, r2
        through[i] = t
        for ch in range(3):
            factor[i, ch] = w if dielectric[o] else w * mirror_factor(table, o, ch, c)
    return out, factor, through


@numba.njit(cache=True, nogil=True, inline="always")
def event(d0, d1, d2, n0, n1, n2, g0, g1, g2, outer, dielectric, ior, alpha, ggx, u1, u2, u3):
    """One rough event (module docstring) of a ray along (d0, d1, d2), shading and geometric
    normals facing it: (new unit direction, the factor on the weight without the Fresnel
    term of a conductor or the reflectance, passed through, the cosine of the ray to the
    microfacet (for a conductor's Fresnel term))."""
    m0, m1, m2, cos_m = normal(n0, n1, n2, alpha, ggx, u1, u2)
    i_m = -((d0 * m0 + d1 * m1) + d2 * m2)
    if i_m <= 0.0:
        return d0, d1, d2, 0.0, False, 0.0
    r0, r1, r2 = d0 + 2.0 * i_m * m0, d1 + 2.0 * i_m * m1, d2 + 2.0 * i_m * m2
    through = False
    if dielectric:
        eta = 1.0 / ior if outer else ior
        sin2_t = eta * eta * (1.0 - i_m * i_m)
        if sin2_t < 1.0 and u3 >= fresnel(i_m, eta):
            cos_t = math.sqrt(1.0 - sin2_t)
            k = eta * i_m - cos_t
            r0, r1, r2 = eta * d0 + k * m0, eta * d1 + k * m1, eta * d2 + k * m2
            through = True
    length = math.sqrt((r0 * r0 + r1 * r1) + r2 * r2)
    r0, r1, r2 = r0 / length, r1 / length, r2 / length
    cos_o = (r0 * n0 + r1 * n1) + r2 * n2
    side = (r0 * g0 + r1 * g1) + r2 * g2
    if (cos_o >= 0.0 or side >= 0.0) if through else (cos_o <= 0.0 or side <= 0.0):
        return r0, r1, r2, 0.0, through, i_m  # below the surface for what it did
    cos_i = -((d0 * n0 + d1 * n1) + d2 * n2)
    o_m = (r0 * m0 + r1 * m1) + r2 * m2
    return r0, r1, r2, weight(cos_i, i_m, cos_o, o_m, cos_m, alpha, ggx), through, i_m


@numba.njit(cache=True, nogil=True, inline="always")
def mirror_factor(table, obj, ch, cos_i):
    """A mirror's factor on channel ``ch`` of a ray at ``cos_i`` to its (micro)facet: its
    reflectance, times a conductor's Fresnel reflectance of eta + i k (``table`` the ray
    caster's per-object table, :attr:`blockhash.scene.raycast.EmbreeGeometry.mirror`)."""
    f = table[obj, ch]
    if table[obj, 9] != 0.0:
        f *= conductor(cos_i, table[obj, 3 + ch], table[obj, 6 + ch])
    return f


@numba.njit(cache=True, nogil=True, inline="always")
def fresnel(cos_i, eta):
    """Unpolarised Fresnel reflectance (:func:`blockhash.scene.optics.fresnel`), scalar."""
    cos_i = min(max(cos_i, 0.0), 1.0)
    sin2_t = eta * eta * (1.0 - cos_i * cos_i)
    if sin2_t >= 1.0:
        return 1.0
    cos_t = math.sqrt(max(1.0 - sin2_t, 0.0))
    a = eta * cos_i + cos_t
    b = cos_i + eta * cos_t
    if a == 0.0 or b == 0.0:
        return 1.0
    rs = (eta * cos_i - cos_t) / a
    rp = (cos_i - eta * cos_t) / b
    return 0.5 * (rs * rs + rp * rp)


@numba.njit(cache=True, nogil=True, inline="always")
def conductor(cos_i, eta, k):
    """:func:`blockhash.scene.optics.conductor_fresnel` of one channel, scalar."""
    c = min(max(cos_i, 0.0), 1.0)
    c2 = c * c
    s2 = 1.0 - c2
    t0 = eta * eta - k * k - s2
    a2b2 = math.sqrt(t0 * t0 + 4.0 * eta * eta * k * k)
    a = math.sqrt(max(0.5 * (a2b2 + t0), 0.0))
    t1 = a2b2 + c2
    t2 = 2.0 * c * a
    rs = (t1 - t2) / (t1 + t2)
    t3 = c2 * a2b2 + s2 * s2
    t4 = t2 * s2
    if t3 + t4 <= 0.0:  # 0 / 0 at eta = k = 0, cos_i = 1: the limit, a perfect reflector
        return rs
    return 0.5 * (rs + rs * (t3 - t4) / (t3 + t4))
