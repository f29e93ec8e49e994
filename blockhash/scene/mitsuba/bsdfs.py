"""Mitsuba 3's BSDFs as blockhash's materials (for :mod:`.importer`): ``diffuse`` (one-sided,
as Mitsuba's; both faces inside ``twosided``), ``plastic`` and ``roughplastic`` (a diffuse
base under a smooth or rough coat: :mod:`blockhash.scene.coat`), ``conductor`` (a perfect mirror, or a smooth
metal of ``eta`` and ``k`` or a named preset), ``dielectric`` (``int_ior`` a number or one of
Mitsuba's named indices), ``roughconductor`` and ``roughdielectric`` (the same with isotropic
microfacets: :mod:`blockhash.scene.microfacet`) and ``twosided`` around one of them, or around two diffuse ones
(:class:`TwoFaced`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blockhash.scene.mitsuba.spectra import conductor_preset, conductor_presets
from blockhash.scene.mitsuba.textures import Checkerboard, TexturedDiffuse, texture
from blockhash.scene.model import DielectricMaterial, MirrorMaterial, PhongMaterial

BSDFS = ("diffuse", "plastic", "roughplastic", "conductor", "roughconductor", "dielectric",
         "roughdielectric", "twosided")
#: What a rough BSDF reads of its microfacets (:func:`roughness`).
ROUGHNESS = {"distribution": ("string",), "alpha": ("float", "texture"),
             "alpha_u": ("float", "texture"), "alpha_v": ("float", "texture"),
             "sample_visible": ("boolean",)}
#: The indices of refraction Mitsuba 3 names (its documentation's table of the dielectric
#: BSDF, at 589 nm), for int_ior and ext_ior.
IORS = {"vacuum": 1.0, "helium": 1.000036, "hydrogen": 1.000132, "air": 1.000277,
        "carbon dioxide": 1.00045, "water": 1.3330, "acetone": 1.36, "ethanol": 1.361,
        "carbon tetrachloride": 1.461, "glycerol": 1.4729, "benzene": 1.501,
        "silicone oil": 1.52045, "bromine": 1.661, "water ice": 1.31, "fused quartz": 1.458,
        "pyrex": 1.470, "acrylic glass": 1.49, "polypropylene": 1.49, "bk7": 1.5046,
        "sodium chloride": 1.544, "amber": 1.55, "pet": 1.5750, "diamond": 2.419}


def bsdf(r, el, key: str, *, twosided: bool = False):
    """The material of a ``<bsdf>`` (``key`` its id, for messages), as Mitsuba reads it
    (:mod:`.importer`'s docstring lists what is read); ``r`` the file's reader."""
    kind = el.get("type")
    if kind == "twosided":
        inner = [k for k in el if isinstance(k.tag, str)]
        if not 1 <= len(inner) <= 2 or any(k.tag != "bsdf" for k in inner):
            r.fail(el, "expected one <bsdf> inside (the same on both faces) or two (the front's, "
                   "then the back's)")
        if twosided:
            r.fail(el, "a twosided inside a twosided; keep one")
        if len(inner) == 1:
            return bsdf(r, inner[0], key, twosided=True)
        faces = [bsdf(r, k, key) for k in inner]  # each one-sided
        if not all(isinstance(m, PhongMaterial) for m in faces):
            r.fail(el, "a twosided of two BSDFs is read for two diffuse ones (a front and a "
                   "back reflectance); give each face a diffuse BSDF, or one BSDF for both")
        return TwoFaced(*faces)
    if kind == "diffuse":
        p = r.props(el, {"reflectance": ("rgb", "spectrum", "float", "texture")})
        kd = p.get("reflectance", 0.5)
        if not isinstance(kd, (float, np.ndarray)):  # a texture's element
            tex = texture(r, kd)
            sided = "two" if twosided else "one"
            if isinstance(tex, Checkerboard):
                return TexturedDiffuse(tex, sided)
            return r.build(el, PhongMaterial, kd=tex.mean, ks=0.0, n=0.0, sided=sided,
                           texture=tex)
        # Mitsuba's diffuse reflects on the front face only; twosided on both
        return r.build(el, PhongMaterial, kd=np.broadcast_to(kd, (3,)), ks=0.0, n=0.0,
                          sided="two" if twosided else "one")
    if kind in ("plastic", "roughplastic"):
        return plastic(r, el, twosided)
    if kind in ("conductor", "roughconductor"):
        return conductor(r, el)
    if kind in ("dielectric", "roughdielectric"):
        return dielectric(r, el)
    r.fail(el, f"unsupported BSDF; supported: {', '.join(BSDFS)}")


def plastic(r, el, twosided: bool) -> PhongMaterial:
    """A ``plastic`` or ``roughplastic`` as Mitsuba reads it: a diffuse base
    (``diffuse_reflectance``, a colour or a bitmap) under a smooth or rough (:func:`roughness`)
    coat of index ``int_ior`` (in air), which reflects with ``specular_reflectance``;
    ``nonlinear`` as Mitsuba's (:mod:`blockhash.scene.coat`).  One-sided, as Mitsuba's; both
    faces inside ``twosided``."""
    from dataclasses import replace

    from blockhash.scene.coat import coated_albedo

    rough = el.get("type") == "roughplastic"
    spectra = ("rgb", "spectrum", "float")
    p = r.props(el, {"diffuse_reflectance": (*spectra, "texture"),
                     "specular_reflectance": spectra, "int_ior": ("float", "string"),
                     "ext_ior": ("float", "string"), "nonlinear": ("boolean",),
                     **(ROUGHNESS if rough else {})})
    micro = roughness(r, el, p, rough)
    eta = ior(r, el, "int_ior", p.get("int_ior", "polypropylene"))
    ext = ior(r, el, "ext_ior", p.get("ext_ior", "air"))
    if not abs(ext - 1.0) < 1e-3:
        r.fail(el, f"ext_ior {ext!r}: blockhash's plastics sit in air (index 1); give ext_ior 1")
    eta /= ext
    nonlinear = bool(p.get("nonlinear", False))
    base = p.get("diffuse_reflectance", 0.5)
    common = {"ks": 0.0, "n": 0.0, "sided": "two" if twosided else "one", "coat": eta,
              "coat_reflectance": np.broadcast_to(p.get("specular_reflectance", 1.0), (3,)),
              **micro}
    if not isinstance(base, (float, np.ndarray)):  # a texture's element
        tex = texture(r, base)
        if isinstance(tex, Checkerboard):
            r.fail(base, "a checkerboard under a plastic's coat is not supported; give the "
                   "diffuse_reflectance as a colour or a bitmap")
        tex = replace(tex, image=coated_albedo(tex.image, eta, nonlinear, **micro), bounded=False)
        return r.build(el, PhongMaterial, kd=tex.mean, texture=tex, **common)
    return r.build(el, PhongMaterial, kd=coated_albedo(np.broadcast_to(base, (3,)), eta, nonlinear,
                                                       **micro), **common)


def dielectric(r, el) -> DielectricMaterial:
    """A ``dielectric`` or ``roughdielectric`` as Mitsuba reads it (in air: ``ext_ior`` 1)."""
    rough = el.get("type") == "roughdielectric"
    p = r.props(el, {"int_ior": ("float", "string"), "ext_ior": ("float", "string"),
                     "specular_transmittance": ("rgb", "spectrum", "float"),
                     "specular_reflectance": ("rgb", "spectrum", "float"),
                     **(ROUGHNESS if rough else {})})
    inside = ior(r, el, "int_ior", p.get("int_ior", "bk7"))  # Mitsuba's default
    ext = ior(r, el, "ext_ior", p.get("ext_ior", "air"))
    if not abs(ext - 1.0) < 1e-3:
        r.fail(el, f"ext_ior {ext!r}: blockhash's dielectrics sit in air (index 1); "
               "give ext_ior 1")
    if "specular_reflectance" in p and not np.allclose(p["specular_reflectance"], 1.0):
        r.fail(el, "specular_reflectance other than 1 is not supported")
    tint = p.get("specular_transmittance", 1.0)
    return r.build(el, DielectricMaterial, ior=float(inside),
                   tint=np.broadcast_to(tint, (3,)), **roughness(r, el, p, rough))


@dataclass(frozen=True, eq=False)
class TwoFaced:
    """A ``twosided`` of two diffuse BSDFs: ``front`` on the faces' front, ``back`` on their
    back, each one-sided.  A shape with it becomes two sheets (:func:`two_sheets`)."""

    front: PhongMaterial
    back: PhongMaterial


#: How far a two-faced shape's back sheet lies behind its front, over the shape's size: far
#: above float32's resolution at that size, far below a pixel's footprint.
SHEET_GAP = 1e-4


def two_sheets(mesh):
    """(front mesh, back mesh) of a shape whose faces reflect differently on each side: the
    mesh, and a copy turned inside out (winding and normals reversed) that lies
    :data:`SHEET_GAP` of the shape's size behind it along its normals.  Each sheet is
    one-sided, so a ray or photon meets the front's face from the front and the back's from
    the back, and never the other's."""
    from blockhash.scene.meshes import with_normals

    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    normals = np.asarray(mesh.vertex_normals, dtype=np.float64)
    size = float(np.linalg.norm(np.ptp(vertices, axis=0))) or 1.0
    back = with_normals(vertices - normals * (SHEET_GAP * size), np.asarray(mesh.faces)[:, ::-1],
                        -normals)
    return mesh, back


def conductor(r, el) -> MirrorMaterial:
    """A smooth ``conductor`` as Mitsuba reads it: ``material`` none (its default) takes
    ``eta`` (default 0) and ``k`` (default 1), a perfect mirror where neither is given;
    another ``material`` is one of Mitsuba's presets (:func:`.spectra.conductor_preset`);
    ``specular_reflectance`` scales either."""
    spectra = ("rgb", "spectrum", "float")
    rough = el.get("type") == "roughconductor"
    p = r.props(el, {"material": ("string",), "specular_reflectance": spectra,
                     "eta": spectra, "k": spectra, **(ROUGHNESS if rough else {})},
                unbounded=("eta", "k"))
    micro = roughness(r, el, p, rough)
    scale = np.broadcast_to(p.get("specular_reflectance", 1.0), (3,))
    material = p.get("material", "none")
    if material == "none":
        if "eta" not in p and "k" not in p:
            return r.build(el, MirrorMaterial, reflectance=scale, **micro)
        eta, k = p.get("eta", 0.0), p.get("k", 1.0)
    else:
        if "eta" in p or "k" in p:
            r.fail(el, f"material {material!r} and eta or k: give either a material "
                   "preset or eta and k, not both (as Mitsuba asks)")
        preset = conductor_preset(material)
        if preset is None:
            r.fail(el, f"material {material!r} is not one of Mitsuba's conductor presets "
                   f"({', '.join(conductor_presets())}, or none); give eta and k")
        eta, k = preset
    return r.build(el, MirrorMaterial, reflectance=scale, eta=np.broadcast_to(eta, (3,)),
                   k=np.broadcast_to(k, (3,)), **micro)


def roughness(r, el, p: dict, rough: bool) -> dict:
    """The microfacets of a ``roughconductor``, ``roughdielectric`` or ``roughplastic`` (none
    for a smooth BSDF) as Mitsuba reads them: ``distribution`` (``beckmann``, its default, or ``ggx``) and
    ``alpha`` (default 0.1), or ``alpha_u`` and ``alpha_v`` where they are equal (blockhash's
    rough surfaces are isotropic).  ``sample_visible`` only chooses how Mitsuba samples the
    same BSDF, and changes nothing."""
    if not rough:
        return {}
    for name in ("alpha", "alpha_u", "alpha_v"):
        if name in p and not isinstance(p[name], (int, float)):  # a texture's element
            r.fail(p[name], f"{name} given by a texture: a rough surface has one roughness "
                   f"in blockhash; give {name} as <float value=\"...\"/>, e.g. the texture's "
                   "mean")
    alpha = p.get("alpha", 0.1)
    if "alpha_u" in p or "alpha_v" in p:
        if "alpha" in p:
            r.fail(el, "alpha and alpha_u / alpha_v: give one roughness (as Mitsuba asks)")
        u, v = p.get("alpha_u", 0.1), p.get("alpha_v", 0.1)
        if not np.isclose(u, v):
            r.fail(el, f"alpha_u {u:g} and alpha_v {v:g}: anisotropic roughness is not "
                   "supported (blockhash's rough surfaces are isotropic); give one alpha, "
                   f"e.g. {float(np.sqrt(u * v)):g}")
        alpha = u
    return {"alpha": float(alpha), "distribution": p.get("distribution", "beckmann")}


def ior(r, el, name: str, value) -> float:
    """An index of refraction: a number, or a material Mitsuba names (:data:`IORS`)."""
    if not isinstance(value, str):
        return float(value)
    if value.lower() not in IORS:
        r.fail(el, f"{name} {value!r} is not one of Mitsuba's named indices of refraction "
               f"({', '.join(IORS)}); give the index as a number")
    return IORS[value.lower()]
