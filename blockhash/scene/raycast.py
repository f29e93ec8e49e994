"""Ray casting through embree: one scene of every mesh, first hits, hit geometry.

Photon tracing (:mod:`blockhash.photons.tracing`) and shading (:mod:`blockhash.frame.shading`) both cast rays
against the same meshes; this module holds what they share.  ``EmbreeScene.run``
is called directly (trimesh's wrappers are 2-3x slower, and trimesh
silently falls back to a pure-numpy caster when embreex is missing).
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.scene import coat_tables

#: Ray origins leaving a mirror move this far along its geometric normal, relative
#: to the scene's bounding-box diagonal.  embree works in float32 (ulp 2.4e-7 at 2 m);
#: 1e-5 of a 4 m scene is 4e-5 m, ~170 ulps, still 750x thinner than the ring wall.
RAY_OFFSET = 1e-5


def reflect(d: np.ndarray, n: np.ndarray) -> np.ndarray:
    """(n, 3) mirror reflection of directions ``d`` about unit normals ``n``."""
    return d - 2.0 * np.sum(d * n, axis=1, keepdims=True) * n


class EmbreeGeometry:
    """All meshes of a scene in one embree scene, with per-triangle lookup tables.

    embree numbers the meshes (geomID) 0, 1, ... in the order they are added and
    the triangles (primID) within each; ``face_offset[geomID] + primID`` indexes the
    concatenated float64 tables.  At least one mesh must have triangles.
    """

    def __init__(self, objects):
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        self.embree = rtcore_scene.EmbreeScene()
        self._keep = []  # TriangleMesh objects must outlive the scene
        geom_faces, tri, vnrm, fnrm, fobj = [], [], [], [], []
        self.is_specular = np.array([o.is_specular for o in objects], dtype=bool)
        #: per object: a dielectric, its index of refraction (1 elsewhere) and tint
        self.is_dielectric = np.array([o.is_dielectric for o in objects], dtype=bool)
        self.ior = np.array([getattr(o.material, "ior", 1.0) for o in objects], dtype=np.float64)
        self.tint = np.array([getattr(o.material, "tint", np.ones(3)) for o in objects],
                             dtype=np.float64).reshape(len(objects), 3)
        self.reflectance = np.zeros((len(objects), 3))
        #: per object: a conductor (a mirror whose reflectance is Fresnel's of its complex
        #: index eta + i k, MirrorMaterial.eta and .k; 0 elsewhere)
        self.conductor = np.array([bool(getattr(o.material, "is_conductor", False))
                                   for o in objects], dtype=bool)
        self.eta = np.zeros((len(objects), 3))
        self.k = np.zeros((len(objects), 3))
        #: per object: a receiver that reflects on its front face only (PhongMaterial.sided)
        self.one_sided = np.array([bool(getattr(o.material, "one_sided", False)) for o in objects],
                                  dtype=bool)
        #: the textured receivers' textures (PhongMaterial.texture), and per object the index
        #: of its texture in it (-1: none); per face its corners' texture coordinates
        self.textures = []
        self.texture_of = np.full(len(objects), -1, dtype=np.int64)
        face_uv = []
        all_vertices = []
        for i, obj in enumerate(objects):
            texture = getattr(obj.material, "texture", None)
            if texture is not None and len(obj.mesh.faces):
                self.texture_of[i] = len(self.textures)
                self.textures.append(texture)
            if self.is_specular[i] and not self.is_dielectric[i]:
                self.reflectance[i] = np.asarray(obj.material.reflectance, dtype=np.float64)
                if self.conductor[i]:
                    self.eta[i], self.k[i] = obj.material.eta, obj.material.k
            mesh = obj.mesh
            faces = np.asarray(mesh.faces, dtype=np.int64)
            if len(faces) == 0:
                continue
            verts = np.asarray(mesh.vertices, dtype=np.float64)
            all_vertices.append(verts)
            self._keep.append(TriangleMesh(scene=self.embree,
                                           vertices=np.ascontiguousarray(verts, dtype=np.float32),
                                           indices=np.ascontiguousarray(faces, dtype=np.int32)))
            geom_faces.append(len(faces))
            tri.append(verts[faces])
            vnrm.append(np.asarray(mesh.vertex_normals, dtype=np.float64)[faces])
            fnrm.append(np.asarray(mesh.face_normals, dtype=np.float64))
            fobj.append(np.full(len(faces), i, dtype=np.int64))
            face_uv.append(np.asarray(obj.uv, dtype=np.float64)[faces] if texture is not None
                           else np.zeros((len(faces), 3, 2)))
        # geomIDs are assigned 0, 1, ... in creation order
        self.face_offset = np.concatenate([[0], np.cumsum(geom_faces)]).astype(np.int64)
        self.triangles = np.concatenate(tri)
        self.vertex_normals = np.concatenate(vnrm)
        self.face_normals = np.concatenate(fnrm)
        self.face_object = np.concatenate(fobj)
        self.face_uv = np.concatenate(face_uv)
        allv = np.concatenate(all_vertices)
        self.scale = float(np.linalg.norm(allv.max(axis=0) - allv.min(axis=0))) or 1.0
        #: per object, the microfacet roughness of a rough mirror or glass (0: smooth) and its
        #: distribution (0 Beckmann, 1 GGX: :mod:`blockhash.scene.microfacet`)
        self.alpha = np.array([float(getattr(o.material, "alpha", 0.0)) for o in objects])
        self.ggx = np.array([getattr(o.material, "distribution", "") == "ggx" for o in objects])
        #: per object, a coated receiver's coat: its index (0: none) and reflectance
        #: (PhongMaterial.coat, :mod:`blockhash.scene.coat`)
        self.coat = np.array([float(getattr(o.material, "coat", 0.0)) for o in objects])
        self.coat_reflectance = np.array(
            [getattr(o.material, "coat_reflectance", np.ones(3)) for o in objects],
            dtype=np.float64).reshape(len(objects), 3)
        self.coat_table = np.zeros((len(objects), coat_tables.NODES))
        for i in np.flatnonzero(self.coat > 0.0):
            # a coat reflects as a conductor of its index and k = 0 (smooth or rough)
            self.reflectance[i], self.eta[i], self.k[i] = self.coat_reflectance[i], self.coat[i], 0.0
            self.conductor[i] = True
            if self.alpha[i] > 0.0:
                self.coat_table[i] = coat_tables.rough_tables(self.coat[i], self.alpha[i],
                                                              bool(self.ggx[i]))[0]
        #: per object, the table the compiled events read (:func:`blockhash.photons.bounce.
        #: _event`): reflectance, eta, k, conductor (0 or 1), roughness and distribution of
        #: the specular ones and of a coat's reflection, the coat (index, reflectance) of a coated
        #: receiver, and a rough coat's transmittance (:data:`blockhash.scene.coat.COAT_TABLE`)
        self.mirror = np.ascontiguousarray(np.column_stack(
            [self.reflectance, self.eta, self.k, self.conductor.astype(np.float64), self.alpha,
             self.ggx.astype(np.float64), self.coat, self.coat_reflectance, self.coat_table]))

    @property
    def casts(self) -> np.ndarray:
        """(objects,) bool: the object casts caustics (a mirror, glass or a coated receiver)."""
        return self.is_specular | (self.coat > 0.0)

    @property
    def draws(self) -> bool:
        """Its specular events draw uniforms (it holds glass, a rough mirror or a coat)."""
        return bool(self.is_dielectric.any() or (self.alpha > 0.0).any()
                    or (self.coat > 0.0).any())

    def intersect(self, origins: np.ndarray, dirs: np.ndarray):
        """First hits: (hit mask (n,), global face (m,), u (m,), v (m,)) for the hit rays."""
        res = self.embree.run(np.ascontiguousarray(origins, dtype=np.float32),
                              np.ascontiguousarray(dirs, dtype=np.float32), output=1)
        geom = res["geomID"]
        hit = (geom >= 0) & np.isfinite(res["tfar"]) & (res["primID"] >= 0)
        face = self.face_offset[geom[hit]] + res["primID"][hit].astype(np.int64)
        return hit, face, res["u"][hit].astype(np.float64), res["v"][hit].astype(np.float64)


    def albedo(self, face, u, v) -> tuple[np.ndarray, np.ndarray]:
        """(textured (m,) bool, (m, 3) the texture's value there) at hits on ``face`` with
        barycentrics ``u``, ``v``: the reflectance of a textured receiver
        (:mod:`blockhash.scene.texture`), zeros where the object has no texture."""
        face = np.asarray(face, dtype=np.int64)
        which = self.texture_of[self.face_object[face]]
        out = np.zeros((len(face), 3))
        for t in np.unique(which[which >= 0]):
            rows = np.flatnonzero(which == t)
            b = np.stack([1.0 - u[rows] - v[rows], u[rows], v[rows]], axis=1)
            uv = np.einsum("ij,ijk->ik", b, self.face_uv[face[rows]])
            out[rows] = self.textures[t].value(uv)
        return which >= 0, out

    def occluded(self, origins: np.ndarray, dirs: np.ndarray, tmax: np.ndarray) -> np.ndarray:
        """(n,) bool: each ray meets a surface before ``tmax`` (embree's occlusion query,
        which stops at any hit and computes no hit record)."""
        res = self.embree.run(np.ascontiguousarray(origins, dtype=np.float32),
                              np.ascontiguousarray(dirs, dtype=np.float32),
                              dists=np.ascontiguousarray(tmax, dtype=np.float32), query="OCCLUDED")
        return np.asarray(res) != -1


def entering(geom: EmbreeGeometry, face, d) -> np.ndarray:
    """(m,) bool: rays ``d`` meet ``face`` from its outer side (against its face normal;
    a closed mesh's faces point outward)."""
    return np.einsum("ij,ij->i", d, geom.face_normals[face]) < 0.0


def surface_hits(geom: EmbreeGeometry, face, u, v, d):
    """Hit points, shading normals and geometric normals (each (m, 3)) of hits on ``face``.

    Points and shading normals interpolate with embree's barycentrics
    (``p = (1-u-v) v0 + u v1 + v v2``); both normals are flipped to face the side
    the photon came from (which face was met is :func:`entering`'s question; a one-sided
    receiver's back face is its callers' to refuse); a shading normal that
    cancels falls back to the face normal.  One pass per hit (numba), no temporaries.
    """
    face = np.ascontiguousarray(face, dtype=np.int64)
    m = len(face)
    p, ns, ng = np.empty((m, 3)), np.empty((m, 3)), np.empty((m, 3))
    _surface_hits(geom.triangles, geom.vertex_normals, geom.face_normals, face,
                  np.ascontiguousarray(u, dtype=np.float64), np.ascontiguousarray(v, dtype=np.float64),
                  np.ascontiguousarray(d, dtype=np.float64), p, ns, ng)
    return p, ns, ng


@numba.njit(cache=True, nogil=True, inline="always")
def hit_frame(tri, vn, fn, f, u, v, d0, d1, d2):
    """One hit on face ``f`` (barycentrics ``u``, ``v``) of a ray along (d0, d1, d2): the
    point, the shading normal and the geometric normal, both facing the ray (9 scalars)."""
    b0, b1, b2 = 1.0 - u - v, u, v
    g0, g1, g2 = fn[f, 0], fn[f, 1], fn[f, 2]
    s = -1.0 if (d0 * g0 + d1 * g1) + d2 * g2 > 0.0 else 1.0
    p0 = (b0 * tri[f, 0, 0] + b1 * tri[f, 1, 0]) + b2 * tri[f, 2, 0]
    p1 = (b0 * tri[f, 0, 1] + b1 * tri[f, 1, 1]) + b2 * tri[f, 2, 1]
    p2 = (b0 * tri[f, 0, 2] + b1 * tri[f, 1, 2]) + b2 * tri[f, 2, 2]
    n0 = (b0 * vn[f, 0, 0] + b1 * vn[f, 1, 0]) + b2 * vn[f, 2, 0]
    n1 = (b0 * vn[f, 0, 1] + b1 * vn[f, 1, 1]) + b2 * vn[f, 2, 1]
    n2 = (b0 * vn[f, 0, 2] + b1 * vn[f, 1, 2]) + b2 * vn[f, 2, 2]
    length = np.sqrt((n0 * n0 + n1 * n1) + n2 * n2)
    if length < 1e-12:
        n0, n1, n2, length = g0, g1, g2, 1.0
    k = s / length
    return p0, p1, p2, n0 * k, n1 * k, n2 * k, g0 * s, g1 * s, g2 * s


@numba.njit(cache=True, nogil=True)
def _surface_hits(tri, vn, fn, face, u, v, d, p, ns, ng):
    # Serial, and scalars only: a few dozen flops a hit are less than the threads' start and
    # join (with the cores shared, parallel=True made this kernel 40% of the photon tracing),
    # and an array made per hit (np.empty(3)) would be a heap allocation per iteration.
    for i in range(len(face)):
        (p[i, 0], p[i, 1], p[i, 2], ns[i, 0], ns[i, 1], ns[i, 2], ng[i, 0], ng[i, 1],
         ng[i, 2]) = hit_frame(tri, vn, fn, face[i], u[i], v[i], d[i, 0], d[i, 1], d[i, 2])
