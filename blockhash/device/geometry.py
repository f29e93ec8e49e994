"""A scene's triangles and materials as device arrays: the same tables as
:class:`blockhash.scene.raycast.EmbreeGeometry` (which it is built from), in float32, and a
Mitsuba scene over the same triangles for the ray casts (Embree on the CPU, OptiX on a GPU).

Each object with triangles is one Mitsuba mesh; a hit's global face is its mesh's first face
(:attr:`DeviceGeometry.face_offset`, gathered by the shape's registry id) plus Mitsuba's
primitive index, which indexes the tables as embree's face does on the host.  The kernels read
the hit point and normals from the tables (:meth:`DeviceGeometry.hit_frame`), as the host's
:func:`blockhash.scene.raycast.hit_frame` does, so that both follow one definition.
"""

from __future__ import annotations

import numpy as np

from blockhash.device.arrays import floats, uints
from blockhash.scene.raycast import RAY_OFFSET

#: Object kinds in :attr:`DeviceGeometry.kind`.
DIFFUSE, MIRROR, GLASS = 0, 1, 2
#: A shading normal shorter than this (the vertex normals cancel) falls back to the face's.
NORMAL_EPS = 1e-12


class DeviceGeometry:
    """``geometry``'s (an :class:`~blockhash.scene.raycast.EmbreeGeometry`) tables and a
    Mitsuba scene of its triangles on ``device`` (:class:`blockhash.device.choice.Device`)."""

    @classmethod
    def of(cls, geometry, device) -> "DeviceGeometry":
        """``geometry``'s copy on ``device``, built once (the caustic and the indirect tracers
        of a render, and the frames that keep its objects, share it)."""
        copies = geometry.__dict__.setdefault("device_copies", {})
        if device.variant not in copies:
            copies[device.variant] = cls(geometry, device)
        return copies[device.variant]

    @staticmethod
    def move(old, new) -> None:
        """Hand ``old``'s device copies to ``new`` (an EmbreeGeometry of the same meshes, some
        placed elsewhere: a frame whose objects moved), each updated in place: the moved
        meshes' vertices given to the device's scene, which updates its acceleration
        structure, and the tables read again.  ``old``'s copies are ``new``'s from then on;
        copies of other meshes (another face count) are left to be built when asked."""
        if not np.array_equal(old.face_offset, new.face_offset):
            return
        copies = getattr(old, "device_copies", {})
        for copy in copies.values():
            copy._moved(old, new)
        new.__dict__["device_copies"] = copies
        old.__dict__["device_copies"] = {}

    def _moved(self, old, new) -> None:
        mi = self.mi
        params = mi.traverse(self.scene)
        offsets = new.face_offset
        for g in range(len(offsets) - 1):
            first, last = int(offsets[g]), int(offsets[g + 1])
            if not np.array_equal(old.triangles[first:last], new.triangles[first:last]):
                tri = np.asarray(new.triangles[first:last], dtype=np.float32)
                params[f"g{g}.vertex_positions"] = mi.Float(tri.reshape(-1))
        params.update()
        self._tables(new)

    def __init__(self, geometry, device):
        self.device = device
        mi, dr = self.mi, self.dr = device.modules()
        tri = np.asarray(geometry.triangles, dtype=np.float32)
        shapes = {}
        offsets = geometry.face_offset
        for g in range(len(offsets) - 1):
            first, last = int(offsets[g]), int(offsets[g + 1])
            n = last - first
            mesh = mi.Mesh(f"g{g}", 3 * n, n, has_vertex_normals=False,
                           has_vertex_texcoords=False)
            params = mi.traverse(mesh)
            params["vertex_positions"] = mi.Float(tri[first:last].reshape(-1))
            params["faces"] = mi.UInt32(np.arange(3 * n, dtype=np.uint32))
            params.update()
            shapes[f"g{g}"] = (mesh, first)
        self.scene = mi.load_dict({"type": "scene", **{k: m for k, (m, _) in shapes.items()}})
        # The shape registry ids Mitsuba's hits carry, to each mesh's first face.
        ids = {s.id(): int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(s))[0])
               for s in self.scene.shapes()}
        face_offset = np.zeros(max(ids.values()) + 1, dtype=np.uint32)
        for key, (_, first) in shapes.items():
            face_offset[ids[key]] = first
        self.face_offset = uints(mi, face_offset)
        self._tables(geometry)

    def _tables(self, geometry) -> None:
        """The per-face and per-object tables the kernels gather from, of ``geometry``."""
        mi = self.mi
        self.offset = float(RAY_OFFSET * geometry.scale)
        f32 = lambda a: floats(mi, a)  # noqa: E731
        self.triangles = f32(geometry.triangles)
        self.vertex_normals = f32(geometry.vertex_normals)
        self.face_normals = f32(geometry.face_normals)
        self.face_object = uints(mi, geometry.face_object)
        self.kind = uints(mi, np.where(geometry.is_dielectric, GLASS,
                                       np.where(geometry.is_specular, MIRROR, DIFFUSE)))
        self.one_sided = uints(mi, geometry.one_sided)
        self.reflectance = f32(geometry.reflectance)
        self.any_conductor = bool(np.any(geometry.conductor))
        self.conductor = uints(mi, geometry.conductor)
        self.eta = f32(geometry.eta)
        self.k = f32(geometry.k)
        self.tint = f32(geometry.tint)
        self.ior = f32(geometry.ior)
        self.any_glass = bool(np.any(geometry.is_dielectric))
        self.alpha = f32(geometry.alpha)
        self.ggx = uints(mi, geometry.ggx)
        self.any_rough = bool(np.any(geometry.alpha > 0.0))
        self.coat = f32(geometry.coat)
        self.coat_reflectance = f32(geometry.coat_reflectance)
        self.any_coat = bool(np.any(geometry.coat > 0.0))
        self.coat_table = f32(geometry.coat_table)  # a rough coat's (blockhash.scene.coat)
        self.any_rough_coat = bool(np.any((geometry.coat > 0.0) & (geometry.alpha > 0.0)))

    def intersect(self, o, d, active):
        """(hit, global face) of the rays ``o + t d`` (Mitsuba's preliminary intersection:
        no surface interaction is built) and their barycentrics (u, v)."""
        mi, dr = self.mi, self.dr
        pi = self.scene.ray_intersect_preliminary(mi.Ray3f(o, d), active=active)
        hit = active & pi.is_valid()
        shape = dr.reinterpret_array(mi.UInt32, pi.shape)
        face = dr.gather(mi.UInt32, self.face_offset, shape, hit) + pi.prim_index
        return hit, face, pi.prim_uv.x, pi.prim_uv.y

    def hit_frame(self, face, u, v, d, active):
        """(point, shading normal, geometric normal, met from outside): both normals facing
        the ray along ``d``; a shading normal that cancels is the face's."""
        mi, dr = self.mi, self.dr
        b0 = 1.0 - u - v

        def corner(table, c):
            return dr.gather(mi.Vector3f, table, face * 3 + c, active)

        fn = dr.gather(mi.Vector3f, self.face_normals, face, active)
        cos = dr.dot(d, fn)
        outer = cos < 0.0
        s = dr.select(cos > 0.0, -1.0, 1.0)
        p = b0 * corner(self.triangles, 0) + u * corner(self.triangles, 1) + v * corner(self.triangles, 2)
        n = (b0 * corner(self.vertex_normals, 0) + u * corner(self.vertex_normals, 1)
             + v * corner(self.vertex_normals, 2))
        length = dr.norm(n)
        flat = length < NORMAL_EPS
        n = dr.select(flat, fn, n / dr.select(flat, 1.0, length))
        return mi.Point3f(p), n * s, fn * s, outer
