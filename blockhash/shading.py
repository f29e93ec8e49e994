"""Shading points and direct light (the non-caustic part of the image).

Ray queries go through embree (trimesh's embreex intersector; embreex is a hard
dependency because trimesh otherwise falls back silently to a caster ~60,000x
slower, DESIGN.md).  Perfect mirrors seen by the camera are resolved by one
reflection: the pixel's shading point moves to what the mirror reflects, with the
mirror's reflectance as path weight (up to ``MAX_MIRROR_BOUNCES``).  Direct light
is point and spot lights with shadow rays, through the modified Phong BRDF.
"""

from __future__ import annotations

import numpy as np
import trimesh
from trimesh.ray.ray_pyembree import RayMeshIntersector

from .caustic import ShadingPoints, phong_brdf

#: Mirror-to-mirror reflections followed for camera rays.
MAX_MIRROR_BOUNCES = 4
#: Ray origins move this far along the geometric normal, relative to the scene size,
#: so that a ray does not hit the surface it leaves.
RAY_OFFSET = 1e-5


class SceneRays:
    """Embree ray queries over all objects of a scene."""

    def __init__(self, objects):
        meshes = [o.mesh for o in objects]
        self.mesh = trimesh.util.concatenate(meshes)
        self.normals = np.concatenate([m.vertex_normals for m in meshes])
        self.face_object = np.repeat(np.arange(len(meshes)), [len(m.faces) for m in meshes])
        self.scale = float(np.linalg.norm(self.mesh.extents))
        self.caster = RayMeshIntersector(self.mesh)

    def first_hit(self, origins, dirs):
        """(hit mask, points, shading normals, object ids, geometric normals) for each ray."""
        n = len(origins)
        tri, ray, loc = self.caster.intersects_id(origins, dirs, multiple_hits=False,
                                                  return_locations=True)
        hit = np.zeros(n, dtype=bool)
        hit[ray] = True
        points = np.zeros((n, 3))
        points[ray] = loc
        faces = self.mesh.faces[tri]
        bary = trimesh.triangles.points_to_barycentric(self.mesh.triangles[tri], loc)
        shade = np.zeros((n, 3))
        sn = np.einsum("ij,ijk->ik", bary, self.normals[faces])
        shade[ray] = sn / np.linalg.norm(sn, axis=1, keepdims=True)
        geo = np.zeros((n, 3))
        geo[ray] = self.mesh.face_normals[tri]
        obj = np.full(n, -1)
        obj[ray] = self.face_object[tri]
        return hit, points, shade, obj, geo

    def visible(self, points, normals, targets) -> np.ndarray:
        """(n,) bool: nothing blocks the segment from each point (lifted off its surface) to its target."""
        d = targets - points
        dist = np.linalg.norm(d, axis=1)
        d = d / dist[:, None]
        origins = points + normals * (RAY_OFFSET * self.scale)
        tri, ray, loc = self.caster.intersects_id(origins, d, multiple_hits=False, return_locations=True)
        blocked = np.zeros(len(points), dtype=bool)
        t = np.linalg.norm(loc - origins[ray], axis=1)
        blocked[ray[t < dist[ray] * (1 - 1e-6)]] = True
        return ~blocked


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
