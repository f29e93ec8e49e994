"""The camera side's ray casts on the device: first hits and shadow rays of host arrays, cast
through the Mitsuba scene of the photon kernels (Embree on the CPU, OptiX on a GPU).

:class:`blockhash.frame.scene_rays.SceneRays` casts through this when a render's photons run on
Dr.Jit (:meth:`~blockhash.frame.scene_rays.SceneRays.on_device`): the camera's samples, their
mirror and glass chains, direct light's shadow rays and the pixel splat's visibility then run
on the device that traces the photons, one launch a call, and only the rays in and their hit
records out cross to the host.  A hit's point and normals come from the same tables and the
same definition as the photons' (:meth:`.geometry.DeviceGeometry.hit_frame`), in float32;
embree's host casts (float64 from float32 barycentrics) stay as their oracle
(``tests/device/test_rays.py``).
"""

from __future__ import annotations

import numpy as np

from blockhash.device.geometry import DeviceGeometry


class DeviceCasts:
    """First hits and occlusion of host rays on ``device`` (a jit
    :class:`~blockhash.device.choice.Device`), over ``geometry``'s
    (:class:`~blockhash.scene.raycast.EmbreeGeometry`) device copy."""

    def __init__(self, geometry, device):
        self.device = device
        self.embree_geometry = geometry

    @property
    def geometry(self) -> DeviceGeometry:
        # Looked up at each call: a frame whose objects moved hands the copy to its new
        # geometry (DeviceGeometry.move), and this one's is then built again when asked.
        return DeviceGeometry.of(self.embree_geometry, self.device)

    def _rays(self, origins, dirs):
        """(origins as Point3f, unit directions as Vector3f) of host (n, 3) arrays."""
        mi, dr = self.device.modules()
        return [dr.unravel(kind, mi.Float(np.ascontiguousarray(a, dtype=np.float32).reshape(-1)))
                for kind, a in ((mi.Point3f, origins), (mi.Vector3f, dirs))]

    def first_hit(self, origins, dirs):
        """(hit (n,) bool, face (n,) int64 (-1: a miss), barycentrics u and v (n,), points,
        shading normals and geometric normals (n, 3) float64 (zeros where nothing was hit),
        both normals facing the ray; and (n,) bool: the ray met its face's outer side)."""
        mi, dr = self.device.modules()
        n = len(origins)
        if n == 0:
            empty = np.zeros((0, 3))
            return (np.zeros(0, bool), np.zeros(0, np.int64), np.zeros(0), np.zeros(0), empty,
                    empty, empty, np.zeros(0, bool))
        geo = self.geometry
        o, d = self._rays(origins, dirs)
        hit, face, u, v = geo.intersect(o, d, dr.full(mi.Bool, True, n))
        p, ns, ng, outer = geo.hit_frame(face, u, v, d, hit)
        zero = mi.Vector3f(0.0)
        p, ns, ng = (dr.select(hit, a, zero) for a in (p, ns, ng))
        vectors = [dr.ravel(a) for a in (p, ns, ng)]
        dr.eval(hit, face, u, v, outer, vectors)
        del o, d, p, ns, ng
        hit = np.asarray(hit, dtype=bool)
        face = np.where(hit, np.asarray(face).astype(np.int64), -1)
        u, v = (np.where(hit, np.asarray(a, dtype=np.float64), 0.0) for a in (u, v))
        outer = np.asarray(outer, dtype=bool) & hit
        p, ns, ng = (np.asarray(a, dtype=np.float64).reshape(n, 3) for a in vectors)
        del vectors
        dr.flush_malloc_cache()  # the launch's arrays given back, not kept beside the host's
        return hit, face, u, v, p, ns, ng, outer

    def occluded(self, origins, dirs, tmax) -> np.ndarray:
        """(n,) bool: each ray meets a surface before ``tmax`` (an any-hit query)."""
        mi, dr = self.device.modules()
        n = len(origins)
        if n == 0:
            return np.zeros(0, bool)
        o, d = self._rays(origins, dirs)
        t = mi.Float(np.ascontiguousarray(tmax, dtype=np.float32).reshape(-1))
        ray = mi.Ray3f(o, d)
        ray.maxt = t
        blocked = self.geometry.scene.ray_test(ray, dr.full(mi.Bool, True, n))
        out = np.asarray(blocked, dtype=bool)
        del o, d, t, ray, blocked
        dr.flush_malloc_cache()
        return out
