"""Mitsuba 3's ``checkerboard`` texture on a diffuse reflectance, modelled exactly by cutting
the shape it covers along the checks' borders (for :mod:`.importer`).

Mitsuba's checkerboard (``color0``, default 0.4; ``color1``, default 0.2; ``to_uv``, an affine
map of the texture coordinates) is ``color0`` where ``frac(u) > 1/2`` and ``frac(v) > 1/2``
agree and ``color1`` elsewhere, (u, v) the surface's texture coordinates after ``to_uv``.  It
is two colours, constant over cells bounded by the lines u = k / 2 and v = k / 2, and texture
coordinates vary linearly over each triangle.  So each triangle is cut along those lines
(:func:`split`, in barycentric coordinates), and the pieces of each colour become one object
with a plain diffuse material of that colour: every stage downstream (the photons on the host
and on the device, the gathers, direct light, the light tracer) renders it unchanged, exactly.

Texture coordinates are Mitsuba's: a ``rectangle``'s (x / 2 + 1/2, y / 2 + 1/2) in its own
frame; an OBJ file's ``vt`` with v flipped (1 - v), as Mitsuba's OBJ loader takes them; a PLY
file's ``u``, ``v`` (or ``s``, ``t``); a ``serialized`` mesh's own; a ``sphere``'s, ``disk``'s
and ``cylinder``'s Mitsuba's parametrisation at the tessellation's corners
(:func:`.shapes.uv_mesh`).  A mesh without texture coordinates has (0, 0) everywhere in
Mitsuba, so it takes ``color0`` whole.  A ``bitmap`` is read by :func:`bitmap` as a
:class:`blockhash.scene.texture.Texture`, looked up per point, not cut.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Least area of a piece, as a share of its triangle's (the determinant of its corners'
#: barycentrics): below it a piece is a sliver the cut left along a border, and is dropped.
SLIVER = 1e-12
#: Mitsuba's checkerboard defaults.
DEFAULT_COLOR0, DEFAULT_COLOR1 = 0.4, 0.2


@dataclass(frozen=True, eq=False)
class Checkerboard:
    """A checkerboard: ``color0``, ``color1`` (3,) and ``to_uv`` (2, 3), the affine map of the
    texture coordinates (module docstring); ``name`` its id, for the objects' names."""

    color0: np.ndarray
    color1: np.ndarray
    to_uv: np.ndarray
    name: str = "checkerboard"

    def uv(self, uv) -> np.ndarray:
        """(..., 2) texture coordinates after ``to_uv``."""
        uv = np.asarray(uv, dtype=np.float64)
        return uv @ self.to_uv[:, :2].T + self.to_uv[:, 2]

    def is_color0(self, uv) -> np.ndarray:
        """(...) bool: ``color0`` at texture coordinates ``uv`` (after ``to_uv``)."""
        frac = uv - np.floor(uv)
        high = frac > 0.5
        return high[..., 0] == high[..., 1]


def checkerboard(r, el) -> Checkerboard:
    """The :class:`Checkerboard` of a ``<texture type="checkerboard">``."""
    spectra = ("rgb", "spectrum", "float")
    p = r.props(el, {"color0": spectra, "color1": spectra, "to_uv": ("transform",)})
    m = p.get("to_uv", np.eye(4))
    to_uv = np.array([[m[0, 0], m[0, 1], m[0, 3]], [m[1, 0], m[1, 1], m[1, 3]]])
    return Checkerboard(np.broadcast_to(p.get("color0", DEFAULT_COLOR0), (3,)).copy(),
                        np.broadcast_to(p.get("color1", DEFAULT_COLOR1), (3,)).copy(), to_uv,
                        el.get("id") or "checkerboard")


def texture(r, el):
    """The texture a property element ``el`` gives: an inline ``<texture>``, or a ``<ref id>``
    to one at the scene's top; a :class:`Checkerboard` or a bitmap's
    :class:`blockhash.scene.texture.Texture`, else an error naming the kind."""
    if el.tag == "ref":
        tid = r.attr(el, "id")
        if tid not in r.textures:
            r.fail(el, f"no texture with id {tid!r}; defined: {', '.join(r.textures) or 'none'}")
        el = r.textures[tid]
    if el.get("type") == "bitmap":
        return bitmap(r, el)
    if el.get("type") != "checkerboard":
        r.fail(el, f"a {el.get('type')} texture is not supported; supported: checkerboard and "
               "bitmap (on a diffuse reflectance); give the colour as <rgb value=\"r, g, b\"/>, "
               "e.g. the texture's mean")
    return checkerboard(r, el)


def bitmap(r, el, *, bounded: bool = True):
    """The :class:`blockhash.scene.texture.Texture` of a ``<texture type="bitmap">``: its
    ``filename`` found as a mesh file is, ``filter_type``, ``wrap_mode``, ``raw`` (8-bit
    values not decoded from sRGB) and ``to_uv``, as Mitsuba reads them; ``format`` (the
    precision Mitsuba keeps it in) changes nothing here.  ``bounded``: a reflectance's, its
    values at most 1 (a light's texture may exceed it)."""
    from blockhash.errors import InputError
    from blockhash.scene.texture import FILTERS, WRAPS, Texture, read_image

    p = r.props(el, {"filename": ("string",), "filter_type": ("string",),
                     "wrap_mode": ("string",), "raw": ("boolean",), "to_uv": ("transform",),
                     "format": ("string",)})
    if "filename" not in p:
        r.fail(el, "a bitmap needs its image: add <string name=\"filename\" value=\"wood.jpg\"/>")
    path = r.resolve(el, p["filename"], "texture image")
    filt, wrap = p.get("filter_type", "bilinear"), p.get("wrap_mode", "repeat")
    if filt not in FILTERS or wrap not in WRAPS:
        r.fail(el, f"filter_type {filt!r}, wrap_mode {wrap!r}: supported filter_type "
               f"{', '.join(FILTERS)} and wrap_mode {', '.join(WRAPS)}")
    try:
        image = read_image(path, raw=bool(p.get("raw", False)))
    except InputError as exc:
        r.fail(el, str(exc))
    if bounded and image.max() > 1.0:
        r.fail(el, f"the image {path.name!r} reaches {image.max():g}: a reflectance texture's "
               "values lie in [0, 1] (above 1 it would make light); scale the image down")
    m = p.get("to_uv", np.eye(4))
    to_uv = np.array([[m[0, 0], m[0, 1], m[0, 3]], [m[1, 0], m[1, 1], m[1, 3]]])
    return r.build(el, Texture, image=image, to_uv=to_uv, wrap=wrap, filter=filt,
                   name=el.get("id") or path.name, bounded=bounded)


@dataclass(frozen=True, eq=False)
class TexturedDiffuse:
    """A ``diffuse`` BSDF whose reflectance is a :class:`Checkerboard`, ``sided`` "one" or
    "two" as the plain one: a shape with it becomes two objects (module docstring)."""

    checker: Checkerboard
    sided: str

    def materials(self):
        """(color0's material, color1's material)."""
        from blockhash.scene.model import PhongMaterial

        return tuple(PhongMaterial(kd=c, ks=0.0, n=0.0, sided=self.sided)
                     for c in (self.checker.color0, self.checker.color1))


def split(faces, uv, checker: Checkerboard):
    """The triangles of ``faces`` ((m, 3), indices into the vertices whose texture coordinates
    are ``uv`` (n, 2)) cut along the checks' borders, by colour: ``(pieces of color0, pieces
    of color1)``, each ``(triangle (k,) int, barycentrics (k, 3, 3))``: piece j is the
    triangle ``triangle[j]`` of ``faces`` with its corners at ``barycentrics[j]`` (rows: the
    piece's corners, columns: the weights of the triangle's corners)."""
    faces = np.asarray(faces, dtype=np.int64)
    t = checker.uv(np.asarray(uv, dtype=np.float64)[faces])  # (m, 3, 2)
    lo = np.floor(2.0 * t.min(axis=1))
    hi = np.maximum(np.ceil(2.0 * t.max(axis=1)) - 1.0, lo)  # a corner on a border: not past it
    whole = (lo == hi).all(axis=1)
    eye = np.broadcast_to(np.eye(3), (len(faces), 3, 3))
    colour0 = checker.is_color0(t.mean(axis=1))
    out = [([np.flatnonzero(whole & colour0)], [eye[whole & colour0]]),
           ([np.flatnonzero(whole & ~colour0)], [eye[whole & ~colour0]])]
    for i in np.flatnonzero(~whole):
        for piece in _cut(t[i]):
            centre = piece.mean(axis=0) @ t[i]
            side = 0 if checker.is_color0(centre) else 1
            fan = np.stack([np.stack([piece[0], piece[k], piece[k + 1]])
                            for k in range(1, len(piece) - 1)])
            fan = fan[np.abs(np.linalg.det(fan)) > SLIVER]  # no triangle of no area
            if not len(fan):
                continue
            out[side][0].append(np.full(len(fan), i))
            out[side][1].append(fan)
    return tuple((np.concatenate(tri).astype(np.int64),
                  np.concatenate(bary).reshape(-1, 3, 3)) for tri, bary in out)


def _cut(t: np.ndarray) -> list:
    """The pieces of one triangle with texture coordinates ``t`` (3, 2) between the lines
    u = k / 2 and v = k / 2: convex polygons as (corners, 3) barycentrics, each with at least
    three corners (slivers of no area left out)."""
    pieces = [np.eye(3)]
    for axis in (0, 1):
        lines = np.arange(np.floor(2.0 * t[:, axis].min()) + 1,
                          np.ceil(2.0 * t[:, axis].max())) / 2.0  # the borders inside it
        for line in lines:
            cut = []
            for poly in pieces:
                value = poly @ t[:, axis] - line
                cut.extend(p for p in (_clip(poly, value, 1.0), _clip(poly, value, -1.0))
                           if len(p) >= 3)
            pieces = cut
    return pieces


def _clip(poly: np.ndarray, value: np.ndarray, sign: float) -> np.ndarray:
    """The part of the convex polygon ``poly`` (corners, 3) where ``sign * value >= 0``
    (``value`` linear over it, given at its corners): Sutherland and Hodgman's one edge."""
    keep = []
    n = len(poly)
    for k in range(n):
        a, b = poly[k], poly[(k + 1) % n]
        va, vb = sign * value[k], sign * value[(k + 1) % n]
        if va >= 0:
            keep.append(a)
        if (va >= 0) != (vb >= 0):
            keep.append(a + (b - a) * (va / (va - vb)))
    return np.array(keep).reshape(-1, 3)
