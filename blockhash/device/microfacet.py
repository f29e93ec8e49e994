"""Rough mirrors and glass in the photons' kernels: the host's microfacet event
(:func:`blockhash.scene.microfacet.event`, which the tests hold this to) in Dr.Jit, for
:func:`blockhash.device.caustic.specular_event`."""

from __future__ import annotations

import math


def _normal(dr, mi, n, alpha, ggx, u1, u2):
    """A microfacet normal about ``n`` from D(m) cos(theta_m) (:func:`blockhash.scene.
    microfacet.normal`): (m, cos(theta_m))."""
    a2 = alpha * alpha
    u1 = dr.minimum(u1, 1.0 - 1e-7)
    tan2 = dr.select(ggx, a2 * u1 / (1.0 - u1), -a2 * dr.log(1.0 - u1))
    cos_m = dr.rsqrt(1.0 + tan2)
    sin_m = dr.safe_sqrt(1.0 - cos_m * cos_m)
    s, c = dr.sincos(2.0 * math.pi * u2)
    frame = mi.Frame3f(n)
    return frame.to_world(mi.Vector3f(sin_m * c, sin_m * s, cos_m)), cos_m


def _g1(dr, cos_v, v_m, alpha, ggx):
    """Smith's G1 (:func:`blockhash.scene.microfacet.smith_g1`)."""
    c2 = cos_v * cos_v
    tan2 = alpha * alpha * dr.maximum(1.0 - c2, 0.0) / dr.maximum(c2, 1e-30)
    g_ggx = 2.0 / (1.0 + dr.sqrt(1.0 + tan2))
    a = dr.rsqrt(dr.maximum(tan2, 1e-30))
    g_beck = dr.select(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a)
                       / (1.0 + 2.276 * a + 2.577 * a * a))
    g = dr.select(c2 >= 1.0, 1.0, dr.select(ggx, g_ggx, g_beck))
    return dr.select(v_m * cos_v <= 0.0, 0.0, g)


def rough_event(geo, d, ns, ng, outer, obj, glass, rng, active, fresnel):
    """The rough events of photons ``active`` along ``d`` (shading and geometric normals
    facing them, met from the ``outer`` side; ``glass`` those on rough glass):
    (new unit direction, the factor on the weight without a mirror's reflectance and
    Fresnel term, passed through, the cosine to the microfacet).  ``fresnel`` is the
    caustic kernel's dielectric Fresnel reflectance."""
    mi, dr = geo.mi, geo.dr
    alpha = dr.gather(mi.Float, geo.alpha, obj, active)
    ggx = dr.gather(mi.UInt32, geo.ggx, obj, active) != 0
    u1, u2, u3 = (rng.next_float32(active) for _ in range(3))
    m, cos_m = _normal(dr, mi, ns, alpha, ggx, u1, u2)
    i_m = -dr.dot(d, m)
    r = d + 2.0 * i_m * m
    ior = dr.gather(mi.Float, geo.ior, obj, glass)
    eta = dr.select(outer, 1.0 / ior, ior)
    sin2_t = eta * eta * (1.0 - i_m * i_m)
    through = glass & (sin2_t < 1.0) & (u3 >= fresnel(dr, i_m, eta))
    t = eta * d + (eta * i_m - dr.safe_sqrt(1.0 - sin2_t)) * m
    r = dr.normalize(dr.select(through, t, r))
    cos_i = -dr.dot(d, ns)
    cos_o = dr.dot(r, ns)
    side = dr.dot(r, ng)
    wrong = dr.select(through, (cos_o >= 0.0) | (side >= 0.0), (cos_o <= 0.0) | (side <= 0.0))
    g = _g1(dr, cos_i, i_m, alpha, ggx) * _g1(dr, cos_o, dr.dot(r, m), alpha, ggx)
    ok = ~wrong & (i_m > 0.0) & (cos_i > 0.0) & (cos_m > 0.0)
    factor = dr.select(ok, g * i_m / dr.maximum(cos_i * cos_m, 1e-30), 0.0)
    return r, factor, through, i_m
