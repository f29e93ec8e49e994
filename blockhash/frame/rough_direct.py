"""Direct light at the rough vertices of the camera's rays: the highlight of a point, spot or
directional light on a rough mirror, and its light through rough glass.

A camera ray on a rough mirror or glass goes on about a sampled microfacet
(:mod:`blockhash.scene.microfacet`); a light that no direction can hit (a point, a spot, a
directional light) is met there by a shadow ray instead, as a path tracer's next-event
estimate: ``weight f(w_v, w_l) |cos theta_l| L`` with ``w_v`` toward the camera, ``w_l``
toward the light and L its intensity over the distance squared (a spot's falloff and texture
on it) or a directional light's irradiance.  Area and environment lights are reached by the
sampled rays themselves (:func:`blockhash.frame.surface_lights.emission_seen`, the escaped
rays); they are also sampled at the vertex (:func:`sampled_lights`: one point on an area
light by area, or one direction from an environment, and a shadow ray), and the two ways of
reaching a light are weighted by Veach's power heuristic (1997), as Mitsuba's ``path`` and
``direct`` integrators weigh them: the point on the light by ``p_l^2 / (p_l^2 + p_b^2)``,
the light that the vertex's sampled ray meets by ``p_b^2 / (p_l^2 + p_b^2)``
(:func:`blockhash.frame.surface_lights.light_weight`), ``p_l = d^2 / (cos_y A)`` the light
point's density over directions and ``p_b`` the microfacet event's (:func:`sampling_pdf`).
A sharp highlight of a large light is then the sampled rays', a blurred one of a small light
the light points' (Veach's four plates).  An environment's direction comes from its map's
sampling, of density ``p_l`` (:meth:`blockhash.scene.environment_light.EnvironmentLight.pdf`),
weighed against the sampled rays that leave the scene
(:func:`blockhash.frame.surface_lights.sampled_weight`).

:func:`microfacet_bsdf` is Mitsuba 3's ``roughconductor`` and ``roughdielectric`` evaluation
(Walter et al. 2007) with the cosine, written for the directions the camera's rays sample
(no eta^2 on a refraction, as :mod:`blockhash.scene.microfacet`'s events; the tests hold
it to Mitsuba's own in that transport mode)."""

from __future__ import annotations

import numpy as np

from blockhash.frame.surface_lights import escapes, light_points_from, light_uniforms
from blockhash.scene.microfacet import smith_g1_rays
from blockhash.scene.optics import conductor_fresnel, fresnel
from blockhash.scene.raycast import RAY_OFFSET

#: The light samples of rough vertices take the streams ``light + VERTEX_STREAMS (event + 1)``
#: of :func:`blockhash.frame.surface_lights.light_uniforms` (a shading point's area light
#: takes stream ``light``), so that no two vertices of a camera ray share their points.
VERTEX_STREAMS = 4096


def distribution(cos_h, alpha, ggx):
    """D(h) of microfacet normals at ``cos_h`` to the surface normal (per ray)."""
    c2 = np.clip(cos_h, 1e-12, 1.0) ** 2
    tan2 = (1.0 - c2) / c2
    a2 = alpha * alpha
    beckmann = np.exp(-tan2 / a2) / (np.pi * a2 * c2 * c2)
    trowbridge = 1.0 / (np.pi * a2 * c2 * c2 * (1.0 + tan2 / a2) ** 2)
    return np.where(cos_h > 0.0, np.where(ggx, trowbridge, beckmann), 0.0)


def _half(v, light, n, outer, ior):
    """The half vector of ``v`` and ``light`` (normals ``n`` on ``v``'s side): (cos_v, cos_l,
    light reflected (cos_l > 0), eta_t the far side's index over ``v``'s, cos_h, v . h,
    l . h), h the reflection's or the refraction's, on the normal's side."""
    cos_v = np.sum(v * n, axis=1)
    cos_l = np.sum(light * n, axis=1)
    reflect = cos_l > 0.0
    eta_t = np.where(outer, ior, 1.0 / ior)
    h = v + light * np.where(reflect, 1.0, eta_t)[:, None]
    h /= np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-30)
    h *= np.where(np.sum(h * n, axis=1) < 0.0, -1.0, 1.0)[:, None]
    return (cos_v, cos_l, reflect, eta_t, np.sum(h * n, axis=1), np.sum(v * h, axis=1),
            np.sum(light * h, axis=1))


def sampling_pdf(v, light, n, outer, alpha, ggx, dielectric, ior):
    """(m,) the density over directions with which a rough event
    (:func:`blockhash.scene.microfacet.event`: m from D(m) cos(theta_m), a dielectric's
    choice by F) sends a ray arriving from ``v`` along ``light`` (arguments as
    :func:`microfacet_bsdf`'s): ``D cos_h / (4 |l . h|)`` for a reflection, a dielectric's
    times F, and ``(1 - F) D cos_h eta_t^2 |l . h| / (v . h + eta_t l . h)^2`` for a
    refraction."""
    cos_v, _, reflect, eta_t, cos_h, v_h, l_h = _half(v, light, n, outer, ior)
    d = distribution(cos_h, np.asarray(alpha, np.float64), np.asarray(ggx, np.bool_)) * cos_h
    f = np.where(dielectric, fresnel(np.clip(v_h, 0.0, 1.0), 1.0 / eta_t), 1.0)
    refl = f * d / np.maximum(4.0 * np.abs(l_h), 1e-30)
    refr = (1.0 - f) * d * eta_t ** 2 * np.abs(l_h) / np.maximum((v_h + eta_t * l_h) ** 2, 1e-30)
    out = np.where(reflect, refl, np.where(dielectric, refr, 0.0))
    return np.where((cos_v > 0.0) & (v_h > 0.0) & np.isfinite(out), out, 0.0)


def microfacet_bsdf(v, light, n, outer, alpha, ggx, dielectric, ior, tint, reflectance, eta, k,
                    conductor):
    """(m, 3) f(v, l) |cos theta_l| of rough surfaces: ``v`` (m, 3) unit directions toward
    the camera, ``light`` (m, 3) toward the light, ``n`` (m, 3) normals on ``v``'s side,
    ``outer`` (m,) ``v`` on the surface's outer side; per ray the material's ``alpha``,
    ``ggx``, ``dielectric``, ``ior``, ``tint`` (3), ``reflectance`` (3), ``eta``, ``k`` (3)
    and ``conductor``."""
    cos_v, cos_l, reflect, eta_t, cos_h, v_h, l_h = _half(v, light, n, outer, ior)
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


def vertex_lights(rays, lights, pos, nrm, view, obj, outer, owner, samples: int,
                  pass_index: int, event: int) -> np.ndarray:
    """(m, 3) the light that rough vertices take by shadow rays, before the camera ray's weight:
    :func:`delta_lights` and :func:`sampled_lights` (their arguments)."""
    return delta_lights(rays, lights, pos, nrm, view, obj, outer) + sampled_lights(
        rays, lights, pos, nrm, view, obj, outer, owner, samples, pass_index, event)


def sampled_lights(rays, lights, pos, nrm, view, obj, outer, owner, samples: int,
                   pass_index: int, event: int) -> np.ndarray:
    """(m, 3) the area and environment lights' direct light at rough vertices (as
    :func:`delta_lights`' arguments), by one point on each area light per vertex, uniform by
    area, and one direction from each environment by its map's sampling, each weighted by the
    power heuristic against the vertex's sampled ray (module docstring).  The uniforms are
    :func:`blockhash.frame.surface_lights.light_uniforms` of the vertices' camera samples
    ``owner`` (of ``samples``) in pass ``pass_index``, a stream of their own per light and
    specular ``event``."""
    m = len(pos)
    out = np.zeros((m, 3))
    if not m:
        return out
    geom = rays.geometry
    table = _table(geom, obj)
    offset = RAY_OFFSET * rays.scale
    for li, light in enumerate(lights):
        if not hasattr(light, "radiance") and not hasattr(light, "image"):
            continue
        u = light_uniforms(samples, owner, pass_index, li + VERTEX_STREAMS * (event + 1))
        if hasattr(light, "image"):  # an environment
            toward, p_light = light.sample(u[:, 0], None, u[:, 1])
            ok = np.flatnonzero(p_light > 0.0)
            side = np.where(np.sum(toward[ok] * nrm[ok], axis=1) > 0.0, 1.0, -1.0)[:, None]
            ok = ok[escapes(rays, pos[ok], nrm[ok] * side, toward[ok])]
            _add_weighted(out, ok, view, toward, nrm, outer, table, light.emitted(toward[ok]),
                          p_light[ok])
            continue
        y, ny, radiance, toward, d2, cos_y = light_points_from(light, u, pos)
        ok = np.flatnonzero((cos_y > 0.0) & (d2 > 0.0))
        if not len(ok):
            continue
        side = np.where(np.sum(toward[ok] * nrm[ok], axis=1) > 0.0, 1.0, -1.0)[:, None]
        ok = ok[rays.visible(pos[ok], nrm[ok] * side, y[ok] + ny[ok] * offset)]
        _add_weighted(out, ok, view, toward, nrm, outer, table, radiance[ok],
                      d2[ok] / (cos_y[ok] * light.area))
    return out


def _add_weighted(out, ok, view, toward, nrm, outer, table, radiance, p_light) -> None:
    """Adds to ``out[ok]`` the light of ``radiance`` (len(ok), 3) arriving along ``toward[ok]``,
    drawn with density ``p_light`` per steradian: ``f |cos| L / p_l`` times the power
    heuristic's weight against the rough event's density, ``p_l^2 / (p_l^2 + p_b^2)``."""
    p_bsdf = sampling_pdf(view[ok], toward[ok], nrm[ok], outer[ok], *(t[ok] for t in table[:4]))
    f = microfacet_bsdf(view[ok], toward[ok], nrm[ok], outer[ok], *(t[ok] for t in table))
    with np.errstate(divide="ignore", over="ignore"):  # p_l / (p_l^2 + p_b^2), 0 at p_l = inf
        scale = 1.0 / (p_light + p_bsdf * (p_bsdf / p_light))
    out[ok] += f * radiance * np.where(np.isfinite(scale), scale, 0.0)[:, None]


def sampled_pdf(geometry, view, dirs, nrm, outer, obj) -> np.ndarray:
    """(m,) :func:`sampling_pdf` of the rays that rough events of objects ``obj`` sent along
    ``dirs`` (``view`` toward where they came from; ``geometry`` the ray caster's tables)."""
    return sampling_pdf(view, dirs, nrm, outer, *_table(geometry, obj)[:4])


def _table(geom, obj):
    """The rough surfaces' parameters per vertex, in :func:`microfacet_bsdf`'s order."""
    return (geom.alpha[obj], geom.ggx[obj], geom.is_dielectric[obj], geom.ior[obj],
            geom.tint[obj], geom.reflectance[obj], geom.eta[obj], geom.k[obj],
            geom.conductor[obj])


def delta_lights(rays, lights, pos, nrm, view, obj, outer) -> np.ndarray:
    """(m, 3) the point, spot and directional lights' direct light at rough vertices
    ``pos`` (normals ``nrm`` facing ``view``, the unit directions toward the camera; on
    objects ``obj``, ``view`` on the ``outer`` side), before the camera ray's weight (module
    docstring); each light a shadow ray per vertex."""
    m = len(pos)
    out = np.zeros((m, 3))
    if not m:
        return out
    table = _table(rays.geometry, obj)
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
