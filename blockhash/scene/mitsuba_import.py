"""Read the Mitsuba 3 XML subset that blockhash models (``blockhash render scene.xml``).

Supported, everything else an InputError naming the element, its line and what is supported:

* ``<scene>`` with ``<default name value>`` (``$name`` is substituted in attribute values)
  and ``<integrator>`` (read by Mitsuba only, accepted and left alone);
* a ``perspective`` sensor: ``fov`` with ``fov_axis`` ``x`` (Mitsuba's default) or ``y``,
  a ``to_world`` transform, an ``hdrfilm`` with ``width`` and ``height``; its ``sampler``
  and ``rfilter`` are accepted and left alone (blockhash's samples per pixel come from
  ``--spp`` or the scene);
* shapes ``ply``, ``obj`` (``filename`` relative to the XML's folder, ``face_normals``),
  ``rectangle`` ([-1, 1]^2 in z = 0, facing +z), ``sphere`` (``center``, ``radius``; an
  icosphere, :func:`blockhash.scene.meshes.sphere`) and ``cube`` ([-1, 1]^3), each with an
  optional ``to_world`` and a BSDF given inline or by ``<ref id>``;
* BSDFs ``diffuse`` (``reflectance``), ``conductor`` with ``material = none``
  (``specular_reflectance``) and ``dielectric`` (``int_ior`` a number, ``ext_ior`` 1 or
  air, ``specular_transmittance``), possibly inside ``twosided``;
* emitters ``point`` (``position`` or ``to_world``, ``intensity``) and ``spot``
  (``to_world``, ``intensity``, ``cutoff_angle``; ``beam_width`` must equal it, as
  blockhash's spot is uniform inside its cone).

Transforms: ``translate``, ``rotate`` (axis and angle, or x/y/z), ``scale``, ``matrix`` and
``lookat``, composed in order as Mitsuba does (each applied after the ones before it).
Values: ``rgb`` and ``spectrum`` (one number), ``float``, ``integer``, ``string``,
``boolean``, ``point`` and ``vector``.

A file written by :mod:`.mitsuba_export` carries the photon settings, the samples per pixel
and the description in a comment; they are read back from it.

Why this module is long: every supported element, property and transform is checked here
with an error naming its line, in one reader class, so that nothing unsupported passes
silently; split by element, each part would need the reader's line table and defaults.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path
from xml.parsers import expat

import numpy as np
import trimesh

from blockhash.errors import InputError
from blockhash.scene import meshes
from blockhash.scene.mitsuba_export import METADATA_MARK
from blockhash.scene.model import (
    Camera,
    DielectricMaterial,
    MirrorMaterial,
    PhongMaterial,
    PhotonSettings,
    PointLight,
    Scene,
    SceneObject,
    SpotLight,
)

SHAPES = ("ply", "obj", "rectangle", "sphere", "cube")
BSDFS = ("diffuse", "conductor", "dielectric", "twosided")
EMITTERS = ("point", "spot")
#: Indices of refraction Mitsuba names for the outside that blockhash takes as 1 (vacuum).
AIR = ("air", "vacuum")


class _Builder(ET.TreeBuilder):
    """An element tree built from expat's events, keeping comments and each element's line."""

    def __init__(self):
        super().__init__(insert_comments=True)
        self.lines: dict[int, int] = {}

    def parse(self, data: bytes):
        parser = expat.ParserCreate()

        def start(tag, attrs):
            self.lines[id(self.start(tag, attrs))] = parser.CurrentLineNumber

        parser.StartElementHandler = start
        parser.EndElementHandler = self.end
        parser.CommentHandler = self.comment
        parser.Parse(data, True)
        return self.close()


class _Reader:
    def __init__(self, path: Path, builder: _Builder):
        self.path = path
        self.lines = builder.lines
        self.defaults: dict[str, str] = {}

    def fail(self, el, what: str):
        raise InputError(f"{self.path}:{self.lines.get(id(el), '?')}: <{el.tag}"
                         + (f" type=\"{el.get('type')}\"" if el.get("type") else "")
                         + (f" name=\"{el.get('name')}\"" if el.get("name") else "")
                         + f">: {what}")

    def attr(self, el, key: str, default=None) -> str:
        v = el.get(key)
        if v is None:
            if default is not None:
                return default
            self.fail(el, f"missing attribute {key!r}")
        for name, value in self.defaults.items():
            v = v.replace(f"${name}", value)
        return v

    def floats(self, el, text: str, count: int | None = None) -> np.ndarray:
        try:
            v = np.array([float(t) for t in text.replace(",", " ").split()], dtype=np.float64)
        except ValueError:
            self.fail(el, f"expected numbers; got {text!r}")
        if count is not None and len(v) != count:
            self.fail(el, f"expected {count} numbers; got {len(v)} ({text!r})")
        if not np.isfinite(v).all():
            self.fail(el, f"expected finite numbers; got {text!r}")
        return v

    # ------------------------------------------------------------------ properties

    def value(self, el):
        tag = el.tag
        if tag in ("float", "integer"):
            v = self.floats(el, self.attr(el, "value"), 1)[0]
            return int(v) if tag == "integer" else float(v)
        if tag == "string":
            return self.attr(el, "value")
        if tag == "boolean":
            v = self.attr(el, "value").lower()
            if v not in ("true", "false"):
                self.fail(el, f"expected true or false; got {v!r}")
            return v == "true"
        if tag == "rgb":
            v = self.floats(el, self.attr(el, "value"))
            if len(v) not in (1, 3):
                self.fail(el, "expected one number or three (r, g, b)")
            return np.broadcast_to(v, (3,)).copy()
        if tag == "spectrum":
            text = self.attr(el, "value")
            if ":" in text:
                self.fail(el, "a spectrum of wavelength:value pairs is not supported; give one "
                          "number or use <rgb>")
            return np.full(3, self.floats(el, text, 1)[0])
        if tag in ("point", "vector"):
            if el.get("value") is not None:
                return self.floats(el, self.attr(el, "value"), 3)
            return np.array([float(self.floats(el, self.attr(el, a, "0"), 1)[0]) for a in "xyz"])
        if tag == "transform":
            return self.transform(el)
        self.fail(el, "unsupported property; supported: float, integer, string, boolean, rgb, "
                  "spectrum, point, vector, transform")

    def props(self, el, allowed: dict, *, children=()) -> dict:
        """The named properties of ``el`` (``allowed``: name -> tags), every other child an
        error unless its tag is in ``children`` (returned under ``'<children>'``)."""
        out, kids = {}, []
        for child in el:
            if not isinstance(child.tag, str):
                continue  # a comment
            if child.tag in children:
                kids.append(child)
                continue
            name = child.get("name")
            if name not in allowed:
                self.fail(child, f"unsupported here; <{el.tag} type=\"{el.get('type')}\"> takes "
                          + (", ".join(f"{n} ({'/'.join(t)})" for n, t in allowed.items()) or "nothing")
                          + (f" and {', '.join(children)}" if children else ""))
            if child.tag not in allowed[name]:
                self.fail(child, f"{name} must be given as {' or '.join(allowed[name])}")
            out[name] = self.value(child)
        out["<children>"] = kids
        return out

    def transform(self, el) -> np.ndarray:
        m = np.eye(4)
        for op in el:
            if not isinstance(op.tag, str):
                continue
            t = np.eye(4)
            if op.tag == "translate":
                t[:3, 3] = self.value_xyz(op, 0.0)
            elif op.tag == "scale":
                if op.get("value") is not None:
                    s = self.floats(op, self.attr(op, "value"))
                    s = np.broadcast_to(s, (3,)) if len(s) in (1, 3) else self.fail(op, "expected 1 or 3 numbers")
                else:
                    s = self.value_xyz(op, 1.0)
                t[:3, :3] = np.diag(s)
            elif op.tag == "rotate":
                angle = math.radians(self.floats(op, self.attr(op, "angle"), 1)[0])
                axis = (self.floats(op, self.attr(op, "value"), 3) if op.get("value") is not None
                        else self.value_xyz(op, 0.0))
                if not np.linalg.norm(axis) > 0:
                    self.fail(op, "the rotation axis is zero")
                t[:3, :3] = trimesh.transformations.rotation_matrix(angle, axis)[:3, :3]
            elif op.tag == "matrix":
                v = self.floats(op, self.attr(op, "value"))
                if len(v) not in (9, 16):
                    self.fail(op, f"expected 9 or 16 numbers; got {len(v)}")
                if len(v) == 9:
                    t[:3, :3] = v.reshape(3, 3)
                else:
                    t = v.reshape(4, 4)
            elif op.tag == "lookat":
                t = self.lookat(op)[0]
            else:
                self.fail(op, "unsupported transform; supported: translate, rotate, scale, "
                          "matrix, lookat")
            m = t @ m
        return m

    def value_xyz(self, op, default: float) -> np.ndarray:
        if op.get("value") is not None:
            return self.floats(op, self.attr(op, "value"), 3)
        return np.array([self.floats(op, self.attr(op, a, str(default)), 1)[0] for a in "xyz"])

    def lookat(self, op):
        """(matrix, origin, target, up) of a <lookat>, Mitsuba's frame (local +z forward)."""
        o = self.floats(op, self.attr(op, "origin"), 3)
        t = self.floats(op, self.attr(op, "target"), 3)
        up = self.floats(op, self.attr(op, "up", "0, 1, 0"), 3)
        d = t - o
        if not np.linalg.norm(d) > 0:
            self.fail(op, "origin equals target")
        d /= np.linalg.norm(d)
        left = np.cross(up, d)
        if not np.linalg.norm(left) > 1e-12:
            self.fail(op, "up is parallel to the view direction")
        left /= np.linalg.norm(left)
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, np.cross(d, left), d, o
        return m, o, t, up

    # ------------------------------------------------------------------ elements

    def sensor(self, el) -> Camera:
        if el.get("type") != "perspective":
            self.fail(el, "unsupported sensor; supported: perspective")
        p = self.props(el, {"fov": ("float",), "fov_axis": ("string",), "to_world": ("transform",),
                            "near_clip": ("float",), "far_clip": ("float",)},
                       children=("film", "sampler"))
        if "fov" not in p:
            self.fail(el, "missing <float name=\"fov\">; blockhash's camera needs a field of view")
        width = height = None
        for kid in p["<children>"]:
            if kid.tag == "sampler":
                continue
            if kid.get("type") != "hdrfilm":
                self.fail(kid, "unsupported film; supported: hdrfilm")
            f = self.props(kid, {"width": ("integer",), "height": ("integer",),
                                 "pixel_format": ("string",), "file_format": ("string",),
                                 "component_format": ("string",)}, children=("rfilter",))
            width, height = f.get("width", 768), f.get("height", 576)  # Mitsuba's defaults
        if width is None:
            width, height = 768, 576
        eye, target, up = self.camera_frame(el)
        axis = p.get("fov_axis", "x")
        fov = float(p["fov"])
        if axis == "x":
            fov = math.degrees(2.0 * math.atan(math.tan(math.radians(fov) / 2.0) * height / width))
        elif axis != "y":
            self.fail(el, f"fov_axis {axis!r} is not supported; supported: x, y")
        return Camera(eye=eye, target=target, up=up, fov_y_deg=fov, width=width, height=height)

    def camera_frame(self, el):
        tw = [k for k in el if k.tag == "transform" and k.get("name") == "to_world"]
        if not tw:
            return np.zeros(3), np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])
        ops = [op for op in tw[0] if isinstance(op.tag, str)]
        if len(ops) == 1 and ops[0].tag == "lookat":  # as written: keep the values exactly
            _, o, t, up = self.lookat(ops[0])
            return o, t, up
        m = self.transform(tw[0])
        eye = m[:3, 3]
        return eye, eye + m[:3, :3] @ [0.0, 0.0, 1.0], m[:3, :3] @ [0.0, 1.0, 0.0]

    def bsdf(self, el, key: str):
        kind = el.get("type")
        if kind == "twosided":
            inner = [k for k in el if isinstance(k.tag, str)]
            if len(inner) != 1 or inner[0].tag != "bsdf":
                self.fail(el, "expected exactly one <bsdf> inside")
            return self.bsdf(inner[0], key)
        if kind == "diffuse":
            p = self.props(el, {"reflectance": ("rgb", "spectrum", "float")})
            kd = p.get("reflectance", 0.5)
            return self.material(el, PhongMaterial, kd=np.broadcast_to(kd, (3,)), ks=0.0, n=0.0)
        if kind == "conductor":
            p = self.props(el, {"material": ("string",), "specular_reflectance": ("rgb", "spectrum", "float")})
            if p.get("material") != "none":
                self.fail(el, "only a conductor with <string name=\"material\" value=\"none\"/> "
                          "(a perfect mirror of specular_reflectance) is supported; measured "
                          "metals (eta, k) are not")
            r = p.get("specular_reflectance", 1.0)
            return self.material(el, MirrorMaterial, reflectance=np.broadcast_to(r, (3,)))
        if kind == "dielectric":
            p = self.props(el, {"int_ior": ("float", "string"), "ext_ior": ("float", "string"),
                                "specular_transmittance": ("rgb", "spectrum", "float"),
                                "specular_reflectance": ("rgb", "spectrum", "float")})
            ior = p.get("int_ior", 1.5046)  # Mitsuba's default, bk7
            if isinstance(ior, str):
                self.fail(el, f"int_ior {ior!r}: give the index of refraction as a number")
            ext = p.get("ext_ior", "air")
            if not (ext in AIR or (isinstance(ext, float) and abs(ext - 1.0) < 1e-3)):
                self.fail(el, f"ext_ior {ext!r}: blockhash's dielectrics sit in air (index 1); "
                          "give ext_ior 1")
            if "specular_reflectance" in p and not np.allclose(p["specular_reflectance"], 1.0):
                self.fail(el, "specular_reflectance other than 1 is not supported")
            tint = p.get("specular_transmittance", 1.0)
            return self.material(el, DielectricMaterial, ior=float(ior),
                                 tint=np.broadcast_to(tint, (3,)))
        self.fail(el, f"unsupported BSDF; supported: {', '.join(BSDFS)}")

    def material(self, el, cls, **kwargs):
        try:
            return cls(**kwargs)
        except InputError as exc:
            self.fail(el, str(exc))

    def emitter(self, el):
        kind = el.get("type")
        if kind not in EMITTERS:
            self.fail(el, f"unsupported emitter; supported: {', '.join(EMITTERS)} "
                      "(blockhash's lights)")
        spectra = ("rgb", "spectrum", "float")
        if kind == "point":
            p = self.props(el, {"position": ("point",), "intensity": spectra,
                                "to_world": ("transform",)})
            pos = p["to_world"][:3, 3] if "to_world" in p else p.get("position", np.zeros(3))
            power = np.broadcast_to(p.get("intensity", 1.0), (3,)) * 4.0 * math.pi
            return self.material(el, PointLight, position=pos, power=power)
        p = self.props(el, {"intensity": spectra, "to_world": ("transform",),
                            "cutoff_angle": ("float",), "beam_width": ("float",)})
        cone = float(p.get("cutoff_angle", 20.0))
        if abs(float(p.get("beam_width", cone * 0.75)) - cone) > 1e-9:
            self.fail(el, "beam_width must equal cutoff_angle: blockhash's spot light is uniform "
                      "inside its cone (Mitsuba's default beam_width is 3/4 of cutoff_angle)")
        m = p.get("to_world", np.eye(4))
        axis = m[:3, :3] @ [0.0, 0.0, 1.0]
        power = np.broadcast_to(p.get("intensity", 1.0), (3,)) * 2.0 * math.pi * (
            1.0 - math.cos(math.radians(cone)))
        return self.material(el, SpotLight, position=m[:3, 3], direction=axis, power=power,
                             cone_deg=cone)

    def shape(self, el, bsdfs: dict, index: int):
        kind = el.get("type")
        if kind not in SHAPES:
            self.fail(el, f"unsupported shape; supported: {', '.join(SHAPES)}")
        allowed = {"to_world": ("transform",)}
        if kind in ("ply", "obj"):
            allowed |= {"filename": ("string",), "face_normals": ("boolean",),
                        "flip_normals": ("boolean",)}
        if kind == "sphere":
            allowed |= {"center": ("point",), "radius": ("float",)}
        p = self.props(el, allowed, children=("bsdf", "ref", "emitter"))
        material = None
        for kid in p["<children>"]:
            if kid.tag == "emitter":
                self.fail(kid, "area lights are not supported; use point or spot emitters")
            if material is not None:
                self.fail(kid, "a shape takes one BSDF")
            if kid.tag == "ref":
                ref = self.attr(kid, "id")
                if ref not in bsdfs:
                    self.fail(kid, f"no BSDF with id {ref!r} before it; defined: "
                              f"{', '.join(bsdfs) or 'none'}")
                material = bsdfs[ref]
            else:
                material = self.bsdf(kid, "")
        if material is None:
            self.fail(el, "the shape has no BSDF; add <ref id=\"...\"/> or an inline <bsdf>")
        mesh = self.mesh(el, kind, p)
        name = el.get("id") or f"{kind}-{index}"
        return self.material(el, SceneObject, name=name, mesh=mesh, material=material)

    def mesh(self, el, kind: str, p: dict) -> trimesh.Trimesh:
        if kind in ("ply", "obj"):
            if "filename" not in p:
                self.fail(el, "missing <string name=\"filename\">")
            full = self.path.parent / p["filename"]
            if not full.is_file():
                self.fail(el, f"mesh file not found: {str(full)!r} (filename "
                          f"{p['filename']!r} is relative to the XML file's folder)")
            try:
                mesh = meshes.load_mesh(full, normals="flat" if p.get("face_normals") else "auto")
            except InputError as exc:
                self.fail(el, str(exc))
            if p.get("flip_normals"):
                mesh = meshes.with_normals(mesh.vertices, mesh.faces[:, ::-1], -mesh.vertex_normals)
        elif kind == "rectangle":
            v = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]])
            mesh = meshes.with_normals(v, [[0, 1, 2], [0, 2, 3]], np.tile([0.0, 0.0, 1.0], (4, 1)))
        elif kind == "cube":
            box = trimesh.creation.box(extents=(2.0, 2.0, 2.0))
            box.unmerge_vertices()
            mesh = meshes.with_normals(box.vertices, box.faces, np.repeat(box.face_normals, 3, axis=0))
        else:
            mesh = meshes.sphere(center=p.get("center", np.zeros(3)), radius=p.get("radius", 1.0))
        if "to_world" not in p:
            return mesh
        m = p["to_world"]
        if not abs(np.linalg.det(m[:3, :3])) > 0:
            self.fail(el, "the to_world transform is singular")
        normal = np.linalg.inv(m[:3, :3]).T
        return meshes.with_normals(trimesh.transform_points(mesh.vertices, m), mesh.faces,
                                   np.asarray(mesh.vertex_normals) @ normal.T)


def load_mitsuba(path) -> Scene:
    """The scene of the Mitsuba 3 XML file at ``path`` (module docstring)."""
    path = Path(path)
    builder = _Builder()
    try:
        root = builder.parse(path.read_bytes())
    except expat.ExpatError as exc:
        raise InputError(f"{path}: XML syntax error: {exc}; fix the file") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read the file: {exc}") from None
    r = _Reader(path, builder)
    if root.tag != "scene":
        r.fail(root, "expected <scene> at the top")
    meta = {}
    camera, lights, objects, bsdfs = None, [], [], {}
    for el in root:
        if not isinstance(el.tag, str):
            text = (el.text or "").strip()
            if text.startswith(METADATA_MARK):
                try:
                    meta = json.loads(text[len(METADATA_MARK):])
                except json.JSONDecodeError:
                    meta = {}
            continue
        if el.tag == "default":
            r.defaults[r.attr(el, "name")] = r.attr(el, "value")
        elif el.tag == "integrator":
            continue  # Mitsuba's
        elif el.tag == "sensor":
            if camera is not None:
                r.fail(el, "a second sensor; blockhash renders one camera")
            camera = r.sensor(el)
        elif el.tag == "bsdf":
            bid = r.attr(el, "id")
            bsdfs[bid] = r.bsdf(el, bid)
        elif el.tag == "emitter":
            lights.append(r.emitter(el))
        elif el.tag == "shape":
            objects.append(r.shape(el, bsdfs, len(objects)))
        else:
            r.fail(el, "unsupported element; supported: default, integrator, sensor, bsdf, "
                   "emitter, shape")
    if camera is None:
        raise InputError(f"{path}: no <sensor>; add a perspective sensor")
    if meta.get("spp"):
        camera = Camera(eye=camera.eye, target=camera.target, up=camera.up,
                        fov_y_deg=camera.fov_y_deg, width=camera.width, height=camera.height,
                        spp=meta["spp"])
    photons = PhotonSettings(**meta["photons"]) if "photons" in meta else PhotonSettings()
    try:
        return Scene(camera=camera, lights=tuple(lights), objects=tuple(objects), photons=photons,
                     path=path, description=str(meta.get("description", "")))
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


__all__ = ["load_mitsuba"]
