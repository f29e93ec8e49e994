"""Direct light at the rough vertices of the camera's rays: the highlight of a point, spot or
directional light on a rough mirror, and its light through rough glass.

A camera ray on a rough mirror or glass goes on about a sampled microfacet
(:mod:`blockhash.scene.microfacet`); a light that no direction can hit (a point, a spot, a
directional light) is met there by a shadow ray instead, as a path tracer's next-event
estimate: ``weight f(w_v, w_l) |cos theta_l| L`` with ``w_v`` toward the camera, ``w_l``
toward the light and L its intensity over the distance squared (a spot's falloff and texture
on it) or a directional light's irradiance.  Area and environment lights are reached by the
sampled rays themselves (:func:`blockhash.frame.surface_lights.emission_seen`, the escaped
rays), so each light is counted once.

:func:`microfacet_bsdf` is Mitsuba 3's ``roughconductor`` and ``roughdielectric`` evaluation
(Walter et al. 2007) with the cosine, written for the directions the camera's rays sample
(no eta^2 on a refraction, as :mod:`blockhash.scene.microfacet`'s events; the tests hold
it to Mitsuba's own in that transport mode)."""

from __future__ import annotations

import numpy as np

from blockhash.frame.surface_lights import escapes
from blockhash.scene.microfacet import smith_g1_rays
from blockhash.scene.optics import conductor_fresnel, fresnel


def distribution(cos_h, alpha, ggx):
    """D(h) of microfacet normals at ``cos_h`` to the surface normal (per ray)."""
    c2 = np.clip(cos_h, 1e-12, 1.0) ** 2
    tan2 = (1.0 - c2) / c2
    a2 = alpha * alpha
    beckmann = np.exp(-tan2 / a2) / (np.pi * a2 * c2 * c2)
    trowbridge = 1.0 / (np.pi * a2 * c2 * c2 * (1.0 + tan2 / a2) ** 2)
    return np.where(cos_h > 0.0, np.where(ggx, trowbridge, beckmann), 0.0)


def microfacet_bsdf(v, light, n, outer, alpha, ggx, dielectric, ior, tint, reflectance, eta, k,
                    conductor):
    """(m, 3) f(v, l) |cos theta_l| of rough surfaces: ``v`` (m, 3) unit directions toward
    the camera, ``light`` (m, 3) toward the light, ``n`` (m, 3) normals on ``v``'s side,
    ``outer`` (m,) ``v`` on the surface's outer side; per ray the material's ``alpha``,
    ``ggx``, ``dielectric``, ``ior``, ``tint`` (3), ``reflectance`` (3), ``eta``, ``k`` (3)
    and ``conductor``."""
    cos_v = np.sum(v * n, axis=1)
    cos_l = np.sum(light * n, axis=1)
    reflect = cos_l > 0.0
    eta_t = np.where(outer, ior, 1.0 / ior)  # the far side's index over the camera side's
    h = v + light * np.where(reflect, 1.0, eta_t)[:, None]
    h /= np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-30)
    h *= np.where(np.sum(h * n, axis=1) < 0.0, -1.0, 1.0)[:, None]
    cos_h = np.sum(h * n, axis=1)
    v_h, l_h = np.sum(v * h, axis=1), np.sum(light * h, axis=1)
    alpha, ggx = np.asarray(alpha, np.float64), np.asarray(ggx, np.bool_)
    dg = distribution(cos_h, alpha, ggx) * smith_g1_rays(cos_v, v_h, alpha, ggx) \
        * smith_g1_rays(cos_l, l_h, alpha, ggx)
    f_glass = fresnel(np.clip(v_h, 0.0, 1.0), 1.0 / eta_t)
    f_metal = np.where(conductor[:, None],
                       conductor_fresnel(np.clip(v_h, 0.0, 1.0)[:, None], eta, k), 1.0) \
        * reflectance
    f_refl = np.where(dielectric[:, None], f_glass[:, None], f_metal)
    cos_v = np.maximum(cos_v, 1e-30)
    out = f_refl * (dg / (4.0 * cos_v))[:, None]
    denom = (v_h + eta_t * l_h) ** 2
    trans = (1.0 - f_glass) * dg * eta_t ** 2 * np.abs(v_h * l_h) / np.maximum(cos_v * denom, 1e-30)
    out = np.where((reflect & (cos_v > 0.0))[:, None], out,
                   np.where(dielectric[:, None], trans[:, None] * tint, 0.0))
    return np.where(np.isfinite(out), out, 0.0)


def delta_lights(rays, lights, pos, nrm, view, obj, outer) -> np.ndarray:
    """(m, 3) the point, spot and directional lights' direct light at rough vertices
    ``pos`` (normals ``nrm`` facing ``view``, the unit directions toward the camera; on
    objects ``obj``, ``view`` on the ``outer`` side), before the camera ray's weight (module
    docstring); each light a shadow ray per vertex."""
    geom = rays.geometry
    m = len(pos)
    out = np.zeros((m, 3))
    if not m:
        return out
    table = (geom.alpha[obj], geom.ggx[obj], geom.is_dielectric[obj], geom.ior[obj],
             geom.tint[obj], geom.reflectance[obj], geom.eta[obj], geom.k[obj],
             geom.conductor[obj])
    for light in lights:
        if hasattr(light, "irradiance"):  # directional
            toward = np.broadcast_to(-np.asarray(light.direction, np.float64), (m, 3)).copy()
            side = np.where(np.sum(toward * nrm, axis=1) > 0.0, 1.0, -1.0)[:, None]
            seen = escapes(rays, pos, nrm * side, toward)
            li = np.broadcast_to(np.asarray(light.irradiance, np.float64), (m, 3))
        elif hasattr(light, "position"):  # point or spot
            to = np.asarray(light.position, np.float64) - pos
            dist = np.maximum(np.linalg.norm(to, axis=1), 1e-30)
            toward = to / dist[:, None]
            side = np.where(np.sum(toward * nrm, axis=1) > 0.0, 1.0, -1.0)[:, None]
            seen = rays.visible(pos, nrm * side, np.asarray(light.position, np.float64)[None])
            li = _intensity(light, -toward) / (dist * dist)[:, None]
        else:  # area and environment lights: the sampled rays reach them
            continue
        if not seen.any():
            continue
        on = np.flatnonzero(seen)
        out[on] += microfacet_bsdf(view[on], toward[on], nrm[on], outer[on],
                                   *(t[on] for t in table)) * li[on]
    return out


def _intensity(light, dirs) -> np.ndarray:
    """(m, 3) W/sr of a point or spot light along ``dirs`` leaving it."""
    power = np.asarray(light.power, dtype=np.float64)
    if getattr(light, "cone_deg", None) is None:
        return np.broadcast_to(power / (4.0 * np.pi), (len(dirs), 3))
    fall = light.falloff(dirs @ np.asarray(light.direction, dtype=np.float64))
    out = light.peak_intensity * fall[:, None]
    if getattr(light, "texture", None) is not None:
        out = out * light.texture_factor(dirs)
    return out
