"""The scene file format (TOML) and its loader.

Units are metres and watts, y is up, the frame is right-handed.  A scene file
has these tables (every key is listed; a key not listed here is an error, so a
typo is never silently ignored)::

    description = "..."             # optional, one line shown by Scene.summary();
                                    #   top-level keys go before the first table

    [camera]                        # required: a pinhole camera
    eye = [0.0, 1.9, 1.6]           # required, metres
    target = [0.0, 0.0, 0.05]       # required, metres, != eye
    up = [0.0, 1.0, 0.0]            # default [0, 1, 0]; not parallel to target - eye
    fov_y_deg = 38.0                # required, vertical field of view, 0 < fov < 180
    width = 512                     # required, pixels, 1 .. 16384
    height = 512                    # required, pixels, 1 .. 16384
    spp = 4                         # default: the renderer's (DEFAULT_SPP); samples per
                                    #   pixel per pass, 1 .. 1024, stratified jitter in cells
                                    #   as near square as the count divides (32: 4 x 8)
    filter = "box"                  # default "box" (each pixel its samples' mean); "tent"
                                    #   or "gaussian", or a table such as {kind = "tent",
                                    #   radius = 1.0} or {kind = "gaussian", stddev = 0.5}
                                    #   (Mitsuba's filters and defaults, in pixels)
    crop = [0.25, 0.0, 0.75, 0.5]   # default none: the part of the film the image holds,
                                    #   [x0, y0, x1, y1] as fractions of it (y from the top);
                                    #   fov_y_deg is the whole film's, width x height the part's
    aperture_radius = 0.05          # default 0 (a pinhole): a thin lens's radius, scene units
    focus_distance = 4.0            # default 1: the distance in focus along the view axis

    [materials.NAME]                # one table per material; at least one
    kind = "phong"                  # modified Phong (Lafortune & Willems 1994):
    kd = 0.55                       #   required, number or [r, g, b], each >= 0
    ks = 0.25                       #   default 0, number or [r, g, b], each >= 0;
                                    #   kd + ks <= 1 per channel (energy conservation)
    n = 20                          #   exponent >= 0; required when ks > 0, else default 0
    #   f = kd / pi + ks (n + 2) / (2 pi) cos^n(alpha), alpha from the mirror direction
    sided = "two"                   #   default "two": reflects on both faces; "one": on the
                                    #   front face only (where the face normal points,
                                    #   counter-clockwise winding), black from the back, as
                                    #   Mitsuba's bare diffuse (the export writes it so)

    [materials.OTHER]
    kind = "mirror"                 # perfect specular reflector
    reflectance = [0.95, 0.78, 0.45]  # required, number or [r, g, b], each in [0, 1]
    eta = [0.143, 0.375, 1.442]     # optional, with k: a smooth conductor, the reflectance
    k = [3.983, 2.386, 1.603]       #   times the Fresnel reflectance of eta + i k per channel
                                    #   (here Mitsuba's gold, Au); both or neither
    alpha = 0.1                     # default 0 (smooth): a rough mirror, microfacets of this
                                    #   roughness in [0, 1] (Mitsuba's roughconductor)
    distribution = "ggx"            # default "beckmann"; or "ggx"

    [materials.GLASS]
    kind = "dielectric"             # smooth dielectric: Fresnel reflection, Snell refraction
    ior = 1.5                       #   required, index of refraction, 1 < ior <= 4 (air outside)
    tint = [1.0, 0.95, 0.9]         #   default 1, number or [r, g, b] in [0, 1]: the
                                    #   transmittance per crossing of the surface
                                    # alpha and distribution as a mirror's: frosted glass
                                    #   (Mitsuba's roughdielectric)

    [[lights]]                      # one table per light; at least one
    kind = "point"                  # isotropic point light
    position = [-2.0, 1.0, 0.0]     # required, metres
    power = 100.0                   # required, watts, number (white) or [r, g, b];
                                    #   each >= 0 and not all 0
    [[lights]]
    kind = "spot"                   # a cone, uniform in solid angle inside its beam
    position = [0.0, 2.0, 0.0]      # required, metres
    direction = [0.0, -1.0, 0.0]    # required, the cone's axis (normalised on load)
    power = 50.0                    # required, watts emitted into the whole cone
    cone_deg = 30.0                 # required, half angle, 0 < cone_deg <= 90
    beam_deg = 22.5                 # optional, default cone_deg: full intensity inside it,
                                    #   falling linearly in the angle to 0 at cone_deg
    [[lights]]
    kind = "directional"            # sunlight: parallel light from outside the scene
    direction = [0.3, -1.0, 0.2]    # required, the direction the light travels (normalised)
    irradiance = 4.0                # required, W m^-2 on a surface facing the light,
                                    #   number (white) or [r, g, b]; each >= 0, not all 0
    [[lights]]
    kind = "environment"            # an environment map: light from infinitely far, by
    file = "sky.exr"                #   direction; required, a latitude-longitude image
                                    #   (EXR, HDR, PNG, JPEG) of radiance, W m^-2 sr^-1,
                                    #   Mitsuba's envmap layout (+y its pole); one a scene
    scale = 1.0                     # optional, > 0, times the image
    rotate_deg = [0.0, 90.0, 0.0]   # optional, degrees about x, then y, then z
    # [[lights]] may be left out where an object emits (an area light, below)

    [[objects]]                     # one table per object; at least one
    name = "floor"                  # required, unique
    material = "floor"              # required, the NAME of a [materials.NAME] table
    mesh = "meshes/floor.obj"       # a .obj, .ply or .stl file, relative to the
                                    #   scene file's folder (or absolute) ...
    emission = [17.0, 12.0, 4.0]    # optional: the object is an area light, emitting this
                                    #   radiance (W m^-2 sr^-1, number or [r, g, b], >= 0,
                                    #   not all 0) from the front of each face (where the
                                    #   face normal points), Lambertian, as Mitsuba's area
                                    #   emitter; its material (phong) is what it reflects
    normals = "auto"                #   only with mesh: "auto" (the file's vertex
                                    #   normals, else smooth), "smooth" (averaged
                                    #   over shared vertices) or "flat" (per face)
    [objects.shape]                 # ... or a generated shape: exactly one of the two
    kind = "rectangle"              # see blockhash.scene.meshes; keys per kind:
    #   rectangle: x = [min, max], z = [min, max] (required), y = 0.0; faces +y
    #   ring: inner_radius, outer_radius, height (required, > 0, inner < outer),
    #         segments = 256 (3 .. 65536), center = [0, 0, 0] (centre of the base),
    #         bottom = false (close the base; for a ring that floats)
    #   sphere: center, radius (required, > 0), subdivisions = 5 (0 .. 8): an
    #         icosphere of 20 * 4**subdivisions triangles with exact smooth normals
    #   bust: center = [0, 0, 0] (centre of the base), segments = 384 (8 .. 4096),
    #         rings = 200 (4 .. 4096); 0.66 m tall, facing +z, neck at 0.35 .. 0.425 m
    #         above the base, 152,064 triangles by default
    # optional placement of the mesh or shape, applied as scale, rotate, translate:
    # scale = 1.0                   # > 0, uniform
    # rotate_deg = [0.0, 0.0, 0.0]  # degrees about x, then y, then z (fixed axes)
    # translate = [0.0, 0.0, 0.0]   # metres

    [animation]                     # optional: keyframes of the camera, the lights and the
                                    #   objects (blockhash/scene/animation.py lists the keys)

    [photons]                       # optional; every key has a default
    count = 200000                  # caustic photons to store (target), >= 1
    k = 50                          # photons per density estimate, 1 <= k <= count
    A = 8                           # accuracy multiplier: A * k candidates (section 4.3), >= 1
    seed = 1                        # random seed, >= 0
    max_bounces = 4                 # specular events (mirror bounces, glass reflections
                                    #   and refractions) followed per photon, >= 1;
                                    #   default 4, or 8 when the scene holds a dielectric

Every error raised while loading is an :class:`~blockhash.errors.InputError`
naming the file and the key path, what was expected, what was received and the
way out, e.g. ``scenes/ring.toml: objects[1].material: unknown material 'gold';
defined materials: floor, mirror; define [materials.gold] or use one of those``.

Why this module is long: its docstring is the scene format's reference, every key listed.

The dataclasses are frozen and their arrays read-only; all but
``PhotonSettings`` compare by identity (numpy arrays have no single truth value).  Do not modify an object's
mesh in place: trimesh would recompute its vertex normals from the faces.
"""

from __future__ import annotations

import difflib
import tomllib
from dataclasses import replace
from pathlib import Path

import trimesh

from blockhash.errors import InputError
from blockhash.scene import meshes
from blockhash.scene.model import (
    AreaLight,
    Camera,
    DielectricMaterial,
    DirectionalLight,
    EnvironmentLight,
    MirrorMaterial,
    PhongMaterial,
    PhotonSettings,
    PointLight,
    Scene,
    SceneObject,
    SpotLight,
    check_mesh,
)
from blockhash.scene.pixel_filter import pixel_filter
from blockhash.scene.texture import read_image
from blockhash.scene.values import FieldError as _FieldError
from blockhash.scene.values import boolean as _boolean
from blockhash.scene.values import choice as _choice
from blockhash.scene.values import got as _got
from blockhash.scene.values import integer as _integer
from blockhash.scene.values import number as _number
from blockhash.scene.values import rgb as _rgb
from blockhash.scene.values import string as _string
from blockhash.scene.values import under as _under
from blockhash.scene.values import vector as _vector


def _load_mesh_file(value, key: str, base: Path, normals: str) -> trimesh.Trimesh:
    """Resolve a mesh path against the scene file's folder and load it."""
    text = _string(value, key, what="a mesh file path")
    path = Path(text).expanduser()
    full = path if path.is_absolute() else base / path
    if full.suffix.lower() not in meshes.MESH_SUFFIXES:
        raise _FieldError(key, f"unsupported mesh file type {full.suffix or '(none)'!r} in {text!r}; "
                          f"expected one of {', '.join(meshes.MESH_SUFFIXES)}; convert it "
                          "(e.g. with trimesh)")
    if not full.is_file():
        raise _FieldError(key, f"mesh file not found: {str(full)!r} ({text!r} is resolved relative to "
                          f"the scene file's folder {str(base)!r}); check the path or give an "
                          "absolute one")
    try:
        mesh = meshes.load_mesh(full, normals=normals)
    except InputError as exc:
        raise _FieldError(key, str(exc)) from None
    check_mesh(mesh, key)
    return mesh


# --------------------------------------------------------------------------- TOML

def _keys(table, key: str, required: tuple, optional: tuple = (), *, what: str) -> dict:
    """Check ``table`` is a table with all ``required`` and no unknown keys."""
    if not isinstance(table, dict):
        raise _FieldError(key, f"expected a table ({what}); got {_got(table)}")
    allowed = tuple(required) + tuple(optional)
    for name in table:
        if name not in allowed:
            close = difflib.get_close_matches(name, allowed, n=1) or \
                [a for a in allowed if a.startswith(name) or name.startswith(a)]
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise _FieldError(f"{key}.{name}" if key else name,
                              f"unknown key{hint}; allowed keys here: {', '.join(allowed)}; "
                              "remove or rename it")
    for name in required:
        if name not in table:
            raise _FieldError(f"{key}.{name}" if key else name,
                              f"missing required key; {what} needs {', '.join(required)}")
    return table


def _array_of_tables(value, key: str, *, what: str) -> list:
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise _FieldError(key, f"expected an array of tables, written [[{key}]] ({what}); "
                          f"got {_got(value)}")
    if not value:
        raise _FieldError(key, f"expected at least one [[{key}]] table ({what}); got none")
    return value


def _parse_camera(t) -> Camera:
    _keys(t, "camera", ("eye", "target", "fov_y_deg", "width", "height"),
          ("up", "spp", "filter", "crop", "aperture_radius", "focus_distance"),
          what="the camera")
    with _under("camera"):
        return Camera(eye=t["eye"], target=t["target"], up=t.get("up", [0.0, 1.0, 0.0]),
                      fov_y_deg=t["fov_y_deg"], width=t["width"], height=t["height"],
                      spp=t.get("spp"), filter=pixel_filter(t.get("filter", "box")),
                      crop=t.get("crop"), aperture_radius=t.get("aperture_radius", 0.0),
                      focus_distance=t.get("focus_distance", 1.0))


def _parse_materials(t) -> dict:
    if not isinstance(t, dict) or not t:
        raise _FieldError("materials", "expected at least one [materials.NAME] table; got "
                          + ("none" if isinstance(t, dict) else _got(t)))
    out = {}
    for name, m in t.items():
        key = f"materials.{name}"
        if not isinstance(m, dict):
            raise _FieldError(key, f"expected a table [materials.{name}] with kind = \"phong\", "
                              f"\"mirror\" or \"dielectric\"; got {_got(m)}")
        if "kind" not in m:
            raise _FieldError(f"{key}.kind", "missing required key; expected \"phong\", "
                              "\"mirror\" or \"dielectric\"")
        kind = _choice(m["kind"], f"{key}.kind", ("phong", "mirror", "dielectric"))
        with _under(key):
            if kind == "phong":
                _keys(m, "", ("kind", "kd"), ("ks", "n", "sided"), what="a phong material")
                ks = _rgb(m.get("ks", 0.0), "ks", what="ks")
                if "n" not in m and ks.any():
                    raise _FieldError("n", "missing required key; a phong material with ks > 0 needs "
                                      "the exponent n (e.g. n = 20)")
                out[name] = PhongMaterial(kd=m["kd"], ks=ks, n=m.get("n", 0.0),
                                          sided=m.get("sided", "two"))
            elif kind == "mirror":
                _keys(m, "", ("kind", "reflectance"), ("eta", "k", *ROUGH_KEYS),
                      what="a mirror material")
                out[name] = MirrorMaterial(reflectance=m["reflectance"], eta=m.get("eta"),
                                           k=m.get("k"), **_rough(m))
            else:
                _keys(m, "", ("kind", "ior"), ("tint", *ROUGH_KEYS), what="a dielectric material")
                out[name] = DielectricMaterial(ior=m["ior"], tint=m.get("tint", 1.0), **_rough(m))
    return out


#: The optional keys of a rough mirror or dielectric.
ROUGH_KEYS = ("alpha", "distribution")


def _rough(m: dict) -> dict:
    return {k: m[k] for k in ROUGH_KEYS if k in m}


def _parse_light(t, i: int, base: Path):
    key = f"lights[{i}]"
    if "kind" not in t:
        raise _FieldError(f"{key}.kind", "missing required key; expected \"point\", \"spot\", "
                          "\"directional\" or \"environment\" (an area light is an object with "
                          "emission)")
    kind = _choice(t["kind"], f"{key}.kind", ("point", "spot", "directional", "environment"))
    with _under(key):
        if kind == "environment":
            _keys(t, "", ("kind", "file"), ("scale", "rotate_deg"), what="an environment light")
            text = _string(t["file"], "file", what="an image file path")
            full = Path(text).expanduser()
            full = full if full.is_absolute() else base / full
            if not full.is_file():
                raise _FieldError("file", f"image not found: {str(full)!r} ({text!r} is resolved "
                                  f"relative to the scene file's folder {str(base)!r}); check "
                                  "the path or give an absolute one")
            try:
                image = read_image(full)
            except InputError as exc:
                raise _FieldError("file", str(exc)) from None
            scale = _number(t.get("scale", 1.0), "scale", lo=0.0, lo_open=True)
            turn = meshes.rotation(_vector(t.get("rotate_deg", [0.0, 0.0, 0.0]), "rotate_deg",
                                           unit="degrees"))
            return EnvironmentLight(image=image * scale, to_world=turn, name=full.name)
        if kind == "directional":
            _keys(t, "", ("kind", "direction", "irradiance"), what="a directional light")
            return DirectionalLight(direction=t["direction"], irradiance=t["irradiance"])
        if kind == "point":
            _keys(t, "", ("kind", "position", "power"), what="a point light")
            return PointLight(position=t["position"], power=t["power"])
        _keys(t, "", ("kind", "position", "direction", "power", "cone_deg"), ("beam_deg",),
              what="a spot light")
        return SpotLight(position=t["position"], direction=t["direction"], power=t["power"],
                         cone_deg=t["cone_deg"], beam_deg=t.get("beam_deg"))


def _pair(value, key: str) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise _FieldError(key, f"expected [min, max] in metres; got {_got(value)}")
    lo, hi = (_number(v, f"{key}[{j}]") for j, v in enumerate(value))
    if not lo < hi:
        raise _FieldError(key, f"expected [min, max] with min < max; got {value!r}; swap or widen them")
    return lo, hi


def _positive(value, key):
    return _number(value, key, lo=0.0, lo_open=True)


#: kind -> {key: (check, default or _REQUIRED)} for [objects.shape].
_REQUIRED = object()
_SHAPES = {
    "rectangle": {"x": (_pair, _REQUIRED), "z": (_pair, _REQUIRED), "y": (_number, 0.0)},
    "ring": {
        "inner_radius": (_positive, _REQUIRED), "outer_radius": (_positive, _REQUIRED),
        "height": (_positive, _REQUIRED),
        "segments": (lambda v, k: _integer(v, k, lo=3, hi=65536), 256),
        "center": (_vector, [0.0, 0.0, 0.0]), "bottom": (_boolean, False)},
    "sphere": {
        "center": (_vector, _REQUIRED), "radius": (_positive, _REQUIRED),
        "subdivisions": (lambda v, k: _integer(v, k, lo=0, hi=8), meshes.SPHERE_SUBDIVISIONS)},
    "bust": {
        "center": (_vector, [0.0, 0.0, 0.0]),
        "segments": (lambda v, k: _integer(v, k, lo=8, hi=4096), 384),
        "rings": (lambda v, k: _integer(v, k, lo=4, hi=4096), 200)},
}
_BUILDERS = {"rectangle": meshes.rectangle, "ring": meshes.ring, "sphere": meshes.sphere,
             "bust": meshes.bust}


def _parse_shape(t, key: str) -> trimesh.Trimesh:
    if not isinstance(t, dict):
        raise _FieldError(key, f"expected a table [objects.shape] with a kind; got {_got(t)}")
    if "kind" not in t:
        raise _FieldError(f"{key}.kind", "missing required key; expected one of "
                          + ", ".join(map(repr, _SHAPES)))
    kind = _choice(t["kind"], f"{key}.kind", tuple(_SHAPES))
    spec = _SHAPES[kind]
    required = tuple(k for k, (_, d) in spec.items() if d is _REQUIRED)
    optional = tuple(k for k, (_, d) in spec.items() if d is not _REQUIRED)
    _keys(t, key, ("kind",) + required, optional, what=f"a {kind} shape")
    args = {k: check(t[k] if k in t else default, f"{key}.{k}")
            for k, (check, default) in spec.items()}
    try:
        return _BUILDERS[kind](**args)
    except InputError as exc:
        raise _FieldError(key, str(exc)) from None


def _parse_object(t, i: int, materials: dict, base: Path) -> tuple[SceneObject, AreaLight | None]:
    key = f"objects[{i}]"
    _keys(t, key, ("name", "material"),
          ("mesh", "shape", "normals", "scale", "rotate_deg", "translate", "emission"),
          what="an object")
    name = _string(t["name"], f"{key}.name", what="the object's name")
    mat = _string(t["material"], f"{key}.material", what="a material name")
    if mat not in materials:
        raise _FieldError(f"{key}.material", f"unknown material {mat!r}; defined materials: "
                          f"{', '.join(materials)}; define [materials.{mat}] or use one of those")
    if ("mesh" in t) == ("shape" in t):
        raise _FieldError(key, "expected exactly one of mesh = \"file.obj\" or an [objects.shape] "
                          f"table; got {'both' if 'mesh' in t else 'neither'}")
    if "normals" in t and "mesh" not in t:
        raise _FieldError(f"{key}.normals", "normals applies to mesh files only; generated shapes "
                          "carry their own normals; remove it")
    scale = _positive(t.get("scale", 1.0), f"{key}.scale")
    rotate = _vector(t.get("rotate_deg", [0.0, 0.0, 0.0]), f"{key}.rotate_deg", unit="degrees")
    translate = _vector(t.get("translate", [0.0, 0.0, 0.0]), f"{key}.translate")
    if "mesh" in t:
        normals = _choice(t.get("normals", "auto"), f"{key}.normals", meshes.NORMAL_MODES)
        mesh = _load_mesh_file(t["mesh"], f"{key}.mesh", base, normals)
    else:
        mesh = _parse_shape(t["shape"], f"{key}.shape")
    with _under(key):
        obj = SceneObject(name=name, mesh=meshes.placed(mesh, scale=scale, rotate_deg=rotate,
                                                         translate=translate),
                          material=materials[mat])
    if "emission" not in t:
        return obj, None
    if obj.is_specular:
        raise _FieldError(f"{key}.emission", f"object {name!r} has the {mat!r} material, a "
                          f"{'glass' if obj.is_dielectric else 'mirror'}: blockhash's emitters "
                          "are diffuse surfaces; give the emitting object a phong material "
                          "(kd = 0 for a light that reflects nothing)")
    with _under(key):
        light = AreaLight(object=name, mesh=obj.mesh, radiance=_emission(t["emission"]))
    return obj, light


def _emission(value):
    from blockhash.scene.values import rgb

    return rgb(value, "emission", what="emitted radiance in W m^-2 sr^-1")


def _parse_photons(t) -> PhotonSettings:
    fields = ("count", "k", "A", "seed", "max_bounces")
    _keys(t, "photons", (), fields, what="the photon settings")
    with _under("photons"):
        # max_bounces left out: the Scene chooses (4, or 8 with a dielectric)
        return PhotonSettings(**{k: t[k] for k in fields if k in t})


def _parse(data: dict, base: Path, path: Path | None) -> Scene:
    _keys(data, "", ("camera", "materials", "objects"),
          ("lights", "photons", "description", "animation"), what="a scene file")
    description = _string(data["description"], "description", what="a one-line description") \
        if "description" in data else ""
    camera = _parse_camera(data["camera"])
    materials = _parse_materials(data["materials"])
    lights = [_parse_light(t, i, base) for i, t in enumerate(
        _array_of_tables(data["lights"], "lights", what="a light"))] if "lights" in data else []
    objects, seen = [], {}
    for i, t in enumerate(_array_of_tables(data["objects"], "objects", what="an object")):
        obj, area = _parse_object(t, i, materials, base)
        if area is not None:
            lights.append(area)
        if obj.name in seen:
            raise _FieldError(f"objects[{i}].name", f"duplicate object name {obj.name!r} (also "
                              f"objects[{seen[obj.name]}]); expected unique names; rename one")
        seen[obj.name] = i
        objects.append(obj)
    photons = _parse_photons(data.get("photons", {}))
    scene = Scene(camera=camera, lights=tuple(lights), objects=tuple(objects), photons=photons,
                  path=path, description=description)
    if "animation" not in data:
        return scene
    from blockhash.scene.animation import check_animation, parse_animation

    scene = replace(scene, animation=parse_animation(data["animation"], scene))
    check_animation(scene.animation, scene)
    return scene


def parse_scene(text: str, *, path: Path | str | None = None) -> Scene:
    """Parse a scene from TOML ``text``.  ``path`` names the file in errors and
    is the folder mesh paths are resolved from (the working directory without
    one); it is not read."""
    label = str(path) if path is not None else "<string>"
    base = Path(path).parent if path is not None else Path.cwd()
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{label}: TOML syntax error: {exc}; fix the file (see https://toml.io)") \
            from None
    try:
        return _parse(data, base, Path(path) if path is not None else None)
    except _FieldError as exc:
        raise InputError(f"{label}: {exc.key}: {exc.detail}") from None


def load_scene(path: Path | str, defines: dict | None = None) -> Scene:
    """Load the scene file at ``path``: TOML (the module docstring), or a Mitsuba 3 XML file
    (``.xml``, the subset :mod:`.importer` reads).  ``defines``: a Mitsuba file's parameters,
    name -> value, over its ``<default>``s (Mitsuba's ``-D name=value``)."""
    p = Path(path)
    if not p.is_file():
        where = f" (resolved to {str(p.resolve())!r})" if not p.is_absolute() else ""
        what = "is a directory, not a scene file" if p.is_dir() else "scene file not found"
        raise InputError(f"{path}: {what}{where}; give the path of a .toml scene "
                         "(or a Mitsuba 3 .xml), e.g. scenes/ring.toml")
    if p.suffix.lower() == ".xml":
        from blockhash.scene.mitsuba.importer import load_mitsuba
        return load_mitsuba(p, defines)
    if defines:
        raise InputError(f"{path}: parameters ({', '.join(defines)}) are given to a Mitsuba XML "
                         "file's $name; a TOML scene has none, so leave them out")
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the scene file: {exc}; check its permissions and "
                         "that it is UTF-8 text") from None
    return parse_scene(text, path=p)
