"""Mitsuba 3's sensor, film, sampler and reconstruction filter, mapped onto blockhash's camera
and samples per pixel (for :mod:`.importer`).

What is mapped, each as Mitsuba 3.9 does it:

* ``perspective`` sensor: ``fov`` with ``fov_axis`` ``x`` (the default), ``y``,
  ``diagonal``, ``smaller`` or ``larger``, or ``focal_length`` (``"50mm"``, the default when
  neither is given: the diagonal of a 36 x 24 mm film); the horizontal angle must lie in
  (0, 180).  ``to_world``: eye, view direction and up; a ``lookat`` without ``up`` takes
  Mitsuba's (:func:`.xml_values.coordinate_system`).  ``near_clip`` (default 0.01) and
  ``far_clip`` (default 10000) are honoured when they clip nothing of the scene the camera
  sees, and refused otherwise (blockhash's camera does not clip).
* ``hdrfilm``: ``width``, ``height`` (768 x 576 by default); ``pixel_format`` ``rgb`` or
  ``rgba``, ``file_format`` ``openexr``, ``component_format`` ``float16`` or ``float32``
  (Mitsuba's output file only; blockhash writes its own float32 EXR).  ``rfilter``: ``box``
  (the pixel mean), ``tent`` (``radius``, default 1) or ``gaussian`` (``stddev``, default
  0.5), weighted across pixel borders as Mitsuba's film weighs them
  (:mod:`blockhash.scene.pixel_filter`); without one, Mitsuba's default Gaussian.
* ``sampler``: ``sample_count`` is the samples per pixel after Mitsuba's rounding (``independent``
  as given, ``stratified`` up to a square, ``ldsampler`` up to a power of 4, ``orthogonal``
  up to the square of a prime, ``multijitter`` up to floor(sqrt(n)) rows of ceil(n / rows)),
  up to 1024, stratified in cells as near square as the count divides
  (:func:`blockhash.scene.camera.spp_grid`; 32: 4 x 8); without one, blockhash's default.  ``seed`` and ``jitter = true`` change only the noise and are accepted.
* ``integrator``: :mod:`.integrator` (its ``max_depth`` as the specular events followed).

Refused: scale or shear in the sensor's to_world (Mitsuba refuses them too), a mirror flip
(negative determinant: Mitsuba renders the image mirrored, which blockhash's camera cannot),
every other sensor, film, sampler, filter and integrator type and every other property.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import trimesh

from blockhash.scene.camera import MAX_SPP
from blockhash.scene.mitsuba.xml_values import (  # noqa: F401 (MitsubaWarning importable from here)
    ORTHONORMAL_TOLERANCE,
    MitsubaWarning,
    XmlReader,
)
from blockhash.scene.model import Camera
from blockhash.scene.pixel_filter import FILTERS, PixelFilter

#: Mitsuba's defaults: film size, clip planes, focal length (mm) and its film's diagonal.
DEFAULT_SIZE = (768, 576)
DEFAULT_NEAR, DEFAULT_FAR = 0.01, 10000.0
DEFAULT_FOCAL = "50mm"
FILM_DIAGONAL_MM = math.hypot(36.0, 24.0)
#: A film's filter where it names none: Mitsuba's Gaussian of standard deviation 0.5 pixel.
DEFAULT_FILTER = PixelFilter("gaussian")
SAMPLERS = ("independent", "stratified", "multijitter", "orthogonal", "ldsampler")


@dataclass
class Render:
    """What a sensor and an integrator say: the camera, its clip planes, samples per pixel
    (None: blockhash's default) and the elements that set them (for errors)."""

    camera: Camera
    near: float
    far: float
    sensor: object
    spp: int | None = None
    sampler: object = None
    max_depth: int | None = None
    integrator: object = None
    clips: set = None


def x_fov(r: XmlReader, el, p: dict, width: int, height: int) -> float:
    """The horizontal field of view in degrees, as Mitsuba's ``parse_fov`` gives it."""
    aspect = width / height
    if "fov" in p and "focal_length" in p:
        r.fail(el, "give either fov or focal_length, not both (Mitsuba refuses both)")
    if "fov" in p:
        fov, axis = float(p["fov"]), p.get("fov_axis", "x").lower()
        if axis == "smaller":
            axis = "y" if aspect > 1 else "x"
        elif axis == "larger":
            axis = "x" if aspect > 1 else "y"
    else:
        if "fov_axis" in p:
            r.fail(el, "fov_axis without fov; give <float name=\"fov\"> or drop fov_axis")
        text = p.get("focal_length", DEFAULT_FOCAL)
        try:
            mm = float(text[:-2] if text.endswith("mm") else text)
        except ValueError:
            mm = float("nan")
        if not mm > 0:
            r.fail(el, f"focal_length {text!r}: expected a length like \"50mm\"")
        fov, axis = 2.0 * math.degrees(math.atan(FILM_DIAGONAL_MM / (2.0 * mm))), "diagonal"
    half = math.radians(fov) / 2.0
    if axis == "x":
        out = fov
    elif axis == "y":
        out = 2.0 * math.degrees(math.atan(math.tan(half) * aspect))
    elif axis == "diagonal":
        out = 2.0 * math.degrees(math.atan(math.tan(half) / math.sqrt(1.0 + 1.0 / aspect ** 2)))
    else:
        r.fail(el, f"fov_axis {axis!r}: supported: x, y, diagonal, smaller, larger")
    if not 0.0 < out < 180.0:
        r.fail(el, f"fov {fov:g} on axis {axis} gives a horizontal field of view of {out:g} "
               "degrees; it must lie strictly between 0 and 180 (as in Mitsuba)")
    return out


#: A thin lens's distance in focus where a file gives none (Mitsuba's default).
DEFAULT_FOCUS = 10000.0


def sensor(r: XmlReader, el) -> Render:
    kind = el.get("type")
    if kind not in ("perspective", "thinlens"):
        r.fail(el, "unsupported sensor; supported: perspective (a pinhole camera), thinlens")
    lens = {"aperture_radius": ("float",)} if kind == "thinlens" else {}
    p = r.props(el, {"fov": ("float",), "fov_axis": ("string",), "focal_length": ("string",),
                     "to_world": ("transform",), "near_clip": ("float",),
                     "far_clip": ("float",), "focus_distance": ("float",), **lens},
                children=("film", "sampler", "ref"))  # focus_distance: no effect on a pinhole
    if kind == "thinlens" and "aperture_radius" not in p:
        r.fail(el, "a thinlens sensor needs <float name=\"aperture_radius\"> (Mitsuba asks for "
               "it too)")
    optics = ({"aperture_radius": p["aperture_radius"],
               "focus_distance": p.get("focus_distance", DEFAULT_FOCUS)} if lens else {})
    width, height = DEFAULT_SIZE
    pf = DEFAULT_FILTER
    sampler = crop = None
    films = [k for k in p["<children>"] if k.tag == "film"]
    for kid in p["<children>"]:
        if kid.tag == "ref":  # a sampler the scene defines at its top, by id
            ref = r.attr(kid, "id")
            if ref not in r.samplers:
                r.fail(kid, f"no sampler with id {ref!r}; defined: {', '.join(r.samplers) or 'none'}"
                       " (a sensor's <ref id> names a top-level <sampler id>)")
            kid = r.samplers[ref]
        if kid.tag == "sampler":
            if sampler is not None:
                r.fail(kid, "a second sampler; a sensor takes one")
            sampler = kid
        elif kid is not films[0]:
            r.fail(kid, "a second film; a sensor takes one")
        else:
            width, height, pf, crop = film(r, kid)
    near, far = float(p.get("near_clip", DEFAULT_NEAR)), float(p.get("far_clip", DEFAULT_FAR))
    given = {k for k in ("near_clip", "far_clip") if k in p}
    if not near > 0:
        r.fail(el, f"near_clip {near:g} must be > 0 (as in Mitsuba)")
    if not near < far:
        r.fail(el, f"near_clip {near:g} must be below far_clip {far:g} (as in Mitsuba)")
    fx = x_fov(r, el, p, width, height)
    fov_y = math.degrees(2.0 * math.atan(math.tan(math.radians(fx) / 2.0) * height / width))
    eye, target, up = camera_frame(r, el)
    window = {}
    if crop is not None:  # the image is the crop window's pixels, the field of view the film's
        x, y, w, h = crop
        window = {"width": w, "height": h,
                  "crop": (x / width, y / height, (x + w) / width, (y + h) / height)}
    camera = r.build(el, Camera, eye=eye, target=target, up=up, fov_y_deg=fov_y,
                     **{"width": width, "height": height, **window}, filter=pf, **optics)
    out = Render(camera=camera, near=near, far=far, sensor=el, sampler=sampler, clips=given)
    if sampler is not None:
        out.spp = samples(r, sampler)
    return out


def camera_frame(r: XmlReader, el):
    """(eye, target, up) of the sensor's to_world (module docstring)."""
    tw = [k for k in el if k.tag == "transform" and k.get("name") == "to_world"]
    if not tw:
        return np.zeros(3), np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])
    ops = [op for op in tw[0] if isinstance(op.tag, str)]
    if len(ops) == 1 and ops[0].tag == "lookat":  # as written: keep the values exactly
        _, o, t, up = r.lookat(ops[0])
        return o, t, up
    m = r.transform(tw[0])
    a = m[:3, :3]
    if not np.allclose(m[3], [0.0, 0.0, 0.0, 1.0]):
        r.fail(tw[0], "a projective sensor to_world (last row not 0 0 0 1) is not supported; "
               "give a rotation and a translation")
    if np.abs(a.T @ a - np.eye(3)).max() > ORTHONORMAL_TOLERANCE:
        r.fail(tw[0], "scale or shear in the sensor's to_world (Mitsuba refuses it too: \"Scale "
               "factors in the camera-to-world transformation are not allowed\"); keep only "
               "rotations, translations and lookat")
    if np.linalg.det(a) < 0:
        r.fail(tw[0], "a mirror flip in the sensor's to_world (negative determinant, e.g. a "
               "<scale> by -1): Mitsuba renders the image mirrored, and blockhash's camera (eye, "
               "target, up) cannot; remove the flip and mirror the rendered image instead")
    eye = m[:3, 3]
    return eye, eye + a @ [0.0, 0.0, 1.0], a @ [0.0, 1.0, 0.0]


CROP = ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height")


def film(r: XmlReader, el) -> tuple[int, int, PixelFilter, tuple | None]:
    """(width, height, pixel filter, crop window in pixels (x, y, width, height) or None) of an
    ``hdrfilm`` (Mitsuba's Gaussian where it names no ``rfilter``)."""
    if el.get("type") != "hdrfilm":
        r.fail(el, "unsupported film; supported: hdrfilm")
    f = r.props(el, {"width": ("integer",), "height": ("integer",), "pixel_format": ("string",),
                     "file_format": ("string",), "component_format": ("string",),
                     **{k: ("integer",) for k in CROP}},
                children=("rfilter",))
    for key, ok in (("pixel_format", ("rgb", "rgba")), ("file_format", ("openexr", "exr")),
                    ("component_format", ("float16", "float32"))):
        if key in f and f[key].lower() not in ok:
            r.fail(el, f"{key} {f[key]!r} is not supported; supported: {', '.join(ok)} "
                   "(blockhash writes RGB layers to a float32 EXR)")
    pf = DEFAULT_FILTER
    for kid in f["<children>"]:
        if len(f["<children>"]) > 1:
            r.fail(kid, "a second rfilter; a film takes one")
        pf = rfilter(r, kid)
    width, height = f.get("width", DEFAULT_SIZE[0]), f.get("height", DEFAULT_SIZE[1])
    for key, v in (("width", width), ("height", height)):
        if not v >= 1:
            r.fail(el, f"{key} {v} must be at least 1 pixel")
    if not any(k in f for k in CROP):
        return width, height, pf, None
    x, y = f.get("crop_offset_x", 0), f.get("crop_offset_y", 0)
    w, h = f.get("crop_width", width - x), f.get("crop_height", height - y)
    if not (0 <= x and 0 <= y and w >= 1 and h >= 1 and x + w <= width and y + h <= height):
        r.fail(el, f"the crop window at ({x}, {y}) of {w} x {h} pixels does not lie inside the "
               f"{width} x {height} film; give crop_offset_x/y >= 0 and crop_width/height >= 1 "
               "within it (as Mitsuba asks)")
    return width, height, pf, (x, y, w, h)


def rfilter(r: XmlReader, el) -> PixelFilter:
    """The pixel filter of an ``<rfilter>``: ``box`` (its radius Mitsuba's 0.5: the pixel
    mean), ``tent`` (``radius``) or ``gaussian`` (``stddev``)."""
    kind = el.get("type")
    if kind not in FILTERS:
        r.fail(el, f"unsupported reconstruction filter; supported: {', '.join(FILTERS)}")
    name = FILTERS[kind][0] or "radius"
    p = r.props(el, {name: ("float",)})
    if kind == "box":
        if p.get("radius", 0.5) != 0.5:
            r.fail(el, f"a box filter of radius {p['radius']:g}: blockhash's box is the pixel "
                   "mean (radius 0.5); leave the radius out, or use a tent or gaussian filter")
        return PixelFilter()
    return r.build(el, PixelFilter, kind=kind, width=p.get(name))


def _prime(n: int) -> bool:
    return n >= 2 and all(n % d for d in range(2, math.isqrt(n) + 1))


def sample_count(kind: str, n: int) -> int:
    """The samples per pixel Mitsuba's sampler ``kind`` takes for ``sample_count = n``."""
    if kind == "independent":
        return n
    if kind == "stratified":
        return math.ceil(math.sqrt(n)) ** 2
    if kind == "ldsampler":
        s = 4
        while s < n:
            s *= 4
        return s
    if kind == "orthogonal":
        p = max(2, math.ceil(math.sqrt(n)))
        while not _prime(p):
            p += 1
        return p * p
    rows = math.isqrt(n)  # multijitter: floor(sqrt(n)) rows of ceil(n / rows)
    return rows * -(-n // rows)


def samples(r: XmlReader, el) -> int | None:
    kind = el.get("type")
    if kind not in SAMPLERS:
        r.fail(el, f"unsupported sampler; supported: {', '.join(SAMPLERS)}")
    allowed = {"sample_count": ("integer",), "seed": ("integer",)}
    if kind in ("stratified", "multijitter", "orthogonal"):
        allowed["jitter"] = ("boolean",)
    p = r.props(el, allowed)
    if p.get("jitter", True) is False:
        r.fail(el, "jitter = false (samples at the cell centres) is not supported; blockhash's "
               "samples are jittered in stratified cells: remove it")
    if "sample_count" not in p:
        return None
    n = p["sample_count"]
    spp = sample_count(kind, n) if n >= 1 else n
    if not 1 <= spp <= MAX_SPP:
        what = f"{n}" if spp == n else f"{n} ({kind} takes {spp})"
        r.fail(el, f"sample_count {what}: blockhash takes 1 to {MAX_SPP} samples per pixel a "
               "pass; give fewer and render more passes")
    return spp


def _default(render: Render, key: str) -> str:
    return "" if key in (render.clips or ()) else " (Mitsuba's default)"


def check_clip(r: XmlReader, render: Render, objects) -> None:
    """Refuse clip planes that would clip what the camera sees (module docstring)."""
    cam = render.camera
    right, up, forward = cam.basis()
    verts = np.concatenate([np.asarray(o.mesh.vertices) for o in objects])
    deepest = float(((verts - cam.eye) @ forward).max())
    if deepest > render.far:
        r.fail(render.sensor, f"far_clip {render.far:g}{_default(render, 'far_clip')} clips the scene (it reaches "
               f"{deepest:.4g} in front of the camera) and blockhash's camera does not clip; "
               f"give far_clip >= {deepest:.4g}")
    tris = np.concatenate([np.asarray(o.mesh.triangles) for o in objects])
    nearest = np.linalg.norm(trimesh.triangles.closest_point(
        tris, np.broadcast_to(cam.eye, (len(tris), 3))) - cam.eye, axis=1).min()
    tan_y = math.tan(math.radians(cam.fov_y_deg) / 2.0)
    cos_corner = 1.0 / math.sqrt(1.0 + tan_y ** 2 * (1.0 + cam.aspect ** 2))
    if nearest * cos_corner < render.near:
        r.fail(render.sensor, f"near_clip {render.near:g}{_default(render, 'near_clip')} may clip the scene (it comes within "
               f"{nearest:.4g} of the camera) and blockhash's camera does not clip; give "
               f"near_clip <= {nearest * cos_corner:.4g}")


__all__ = ["sensor", "check_clip", "sample_count", "x_fov", "Render"]
