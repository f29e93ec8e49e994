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

from blockhash.device.arrays import floats
from blockhash.device.geometry import DeviceGeometry

#: Camera rays made and cast a launch (:meth:`DeviceCasts.film_hits`): their device arrays,
#: about 30 floats a ray, stay near 30 MiB whatever the film.
CHUNK = 1 << 18


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
        return [dr.unravel(kind, floats(mi, a)) for kind, a in ((mi.Point3f, origins),
                                                                 (mi.Vector3f, dirs))]

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
        hit = np.array(hit, dtype=bool)  # a copy: no view keeps the launch's array
        face = np.where(hit, np.asarray(face).astype(np.int64), -1)
        u, v = (np.where(hit, np.asarray(a, dtype=np.float64), 0.0) for a in (u, v))
        outer = np.asarray(outer, dtype=bool) & hit
        p, ns, ng = (np.asarray(a, dtype=np.float64).reshape(n, 3) for a in vectors)
        del vectors
        dr.flush_malloc_cache()  # the launch's arrays given back, not kept beside the host's
        return hit, face, u, v, p, ns, ng, outer

    def film_hits(self, pin, x, y, lens):
        """The G-buffer's columns of the camera rays through film points ``(x, y)`` (pixels
        from the top left, (m,)) of ``pin`` (a :class:`~blockhash.scene.camera.Pinhole`), the
        rays made on the device as :meth:`~blockhash.scene.camera.Pinhole.lens_rays` makes
        them (``lens``: its (m, 2) uniforms, None for a pinhole), :data:`CHUNK` rays a launch:
        (points (a miss: one unit along its ray), normals facing the camera, objects (-1: a
        miss), met the face's outer side, the rays' origins (None for a pinhole))."""
        m = len(x)
        out = (np.empty((m, 3), np.float32), np.empty((m, 3), np.float32),
               np.empty(m, np.int32), np.empty(m, bool),
               np.empty((m, 3)) if lens is not None else None)
        for start in range(0, m, CHUNK):
            s = slice(start, start + CHUNK)
            self._film_chunk(pin, x[s], y[s], None if lens is None else lens[s],
                             [None if column is None else column[s] for column in out])
        return out

    def _film_chunk(self, pin, x, y, lens, out):
        """:meth:`film_hits` of one launch, written into ``out`` (its columns' slices)."""
        mi, dr = self.device.modules()
        n = len(x)
        # The camera's numbers as opaque values, not literals: one kernel for every camera
        # (literals would compile a kernel again for each frame of a moving camera).
        one = lambda c: dr.opaque(mi.Float, float(c))  # noqa: E731
        vec = lambda a: mi.Vector3f(*(one(c) for c in a))  # noqa: E731
        right, up, forward, eye = vec(pin.right), vec(pin.up), vec(pin.forward), vec(pin.eye)
        cx, cy, tan_x, tan_y = (one(c) for c in (pin.cx, pin.cy, pin.tan_x, pin.tan_y))
        sx = cx + (2.0 * floats(mi, x) / one(pin.width) - 1.0) * tan_x
        sy = cy + (1.0 - 2.0 * floats(mi, y) / one(pin.height)) * tan_y
        d = dr.normalize(forward + sx * right + sy * up)
        o = mi.Point3f(eye)
        if lens is not None:  # Shirley and Chiu's concentric map, as Pinhole.lens_rays
            u0, u1 = floats(mi, lens[:, 0]), floats(mi, lens[:, 1])
            big = dr.abs(u0) > dr.abs(u1)
            r = dr.select(big, u0, u1)
            phi = dr.select(big, (dr.pi / 4) * u1 / dr.select(u0 == 0, 1.0, u0),
                            dr.pi / 2 - (dr.pi / 4) * u0 / dr.select(u1 == 0, 1.0, u1))
            phi = dr.select((u0 == 0) & (u1 == 0), 0.0, phi)
            o = mi.Point3f(eye + one(pin.aperture) * r * (dr.cos(phi) * right + dr.sin(phi) * up))
            focus = eye + d * (one(pin.focus) / dr.dot(d, forward))
            d = dr.normalize(focus - o)
        geo = self.geometry
        hit, face, u, v = geo.intersect(o, d, dr.full(mi.Bool, True, n))
        p, ns, _, outer = geo.hit_frame(face, u, v, d, hit)
        ns = dr.select(dr.dot(ns, d) > 0.0, -ns, ns)
        p = dr.select(hit, p, o + d)
        ns = dr.select(hit, ns, mi.Vector3f(0.0))
        obj = dr.select(hit, mi.Int32(dr.gather(mi.UInt32, geo.face_object, face, hit)), -1)
        columns = [dr.ravel(p), dr.ravel(ns), obj, outer & hit]
        if lens is not None:
            columns.append(dr.ravel(o))
        dr.eval(columns)
        del o, d, p, ns, hit, face, u, v, outer, obj
        for column, values in zip(out, columns):  # copied out before the arrays are let go
            column[...] = np.asarray(values).reshape(column.shape)
        del columns
        dr.flush_malloc_cache()

    def occluded(self, origins, dirs, tmax) -> np.ndarray:
        """(n,) bool: each ray meets a surface before ``tmax`` (an any-hit query)."""
        mi, dr = self.device.modules()
        n = len(origins)
        if n == 0:
            return np.zeros(0, bool)
        o, d = self._rays(origins, dirs)
        t = floats(mi, tmax)
        ray = mi.Ray3f(o, d)
        ray.maxt = t
        blocked = self.geometry.scene.ray_test(ray, dr.full(mi.Bool, True, n))
        out = np.array(blocked, dtype=bool)
        del o, d, t, ray, blocked
        dr.flush_malloc_cache()
        return out
