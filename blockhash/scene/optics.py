"""Smooth dielectrics (glass): Snell refraction, exact Fresnel reflectance, and the choice
between them that photons and camera rays make; and the Fresnel reflectance of a smooth
conductor (a metal's complex index, :func:`conductor_fresnel`).

A ray meets a dielectric interface from the medium of index ``n_i`` toward ``n_t``, with
``eta = n_i / n_t`` (entering glass of index ``ior`` from air: ``eta = 1 / ior``; leaving
it: ``eta = ior``).  With ``cos_i = -d . n`` (``n`` facing the incoming ray) Snell's law
gives ``sin_t = eta sin_i``; past ``sin_t = 1`` the ray is totally reflected.  The
unpolarised reflectance is the mean of the two polarisations' (exact, not Schlick's):

    r_s = (eta cos_i - cos_t) / (eta cos_i + cos_t)
    r_p = (cos_i - eta cos_t) / (cos_i + eta cos_t)
    F = (r_s^2 + r_p^2) / 2

A ray reflects with probability F and refracts with 1 - F (always reflects under total
internal reflection), so its weight is unchanged in expectation and no ray is split; a
refracted ray's weight is multiplied by the material's ``tint`` per crossing.
"""

from __future__ import annotations

import numpy as np

from blockhash.scene.raycast import reflect

#: Key offset of the uniforms that choose reflection or refraction: a stream of its own,
#: independent of the emission stream under the same seed.
CHOICE_KEY = 0x6A09E667F3BCC908B2FB1366EA957D3E
#: Philox counter steps (4 uniforms each) a path's choices use per ray.
CHOICE_STEPS = 4


def fresnel(cos_i, eta) -> np.ndarray:
    """Unpolarised Fresnel reflectance for ``cos_i`` in [0, 1] and ``eta = n_i / n_t``; 1
    under total internal reflection."""
    cos_i = np.clip(np.asarray(cos_i, dtype=np.float64), 0.0, 1.0)
    eta = np.asarray(eta, dtype=np.float64)
    sin2_t = eta * eta * (1.0 - cos_i * cos_i)
    tir = sin2_t >= 1.0
    cos_t = np.sqrt(np.maximum(1.0 - sin2_t, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
        rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    f = 0.5 * (rs * rs + rp * rp)
    return np.where(tir, 1.0, np.nan_to_num(f, nan=1.0))


def conductor_fresnel(cos_i, eta, k) -> np.ndarray:
    """Unpolarised Fresnel reflectance of a conductor of complex index ``eta + i k`` (the
    outside air) at ``cos_i`` in [0, 1], exact (the form of pbrt's and Mitsuba's
    ``fresnel_conductor``); broadcasts, e.g. ``cos_i`` (m, 1) against ``eta``, ``k`` (3,)."""
    c = np.clip(np.asarray(cos_i, dtype=np.float64), 0.0, 1.0)
    eta, k = np.asarray(eta, dtype=np.float64), np.asarray(k, dtype=np.float64)
    c2 = c * c
    s2 = 1.0 - c2
    t0 = eta * eta - k * k - s2
    a2b2 = np.sqrt(t0 * t0 + 4.0 * eta * eta * k * k)
    a = np.sqrt(np.maximum(0.5 * (a2b2 + t0), 0.0))
    t1 = a2b2 + c2
    t2 = 2.0 * c * a
    rs = (t1 - t2) / (t1 + t2)
    t3 = c2 * a2b2 + s2 * s2
    t4 = t2 * s2
    with np.errstate(divide="ignore", invalid="ignore"):  # 0 / 0 at eta = k = 0, cos_i = 1
        rp = np.where(t3 + t4 > 0.0, rs * (t3 - t4) / (t3 + t4), rs)
    return 0.5 * (rs + rp)


def refract(d, n, eta):
    """(directions (m, 3), total internal reflection (m,) bool): unit ``d`` refracted
    through unit normals ``n`` facing the incoming ray, ``eta = n_i / n_t`` per ray
    (the direction is meaningless where the mask is set)."""
    eta = np.asarray(eta, dtype=np.float64).reshape(-1, 1)
    cos_i = np.clip(-np.sum(d * n, axis=1, keepdims=True), 0.0, 1.0)
    sin2_t = eta * eta * (1.0 - cos_i * cos_i)
    tir = sin2_t[:, 0] >= 1.0
    cos_t = np.sqrt(np.maximum(1.0 - sin2_t, 0.0))
    t = eta * d + (eta * cos_i - cos_t) * n
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
    return t, tir


def choice_uniforms(seed: int, start: int, count: int) -> np.ndarray:
    """(count, 4 * CHOICE_STEPS) uniforms for the reflect-or-refract choices of paths
    ``start .. start + count - 1``: path ``i`` reads Philox counters ``CHOICE_STEPS *
    (start + i)`` onward under key ``seed + CHOICE_KEY`` (mod 2^128), so its numbers do not
    depend on how paths are batched.  Column ``j`` is the choice at the path's j-th
    dielectric event (events past the last column reuse it modulo the width)."""
    key = (int(seed) + CHOICE_KEY) % (1 << 128)
    bitgen = np.random.Philox(key=key, counter=CHOICE_STEPS * int(start))
    return np.random.Generator(bitgen).random((count, 4 * CHOICE_STEPS))


def scatter(d, ns, ng, entering, ior, tint, u):
    """One dielectric event for rays ``d`` (unit, (m, 3)) at hits with shading and
    geometric normals ``ns``, ``ng`` facing the incoming ray; ``entering`` (m,) bool (the
    ray meets the surface's outer side), ``ior`` (m,), ``tint`` (m, 3), ``u`` (m,) the
    choice's uniforms.

    Returns ``(new directions, transmitted (m,) bool, weight factors (m, 3))``: reflect
    where ``u < F`` or under total internal reflection (factor 1), else refract (factor
    ``tint``).  A direction that the shading normal sends to the wrong side of the
    geometric one is recomputed about the geometric normal.
    """
    eta = np.where(entering, 1.0 / ior, ior)
    cos_i = -np.sum(d * ns, axis=1)
    f = fresnel(cos_i, eta)
    through = u >= f
    out = reflect(d, ns)
    if through.any():
        t, tir = refract(d[through], ns[through], eta[through])
        wrong = np.sum(t * ng[through], axis=1) >= 0.0
        if wrong.any():
            t2, tir2 = refract(d[through][wrong], ng[through][wrong], eta[through][wrong])
            t[wrong], tir[wrong] = t2, tir2
        idx = np.flatnonzero(through)
        out[idx[~tir]] = t[~tir]
        through[idx[tir]] = False
    bad = ~through & (np.sum(out * ng, axis=1) <= 0.0)
    if bad.any():
        out[bad] = reflect(d[bad], ng[bad])
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    factor = np.where(through[:, None], tint, 1.0)
    return out, through, factor
