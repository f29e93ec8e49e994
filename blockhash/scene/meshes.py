"""Generated meshes for the scenes: a floor rectangle, a mirror ring and a bust.

Everything is in metres, y up, right-handed.  Each function returns a
:class:`trimesh.Trimesh` built with ``process=False`` and carrying the vertex
normals to shade with in ``mesh.vertex_normals``:

``rectangle``
    Two triangles in a ``y = const`` plane, flat ``+y`` normals.
``ring``
    A cylindrical shell standing on its base plane (section 6's "Ring" scene):
    inner and outer walls with smoothly interpolated radial normals (a round
    ring, not a faceted one), a flat top rim, optionally a flat bottom.  Each
    part has its own vertices, so normals are smooth within a wall and sharp
    at the rim edges.
``bust``
    A head, neck, shoulders and chest as one closed, smooth surface with
    >= 100,000 triangles (section 6's "Venus with Ring" scene, generated
    instead of shipping a third-party mesh).

:func:`load_mesh` reads a mesh file with its normals and :func:`placed` scales,
rotates and translates a mesh together with its normals.

Do not modify a returned mesh in place (``merge_vertices``, ``fix_normals``,
``apply_transform``...): trimesh recomputes ``vertex_normals`` from the faces
when the geometry changes, which merges the ring's rim into its walls and
loses the smooth normals.  Use :func:`with_normals` to build a new mesh.

Why this module is long: the bust's profile, its neck and the normals of all three
shapes are one recipe that the scenes' normative values depend on; split up, each
piece would need the others' constants.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import trimesh
from scipy.interpolate import PchipInterpolator

from blockhash.errors import InputError

#: The bust has this many triangles at least with the default resolution.
MIN_BUST_TRIANGLES = 100_000
#: Mesh file types :func:`load_mesh` accepts, and its normal modes.
MESH_SUFFIXES = (".obj", ".ply", ".stl")
NORMAL_MODES = ("auto", "smooth", "flat")


def with_normals(vertices, faces, normals) -> trimesh.Trimesh:
    """Return a mesh of ``vertices (n, 3) float64``, ``faces (m, 3) int64``
    shaded with ``normals (n, 3)`` (normalised here), without merging or
    reordering anything (``process=False``)."""
    vertices = np.array(vertices, dtype=np.float64, order="C")      # copies: the mesh owns them
    faces = np.array(faces, dtype=np.int64, order="C")
    normals = np.array(normals, dtype=np.float64)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = normals / np.where(length > 0.0, length, 1.0)
    return trimesh.Trimesh(vertices=vertices, faces=faces, vertex_normals=normals,
                           process=False, validate=False)


def _check_positive(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value) or value <= 0.0:
        raise InputError(f"{name} must be a finite number > 0; got {value!r}")
    return value


def _check_segments(name: str, value: int, minimum: int) -> int:
    whole = (isinstance(value, numbers.Real) and not isinstance(value, bool)
             and math.isfinite(value) and float(value).is_integer())
    if not whole or value < minimum:
        raise InputError(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)


def _check_point(name: str, value) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise InputError(f"{name} must be 3 finite numbers [x, y, z]; got {value!r}")
    return arr


# --------------------------------------------------------------------------- files, placement

def load_mesh(path, *, normals: str = "auto") -> trimesh.Trimesh:
    """Read a triangle mesh file (``.obj``, ``.ply``, ``.stl``) with trimesh.

    ``normals`` : {'auto', 'smooth', 'flat'}
        ``auto`` keeps the file's vertex normals (OBJ ``vn``, PLY ``nx ny nz``)
        and makes smooth ones when it has none; ``smooth`` averages face normals
        over vertices shared by position; ``flat`` gives every face its own
        vertices and normal.

    trimesh 5.2's ``force='mesh'`` concatenates through a path that drops the
    normals a file carries, so the file is loaded as a scene and its geometries
    are concatenated here, each with its node transform.  Raises InputError
    for an unreadable file or one without triangles."""
    path = Path(path)
    if normals not in NORMAL_MODES:
        raise InputError(f"normals={normals!r} is not a normal mode; expected one of "
                         f"{', '.join(map(repr, NORMAL_MODES))}")
    vertices, faces, given, _ = mesh_arrays(path)
    return mesh_from_arrays(vertices, faces, given, normals, f"the mesh file {str(path)!r}")


def mesh_arrays(path):
    """(vertices (n, 3), faces (m, 3), the file's vertex normals or None, its texture
    coordinates (n, 2) or None) of a mesh file, its geometries concatenated with their node
    transforms and no vertex merged (:func:`load_mesh`'s reading)."""
    try:
        loaded = trimesh.load(str(path), force="scene", process=False)
    except (ValueError, KeyError, IndexError, TypeError, AttributeError, OSError,
            NotImplementedError) as exc:
        raise InputError(f"trimesh could not read {str(path)!r}: {exc}; check that the file is "
                         "a valid mesh") from None
    parts = []
    for node in loaded.graph.nodes_geometry:
        transform, name = loaded.graph[node]
        geom = loaded.geometry[name]
        if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
            continue
        from_file = "vertex_normals" in geom._cache.cache     # set by the loader, not computed
        normal_matrix = np.linalg.inv(transform[:3, :3]).T
        uv = getattr(geom.visual, "uv", None)
        parts.append((trimesh.transform_points(geom.vertices, transform), np.asarray(geom.faces),
                      geom.vertex_normals @ normal_matrix.T if from_file else None,
                      None if uv is None else np.asarray(uv, dtype=np.float64)))
    if not parts:
        raise InputError(f"the mesh file {str(path)!r} has no triangles (empty, or only points or "
                         "lines); expected a triangle mesh")
    offsets = np.cumsum([0] + [len(p[0]) for p in parts[:-1]])
    vertices = np.concatenate([p[0] for p in parts])
    faces = np.concatenate([p[1] + o for p, o in zip(parts, offsets)])

    def joined(k):
        return np.concatenate([p[k] for p in parts]) if all(p[k] is not None for p in parts) else None

    return vertices, faces, joined(2), joined(3)


def mesh_from_arrays(vertices, faces, given_normals, normals: str, what: str) -> trimesh.Trimesh:
    """A mesh of ``vertices`` and ``faces`` read from a file (``what`` names it in errors),
    shaded as :func:`load_mesh`'s ``normals`` says; ``given_normals``: the file's vertex
    normals, or None."""
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():  # before trimesh merges vertices, which casts NaN to int
        raise InputError(f"{what} has NaN or infinite vertex coordinates "
                         f"({int(bad.sum()):,} vertices, the first is vertex {int(np.argmax(bad)) + 1}); "
                         "fix the mesh")
    if len(faces) and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise InputError(f"{what} has a face with a vertex index outside 0..{len(vertices) - 1}; "
                         "fix the mesh")
    if normals == "auto" and given_normals is not None:
        return with_normals(vertices, faces, given_normals)
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False, validate=False)
    if normals == "flat":
        mesh.unmerge_vertices()
        return with_normals(mesh.vertices, mesh.faces, np.repeat(mesh.face_normals, 3, axis=0))
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    return with_normals(mesh.vertices, mesh.faces, mesh.vertex_normals)


def rotation(rotate_deg) -> np.ndarray:
    """(3, 3) rotation by ``rotate_deg = (rx, ry, rz)`` degrees about x, then y,
    then z (fixed axes): ``Rz @ Ry @ Rx``."""
    rx, ry, rz = np.radians(np.asarray(rotate_deg, dtype=np.float64))
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    mx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    my = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    mz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return mz @ my @ mx


def placed(mesh: trimesh.Trimesh, *, scale: float = 1.0, rotate_deg=(0.0, 0.0, 0.0),
           translate=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    """``mesh`` scaled (uniformly, > 0), rotated (see :func:`rotation`), then
    translated, with its vertex normals rotated alike; ``mesh`` itself when
    nothing changes."""
    scale = _check_positive("scale", scale)
    rot = rotation(_check_point("rotate_deg", rotate_deg))
    shift = _check_point("translate", translate)
    if scale == 1.0 and np.array_equal(rot, np.eye(3)) and not shift.any():
        return mesh
    vertices = (scale * np.asarray(mesh.vertices)) @ rot.T + shift
    return with_normals(vertices, mesh.faces, np.asarray(mesh.vertex_normals) @ rot.T)


# --------------------------------------------------------------------------- rectangle

def rectangle(*, x=(-1.5, 1.5), z=(-1.5, 1.5), y: float = 0.0) -> trimesh.Trimesh:
    """The rectangle ``x[0] <= x <= x[1]``, ``z[0] <= z <= z[1]`` in the plane
    ``y``, facing ``+y`` (two triangles, four vertices, flat normals)."""
    x0, x1 = (float(v) for v in x)
    z0, z1 = (float(v) for v in z)
    y = float(y)
    if not all(math.isfinite(v) for v in (x0, x1, z0, z1, y)):
        raise InputError(f"rectangle: x={list(x)}, z={list(z)}, y={y} must be finite")
    if not (x0 < x1 and z0 < z1):
        raise InputError(f"rectangle: extents must be increasing, [min, max] with min < max; "
                         f"got x={[x0, x1]}, z={[z0, z1]}")
    vertices = np.array([[x0, y, z0], [x0, y, z1], [x1, y, z1], [x1, y, z0]])
    # (v1 - v0) x (v2 - v0) = (0,0,dz) x (dx,0,dz) = +y
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    normals = np.tile([0.0, 1.0, 0.0], (4, 1))
    return with_normals(vertices, faces, normals)


# --------------------------------------------------------------------------- sphere

#: Icosphere subdivisions of a generated sphere unless given (20 * 4**s triangles); chosen
#: by measuring the glass scene's caustic against a finer sphere (BENCHMARKS.md, "Glass").
SPHERE_SUBDIVISIONS = 5


def sphere(*, center=(0.0, 0.0, 0.0), radius: float = 1.0,
           subdivisions: int = SPHERE_SUBDIVISIONS) -> trimesh.Trimesh:
    """A closed sphere: an icosahedron subdivided ``subdivisions`` times (20 * 4**s
    triangles, vertices on the sphere, faces wound outward) with the exact smooth normals
    ``(v - center) / radius``."""
    c = _check_point("sphere center", center)
    r = _check_positive("sphere radius", radius)
    s = _check_segments("sphere subdivisions", subdivisions, 0)
    if s > 8:
        raise InputError(f"sphere subdivisions must be at most 8 (1.3 M triangles); got {s}")
    ico = trimesh.creation.icosphere(subdivisions=s, radius=1.0)
    unit = np.asarray(ico.vertices, dtype=np.float64)
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    return with_normals(c + r * unit, np.asarray(ico.faces), unit)


# --------------------------------------------------------------------------- ring

#: Segments around the generated disk and cylinder (Mitsuba's analytic ``disk`` and
#: ``cylinder``): their radii are widened so that the polygon's area is the circle's.
ROUND_SEGMENTS = 256


def _area_radius(segments: int) -> float:
    """The radius of a regular ``segments``-gon whose area is that of the unit circle."""
    return math.sqrt(2.0 * math.pi / (segments * math.sin(2.0 * math.pi / segments)))


def disk(segments: int = ROUND_SEGMENTS) -> trimesh.Trimesh:
    """Mitsuba's ``disk``: the unit disk in the plane z = 0, facing +z (a fan of
    ``segments`` triangles with the disk's area)."""
    segments = _check_segments("segments", segments, 3)
    t = np.arange(segments) * (2.0 * math.pi / segments)
    rim = np.stack([np.cos(t), np.sin(t), np.zeros(segments)], axis=1) * _area_radius(segments)
    vertices = np.vstack([[0.0, 0.0, 0.0], rim])
    faces = np.stack([np.zeros(segments, np.int64), 1 + np.arange(segments),
                      1 + (np.arange(segments) + 1) % segments], axis=1)
    return with_normals(vertices, faces, np.tile([0.0, 0.0, 1.0], (segments + 1, 1)))


def cylinder(p0=(0.0, 0.0, 0.0), p1=(0.0, 0.0, 1.0), radius: float = 1.0,
             segments: int = ROUND_SEGMENTS) -> trimesh.Trimesh:
    """Mitsuba's ``cylinder``: the open tube (no caps) of ``radius`` around the axis from
    ``p0`` to ``p1``, facing outward, shaded with smooth radial normals; ``segments`` quads
    around, with the tube's area."""
    p0, p1 = _check_point("p0", p0), _check_point("p1", p1)
    radius = _check_positive("radius", radius)
    segments = _check_segments("segments", segments, 3)
    axis = p1 - p0
    length = float(np.linalg.norm(axis))
    if not length > 0.0:
        raise InputError(f"p0 = p1 = {p0.tolist()}: a cylinder's axis has no length; give "
                         "two different end points")
    w = axis / length
    u = np.cross(w, [1.0, 0.0, 0.0] if abs(w[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    t = np.arange(segments) * (2.0 * math.pi / segments)
    radial = np.cos(t)[:, None] * u + np.sin(t)[:, None] * v
    # the polygon's perimeter is the circle's, so the tube's area is the cylinder's
    rim = radial * radius * (math.pi / (segments * math.sin(math.pi / segments)))
    vertices = np.vstack([p0 + rim, p1 + rim])
    i = np.arange(segments)
    j = (i + 1) % segments
    faces = np.concatenate([np.stack([i, j, segments + j], axis=1),
                            np.stack([i, segments + j, segments + i], axis=1)])
    return with_normals(vertices, faces, np.vstack([radial, radial]))


def _annulus_faces(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Quads between vertex index rows ``a`` and ``b`` (same length, closed
    around), as triangles wound so the normal is (b - a) x (a[j+1] - a[j])."""
    a1, b1 = np.roll(a, -1), np.roll(b, -1)
    return np.concatenate([np.stack([a, b, a1], axis=1), np.stack([b, b1, a1], axis=1)])


def ring(inner_radius: float, outer_radius: float, height: float, segments: int = 256,
         center=(0.0, 0.0, 0.0), *, bottom: bool = False) -> trimesh.Trimesh:
    """A cylindrical shell, axis ``+y``, standing on the plane ``y = center[1]``.

    Parameters
    ----------
    inner_radius, outer_radius : float
        Radii of the walls, ``0 < inner_radius < outer_radius``.
    height : float
        Height of the walls above the base plane.
    segments : int
        Quads around each wall (vertex ``i`` at angle ``2 pi i / segments``
        from ``+x`` towards ``+z``).
    center : (3,) float
        Centre of the base (the axis passes through it).
    bottom : bool
        Also close the base with a flat annulus facing ``-y`` (for a ring that
        floats; a ring standing on a floor leaves it open).

    Returns a mesh whose inner wall (first ``2 * segments`` vertices) has unit
    normals towards the axis, outer wall (next ``2 * segments``) away from it,
    top rim (next ``2 * segments``) ``+y`` and bottom (last ``2 * segments``,
    when asked) ``-y``.  Faces are wound to agree with those normals.
    """
    r0 = _check_positive("ring: inner_radius", inner_radius)
    r1 = _check_positive("ring: outer_radius", outer_radius)
    h = _check_positive("ring: height", height)
    n = _check_segments("ring: segments", segments, 3)
    c = _check_point("ring: center", center)
    if r0 >= r1:
        raise InputError(f"ring: inner_radius={r0} must be < outer_radius={r1}; "
                         "swap them or make the wall thicker")
    theta = 2.0 * np.pi * np.arange(n) / n
    radial = np.stack([np.cos(theta), np.zeros(n), np.sin(theta)], axis=1)
    up = np.array([0.0, 1.0, 0.0])

    def circle(r: float, y: float) -> np.ndarray:
        return c + r * radial + y * up

    idx = np.arange(n)
    parts_v, parts_n, parts_f = [], [], []

    def add(lower: np.ndarray, upper: np.ndarray, normals: np.ndarray, flip: bool) -> None:
        base = sum(len(v) for v in parts_v)
        parts_v.append(np.concatenate([lower, upper]))
        parts_n.append(normals)
        a, b = base + idx, base + n + idx
        f = _annulus_faces(a, b)
        parts_f.append(f[:, ::-1] if flip else f)

    # (b - a) x (a[j+1] - a[j]) with b above a is (+y) x (tangent) = +radial:
    # kept for the outer wall, flipped for the inner one.
    add(circle(r0, 0.0), circle(r0, h), np.tile(-radial, (2, 1)), flip=True)
    add(circle(r1, 0.0), circle(r1, h), np.tile(radial, (2, 1)), flip=False)
    # rim: a inner, b outer: (radial) x (tangent) = -y, flipped to face +y
    add(circle(r0, h), circle(r1, h), np.tile(up, (2 * n, 1)), flip=True)
    if bottom:
        add(circle(r0, 0.0), circle(r1, 0.0), np.tile(-up, (2 * n, 1)), flip=False)
    return with_normals(np.concatenate(parts_v), np.concatenate(parts_f),
                        np.concatenate(parts_n))


# --------------------------------------------------------------------------- bust
#
# The bust is a surface of "stacked cross-sections": a meridian parameter t runs
# from a pole at the centre of the flat base, out across the base, up the chest,
# over the shoulders, up the neck and over the head to a pole at its top.  At each
# t the horizontal cross-section at height y(t) is a superellipse
#     |x / A|^p + |(z - cz) / B|^p = 1,   B = B_front for z > cz, B_back behind,
# which is round (p = 2) at the neck and head and squarer (p = 3 .. 3.6) across the
# torso and shoulders.  y(t) never decreases, so cross-sections never cross and the surface
# is closed and free of self-intersections; the profile is interpolated
# monotonically (PCHIP), so it never overshoots the control values below.

#: Control values (metres) from the base pole to the head's top pole, bottom to top:
#: y, half-width A (x), front depth B_front (+z), back depth B_back (-z),
#: superellipse exponent p, forward offset cz of the cross-section's centre.
_HEAD_CENTRE_Y, _HEAD_HALF_HEIGHT, _HEAD_CZ = 0.540, 0.120, 0.022
_HEAD_A, _HEAD_BF, _HEAD_BB = 0.078, 0.104, 0.098
_BODY = [
    # flat base (y = 0) from the pole outwards, then a rounded bottom edge
    (0.000, 0.000, 0.0000, 0.0000, 3.0, 0.0),
    (0.000, 0.085, 0.0540, 0.0470, 3.0, 0.0),
    (0.000, 0.150, 0.0950, 0.0830, 3.0, 0.0),
    (0.005, 0.168, 0.1065, 0.0930, 3.0, 0.0),
    (0.018, 0.175, 0.1110, 0.0970, 3.0, 0.0),
    # torso: the arms are cut off where they meet it; the chest is fullest at y ~ 0.18
    (0.070, 0.180, 0.1160, 0.0980, 3.0, 0.0),
    (0.130, 0.186, 0.1250, 0.1000, 3.0, 0.0),
    (0.180, 0.192, 0.1280, 0.1010, 3.2, 0.0),
    (0.230, 0.198, 0.1180, 0.1000, 3.4, 0.0),
    # shoulders; above y ~ 0.2 the chest front slopes back to the neck, facing forward and up
    (0.268, 0.202, 0.1040, 0.0960, 3.6, 0.0),
    (0.290, 0.198, 0.0940, 0.0900, 3.6, 0.0),
    (0.302, 0.186, 0.0870, 0.0850, 3.4, 0.0),
    # shoulder tops, rising about 20 degrees to the neck
    (0.311, 0.160, 0.0810, 0.0800, 3.0, 0.0),
    (0.320, 0.130, 0.0750, 0.0750, 2.6, 0.0),
    (0.330, 0.100, 0.0680, 0.0690, 2.3, 0.0),
    (0.342, 0.076, 0.0620, 0.0630, 2.0, 0.0),
    # neck, leaning slightly forward
    (0.360, 0.062, 0.0580, 0.0590, 2.0, 0.002),
    (0.385, 0.057, 0.0560, 0.0570, 2.0, 0.005),
    (0.410, 0.056, 0.0570, 0.0560, 2.0, 0.009),
    (0.428, 0.058, 0.0640, 0.0570, 2.0, 0.013),
    # under the jaw to the chin
    (0.443, 0.058, 0.0720, 0.0600, 2.0, 0.018),
]
#: The neck band (metres above the base): the bust's narrowest part, where a ring goes.
BUST_NECK_Y = (0.350, 0.425)


def _head_rows() -> list[tuple]:
    """Upper part of an ellipsoidal head, from below the jaw line to the top pole."""
    rows = []
    for phi in np.radians([-40.0, -20.0, 0.0, 20.0, 40.0, 55.0, 68.0, 79.0, 90.0]):
        s = math.cos(phi)
        rows.append((_HEAD_CENTRE_Y + _HEAD_HALF_HEIGHT * math.sin(phi), _HEAD_A * s,
                     _HEAD_BF * s, _HEAD_BB * s, 2.0, _HEAD_CZ))
    return rows


@dataclass(frozen=True)
class BustDimensions:
    """Landmarks of :func:`bust` with its base centre at the origin (metres).

    ``neck_y`` is the neck band, ``neck_radius`` the largest distance from the
    y axis of any bust vertex in that band (a ring with a larger inner radius
    clears the neck), ``chest_front_z`` the front of the chest, ``height`` the
    top of the head."""

    height: float
    neck_y: tuple[float, float]
    neck_radius: float
    shoulder_y: float
    shoulder_half_width: float
    chest_front_z: float


@lru_cache(maxsize=8)
def _bust_arrays(segments: int, rings: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(vertices, faces, normals) of the bust at the origin, read-only (cached)."""
    table = np.array(_BODY + _head_rows())
    # chord-length parameter over (y, A, B_front), then a dense, monotone profile
    chord = np.linalg.norm(np.diff(table[:, [0, 1, 2]], axis=0), axis=1)
    knots = np.concatenate([[0.0], np.cumsum(chord)])
    profile = PchipInterpolator(knots, table, axis=0)
    dense_t = np.linspace(0.0, knots[-1], 20 * rings)
    dense = profile(dense_t)
    # resample uniformly in arc length along the widest meridian, so triangles
    # are about as tall over the shoulders and head as up the chest
    step = np.diff(dense[:, :4], axis=0)
    ds = np.hypot(step[:, 0], np.abs(step[:, 1:4]).max(axis=1))
    s = np.concatenate([[0.0], np.cumsum(ds)])
    t = np.interp(np.linspace(0.0, s[-1], rings), s, dense_t)
    y, a, bf, bb, p, cz = profile(t).T
    a[[0, -1]] = bf[[0, -1]] = bb[[0, -1]] = 0.0      # exact poles

    theta = 2.0 * np.pi * np.arange(segments) / segments
    cos, sin = np.cos(theta)[None, :], np.sin(theta)[None, :]
    b = np.where(sin >= 0.0, bf[:, None], bb[:, None])
    with np.errstate(divide="ignore", invalid="ignore"):   # the poles, A = B = 0
        inv = (np.abs(cos) / a[:, None]) ** p[:, None] + (np.abs(sin) / b) ** p[:, None]
        r = np.where(a[:, None] > 0.0, inv ** (-1.0 / p[:, None]), 0.0)
    grid = np.stack([r * cos, np.broadcast_to(y[:, None], r.shape),
                     cz[:, None] + r * sin], axis=-1)          # (rings, segments, 3)

    # normals of the smooth surface: d/dt x d/dtheta points outwards
    d_t = np.gradient(grid, axis=0)
    d_theta = (np.roll(grid, -1, axis=1) - np.roll(grid, 1, axis=1)) / 2.0
    normals = np.cross(d_t, d_theta)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True).clip(1e-300)

    body = grid[1:-1].reshape(-1, 3)
    vertices = np.concatenate([[grid[0, 0]], body, [grid[-1, 0]]])
    vnormals = np.concatenate([[[0.0, -1.0, 0.0]], normals[1:-1].reshape(-1, 3),
                               [[0.0, 1.0, 0.0]]])
    n, top = segments, len(vertices) - 1
    rows = 1 + n * np.arange(rings - 2)[:, None] + np.arange(n)[None, :]
    faces = [np.stack([np.zeros(n, int), rows[0], np.roll(rows[0], -1)], axis=1)]
    for lo, hi in zip(rows[:-1], rows[1:]):
        faces.append(_annulus_faces(lo, hi))
    faces.append(np.stack([np.full(n, top), np.roll(rows[-1], -1), rows[-1]], axis=1))
    arrays = (vertices, np.concatenate(faces), vnormals)
    for arr in arrays:
        arr.setflags(write=False)
    return arrays


def bust(*, center=(0.0, 0.0, 0.0), segments: int = 384, rings: int = 200) -> trimesh.Trimesh:
    """A generated bust: head, neck, shoulders and chest as one closed surface.

    0.66 m tall and 0.40 m wide at the shoulders, facing ``+z``, its flat
    base on the plane ``y = center[1]`` centred on ``center``; the neck is the
    band :data:`BUST_NECK_Y` above the base (see :func:`bust_dimensions`).  The
    chest in front of and below the neck is curved and faces forward and up, so
    a mirror ring around the neck can cast a caustic onto it.

    Parameters
    ----------
    center : (3,) float
        Centre of the base.
    segments : int
        Vertices around each cross-section (>= 8).
    rings : int
        Cross-sections from the base pole to the head pole (>= 4).

    The mesh is watertight, wound outwards, with ``2 * segments * (rings - 2)``
    triangles (152,064 by default) and normals of the smooth surface.
    """
    n = _check_segments("bust: segments", segments, 8)
    m = _check_segments("bust: rings", rings, 4)
    c = _check_point("bust: center", center)
    vertices, faces, normals = _bust_arrays(n, m)
    return with_normals(vertices + c, faces, normals)


def bust_dimensions(*, segments: int = 384, rings: int = 200) -> BustDimensions:
    """Landmarks of ``bust(segments=segments, rings=rings)`` centred at the origin."""
    vertices, _, _ = _bust_arrays(_check_segments("bust: segments", segments, 8),
                                  _check_segments("bust: rings", rings, 4))
    y = vertices[:, 1]
    radius = np.hypot(vertices[:, 0], vertices[:, 2])
    neck = (y >= BUST_NECK_Y[0]) & (y <= BUST_NECK_Y[1])
    i = int(np.argmax(np.abs(vertices[:, 0])))
    return BustDimensions(
        height=float(y.max()), neck_y=BUST_NECK_Y, neck_radius=float(radius[neck].max()),
        shoulder_y=float(y[i]), shoulder_half_width=float(np.abs(vertices[:, 0]).max()),
        chest_front_z=float(vertices[y < BUST_NECK_Y[0], 2].max()))
