"""Shading points and direct light (the non-caustic part of the image).

Ray queries go through the photon tracer's embree scene
(:class:`blockhash.render.raycast.EmbreeGeometry`, embreex called directly).  Perfect mirrors seen by the camera are resolved by one
reflection: the pixel's shading point moves to what the mirror reflects, with the
mirror's reflectance as path weight (up to ``MAX_MIRROR_BOUNCES``).  Direct light
is point and spot lights with shadow rays, through the modified Phong BRDF.
"""

from __future__ import annotations

import numpy as np

from .caustic import ShadingPoints, phong_brdf
from .raycast import RAY_OFFSET, EmbreeGeometry, surface_hits

#: Mirror-to-mirror reflections followed for camera rays.
MAX_MIRROR_BOUNCES = 4


class SceneRays:
    """First-hit and visibility queries over all objects of a scene (embree, as the tracer)."""

    def __init__(self, objects):
        self.geometry = EmbreeGeometry(tuple(objects))
        self.scale = self.geometry.scale

    def first_hit(self, origins, dirs):
        """(hit mask, points, shading normals, object ids, geometric normals) for each ray.

        Normals face the side the ray came from; rays that hit nothing get zeros and -1.
        """
        n = len(origins)
        hit, face, u, v = self.geometry.intersect(origins, dirs)
        p, ns, ng = surface_hits(self.geometry, face, u, v, np.asarray(dirs, dtype=np.float64)[hit])
        points, shade, geo = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        points[hit], shade[hit], geo[hit] = p, ns, ng
        obj = np.full(n, -1)
        obj[hit] = self.geometry.face_object[face]
        return hit, points, shade, obj, geo

    def visible(self, points, normals, targets) -> np.ndarray:
        """(n,) bool: nothing blocks the segment from each point (lifted off its surface) to its target."""
        d = targets - points
        dist = np.linalg.norm(d, axis=1)
        d = d / dist[:, None]
        origins = points + normals * (RAY_OFFSET * self.scale)
        hit, p, _, _, _ = self.first_hit(origins, d)
        t = np.linalg.norm(p - origins, axis=1)
        return ~(hit & (t < dist * (1 - 1e-6)))


def shading_points(camera, gbuffer, objects, rays: SceneRays, mirror_types) -> ShadingPoints:
    """Per-pixel shading points; mirror pixels follow their reflection (path weight = reflectance)."""
    h, w = gbuffer.object.shape
    pos = gbuffer.position.reshape(-1, 3).astype(np.float64)
    nrm = gbuffer.normal.reshape(-1, 3).astype(np.float64)
    obj = gbuffer.object.reshape(-1).copy()
    view = np.asarray(camera.eye, dtype=np.float64) - pos
    view /= np.maximum(np.linalg.norm(view, axis=1, keepdims=True), 1e-30)
    weight = np.ones((h * w, 3))
    # Per object (index len(objects) stands for "nothing hit", obj == -1).
    mirror = np.array([isinstance(o.material, mirror_types) for o in objects] + [False])
    reflectance = np.array([getattr(o.material, "reflectance", np.ones(3)) for o in objects]
                           + [np.ones(3)], dtype=np.float64)
    for _ in range(MAX_MIRROR_BOUNCES):
        is_mirror = mirror[obj]
        if not is_mirror.any():
            break
        idx = np.flatnonzero(is_mirror)
        weight[idx] *= reflectance[obj[idx]]
        wi = view[idx]
        n = nrm[idx]
        r = 2.0 * np.sum(n * wi, axis=1, keepdims=True) * n - wi
        hit, p, sn, o, _ = rays.first_hit(pos[idx] + n * (RAY_OFFSET * rays.scale), r)
        flip = np.sum(sn * -r, axis=1) < 0
        sn[flip] *= -1  # face the incoming ray
        pos[idx], nrm[idx], view[idx] = p, sn, -r
        obj[idx] = np.where(hit, o, -1)
    obj[mirror[obj]] = -1  # still on a mirror after the last bounce: nothing to shade
    return ShadingPoints(position=pos.reshape(h, w, 3).astype(np.float32),
                         normal=nrm.reshape(h, w, 3).astype(np.float32),
                         view=view.reshape(h, w, 3).astype(np.float32),
                         material=obj.reshape(h, w).astype(np.int32),
                         weight=weight.reshape(h, w, 3).astype(np.float32))


def light_intensity(light, directions) -> np.ndarray:
    """(n, 3) radiant intensity (W/sr) of ``light`` toward unit ``directions`` (n, 3)."""
    power = np.asarray(light.power, dtype=np.float64)
    cone = getattr(light, "cone_deg", None)
    if cone is None:
        return np.broadcast_to(power / (4.0 * np.pi), (len(directions), 3))
    axis = np.asarray(light.direction, dtype=np.float64)
    cos_c = np.cos(np.radians(cone))
    inside = directions @ axis >= cos_c
    return np.where(inside[:, None], power / (2.0 * np.pi * (1.0 - cos_c)), 0.0)


def direct_light(points: ShadingPoints, objects, lights, rays: SceneRays) -> np.ndarray:
    """(h, w, 3) direct radiance from point and spot lights, shadowed, times the path weight."""
    h, w = points.shape
    mat = points.material.reshape(-1)
    live = np.flatnonzero(mat >= 0)
    out = np.zeros((h * w, 3))
    if not len(live):
        return out.reshape(h, w, 3)
    p = points.position.reshape(-1, 3)[live].astype(np.float64)
    n = points.normal.reshape(-1, 3)[live].astype(np.float64)
    wo = points.view.reshape(-1, 3)[live].astype(np.float64)
    def per_object(attr, default):
        return np.array([getattr(o.material, attr, default) for o in objects], dtype=np.float64)

    kd = per_object("kd", np.zeros(3))[mat[live]]
    ks = per_object("ks", np.zeros(3))[mat[live]]
    e = per_object("n", 1.0)[mat[live]]
    for light in lights:
        lp = np.asarray(light.position, dtype=np.float64)
        d = lp - p
        dist2 = np.sum(d * d, axis=1)
        wi = d / np.sqrt(dist2)[:, None]
        cos = np.sum(wi * n, axis=1)
        front = cos > 0
        vis = np.zeros(len(p), dtype=bool)
        if front.any():
            vis[front] = rays.visible(p[front], n[front], np.broadcast_to(lp, (int(front.sum()), 3)))
        f = phong_brdf(wi, wo, n, kd, ks, e)
        radiance = f * light_intensity(light, -wi) * (np.maximum(cos, 0) / dist2)[:, None]
        out[live] += np.where(vis[:, None], radiance, 0.0)
    out *= points.weight.reshape(-1, 3)
    return out.reshape(h, w, 3)
