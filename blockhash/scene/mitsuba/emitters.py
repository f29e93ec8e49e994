"""Mitsuba 3's emitters (for :mod:`.importer`): :func:`emitter` the top-level ones, :func:`area`
an ``area`` emitter inside a shape."""

from __future__ import annotations

import math

import numpy as np

from blockhash.scene.lights import falloff_solid_angle
from blockhash.scene.mitsuba import environment as mitsuba_environment
from blockhash.scene.model import AreaLight, DirectionalLight, PointLight, SpotLight

#: The top-level emitters blockhash models (an ``area`` emitter goes inside a shape; a
#: ``constant`` one is read by the importer, beside an ``envmap``).
EMITTERS = ("point", "spot", "directional", "envmap")


def emitter(r, el):
    """The light of a top-level ``<emitter>``: ``point``, ``spot`` (with a projected
    ``texture``), ``directional`` or ``envmap``; every other type an error naming it."""
    kind = el.get("type")
    if kind == "area":
        r.fail(el, "an area emitter belongs inside a <shape> (the surface that emits); "
               "move it into one, or give it an id and <ref id> it from the shape")
    if kind not in EMITTERS:
        r.fail(el, f"unsupported emitter; supported: {', '.join(EMITTERS)}, constant, "
               "and area inside a shape (blockhash's lights)")
    spectra = ("rgb", "spectrum", "float")
    if kind == "envmap":
        return mitsuba_environment.envmap(r, el)
    if kind == "directional":
        p = r.props(el, {"direction": ("vector",), "irradiance": spectra,
                         "to_world": ("transform",)}, children=("texture",), emitter=True)
        no_texture(r, el, p, "irradiance")
        if "direction" in p and "to_world" in p:
            r.fail(el, "only one of direction and to_world can be given (Mitsuba refuses "
                   "both too); keep one")
        d = (p["to_world"][:3, :3] @ [0.0, 0.0, 1.0] if "to_world" in p
             else p.get("direction", np.array([0.0, 0.0, 1.0])))
        return r.build(el, DirectionalLight, direction=d,
                       irradiance=np.broadcast_to(p.get("irradiance", 1.0), (3,)))
    if kind == "point":
        p = r.props(el, {"position": ("point",), "intensity": spectra,
                         "to_world": ("transform",)}, emitter=True)
        if "position" in p and "to_world" in p:
            r.fail(el, "only one of position and to_world can be given (Mitsuba refuses "
                   "both too); keep one")
        pos = p["to_world"][:3, 3] if "to_world" in p else p.get("position", np.zeros(3))
        power = np.broadcast_to(p.get("intensity", 1.0), (3,)) * 4.0 * math.pi
        return r.build(el, PointLight, position=pos, power=power)
    p = r.props(el, {"intensity": spectra, "to_world": ("transform",),
                     "cutoff_angle": ("float",), "beam_width": ("float",),
                     "texture": ("texture",)}, emitter=True)
    cone = float(p.get("cutoff_angle", 20.0))
    beam = float(p.get("beam_width", cone * 0.75))  # Mitsuba's default: 3/4 of the cutoff
    if beam > cone:
        r.fail(el, f"beam_width {beam:g} exceeds cutoff_angle {cone:g}; give a beam_width "
               "at most the cutoff angle")
    m = p.get("to_world", np.eye(4))
    axis = m[:3, :3] @ [0.0, 0.0, 1.0]
    # Mitsuba's intensity is the beam's peak
    power = np.broadcast_to(p.get("intensity", 1.0), (3,)) * falloff_solid_angle(cone, beam)
    texture = frame = None
    if "texture" in p:  # projected across the cone, in the to_world's axes
        texture = light_texture(r, p["texture"])
        frame = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
        if not np.allclose(frame.T @ frame, np.eye(3), atol=1e-6):
            r.fail(el, "a textured spot's to_world must turn and move it only (no shear); "
                   "give it by lookat")
    return r.build(el, SpotLight, position=m[:3, 3], direction=axis, power=power,
                   cone_deg=cone, beam_deg=beam, texture=texture, frame=frame)


def light_texture(r, el):
    """The :class:`blockhash.scene.texture.Texture` of a light's texture (a spot's ``texture``,
    an area emitter's ``radiance``): a ``bitmap`` (its values any >= 0), else an error naming
    the kind."""
    from blockhash.scene.mitsuba.textures import bitmap

    if el.tag == "ref":
        tid = r.attr(el, "id")
        if tid not in r.textures:
            r.fail(el, f"no texture with id {tid!r}; defined: {', '.join(r.textures) or 'none'}")
        el = r.textures[tid]
    if el.get("type") != "bitmap":
        r.fail(el, f"a {el.get('type')} texture on a light is not supported; supported: "
               "bitmap")
    return bitmap(r, el, bounded=False)


def textured(el) -> bool:
    """An ``<emitter>`` element gives its ``radiance`` by a texture."""
    return any(kid.tag in ("texture", "ref") and kid.get("name") == "radiance" for kid in el)


def area(r, el, obj, uv=None):
    """The AreaLight of an ``<emitter type="area">`` inside the shape of ``obj``; a bitmap
    ``radiance`` looked up at ``uv``, the shape's texture coordinates (its mean the light's
    ``radiance``)."""
    kind = el.get("type")
    if kind != "area":
        r.fail(el, f"a {kind!r} emitter inside a shape; the emitter inside a shape is "
               "area (a point, spot or directional emitter goes at the top level)")
    if obj.is_specular:
        what = "glass (dielectric)" if obj.is_dielectric else "mirror (conductor)"
        r.fail(el, f"an area emitter on a {what} shape: blockhash's emitters are diffuse "
               "surfaces; give the emitting shape a diffuse BSDF (or none, Mitsuba's "
               "default)")
    p = r.props(el, {"radiance": ("rgb", "spectrum", "float", "texture")}, emitter=True)
    if textured(el):
        texture = light_texture(r, p["radiance"])
        return r.build(el, AreaLight, object=obj.name, mesh=obj.mesh, radiance=texture.mean,
                       texture=texture, uv=uv)
    return r.build(el, AreaLight, object=obj.name, mesh=obj.mesh,
                   radiance=np.broadcast_to(p.get("radiance", 1.0), (3,)))


def no_texture(r, el, p: dict, name: str) -> None:
    """An error at a texture given for ``name`` (an emitter's value that blockhash keeps as one
    RGB value)."""
    for kid in p["<children>"]:
        r.fail(kid, f"a textured {name} is not supported: blockhash's lights emit one "
               f"RGB value; give <rgb name=\"{name}\" value=\"r, g, b\"/>")
