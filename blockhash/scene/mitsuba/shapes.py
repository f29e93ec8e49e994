"""The meshes of Mitsuba 3's shapes, as Mitsuba places them (for :mod:`.importer`): ``ply``,
``obj`` and ``serialized`` (:mod:`.serialized`, ``shape_index``) files (found as :meth:`.xml_values.XmlReader.resolve` looks), ``rectangle`` ([-1, 1]^2
in z = 0, facing +z), ``disk`` (the unit disk there) and ``cylinder`` (``p0``, ``p1``,
``radius``: the open tube, facing outward), each tessellated with the analytic shape's area
(:func:`blockhash.scene.meshes.disk`, :func:`~blockhash.scene.meshes.cylinder`), ``sphere``
(an icosphere) and ``cube`` ([-1, 1]^3); then ``flip_normals`` and ``to_world``.
"""

from __future__ import annotations

import numpy as np
import trimesh

from blockhash.errors import InputError
from blockhash.scene import meshes
from blockhash.scene.mitsuba.serialized import read_serialized

SHAPES = ("ply", "obj", "serialized", "rectangle", "disk", "cylinder", "sphere", "cube")
_FILE = {"filename": ("string",), "face_normals": ("boolean",)}
#: Each shape's own properties (beside to_world and flip_normals), as Mitsuba names them.
PROPERTIES = {"ply": _FILE, "obj": _FILE, "serialized": {**_FILE, "shape_index": ("integer",)},
              "sphere": {"center": ("point",), "radius": ("float",)},
              "cylinder": {"p0": ("point",), "p1": ("point",), "radius": ("float",)}}


def shape_mesh(r, el, kind: str, p: dict) -> trimesh.Trimesh:
    """The mesh of a ``<shape>`` of ``kind`` with properties ``p`` (read by ``r``, an
    :class:`.xml_values.XmlReader`), in world space."""
    if kind in ("ply", "obj", "serialized"):
        if "filename" not in p:
            r.fail(el, "missing <string name=\"filename\">")
        full = r.resolve(el, p["filename"], "mesh file")
        try:
            if kind == "serialized":
                vertices, faces, normals, flat = read_serialized(full, p.get("shape_index", 0))
                mesh = meshes.mesh_from_arrays(vertices, faces, normals,
                                               "flat" if flat or p.get("face_normals") else "auto",
                                               f"{full} (shape_index {p.get('shape_index', 0)})")
            else:
                mesh = meshes.load_mesh(full, normals="flat" if p.get("face_normals") else "auto")
        except InputError as exc:
            r.fail(el, str(exc))
    elif kind == "rectangle":
        v = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]])
        mesh = meshes.with_normals(v, [[0, 1, 2], [0, 2, 3]], np.tile([0.0, 0.0, 1.0], (4, 1)))
    elif kind == "disk":
        mesh = meshes.disk()
    elif kind == "cylinder":
        try:
            mesh = meshes.cylinder(p.get("p0", np.zeros(3)), p.get("p1", np.array([0.0, 0.0, 1.0])),
                                   p.get("radius", 1.0))
        except InputError as exc:
            r.fail(el, str(exc))
    elif kind == "cube":
        box = trimesh.creation.box(extents=(2.0, 2.0, 2.0))
        box.unmerge_vertices()
        mesh = meshes.with_normals(box.vertices, box.faces, np.repeat(box.face_normals, 3, axis=0))
    else:
        radius = p.get("radius", 1.0)
        if not radius > 0:
            r.fail(el, f"radius {radius:g}: a sphere's radius must be > 0; give a "
                      "positive <float name=\"radius\"> (flip_normals turns it inside out)")
        try:
            mesh = meshes.sphere(center=p.get("center", np.zeros(3)), radius=radius)
        except InputError as exc:
            r.fail(el, str(exc))
    if p.get("flip_normals"):
        mesh = meshes.with_normals(mesh.vertices, mesh.faces[:, ::-1], -mesh.vertex_normals)
    return placed(r, el, mesh, p.get("to_world"))

def placed(r, el, mesh: trimesh.Trimesh, m) -> trimesh.Trimesh:
    """``mesh`` under the ``to_world`` matrix ``m`` (None: as it is), normals with it."""
    if m is None:
        return mesh
    if not abs(np.linalg.det(m[:3, :3])) > 0:
        r.fail(el, "the to_world transform is singular (a scale of 0?); fix it")
    normal = np.linalg.inv(m[:3, :3]).T
    return meshes.with_normals(trimesh.transform_points(mesh.vertices, m), mesh.faces,
                               np.asarray(mesh.vertex_normals) @ normal.T)
