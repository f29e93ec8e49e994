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
#: Mitsuba's rectangle, [-1, 1]^2 in z = 0 facing +z.
RECTANGLE = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]])
RECTANGLE_FACES = np.array([[0, 1, 2], [0, 2, 3]])
#: Each shape's own properties (beside to_world and flip_normals), as Mitsuba names them.
PROPERTIES = {"ply": _FILE, "obj": _FILE, "serialized": {**_FILE, "shape_index": ("integer",)},
              "sphere": {"center": ("point",), "radius": ("float",)},
              "cylinder": {"p0": ("point",), "p1": ("point",), "radius": ("float",)}}


def shape_mesh(r, el, kind: str, p: dict) -> trimesh.Trimesh:
    """The mesh of a ``<shape>`` of ``kind`` with properties ``p`` (read by ``r``, an
    :class:`.xml_values.XmlReader`), in world space."""
    if kind in ("ply", "obj", "serialized"):
        vertices, faces, normals, flat, _, what = _file_arrays(r, el, kind, p)
        try:
            mesh = meshes.mesh_from_arrays(vertices, faces, normals, "flat" if flat else "auto",
                                           what)
        except InputError as exc:
            r.fail(el, str(exc))
    elif kind == "rectangle":
        mesh = meshes.with_normals(RECTANGLE, RECTANGLE_FACES, np.tile([0.0, 0.0, 1.0], (4, 1)))
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

#: The shapes whose texture coordinates a checkerboard may be cut by (:mod:`.textures`).
TEXTURED = ("rectangle", "obj", "ply", "serialized")


def textured_meshes(r, el, kind: str, p: dict, checker) -> tuple:
    """(mesh of ``color0``, mesh of ``color1``) of a ``<shape>`` whose diffuse reflectance is
    the :class:`.textures.Checkerboard` ``checker``, in world space; None for a colour the
    shape does not show."""
    from blockhash.scene.mitsuba.textures import split

    if kind not in TEXTURED:
        r.fail(el, f"a checkerboard on a {kind}: blockhash cuts a textured shape along its "
               f"texture coordinates, which it reads from {', '.join(TEXTURED)} shapes; give "
               "this shape a plain colour")
    vertices, faces, normals, uv = _raw(r, el, kind, p)
    out = []
    for tri, bary in split(faces, uv, checker):
        if not len(tri):
            out.append(None)
            continue
        corners = faces[tri]  # (k, 3)
        pos = np.einsum("kij,kjd->kid", bary, vertices[corners]).reshape(-1, 3)
        nrm = np.einsum("kij,kjd->kid", bary, normals[corners]).reshape(-1, 3)
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
        f = np.arange(len(pos)).reshape(-1, 3)
        if p.get("flip_normals"):
            f, nrm = f[:, ::-1], -nrm
        out.append(placed(r, el, meshes.with_normals(pos, f, nrm), p.get("to_world")))
    return tuple(out)


def uv_mesh(r, el, kind: str, p: dict) -> tuple:
    """(mesh in world space, its (vertices, 2) texture coordinates) of a ``<shape>`` whose
    reflectance is a bitmap (:class:`blockhash.scene.texture.Texture`): vertices not merged,
    so a texture seam keeps both sides' coordinates."""
    if kind not in TEXTURED:
        r.fail(el, f"a bitmap texture on a {kind}: blockhash reads texture coordinates from "
               f"{', '.join(TEXTURED)} shapes; give this shape a plain colour, or export it "
               "as a mesh with its texture coordinates")
    vertices, faces, normals, uv = _raw(r, el, kind, p)
    if p.get("flip_normals"):
        faces, normals = faces[:, ::-1], -normals
    return placed(r, el, meshes.with_normals(vertices, faces, normals), p.get("to_world")), uv


def _raw(r, el, kind: str, p: dict):
    """(vertices, faces, per-vertex normals, texture coordinates) of a textured shape as its
    file or Mitsuba's parametrisation gives them, vertices not merged (texture seams kept)."""
    if kind == "rectangle":  # Mitsuba's texture coordinates: (x / 2 + 1/2, y / 2 + 1/2)
        return (RECTANGLE, RECTANGLE_FACES, np.tile([0.0, 0.0, 1.0], (4, 1)),
                RECTANGLE[:, :2] * 0.5 + 0.5)
    vertices, faces, normals, flat, uv, _ = _file_arrays(r, el, kind, p)
    if uv is None:  # Mitsuba's texture coordinates of a mesh without them: (0, 0)
        uv = np.zeros((len(vertices), 2))
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False, validate=False)
    if flat:  # every face its own corners, with its normal
        corners = faces.reshape(-1)
        return (vertices[corners], np.arange(len(corners)).reshape(-1, 3),
                np.repeat(mesh.face_normals, 3, axis=0), uv[corners])
    return vertices, faces, (normals if normals is not None else mesh.vertex_normals), uv


def _file_arrays(r, el, kind: str, p: dict):
    """(vertices, faces, the file's vertex normals or None, flat (face normals asked or
    stored), texture coordinates as Mitsuba reads them or None, the file's name for errors) of
    a ``ply``, ``obj`` or ``serialized`` shape, vertices not merged."""
    if "filename" not in p:
        r.fail(el, "missing <string name=\"filename\">")
    full = r.resolve(el, p["filename"], "mesh file")
    flat = bool(p.get("face_normals"))
    try:
        if kind == "serialized":
            index = p.get("shape_index", 0)
            vertices, faces, normals, flat_file, uv = read_serialized(full, index)
            return vertices, faces, normals, flat or flat_file, uv, f"{full} (shape_index {index})"
        vertices, faces, normals, uv = meshes.mesh_arrays(full)
    except InputError as exc:
        r.fail(el, str(exc))
    if uv is not None and kind == "obj":  # Mitsuba's OBJ loader flips v
        uv = uv * [1.0, -1.0] + [0.0, 1.0]
    return vertices, faces, normals, flat, uv, f"the mesh file {str(full)!r}"


def placed(r, el, mesh: trimesh.Trimesh, m) -> trimesh.Trimesh:
    """``mesh`` under the ``to_world`` matrix ``m`` (None: as it is), normals with it."""
    if m is None:
        return mesh
    if not abs(np.linalg.det(m[:3, :3])) > 0:
        r.fail(el, "the to_world transform is singular (a scale of 0?); fix it")
    normal = np.linalg.inv(m[:3, :3]).T
    return meshes.with_normals(trimesh.transform_points(mesh.vertices, m), mesh.faces,
                               np.asarray(mesh.vertex_normals) @ normal.T)
