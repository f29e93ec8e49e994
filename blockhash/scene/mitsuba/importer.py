"""Read the Mitsuba 3 XML that blockhash models (``blockhash render scene.xml``).

Each element and property is read as Mitsuba 3.9 reads it, or refused with an InputError
naming the file, the line, the element, what is supported and the way out; nothing is read
and then ignored, and unknown properties are refused (Mitsuba refuses them too).

Mapped:

* ``<scene version>`` (required, as in Mitsuba; 2.x and 3.x; older files use Mitsuba 0.x's
  names and are refused) with ``<default name value>`` parameters (``$name`` in any
  attribute), values and transforms as :mod:`.xml_values` reads them;
  ``<path value>`` folders searched for the files the scene names and ``<include filename>``
  read in place (:meth:`.xml_values.XmlReader.expand`);
* the ``perspective`` sensor, ``hdrfilm``, ``box`` rfilter, sampler (``sample_count`` to
  samples per pixel) and ``path`` / ``ptracer`` integrator (``max_depth`` to the specular
  depth), as :mod:`.sensor` maps them, clip planes included;
* shapes as :mod:`.shapes` makes them (``ply``, ``obj``, ``serialized``, ``rectangle``, ``disk``,
  ``cylinder``, ``sphere``, ``cube``), and a ``shapegroup``'s shapes placed by each
  ``instance``; each with a BSDF inline or by ``<ref id>``, and an area emitter inside or a
  top-level one by ``<ref id>``;
* BSDFs ``diffuse`` (``reflectance``), ``conductor`` with ``material = none`` (Mitsuba's
  default; ``specular_reflectance``) and ``dielectric`` (``int_ior`` a number or a name of
  :data:`.bsdfs.IORS`, ``ext_ior`` within 0.001 of 1, ``specular_transmittance``), possibly inside ``twosided`` (one BSDF for both
  faces).  A bare ``diffuse`` is one-sided, as in Mitsuba (``sided = "one"``: black seen or
  lit from the back, the side opposite its face normal, which ``flip_normals`` turns over);
  inside ``twosided`` it reflects on both faces.  Mirrors and glass are two-sided in
  blockhash, bare or wrapped (Mitsuba's bare ``conductor`` is black from behind: wrap it in
  ``twosided`` where its back face is seen or lit);
* emitters ``point`` (``position`` or ``to_world``, not both, as in Mitsuba;
  ``intensity``), ``spot`` (``to_world``, ``intensity``, ``cutoff_angle``,
  ``beam_width`` with its linear falloff) and
  ``directional`` (``direction`` or ``to_world``'s +z, not both; ``irradiance``), ``envmap``
  (``filename``, ``scale``, ``to_world``'s rotation: an
  :class:`blockhash.scene.environment_light.EnvironmentLight`), ``constant`` (an environment
  light of that radiance everywhere, :mod:`.environment`), and an
  ``area`` emitter inside a shape (``radiance``; the shape becomes an
  :class:`blockhash.scene.model.AreaLight`, emitting from its front face, and keeps its BSDF
  for the light it reflects).  An emitter's ``<spectrum value="v"/>`` is a flat spectrum,
  v * (1.2048, 0.9483, 0.9089) in RGB as in Mitsuba's RGB variants
  (:data:`.xml_values.FLAT_EMITTER_RGB`); a spectrum of wavelength:value pairs as those
  variants take it (:mod:`.spectra`).

Refused: every other element, plugin type and property (an area emitter on a mirror or glass shape, textures but a bitmap or a checkerboard where :mod:`.textures` takes them, media, rough
or measured BSDFs, other sensors and integrators, filters other than box, tent and
Gaussian, spectra from a file, a sensor to_world with scale, shear or a mirror flip,
clip planes that would clip the scene, more than 1024 samples a pixel, depths its
camera rays cannot follow), and a scene with no emitter or no shape (blockhash renders
light on surfaces).

A file written by :mod:`.exporter` carries the photon settings, the samples per pixel
and the description in a comment; they are read back from it (the file's ``sample_count``
and ``max_depth`` are then those the export wrote for Mitsuba's own render, and an edited
one is refused).
"""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np

from blockhash.errors import InputError
from blockhash.scene.mitsuba import emitters as mitsuba_emitters
from blockhash.scene.mitsuba import environment as mitsuba_environment
from blockhash.scene.mitsuba import integrator as mitsuba_integrator
from blockhash.scene.mitsuba import sensor as mitsuba_sensor
from blockhash.scene.mitsuba.bsdfs import TwoFaced, two_sheets
from blockhash.scene.mitsuba.bsdfs import bsdf as read_bsdf
from blockhash.scene.mitsuba.exporter import METADATA_MARK
from blockhash.scene.mitsuba.shapes import (
    PROPERTIES,
    SHAPES,
    placed,
    shape_mesh,
    textured_meshes,
    uv_mesh,
)
from blockhash.scene.mitsuba.textures import TexturedDiffuse
from blockhash.scene.mitsuba.xml_values import XmlReader, parse
from blockhash.scene.model import PhongMaterial, PhotonSettings, Scene, SceneObject

#: The elements a scene's top level takes.
ELEMENTS = ("default", "path", "include", "integrator", "sensor", "sampler", "texture", "bsdf",
            "emitter", "shape")


class _Reader(XmlReader):
    def shape(self, el, bsdfs: dict, index: int, areas: dict):
        """(objects, their AreaLight or None) of a ``<shape>``: one object, or two for a
        checkerboard's colours (:mod:`.textures`); ``areas``: the top-level area emitters by
        id, which a shape takes by ``<ref id>`` as its own."""
        kind = el.get("type")
        if kind not in SHAPES:
            self.fail(el, f"unsupported shape; supported: {', '.join(SHAPES)}, and shapegroup "
                      "with instance")
        allowed = {"to_world": ("transform",), "flip_normals": ("boolean",), **PROPERTIES.get(kind, {})}
        p = self.props(el, allowed, children=("bsdf", "ref", "emitter"))
        material = emitter = None
        for kid in p["<children>"]:
            if kid.tag == "emitter":
                if emitter is not None:
                    self.fail(kid, "a shape takes one emitter; keep one")
                emitter = kid
                continue
            if kid.tag == "ref" and self.attr(kid, "id") in areas:
                if emitter is not None:
                    self.fail(kid, "a shape takes one emitter; keep one")
                emitter = areas[self.attr(kid, "id")]
                self.used.add(id(emitter))
                continue
            if material is not None:
                self.fail(kid, "a shape takes one BSDF; keep one")
            if kid.tag == "ref":
                ref = self.attr(kid, "id")
                if ref not in bsdfs:
                    self.fail(kid, f"no BSDF with id {ref!r}; defined: "
                              f"{', '.join(bsdfs) or 'none'}")
                material = bsdfs[ref]
            else:
                material = read_bsdf(self, kid, "")
        if material is None:  # Mitsuba's default: a one-sided diffuse, 0.5 (0 on an emitter)
            material = self.build(el, PhongMaterial, kd=np.full(3, 0.0 if emitter is not None
                                                               else 0.5), ks=0.0, n=0.0,
                                  sided="one")
        name = el.get("id") or f"{kind}-{index}"
        if isinstance(material, (TexturedDiffuse, TwoFaced)):  # two objects of plain materials
            textured = isinstance(material, TexturedDiffuse)
            if emitter is not None:
                what = ("a textured reflectance" if textured else "a twosided of two BSDFs")
                self.fail(emitter, f"an area emitter on a shape with {what} is not supported; "
                          "give the emitting shape one plain BSDF")
            if textured:
                parts = zip(("color0", "color1"), material.materials(),
                            textured_meshes(self, el, kind, p, material.checker))
            else:
                parts = zip(("front", "back"), (material.front, material.back),
                            two_sheets(shape_mesh(self, el, kind, p)))
            return [self.build(el, SceneObject, name=f"{name}/{part}", mesh=mesh, material=m)
                    for part, m, mesh in parts if mesh is not None], None
        if getattr(material, "texture", None) is not None:  # a bitmap: the mesh's coordinates
            if emitter is not None:
                self.fail(emitter, "an area emitter on a shape with a textured reflectance is "
                          "not supported; give the emitting shape one plain BSDF")
            mesh, uv = uv_mesh(self, el, kind, p)
            return [self.build(el, SceneObject, name=name, mesh=mesh, material=material,
                               uv=uv)], None
        uv = None
        if emitter is not None and mitsuba_emitters.textured(emitter):  # its coordinates
            mesh, uv = uv_mesh(self, el, kind, p)
        else:
            mesh = shape_mesh(self, el, kind, p)
        obj = self.build(el, SceneObject, name=name, mesh=mesh, material=material)
        if emitter is None:
            return [obj], None
        return [obj], mitsuba_emitters.area(self, emitter, obj, uv)

    def instance(self, el, groups: dict, index: int) -> list:
        """The objects of the ``shapegroup`` an ``<shape type="instance">`` refers to, each
        placed by the instance's ``to_world`` (after its own) and named ``instance/shape``."""
        p = self.props(el, {"to_world": ("transform",)}, children=("ref",))
        refs = p["<children>"]
        if len(refs) != 1:
            self.fail(el, "an instance takes exactly one <ref id> to a shapegroup")
        gid = self.attr(refs[0], "id")
        if gid not in groups:
            self.fail(refs[0], f"no shapegroup with id {gid!r} before it; defined: "
                      f"{', '.join(groups) or 'none'}")
        name = el.get("id") or f"instance-{index}"
        return [self.build(el, SceneObject, name=f"{name}/{obj.name}",
                           mesh=placed(self, el, obj.mesh, p.get("to_world")), material=obj.material)
                for obj in groups[gid]]

    def group(self, el, bsdfs: dict) -> list:
        """The shapes of a ``<shape type="shapegroup">`` (drawn only through instances)."""
        self.attr(el, "id")
        p = self.props(el, {}, children=("shape",))
        if not p["<children>"]:
            self.fail(el, "an empty shapegroup; put the shapes it instances inside it")
        out = []
        for i, kid in enumerate(p["<children>"]):
            if kid.get("type") in ("shapegroup", "instance"):
                self.fail(kid, "a shapegroup holds plain shapes (Mitsuba refuses nested groups "
                          "and instances too)")
            objs, area = self.shape(kid, bsdfs, i, {})
            if area is not None:
                self.fail(kid, "an emitter inside a shapegroup (Mitsuba refuses it too); put the "
                          "emitting shape outside the group")
            out.extend(objs)
        return out


def _metadata(root) -> dict:
    """The settings an export left in its comment (module docstring), {} if none."""
    for el in root:
        text = (el.text or "").strip() if not isinstance(el.tag, str) else ""
        if text.startswith(METADATA_MARK):
            try:
                return json.loads(text[len(METADATA_MARK):])
            except json.JSONDecodeError:
                return {}
    return {}


def _version(r: _Reader, root) -> None:
    v = root.get("version")
    if v is None:
        r.fail(root, "missing version attribute (Mitsuba refuses it too); write "
               "<scene version=\"3.0.0\">")
    m = re.fullmatch(r"(\d+)\.(\d+)\.(\d+)", v.strip())
    if not m:
        r.fail(root, f"version {v!r}: expected major.minor.patch, e.g. 3.0.0")
    if int(m.group(1)) < 2:
        r.fail(root, f"version {v}: a file for Mitsuba 0.x, whose property names Mitsuba 3 "
               "upgrades (toWorld, ...) and blockhash does not; write Mitsuba 3's names and "
               "version 3.0.0")


def _exported_settings(r: _Reader, meta: dict, render) -> None:
    """In an exported file, the sample_count and max_depth the export wrote (or an error)."""
    if "photons" not in meta:
        return
    s = render.sampler
    count = next((k for k in s if k.get("name") == "sample_count"), None) if s is not None else None
    if count is not None and r.raw.get(id(count), {}).get("value") != "$spp":
        r.fail(count, "sample_count was edited after blockhash's export, whose comment sets the "
               "samples per pixel; delete the 'blockhash:' comment to use sample_count")
    depth = meta["photons"].get("max_bounces")
    if render.max_depth is not None and depth is not None and render.max_depth != depth + 2:
        r.fail(render.integrator, "max_depth was edited after blockhash's export, whose "
               f"comment sets the photons' depth ({depth} specular events, max_depth "
               f"{depth + 2}); delete the 'blockhash:' comment to use max_depth")


def load_mitsuba(path, defines: dict | None = None) -> Scene:
    """The scene of the Mitsuba 3 XML file at ``path`` (module docstring); ``defines``: its
    parameters, name -> value, over its ``<default>``s (Mitsuba's ``-D name=value``)."""
    path = Path(path)
    root, lines = parse(path)
    r = _Reader(path, lines)
    for name, value in (defines or {}).items():
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", str(name)):
            raise InputError(f"{path}: parameter name {name!r}: expected a name such as spp "
                             "(letters, digits and _)")
        r.defaults[str(name)] = str(value)
    if root.tag != "scene":
        r.fail(root, "expected <scene> at the top")
    _version(r, root)
    r.expand(root)
    r.substitute(root)
    meta = _metadata(root)
    render, integrator, lights, objects, bsdfs, groups, areas = None, None, [], [], {}, {}, {}
    constant = None
    r.used = set()  # the top-level area emitters a shape took
    # What a <ref id> may name is read first: Mitsuba resolves references after the whole file,
    # so a shape may name a BSDF, an area emitter or a sampler defined below it.
    for el in root:
        if el.tag == "emitter" and el.get("type") == "area" and el.get("id"):
            areas[el.get("id")] = el  # a shape takes it by <ref id>
        elif el.tag == "sampler" and el.get("id"):
            r.samplers[el.get("id")] = el  # a sensor takes it by <ref id>
        elif el.tag == "texture" and el.get("id"):
            r.textures[el.get("id")] = el  # a BSDF takes it by <ref id>
    for el in root:
        if el.tag == "bsdf":
            bid = r.attr(el, "id")
            bsdfs[bid] = read_bsdf(r, el, bid)
    referred = {id(v) for v in (*areas.values(), *r.samplers.values(), *r.textures.values())}
    for el in root:
        if not isinstance(el.tag, str) or el.tag in ("default", "bsdf") or id(el) in referred:
            continue
        if el.tag == "integrator":
            if integrator is not None:
                r.fail(el, "a second integrator; a scene takes one")
            integrator = mitsuba_integrator.integrator(r, el)
        elif el.tag == "sensor":
            if render is not None:
                r.fail(el, "a second sensor; blockhash renders one camera")
            render = mitsuba_sensor.sensor(r, el)
        elif el.tag in ("sampler", "texture"):
            r.fail(el, f"a {el.tag} at the top of the scene is taken by <ref id>; give it an id "
                   "and refer to it, or move it where it is used")
        elif el.tag == "emitter" and el.get("type") == "constant":
            if constant is not None:
                r.fail(el, "a second constant emitter; give one (the sum of their radiances)")
            constant = el
        elif el.tag == "emitter":
            lights.append(mitsuba_emitters.emitter(r, el))
        elif el.tag == "shape" and el.get("type") == "shapegroup":
            groups[r.attr(el, "id")] = r.group(el, bsdfs)
        elif el.tag == "shape" and el.get("type") == "instance":
            objects.extend(r.instance(el, groups, len(objects)))
        elif el.tag == "shape":
            objs, area = r.shape(el, bsdfs, len(objects), areas)
            objects.extend(objs)
            if area is not None:
                lights.append(area)
        else:
            r.fail(el, f"unsupported element; supported: {', '.join(ELEMENTS)}")
    for el in areas.values():
        if id(el) not in r.used:
            r.fail(el, "an area emitter no shape refers to: it belongs to a <shape> (the surface "
                   f"that emits); add <ref id=\"{el.get('id')}\"/> inside that shape")
    if render is None:
        r.fail(root, "no <sensor>; add a perspective sensor")
    if constant is not None:
        mitsuba_environment.add_constant(r, constant, lights)
    if not lights:
        r.fail(root, "no <emitter>: blockhash renders the light of point, spot, directional "
               "and area emitters; add one (an area emitter goes inside a shape)")
    if not objects:
        r.fail(root, "no <shape>; add the shapes the light falls on")
    if integrator is not None:
        render.max_depth, render.integrator = integrator
    mitsuba_sensor.check_clip(r, render, objects)
    camera = render.camera
    if "photons" in meta:
        _exported_settings(r, meta, render)
        photons = PhotonSettings(**meta["photons"])
        spp = meta.get("spp")
    else:
        glass = any(o.is_dielectric for o in objects)
        bounces, camera_bounces, direct = mitsuba_integrator.depths(
            r, render, glass, any(o.is_specular for o in objects))
        unbounded = render.max_depth in (None, -1)  # Mitsuba's paths end by roulette alone
        photons = PhotonSettings(max_bounces=bounces, camera_bounces=camera_bounces,
                                 direct_only=direct,
                                 indirect_events=mitsuba_integrator.UNBOUNDED_EVENTS if unbounded
                                 else None)
        spp = render.spp
    if spp:
        camera = replace(camera, spp=spp)
    try:
        return Scene(camera=camera, lights=tuple(lights), objects=tuple(objects), photons=photons,
                     path=path, description=str(meta.get("description", "")))
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


__all__ = ["load_mitsuba"]


