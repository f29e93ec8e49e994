"""A scene as a Mitsuba 3 XML file (``blockhash export SCENE --to mitsuba -o DIR``).

What is written, into ``DIR``:

* ``scene.xml``: a ``perspective`` sensor (``lookat`` from the camera's eye, target and up;
  ``fov`` on the y axis; an ``hdrfilm`` of the camera's size with its pixel filter (``box``, the
  pixel mean, unless the camera names a ``tent`` or ``gaussian``); an ``independent`` sampler whose ``sample_count`` is the
  variable ``spp``), a ``ptracer`` integrator of the scene's specular depth, one BSDF per
  material, the lights and one ``ply`` shape per object.
* ``meshes/NAME.ply``: each object's mesh in world coordinates with its vertex normals
  (binary PLY, trimesh).

Materials: ``phong`` with ks = 0 becomes ``diffuse`` (reflectance kd), inside a ``twosided``
when it reflects on both faces (``sided = "two"``, the TOML default) and bare when on its
front face only (``sided = "one"``), as Mitsuba reads them; ``mirror`` becomes
``conductor`` with ``material = none`` and its reflectance as ``specular_reflectance``;
``dielectric`` becomes ``dielectric`` (``int_ior`` its ior, ``ext_ior`` 1, the outside being
vacuum as in blockhash, ``specular_transmittance`` its tint).  Mitsuba has no modified Phong:
a material with ks > 0 is an error unless ``drop_specular`` is set, in which case the lobe is
left out and the XML says so in a comment beside the BSDF.

Lights: a point light of power P becomes a ``point`` emitter of intensity P / (4 pi); a spot
light of power P in a cone of half angle c becomes a ``spot`` emitter of intensity
P / (2 pi (1 - cos c)) with ``cutoff_angle`` = ``beam_width`` = c (uniform inside the cone,
as blockhash's).

What Mitsuba has no field for (the photon settings, the scene's samples per pixel and its
description) is kept in one XML comment that :mod:`.importer` reads back, so that
export then import gives back the same scene.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from blockhash.errors import InputError
from blockhash.scene.model import (
    AreaLight,
    DielectricMaterial,
    DirectionalLight,
    EnvironmentLight,
    MirrorMaterial,
    PhongMaterial,
    Scene,
    SpotLight,
)

#: The marker of the comment that carries what Mitsuba has no field for.
METADATA_MARK = "blockhash:"
#: Mitsuba's sample count unless ``spp`` is given on its command line (``-D spp=N``).
DEFAULT_MITSUBA_SPP = 64


def _num(x: float) -> str:
    return repr(float(x))


def _rgb(name: str, value) -> str:
    v = np.asarray(value, dtype=np.float64).reshape(-1)
    return f'<rgb name="{name}" value="{", ".join(_num(c) for c in v)}"/>'


def _vec(v) -> str:
    return ", ".join(_num(c) for c in np.asarray(v, dtype=np.float64))


def mesh_file_name(name: str) -> str:
    """The PLY file an object's mesh is written to, under ``meshes/``: its name with every
    character outside ``[A-Za-z0-9_.-]`` replaced by ``_``."""
    return "meshes/" + re.sub(r"[^A-Za-z0-9_.-]", "_", name) + ".ply"


def texture_file_name(bsdf_id: str) -> str:
    """The EXR a textured material's image is written to, under ``textures/``."""
    return "textures/" + re.sub(r"[^A-Za-z0-9_.-]", "_", bsdf_id) + ".exr"


def light_texture_file(light) -> str:
    """The EXR a light's texture (a spot's, an area light's radiance) is written to, under
    ``textures/``, named by its content."""
    import hashlib

    digest = hashlib.sha1(np.ascontiguousarray(light.texture.image).tobytes()).hexdigest()[:12]
    return f"textures/light-{digest}.exr"


def _matrix(m: np.ndarray) -> str:
    """A 4 x 4 matrix as Mitsuba's ``<matrix value>``, row by row."""
    return " ".join(_num(v) for v in np.asarray(m).reshape(-1))


def _bitmap_lines(t, filename: str, name: str) -> list[str]:
    """The ``<texture type="bitmap">`` lines of texture ``t`` read from ``filename``."""
    m = np.eye(4)
    m[:2, :2], m[:2, 3] = t.to_uv[:, :2], t.to_uv[:, 2]
    return [f'    <texture type="bitmap" name="{name}">',
            f'        <string name="filename" value={quoteattr(filename)}/>',
            f'        <string name="filter_type" value="{t.filter}"/>',
            f'        <string name="wrap_mode" value="{t.wrap}"/>',
            '        <transform name="to_uv">',
            f'            <matrix value="{_matrix(m)}"/>',
            "        </transform>", "    </texture>"]


def _rough(material) -> tuple[str, list[str]]:
    """(``"rough"`` or ``""``, the lines of a rough mirror's, glass's or coat's microfacets)."""
    if not material.alpha:
        return "", []
    return "rough", [f'    <string name="distribution" value="{material.distribution}"/>',
                     f'    <float name="alpha" value="{_num(material.alpha)}"/>']


def _bsdf(material, bsdf_id: str, drop_specular: bool, owner: str) -> list[str]:
    if isinstance(material, MirrorMaterial):
        metal = ([f"    {_rgb('eta', material.eta)}", f"    {_rgb('k', material.k)}"]
                 if material.is_conductor else [])
        rough, micro = _rough(material)
        return [f'<bsdf type="{rough}conductor" id={quoteattr(bsdf_id)}>',
                '    <string name="material" value="none"/>', *metal, *micro,
                "    " + _rgb("specular_reflectance", material.reflectance), "</bsdf>"]
    if isinstance(material, DielectricMaterial):
        rough, micro = _rough(material)
        return [f'<bsdf type="{rough}dielectric" id={quoteattr(bsdf_id)}>',
                f'    <float name="int_ior" value="{_num(material.ior)}"/>',
                '    <float name="ext_ior" value="1.0"/>', *micro,
                "    " + _rgb("specular_transmittance", material.tint), "</bsdf>"]
    if not isinstance(material, PhongMaterial):
        raise InputError(f"object {owner!r}: material {material!r} has no Mitsuba equivalent")
    if material.coat:
        return _plastic(material, bsdf_id, owner)
    lines = []
    if np.any(material.ks > 0):
        if not drop_specular:
            raise InputError.about(
                "object {owner!r}: its modified Phong material has ks = {ks} > 0, and Mitsuba 3 "
                "has no modified Phong BSDF; export with {drop_specular:on} to write it as "
                "'diffuse' (kd only), or set ks = 0 in the scene", owner=owner,
                ks=np.round(material.ks, 6).tolist())
        lines.append(f"<!-- {escape(owner)}: the modified Phong lobe ks = "
                     f"{np.round(material.ks, 6).tolist()}, n = {material.n:g} is dropped "
                     "(Mitsuba has no modified Phong); diffuse kd only -->")
    diffuse = ['<bsdf type="diffuse">', "    " + _rgb("reflectance", material.kd), "</bsdf>"]
    if material.texture is not None:  # its image written by export_mitsuba
        diffuse[1:2] = _bitmap_lines(material.texture, texture_file_name(bsdf_id),
                                     "reflectance")
    if material.one_sided:  # Mitsuba's diffuse is one-sided
        return lines + [diffuse[0][:-1] + f" id={quoteattr(bsdf_id)}>", *diffuse[1:]]
    return lines + [f'<bsdf type="twosided" id={quoteattr(bsdf_id)}>',
                    *("    " + line for line in diffuse), "</bsdf>"]


def _plastic(material, bsdf_id: str, owner: str) -> list[str]:
    """A coated receiver as Mitsuba's ``plastic`` or ``roughplastic`` (its base reflectance from ``kd``:
    :func:`blockhash.scene.coat.base_reflectance`), one-sided or inside ``twosided``."""
    from blockhash.scene.coat import base_reflectance

    if material.texture is not None:
        raise InputError(f"object {owner!r}: a textured base under a coat is not exported (its "
                         "texture holds what the coat lets through, not Mitsuba's "
                         "diffuse_reflectance); export the scene's Mitsuba file as it was read")
    rough, micro = _rough(material)
    base = base_reflectance(material.kd, material.coat, alpha=material.alpha,
                            distribution=material.distribution)
    lines = [f'<bsdf type="{rough}plastic">', "    " + _rgb("diffuse_reflectance", base),
             f'    <float name="int_ior" value="{_num(material.coat)}"/>',
             '    <float name="ext_ior" value="1.0"/>', *micro,
             "    " + _rgb("specular_reflectance", material.coat_reflectance), "</bsdf>"]
    if material.one_sided:
        return [lines[0][:-1] + f" id={quoteattr(bsdf_id)}>", *lines[1:]]
    return [f'<bsdf type="twosided" id={quoteattr(bsdf_id)}>', *("    " + x for x in lines),
            "</bsdf>"]


#: The file an environment light's map is written to, beside ``scene.xml``.
ENVIRONMENT_FILE = "environment.exr"


def _emitter(light) -> list[str]:
    if isinstance(light, AreaLight):
        return []  # written inside its shape (scene_xml)
    if isinstance(light, EnvironmentLight):  # its map written by export_mitsuba
        m = np.eye(4)
        m[:3, :3] = light.to_world
        return ['<emitter type="envmap">',
                f'    <string name="filename" value="{ENVIRONMENT_FILE}"/>',
                '    <transform name="to_world">',
                f'        <matrix value="{_matrix(m)}"/>',
                "    </transform>", "</emitter>"]
    if isinstance(light, DirectionalLight):
        return ['<emitter type="directional">',
                f'    <vector name="direction" x="{_num(light.direction[0])}" '
                f'y="{_num(light.direction[1])}" z="{_num(light.direction[2])}"/>',
                "    " + _rgb("irradiance", light.irradiance), "</emitter>"]
    power = np.asarray(light.power, dtype=np.float64)
    if isinstance(light, SpotLight):
        cone = float(light.cone_deg)
        intensity = light.peak_intensity
        target = np.asarray(light.position) + np.asarray(light.direction)
        up = (0.0, 1.0, 0.0) if abs(float(light.direction[1])) < 0.9 else (1.0, 0.0, 0.0)
        place = [f'        <lookat origin="{_vec(light.position)}" target="{_vec(target)}" '
                 f'up="{_vec(up)}"/>']
        texture = []
        if light.texture is not None:  # its frame's axes orient the texture: the whole matrix
            m = np.eye(4)
            m[:3, :3], m[:3, 3] = light.frame, light.position
            place = [f'        <matrix value="{_matrix(m)}"/>']
            texture = _bitmap_lines(light.texture, light_texture_file(light), "texture")
        return ['<emitter type="spot">',
                '    <transform name="to_world">',
                *place,
                "    </transform>", *texture,
                "    " + _rgb("intensity", intensity),
                f'    <float name="cutoff_angle" value="{_num(cone)}"/>',
                f'    <float name="beam_width" value="{_num(light.beam_deg)}"/>', "</emitter>"]
    x, y, z = (float(c) for c in light.position)
    return ['<emitter type="point">',
            f'    <point name="position" x="{_num(x)}" y="{_num(y)}" z="{_num(z)}"/>',
            "    " + _rgb("intensity", power / (4.0 * math.pi)), "</emitter>"]


def scene_xml(scene: Scene, *, drop_specular: bool = False, spp: int = DEFAULT_MITSUBA_SPP,
              integrator: str = "ptracer", max_depth: int | None = None) -> str:
    """The Mitsuba 3 XML text of ``scene`` (module docstring); meshes are referenced as
    :func:`mesh_file_name` gives them, relative to the XML file.  ``max_depth``: the
    integrator's (default the scene's specular events per photon plus 2: light, the
    specular chain, one diffuse vertex, the camera)."""
    c = scene.camera
    p = scene.photons
    depth = int(p.max_bounces) + 2 if max_depth is None else int(max_depth)
    meta = {"photons": {"count": p.count, "k": p.k, "A": p.A, "seed": p.seed,
                        "max_bounces": p.max_bounces},
            "spp": c.spp, "description": scene.description}
    # A comment may not hold "--": dashes (only in strings here) become JSON's \u002d.
    note = json.dumps(meta, sort_keys=True).replace("-", "\\u002d")
    out = ['<?xml version="1.0" encoding="utf-8"?>',
           '<scene version="3.0.0">',
           f"<!-- {METADATA_MARK} {note} -->",
           f'<default name="spp" value="{int(spp)}"/>',
           f'<integrator type="{integrator}">',
           f'    <integer name="max_depth" value="{depth}"/>',
           "</integrator>",
           f'<sensor type="{"thinlens" if c.aperture_radius else "perspective"}">',
           *([f'    <float name="aperture_radius" value="{_num(c.aperture_radius)}"/>',
              f'    <float name="focus_distance" value="{_num(c.focus_distance)}"/>']
             if c.aperture_radius else []),
           f'    <float name="fov" value="{_num(c.fov_y_deg)}"/>',
           '    <string name="fov_axis" value="y"/>',
           '    <transform name="to_world">',
           f'        <lookat origin="{_vec(c.eye)}" target="{_vec(c.target)}" up="{_vec(c.up)}"/>',
           "    </transform>",
           '    <sampler type="independent">',
           '        <integer name="sample_count" value="$spp"/>',
           "    </sampler>",
           '    <film type="hdrfilm">',
           *_film_size(c),
           *_rfilter(c.filter),
           "    </film>",
           "</sensor>"]
    ids: dict[int, str] = {}
    for obj in scene.objects:
        if id(obj.material) not in ids:
            ids[id(obj.material)] = f"{obj.name}-bsdf"
            out += _bsdf(obj.material, ids[id(obj.material)], drop_specular, obj.name)
    for light in scene.lights:
        out += _emitter(light)
    areas = {light.object: light for light in scene.lights if isinstance(light, AreaLight)}
    for obj in scene.objects:
        out += [f'<shape type="ply" id={quoteattr(obj.name)}>',
                f'    <string name="filename" value={quoteattr(mesh_file_name(obj.name))}/>',
                f'    <ref id={quoteattr(ids[id(obj.material)])}/>']
        if obj.name in areas:
            light = areas[obj.name]
            radiance = (["    " + line for line in _bitmap_lines(light.texture,
                                                               light_texture_file(light),
                                                               "radiance")]
                        if light.texture is not None else
                        ["        " + _rgb("radiance", light.radiance)])
            out += ['    <emitter type="area">', *radiance, "    </emitter>"]
        out.append("</shape>")
    out.append("</scene>")
    return "\n".join(out) + "\n"


def export_mitsuba(scene: Scene, directory, *, drop_specular: bool = False,
                   spp: int = DEFAULT_MITSUBA_SPP, integrator: str = "ptracer",
                   max_depth: int | None = None) -> Path:
    """Write ``scene.xml`` and ``meshes/*.ply`` into ``directory`` (made if missing); returns
    the XML's path.  Raises InputError for a material Mitsuba cannot express (module
    docstring) before anything is written."""
    text = scene_xml(scene, drop_specular=drop_specular, spp=spp, integrator=integrator,
                     max_depth=max_depth)
    names = [mesh_file_name(o.name) for o in scene.objects]
    if len(set(names)) != len(names):
        raise InputError(f"object names {[o.name for o in scene.objects]} give the same mesh "
                         "file name twice; rename the objects so that they differ in "
                         "[A-Za-z0-9_.-]")
    root = Path(directory)
    (root / "meshes").mkdir(parents=True, exist_ok=True)
    areas = {light.object: light for light in scene.lights if isinstance(light, AreaLight)}
    for obj, name in zip(scene.objects, names):
        mesh = obj.mesh
        uv = obj.uv if obj.uv is not None else getattr(areas.get(obj.name), "uv", None)
        if uv is not None:  # the texture coordinates as the PLY's u and v
            mesh = mesh.copy()
            mesh.vertex_attributes["u"] = np.ascontiguousarray(uv[:, 0], np.float32)
            mesh.vertex_attributes["v"] = np.ascontiguousarray(uv[:, 1], np.float32)
        data = mesh.export(file_type="ply", encoding="binary", include_attributes=True,
                           vertex_normal=True)
        (root / name).write_bytes(data)
    written = set()
    for obj in scene.objects:
        t = getattr(obj.material, "texture", None)
        if t is not None and id(obj.material) not in written:
            written.add(id(obj.material))
            (root / "textures").mkdir(exist_ok=True)
            _write_map(root / texture_file_name(f"{obj.name}-bsdf"), t.image)
    for light in scene.lights:
        if isinstance(light, EnvironmentLight):
            _write_map(root / ENVIRONMENT_FILE, light.image)
        if getattr(light, "texture", None) is not None:
            (root / "textures").mkdir(exist_ok=True)
            _write_map(root / light_texture_file(light), light.texture.image)
    xml = root / "scene.xml"
    xml.write_text(text, encoding="utf-8")
    return xml


def _write_map(path: Path, image: np.ndarray) -> None:
    """An environment map or a texture as a plain RGB float EXR (channels R, G, B, as Mitsuba
    reads one: linear, as stored)."""
    import OpenImageIO as oiio

    h, w, _ = image.shape
    out = oiio.ImageOutput.create(str(path))
    if out is None or not out.open(str(path), oiio.ImageSpec(w, h, 3, oiio.FLOAT)) \
            or not out.write_image(np.ascontiguousarray(image, dtype=np.float32)):
        raise InputError(f"cannot write the environment map {str(path)!r}: {oiio.geterror()}; "
                         "check that the folder is writable")
    out.close()


def _film_size(c) -> list[str]:
    """The film's size lines: the camera's, or for a crop the whole film's (the nearest whole
    pixels) with its crop window."""
    if c.crop is None:
        return [f'        <integer name="width" value="{c.width}"/>',
                f'        <integer name="height" value="{c.height}"/>']
    x0, y0, x1, y1 = c.crop
    width, height = round(c.width / (x1 - x0)), round(c.height / (y1 - y0))
    values = {"width": width, "height": height, "crop_offset_x": round(x0 * width),
              "crop_offset_y": round(y0 * height), "crop_width": c.width, "crop_height": c.height}
    return [f'        <integer name="{k}" value="{v}"/>' for k, v in values.items()]


def _rfilter(pf) -> list[str]:
    """The ``<rfilter>`` lines of a camera's pixel filter."""
    d = pf.to_dict()
    if len(d) == 1:
        return [f'        <rfilter type="{pf.kind}"/>']
    name = next(k for k in d if k != "kind")
    return [f'        <rfilter type="{pf.kind}">',
            f'            <float name="{name}" value="{_num(d[name])}"/>',
            "        </rfilter>"]


__all__ = ["export_mitsuba", "scene_xml", "mesh_file_name", "METADATA_MARK"]

