"""A rough coat's tables, as Mitsuba 3's ``roughplastic`` computes them (:mod:`.coat`): the
albedos of an interface's microfacet reflection and refraction by quadrature, tabulated over
the cosine of incidence, for the ray caster's per-object table
(:class:`blockhash.scene.raycast.EmbreeGeometry`, which holds each rough coat's)."""

from __future__ import annotations

import functools

import numba
import numpy as np

from blockhash.scene.microfacet import fresnel, normal, smith_g1

#: Cosines at which a rough coat's transmittance is tabulated: i / (NODES - 1), as Mitsuba's.
NODES = 64
#: Gauss-Legendre nodes per axis of the quadrature of a rough coat's albedo.
QUADRATURE = 128


@numba.njit(cache=True, nogil=True)
def rough_albedo(mu, eta, alpha, ggx, nodes, weights):
    """(R, T): the albedos of the microfacet reflection and refraction of an interface of
    relative index ``eta`` (the far side's over the near side's) and roughness ``alpha``
    (GGX where ``ggx``) for light arriving at ``mu`` to its normal: the expectations of
    F(w_i . m) and 1 - F(w_i . m) times the event's factor (Smith's shadowing of both
    directions, :func:`blockhash.scene.microfacet.weight`) over microfacets drawn from
    D(m) cos(theta_m), by Gauss-Legendre quadrature (``nodes``, ``weights`` on [0, 1]) in
    the two uniforms of :func:`blockhash.scene.microfacet.normal`."""
    w0, w2 = np.sqrt(max(1.0 - mu * mu, 0.0)), mu
    r_sum, t_sum = 0.0, 0.0
    e = 1.0 / eta
    for a in range(nodes.shape[0]):
        for b in range(nodes.shape[0]):
            m0, m1, m2, cos_m = normal(0.0, 0.0, 1.0, alpha, ggx, nodes[a], nodes[b])
            i_m = w0 * m0 + w2 * m2
            if i_m <= 0.0:
                continue
            f = fresnel(i_m, e)
            g_i = smith_g1(mu, i_m, alpha, ggx) * weights[a] * weights[b] * i_m / (mu * cos_m)
            o2 = 2.0 * i_m * m2 - w2
            if o2 > 0.0:
                r_sum += f * g_i * smith_g1(o2, i_m, alpha, ggx)
            sin2_t = e * e * (1.0 - i_m * i_m)
            if f < 1.0 and sin2_t < 1.0:
                cos_t = np.sqrt(1.0 - sin2_t)
                k = e * i_m - cos_t
                t0, t2 = -e * w0 + k * m0, -e * w2 + k * m2
                t_m = t0 * m0 + t2 * m2
                if t2 < 0.0:
                    t_sum += (1.0 - f) * g_i * smith_g1(t2, t_m, alpha, ggx)
    return r_sum, t_sum


@functools.lru_cache(maxsize=64)
def rough_tables(eta: float, alpha: float, ggx: bool) -> tuple[np.ndarray, float]:
    """The tables of a rough coat of index ``eta`` and roughness ``alpha`` (GGX where
    ``ggx``): (its transmittance T, the albedo of the refraction into it (:func:`rough_albedo`),
    at the :data:`NODES` cosines i / (NODES - 1) (the first 1e-6); its internal diffuse
    reflectance F_dr = 2 * mean(R_inside(mu) mu) over the same cosines, R_inside the albedo of
    the reflection from inside)."""
    x, w = np.polynomial.legendre.leggauss(QUADRATURE)
    x, w = 0.5 * x + 0.5, 0.5 * w
    mu = np.maximum(np.arange(NODES) / (NODES - 1.0), 1e-6)
    outside = np.array([rough_albedo(m, eta, alpha, ggx, x, w) for m in mu])
    inside = np.array([rough_albedo(m, 1.0 / eta, alpha, ggx, x, w) for m in mu])
    table = np.ascontiguousarray(outside[:, 1])
    table.setflags(write=False)
    return table, float(2.0 * np.mean(inside[:, 0] * mu))
