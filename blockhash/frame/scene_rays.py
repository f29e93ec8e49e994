"""The camera side's ray queries (first hits, shadow rays) over all objects of a scene: embree's
(:class:`blockhash.scene.raycast.EmbreeGeometry`, embreex called directly), as the host photon
tracer's, or the photon kernels' device (:mod:`blockhash.device.rays`) where a render's
photons run on Dr.Jit."""

from __future__ import annotations

import numba
import numpy as np

from blockhash.scene.raycast import RAY_OFFSET, EmbreeGeometry, entering, surface_hits


class SceneRays:
    """First-hit and visibility queries over all objects of a scene: embree's, as the host
    tracer's, or the photon kernels' device after :meth:`on_device`."""

    def __init__(self, objects):
        self.geometry = EmbreeGeometry(tuple(objects))
        self.scale = self.geometry.scale
        #: The device's casts (:class:`blockhash.device.rays.DeviceCasts`), None: embree's.
        self.device = None

    def on_device(self, device) -> "SceneRays":
        """These rays cast on ``device`` (a :class:`~blockhash.device.choice.Device`) where
        it runs Dr.Jit kernels, else on embree; returns itself."""
        if device.jit:
            from blockhash.device.rays import DeviceCasts

            self.device = DeviceCasts(self.geometry, device)
        else:
            self.device = None
        return self

    def first_hit(self, origins, dirs, *, sides: bool = False, faces: bool = False):
        """(hit mask, points, shading normals, object ids, geometric normals) for each ray,
        with ``sides`` also (n,) bool: the ray met the face's outer side, and with ``faces``
        also (global face (n,), -1 for a miss; barycentrics (n, 2)), where a texture is read.

        Normals face the side the ray came from; rays that hit nothing get zeros and -1.
        """
        if self.device is not None:
            hit, face, u, v, points, shade, geo, outer = self.device.first_hit(origins, dirs)
        else:
            hit, face, u, v, points, shade, geo, outer = self._embree_hit(origins, dirs)
        obj = np.full(len(hit), -1)
        obj[hit] = self.geometry.face_object[face[hit]]
        out = (hit, points, shade, obj, geo)
        if sides:
            out += (outer,)
        if faces:
            out += (face, np.stack([u, v], axis=1))
        return out

    def _embree_hit(self, origins, dirs):
        """:meth:`blockhash.device.rays.DeviceCasts.first_hit`'s record of each ray, by embree."""
        n = len(origins)
        hit, face, u, v = self.geometry.intersect(origins, dirs)
        d = np.asarray(dirs, dtype=np.float64)[hit]
        p, ns, ng = surface_hits(self.geometry, face, u, v, d)
        points, shade, geo = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        points[hit], shade[hit], geo[hit] = p, ns, ng
        f, uu, vv, outer = np.full(n, -1), np.zeros(n), np.zeros(n), np.zeros(n, dtype=bool)
        f[hit], uu[hit], vv[hit] = face, u, v
        outer[hit] = entering(self.geometry, face, d)
        return hit, f, uu, vv, points, shade, geo, outer

    def occluded(self, origins, dirs, tmax) -> np.ndarray:
        """(n,) bool: each ray meets a surface before ``tmax``."""
        if self.device is not None:
            return self.device.occluded(origins, dirs, tmax)
        return self.geometry.occluded(origins, dirs, tmax)

    def visible(self, points, normals, targets) -> np.ndarray:
        """(n,) bool: nothing blocks the segment from each point (lifted off its surface) to its target."""
        origins, d, dist = shadow_segments(points, normals, targets, RAY_OFFSET * self.scale)
        return ~self.occluded(origins, d, dist * (1 - 1e-6))


@numba.njit(cache=True, nogil=True, parallel=True)
def shadow_segments(points, normals, targets, offset):
    """Shadow rays from ``points`` (m, 3), lifted by ``offset`` along their ``normals``, to
    ``targets`` ((m, 3), or (1, 3) for one target): (origins (m, 3), unit directions (m, 3)
    from the points, distances (m,) from the points), float64."""
    m = len(points)
    origins, dirs, dist = np.empty((m, 3)), np.empty((m, 3)), np.empty(m)
    step = 0 if targets.shape[0] == 1 else 1  # one target: row 0 for every point
    for i in numba.prange(m):
        t = i * step
        d0 = targets[t, 0] - np.float64(points[i, 0])
        d1 = targets[t, 1] - np.float64(points[i, 1])
        d2 = targets[t, 2] - np.float64(points[i, 2])
        r = np.sqrt((d0 * d0 + d1 * d1) + d2 * d2)
        dist[i] = r
        dirs[i, 0], dirs[i, 1], dirs[i, 2] = d0 / r, d1 / r, d2 / r
        for c in range(3):
            origins[i, c] = np.float64(points[i, c]) + np.float64(normals[i, c]) * offset
    return origins, dirs, dist
