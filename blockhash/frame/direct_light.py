"""Direct light at the shading points (the non-caustic part of the image):
:func:`direct_light`, point, spot, area, directional and environment lights with shadow rays
(an area light sampled at a point per pass and an environment at a direction,
:mod:`.surface_lights`), through the modified Phong BRDF, and the emitters the camera sees."""

from __future__ import annotations

import numba
import numpy as np

from blockhash.frame.scene_rays import SceneRays, shadow_segments
from blockhash.frame.shading_points import ShadingPoints
from blockhash.scene.coat import through
from blockhash.scene.raycast import RAY_OFFSET


def _cone(light):
    """(axis (3,), cos of the half angle, intensity (3,) W/sr at the peak, cos of the beam's
    half angle, the cone's and the beam's half angles in radians): a point light's cone is the
    whole sphere (cos -2: every direction is inside, all of it beam)."""
    power = np.asarray(light.power, dtype=np.float64)
    cone = getattr(light, "cone_deg", None)
    if cone is None:
        return np.zeros(3), -2.0, power / (4.0 * np.pi), -2.0, np.pi, np.pi
    c, b = np.radians(cone), np.radians(light.beam_deg)
    cos_c = float(np.cos(c))
    return (np.asarray(light.direction, dtype=np.float64), cos_c, light.peak_intensity,
            cos_c if light.uniform else float(np.cos(b)), float(c), float(b))


def direct_light(points: ShadingPoints, objects, lights, rays: SceneRays,
                 pass_index: int = 0) -> np.ndarray:
    """(h, w, 3) direct radiance from the lights, shadowed, times the path weight
    (the modified Phong BRDF, :func:`blockhash.scene.materials.phong_brdf`): per light, the
    points on its side of their surface cast one shadow ray each (:meth:`SceneRays.visible`'s
    segments, embree's occlusion query), and :func:`_lit` adds the unshadowed ones' radiance.
    Area and directional lights, and an area light's radiance seen, are
    :mod:`blockhash.frame.surface_lights`' (an area light's point per sample from
    ``pass_index``'s light sample)."""
    from blockhash.frame import surface_lights

    h, w = points.shape
    mat = points.material.reshape(-1)
    live = np.flatnonzero(mat >= 0)
    out = np.zeros((h * w, 3))
    if not len(live) and points.escaped is None:
        return out.reshape(h, w, 3)
    p = points.position.reshape(-1, 3)
    n = points.normal.reshape(-1, 3)
    wo = points.view.reshape(-1, 3)

    def per_object(attr, default):
        return np.array([getattr(o.material, attr, default) for o in objects],
                        dtype=np.float64).reshape(len(objects), -1)

    kd, ks, e = per_object("kd", np.zeros(3)), per_object("ks", np.zeros(3)), per_object("n", 1.0)[:, 0]
    coat = rays.geometry.mirror  # a coated receiver's row: blockhash.scene.coat.through
    surface_lights.emission_seen(out, lights, objects, p, wo, mat, rays,
                                 None if points.rough_pdf is None else points.rough_pdf.reshape(-1))
    surface_lights.environment_seen(out, lights, points)
    owner = np.arange(h * w) if points.owner is None else points.owner
    samples = h * w if points.samples is None else int(np.prod(points.samples))
    for li, light in enumerate(lights):
        if hasattr(light, "radiance"):
            surface_lights.area_light(out, light, live, p, n, wo, mat, kd, ks, e, coat, rays,
                                      pass_index, li, owner, samples)
            continue
        if hasattr(light, "irradiance"):
            surface_lights.directional_light(out, light, live, p, n, wo, mat, kd, ks, e, coat, rays)
            continue
        if hasattr(light, "image"):
            surface_lights.environment_light(out, light, live, p, n, wo, mat, kd, ks, e, coat, rays,
                                             pass_index, li, owner, samples)
            continue
        lp = np.asarray(light.position, dtype=np.float64).reshape(1, 3)
        front = _facing(p, n, live, lp[0])
        origins, wi, dist = shadow_segments(p[front], n[front], lp, RAY_OFFSET * rays.scale)
        lit = ~rays.occluded(origins, wi, dist * (1 - 1e-6))
        # a spot's projected texture toward each point (ones where it has none)
        tint = (light.texture_factor(-wi[lit]) if getattr(light, "texture", None) is not None
                else np.ones((int(lit.sum()), 3)))
        _lit(out, front[lit], wi[lit], dist[lit], n, wo, mat, kd, ks, e, coat, *_cone(light), tint)
    out *= points.weight.reshape(-1, 3)
    return out.reshape(h, w, 3)


@numba.njit(cache=True, nogil=True)
def _facing(p, n, live, lp):
    """The points of ``live`` whose normal faces the light at ``lp``."""
    keep = np.empty(len(live), dtype=np.int64)
    count = 0
    for i in live:
        if ((lp[0] - p[i, 0]) * n[i, 0] + (lp[1] - p[i, 1]) * n[i, 1]) \
                + (lp[2] - p[i, 2]) * n[i, 2] > 0.0:
            keep[count] = i
            count += 1
    return keep[:count]


@numba.njit(cache=True, nogil=True, parallel=True)
def _lit(out, idx, wi, dist, n, wo, mat, kd, ks, e, coat, axis, cos_c, intensity, cos_b, cone,
         beam, tint):
    """Adds to ``out[idx]`` the radiance from one light reaching each point unshadowed along
    ``wi`` from ``dist`` away: f_r(wi, wo) I cos / d^2, the modified Phong f_r of
    :func:`blockhash.scene.materials.phong_brdf` and I the light's intensity toward the point
    (:func:`_cone`: the peak inside the beam, falling linearly in the angle to 0 at the
    cone's edge, :meth:`blockhash.scene.lights.SpotLight.falloff`), times ``tint[j]`` (a
    spot's projected texture toward the point) and a coated receiver's transmittance toward
    the light (``coat`` the ray caster's per-object table: :func:`blockhash.scene.coat.through`)."""
    for j in numba.prange(len(idx)):
        i = idx[j]
        w0, w1, w2 = wi[j, 0], wi[j, 1], wi[j, 2]
        cos = (w0 * n[i, 0] + w1 * n[i, 1]) + w2 * n[i, 2]
        c_axis = -((w0 * axis[0] + w1 * axis[1]) + w2 * axis[2])
        if cos <= 0.0 or c_axis < cos_c:
            continue  # behind the surface, or outside a spot light's cone
        fall = 1.0
        if c_axis < cos_b:  # between the beam and the cone's edge
            fall = min(max((cone - np.arccos(min(c_axis, 1.0))) / (cone - beam), 0.0), 1.0)
        m = mat[i]
        c_alpha = ((2.0 * cos * n[i, 0] - w0) * wo[i, 0] + (2.0 * cos * n[i, 1] - w1) * wo[i, 1]) \
            + (2.0 * cos * n[i, 2] - w2) * wo[i, 2]
        lobe = (e[m] + 2.0) / (2.0 * np.pi) * max(c_alpha, 0.0) ** e[m]
        scale = cos / (dist[j] * dist[j]) * through(cos, coat, m)
        for c in range(3):
            out[i, c] += (kd[m, c] / np.pi + ks[m, c] * lobe) * intensity[c] * tint[j, c] \
                * fall * scale
