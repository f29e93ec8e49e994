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

#: The shapes whose texture coordinates a texture is read at (:mod:`.textures`).
TEXTURED = ("rectangle", "obj", "ply", "serialized", "sphere", "disk", "cylinder")


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
    if kind in ("sphere", "disk", "cylinder"):
        return _parametrised(r, el, kind, p)
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


def _parametrised(r, el, kind: str, p: dict):
    """(vertices, faces, normals, texture coordinates) of Mitsuba's analytic ``sphere``
    (u = phi / 2 pi about its z axis, v = theta / pi from +z), ``disk`` (u = the radius,
    v = phi / 2 pi) or ``cylinder`` (u = phi / 2 pi about the axis in Mitsuba's frame of it,
    v = the height along it over its length), at each corner of the tessellated shape: every
    triangle its own corners, one that crosses phi = 0 taking phi + 2 pi on its small side,
    and a pole's or the centre's corner (no phi of its own) its triangle's other two's mean.
    Linear over each triangle, as the mesh's coordinates are."""
    if kind == "sphere":
        center, radius = p.get("center", np.zeros(3)), p.get("radius", 1.0)
        mesh = shape_mesh(r, el, kind, {k: v for k, v in p.items() if k in ("center", "radius")})
        local = (np.asarray(mesh.vertices) - center) / radius
        phi, other = _phi(local[:, 0], local[:, 1]), np.arccos(np.clip(local[:, 2], -1, 1)) / np.pi
        undefined = np.hypot(local[:, 0], local[:, 1]) < 1e-9
    elif kind == "disk":
        mesh = meshes.disk()
        local = np.asarray(mesh.vertices)
        phi, other = _phi(local[:, 0], local[:, 1]), np.hypot(local[:, 0], local[:, 1])
        undefined = other < 1e-12
    else:
        p0, p1 = p.get("p0", np.zeros(3)), p.get("p1", np.array([0.0, 0.0, 1.0]))
        mesh = shape_mesh(r, el, kind, {k: v for k, v in p.items() if k in ("p0", "p1", "radius")})
        axis = np.asarray(p1, np.float64) - p0
        length = float(np.linalg.norm(axis))
        s_, t_ = _mitsuba_frame(axis / length)
        q = np.asarray(mesh.vertices) - p0
        phi, other = _phi(q @ t_, q @ s_), (q @ axis) / length ** 2
        undefined = np.zeros(len(q), dtype=bool)
    faces = np.asarray(mesh.faces)
    corners = faces.reshape(-1)
    f_phi = phi[faces].copy()
    span = np.where(undefined[faces], np.nan, f_phi)
    wide = (np.nanmax(span, axis=1) - np.nanmin(span, axis=1)) > 0.5
    f_phi[wide] = np.where(f_phi[wide] < 0.5, f_phi[wide] + 1.0, f_phi[wide])
    hole = undefined[faces]
    if hole.any():  # a pole or the centre: its triangle's other corners' mean
        rows = np.flatnonzero(hole.any(axis=1))
        known = np.where(hole[rows], 0.0, f_phi[rows])
        mean = known.sum(axis=1) / np.maximum((~hole[rows]).sum(axis=1), 1)
        f_phi[rows] = np.where(hole[rows], mean[:, None], f_phi[rows])
    uv = np.stack([f_phi.reshape(-1), other[corners]], axis=1)
    if kind == "disk":
        uv = uv[:, ::-1]
    return (np.asarray(mesh.vertices)[corners], np.arange(len(corners)).reshape(-1, 3),
            np.asarray(mesh.vertex_normals)[corners], uv)


def _phi(x, y) -> np.ndarray:
    """atan2(y, x) / 2 pi in [0, 1), as Mitsuba's analytic shapes take their azimuth."""
    return np.mod(np.arctan2(y, x), 2.0 * np.pi) / (2.0 * np.pi)


def _mitsuba_frame(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(s, t) of Mitsuba's ``Frame3f(n)`` (Duff et al. 2017), the frame its cylinder's azimuth
    is measured in."""
    sign = 1.0 if n[2] >= 0.0 else -1.0
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    return (np.array([1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]]),
            np.array([b, sign + n[1] * n[1] * a, -n[1]]))
