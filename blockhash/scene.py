"""Scenes: camera, lights, meshes and materials, read from a TOML file.

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

    [materials.NAME]                # one table per material; at least one
    kind = "phong"                  # modified Phong (Lafortune & Willems 1994):
    kd = 0.55                       #   required, number or [r, g, b], each >= 0
    ks = 0.25                       #   default 0, number or [r, g, b], each >= 0;
                                    #   kd + ks <= 1 per channel (energy conservation)
    n = 20                          #   exponent >= 0; required when ks > 0, else default 0
    #   f = kd / pi + ks (n + 2) / (2 pi) cos^n(alpha), alpha from the mirror direction

    [materials.OTHER]
    kind = "mirror"                 # perfect specular reflector
    reflectance = [0.95, 0.78, 0.45]  # required, number or [r, g, b], each in [0, 1]

    [[lights]]                      # one table per light; at least one
    kind = "point"                  # isotropic point light
    position = [-2.0, 1.0, 0.0]     # required, metres
    power = 100.0                   # required, watts, number (white) or [r, g, b];
                                    #   each >= 0 and not all 0
    [[lights]]
    kind = "spot"                   # uniform in solid angle inside a cone
    position = [0.0, 2.0, 0.0]      # required, metres
    direction = [0.0, -1.0, 0.0]    # required, the cone's axis (normalised on load)
    power = 50.0                    # required, watts emitted into the whole cone
    cone_deg = 30.0                 # required, half angle, 0 < cone_deg <= 90

    [[objects]]                     # one table per object; at least one
    name = "floor"                  # required, unique
    material = "floor"              # required, the NAME of a [materials.NAME] table
    mesh = "meshes/floor.obj"       # a .obj, .ply or .stl file, relative to the
                                    #   scene file's folder (or absolute) ...
    normals = "auto"                #   only with mesh: "auto" (the file's vertex
                                    #   normals, else smooth), "smooth" (averaged
                                    #   over shared vertices) or "flat" (per face)
    [objects.shape]                 # ... or a generated shape: exactly one of the two
    kind = "rectangle"              # see blockhash.meshes; keys per kind:
    #   rectangle: x = [min, max], z = [min, max] (required), y = 0.0; faces +y
    #   ring: inner_radius, outer_radius, height (required, > 0, inner < outer),
    #         segments = 256 (3 .. 65536), center = [0, 0, 0] (centre of the base),
    #         bottom = false (close the base; for a ring that floats)
    #   bust: center = [0, 0, 0] (centre of the base), segments = 384 (8 .. 4096),
    #         rings = 200 (4 .. 4096); 0.66 m tall, facing +z, neck at 0.35 .. 0.425 m
    #         above the base, 152,064 triangles by default
    # optional placement of the mesh or shape, applied as scale, rotate, translate:
    # scale = 1.0                   # > 0, uniform
    # rotate_deg = [0.0, 0.0, 0.0]  # degrees about x, then y, then z (fixed axes)
    # translate = [0.0, 0.0, 0.0]   # metres

    [photons]                       # optional; every key has a default
    count = 200000                  # caustic photons to store (target), >= 1
    k = 50                          # photons per density estimate, 1 <= k <= count
    A = 8                           # accuracy multiplier: A * k candidates (section 4.3), >= 1
    seed = 1                        # random seed, >= 0
    max_bounces = 4                 # specular bounces followed per photon, >= 1

Every error raised while loading is an :class:`~blockhash.errors.InputError`
naming the file and the key path, what was expected, what was received and the
way out, e.g. ``scenes/ring.toml: objects[1].material: unknown material 'gold';
defined materials: floor, mirror; define [materials.gold] or use one of those``.

The dataclasses are frozen and their arrays read-only; all but
``PhotonSettings`` compare by identity (numpy arrays have no single truth value).  Do not modify an object's
mesh in place: trimesh would recompute its vertex normals from the faces.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from . import meshes
from .errors import InputError
from .scene_values import (FieldError as _FieldError, boolean as _boolean, choice as _choice,
                           fmt as _fmt, got as _got, integer as _integer,
                           number as _number, owned as _owned, readonly as _readonly, rgb as _rgb,
                           string as _string, under as _under, vector as _vector)

#: Largest image side: GL_MAX_TEXTURE_SIZE on llvmpipe (DESIGN.md), so a
#: G-buffer of the camera's size can be allocated.
MAX_IMAGE_SIDE = 16384
#: up and the view direction count as parallel when the sine of their angle is
#: below this: the camera basis (cross products) would then be mostly rounding.
PARALLEL_SINE = 1e-6


# --------------------------------------------------------------------------- dataclasses

@dataclass(frozen=True, eq=False)
class Camera:
    """A pinhole camera.

    ``eye``, ``target``, ``up`` : (3,) float64, metres; ``fov_y_deg`` the
    vertical field of view in degrees; ``width``, ``height`` the image size in
    pixels.  ``up`` need not be perpendicular to the view direction, only not
    parallel to it.
    """

    eye: np.ndarray
    target: np.ndarray
    up: np.ndarray
    fov_y_deg: float
    width: int
    height: int

    def __post_init__(self):
        with _owned("Camera"):
            set_ = object.__setattr__
            set_(self, "eye", _vector(self.eye, "eye"))
            set_(self, "target", _vector(self.target, "target"))
            set_(self, "up", _vector(self.up, "up", unit="a direction"))
            set_(self, "fov_y_deg", _number(self.fov_y_deg, "fov_y_deg", lo=0.0, hi=180.0,
                                            lo_open=True, hi_open=True,
                                            hint="give the vertical field of view in degrees, e.g. 38"))
            set_(self, "width", _integer(self.width, "width", lo=1, hi=MAX_IMAGE_SIDE))
            set_(self, "height", _integer(self.height, "height", lo=1, hi=MAX_IMAGE_SIDE))
            view = self.target - self.eye
            dist = float(np.linalg.norm(view))
            if dist == 0.0:
                raise _FieldError("target", f"target {_fmt(self.target)} equals eye; expected a "
                                  "point the camera looks at, away from the eye")
            up_len = float(np.linalg.norm(self.up))
            if up_len == 0.0:
                raise _FieldError("up", "expected a non-zero direction; got (0, 0, 0); use [0, 1, 0]")
            sine = float(np.linalg.norm(np.cross(view / dist, self.up / up_len)))
            if sine < PARALLEL_SINE:
                raise _FieldError("up", f"up {_fmt(self.up)} is parallel to the view direction "
                                  f"target - eye = {_fmt(view)}; expected a direction not parallel "
                                  "to it; for a camera looking straight down use e.g. up = [0, 0, -1]")

    @property
    def aspect(self) -> float:
        """width / height."""
        return self.width / self.height

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Unit ``(right, true_up, forward)`` vectors of the camera frame."""
        forward = self.target - self.eye
        forward = forward / np.linalg.norm(forward)
        right = np.cross(forward, self.up)
        right /= np.linalg.norm(right)
        return right, np.cross(right, forward), forward

    def view_matrix(self) -> np.ndarray:
        """(4, 4) float64 world-to-camera matrix (gluLookAt): right-handed, the
        camera at the origin looking down ``-z`` with ``+y`` up."""
        right, up, forward = self.basis()
        m = np.eye(4)
        m[0, :3], m[1, :3], m[2, :3] = right, up, -forward
        m[:3, 3] = -m[:3, :3] @ self.eye
        return m

    def projection(self, near: float, far: float) -> np.ndarray:
        """(4, 4) float64 OpenGL perspective matrix (gluPerspective) for this
        camera's field of view and aspect, mapping ``z = -near`` and ``z = -far``
        in camera space to NDC depth -1 and +1.  Needs ``0 < near < far``."""
        near = _number(near, "near", lo=0.0, lo_open=True)
        far = _number(far, "far", lo=0.0, lo_open=True)
        if near >= far:
            raise InputError(f"projection: near={near} must be < far={far}; "
                             "pass a near plane closer than the far one")
        f = 1.0 / math.tan(math.radians(self.fov_y_deg) / 2.0)
        m = np.zeros((4, 4))
        m[0, 0], m[1, 1] = f / self.aspect, f
        m[2, 2], m[2, 3] = (far + near) / (near - far), 2.0 * far * near / (near - far)
        m[3, 2] = -1.0
        return m

    def __repr__(self) -> str:
        return (f"Camera(eye={_fmt(self.eye)}, target={_fmt(self.target)}, up={_fmt(self.up)}, "
                f"fov_y_deg={self.fov_y_deg:g}, width={self.width}, height={self.height})")


@dataclass(frozen=True, eq=False)
class PhongMaterial:
    """Modified Phong BRDF (Lafortune & Willems 1994), RGB:
    ``f = kd / pi + ks (n + 2) / (2 pi) cos^n(alpha)``, alpha the angle between
    the outgoing direction and the mirror direction of the incoming one.
    ``kd``, ``ks`` : (3,) float64 >= 0 with ``kd + ks <= 1`` per channel
    (energy conservation); ``n`` >= 0."""

    kd: np.ndarray
    ks: np.ndarray
    n: float

    def __post_init__(self):
        with _owned("PhongMaterial"):
            kd = _rgb(self.kd, "kd", what="kd")
            ks = _rgb(self.ks, "ks", what="ks")
            n = _number(self.n, "n", lo=0.0, hint="the Phong exponent is >= 0")
            if np.any(kd + ks > 1.0):
                c = int(np.argmax(kd + ks))
                raise _FieldError("ks", f"kd + ks = {_fmt(kd + ks)} exceeds 1 in channel {'rgb'[c]}; "
                                  "expected kd + ks <= 1 per channel (energy conservation); "
                                  "lower kd or ks")
            object.__setattr__(self, "kd", kd)
            object.__setattr__(self, "ks", ks)
            object.__setattr__(self, "n", n)

    def __repr__(self) -> str:
        return f"PhongMaterial(kd={_fmt(self.kd)}, ks={_fmt(self.ks)}, n={self.n:g})"


@dataclass(frozen=True, eq=False)
class MirrorMaterial:
    """Perfect specular reflector; ``reflectance`` : (3,) float64 in [0, 1]."""

    reflectance: np.ndarray

    def __post_init__(self):
        with _owned("MirrorMaterial"):
            object.__setattr__(self, "reflectance",
                               _rgb(self.reflectance, "reflectance", hi=1.0, what="reflectance"))

    def __repr__(self) -> str:
        return f"MirrorMaterial(reflectance={_fmt(self.reflectance)})"


def _power(value, key: str) -> np.ndarray:
    p = _rgb(value, key, what="power in watts")
    if not p.any():
        raise _FieldError(key, "the light emits nothing (power 0 in every channel); "
                          "expected watts > 0 in at least one channel")
    return p


@dataclass(frozen=True, eq=False)
class PointLight:
    """Isotropic point light: ``position`` (3,) metres, ``power`` (3,) watts RGB
    (total, over the whole sphere)."""

    position: np.ndarray
    power: np.ndarray

    def __post_init__(self):
        with _owned("PointLight"):
            object.__setattr__(self, "position", _vector(self.position, "position"))
            object.__setattr__(self, "power", _power(self.power, "power"))

    def __repr__(self) -> str:
        return f"PointLight(position={_fmt(self.position)}, power={_fmt(self.power)})"


@dataclass(frozen=True, eq=False)
class SpotLight:
    """Spot light: ``position`` (3,) metres, ``direction`` (3,) unit axis,
    ``power`` (3,) watts RGB emitted into the cone, uniform in solid angle
    inside it, ``cone_deg`` the half angle in (0, 90]."""

    position: np.ndarray
    direction: np.ndarray
    power: np.ndarray
    cone_deg: float

    def __post_init__(self):
        with _owned("SpotLight"):
            object.__setattr__(self, "position", _vector(self.position, "position"))
            d = _vector(self.direction, "direction", unit="a direction")
            length = float(np.linalg.norm(d))
            if length == 0.0:
                raise _FieldError("direction", "expected a non-zero direction for the cone's axis; "
                                  "got (0, 0, 0)")
            object.__setattr__(self, "direction", _readonly(d / length))
            object.__setattr__(self, "power", _power(self.power, "power"))
            object.__setattr__(self, "cone_deg", _number(
                self.cone_deg, "cone_deg", lo=0.0, hi=90.0, lo_open=True,
                hint="cone_deg is the half angle of the cone in degrees"))

    @property
    def solid_angle(self) -> float:
        """Steradians inside the cone, ``2 pi (1 - cos cone)``."""
        return 2.0 * math.pi * (1.0 - math.cos(math.radians(self.cone_deg)))

    def __repr__(self) -> str:
        return (f"SpotLight(position={_fmt(self.position)}, direction={_fmt(self.direction)}, "
                f"power={_fmt(self.power)}, cone_deg={self.cone_deg:g})")


@dataclass(frozen=True, eq=False)
class SceneObject:
    """A named triangle mesh with a material.  ``mesh.vertex_normals`` are the
    normals to shade with (smooth radial ones on the ring's walls, flat on
    planes, the smooth surface's on the bust)."""

    name: str
    mesh: trimesh.Trimesh
    material: PhongMaterial | MirrorMaterial

    def __post_init__(self):
        with _owned("SceneObject"):
            _string(self.name, "name", what="the object's name")
            if not isinstance(self.mesh, trimesh.Trimesh):
                raise _FieldError("mesh", f"expected a trimesh.Trimesh; got {type(self.mesh).__name__}")
            _check_mesh(self.mesh, "mesh")
            if not isinstance(self.material, (PhongMaterial, MirrorMaterial)):
                raise _FieldError("material", "expected a PhongMaterial or MirrorMaterial; got "
                                  f"{type(self.material).__name__}")

    @property
    def is_specular(self) -> bool:
        return isinstance(self.material, MirrorMaterial)

    def __repr__(self) -> str:
        return (f"SceneObject(name={self.name!r}, mesh=<{len(self.mesh.vertices):,} vertices, "
                f"{len(self.mesh.faces):,} triangles>, material={self.material!r})")


@dataclass(frozen=True)
class PhotonSettings:
    """Photon tracing and lookup settings: ``count`` photons to store (a
    target), ``k`` photons per estimate, accuracy multiplier ``A`` (section
    4.3), ``seed``, and ``max_bounces`` specular bounces followed per photon."""

    count: int = 200_000
    k: int = 50
    A: int = 8
    seed: int = 1
    max_bounces: int = 4

    def __post_init__(self):
        with _owned("PhotonSettings"):
            _integer(self.count, "count", lo=1)
            _integer(self.k, "k", lo=1, hi=self.count,
                     hint="k cannot exceed the photon count; lower k or raise count")
            _integer(self.A, "A", lo=1)
            _integer(self.seed, "seed", lo=0, hi=2**63 - 1)
            _integer(self.max_bounces, "max_bounces", lo=1)
            for name in ("count", "k", "A", "seed", "max_bounces"):
                object.__setattr__(self, name, int(getattr(self, name)))


@dataclass(frozen=True, eq=False)
class Scene:
    """A loaded scene.  ``lights`` and ``objects`` are tuples; ``path`` is the
    file it came from (as given), ``None`` for a scene parsed from text."""

    camera: Camera
    lights: tuple
    objects: tuple
    photons: PhotonSettings = field(default_factory=PhotonSettings)
    path: Path | None = None
    description: str = ""

    def __post_init__(self):
        with _owned("Scene"):
            object.__setattr__(self, "lights", tuple(self.lights))
            object.__setattr__(self, "objects", tuple(self.objects))
            if not self.lights:
                raise _FieldError("lights", "the scene has no light; add a [[lights]] table")
            if not self.objects:
                raise _FieldError("objects", "the scene has no object; add an [[objects]] table")
            names = [o.name for o in self.objects]
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise _FieldError("objects", f"object names must be unique; {dup} used more than once")

    @property
    def specular_objects(self) -> tuple[SceneObject, ...]:
        """Objects with a :class:`MirrorMaterial` (they cast the caustics)."""
        return tuple(o for o in self.objects if isinstance(o.material, MirrorMaterial))

    @property
    def diffuse_objects(self) -> tuple[SceneObject, ...]:
        """Objects with a :class:`PhongMaterial` (they receive the caustics)."""
        return tuple(o for o in self.objects if isinstance(o.material, PhongMaterial))

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float64: the box around every object's mesh, [min, max]."""
        boxes = np.array([o.mesh.bounds for o in self.objects])
        return np.stack([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])

    def summary(self) -> str:
        """A few lines describing the scene, for the command line."""
        c = self.camera
        lines = [f"scene {self.path if self.path else '(from text)'}"
                 + (f": {self.description}" if self.description else ""),
                 f"  camera  eye {_fmt(c.eye)} -> target {_fmt(c.target)}, up {_fmt(c.up)}, "
                 f"fov {c.fov_y_deg:g} deg, {c.width} x {c.height}"]
        for light in self.lights:
            if isinstance(light, SpotLight):
                lines.append(f"  light   spot at {_fmt(light.position)} along {_fmt(light.direction)}, "
                             f"cone {light.cone_deg:g} deg, power {_fmt(light.power)} W")
            else:
                lines.append(f"  light   point at {_fmt(light.position)}, power {_fmt(light.power)} W")
        width = max(len(o.name) for o in self.objects)
        for o in self.objects:
            m = o.material
            mat = (f"mirror, reflectance {_fmt(m.reflectance)}" if isinstance(m, MirrorMaterial)
                   else f"phong, kd {_fmt(m.kd)}, ks {_fmt(m.ks)}, n {m.n:g}")
            lines.append(f"  object  {o.name:<{width}}  {len(o.mesh.faces):>9,} triangles  {mat}")
        p = self.photons
        lines.append(f"  photons {p.count:,} stored, k {p.k}, A {p.A}, seed {p.seed}, "
                     f"max {p.max_bounces} bounces")
        lo, hi = self.bounds
        lines.append(f"  bounds  {_fmt(lo)} .. {_fmt(hi)} m")
        if not self.specular_objects:
            lines.append("  note    no specular (mirror) object: the scene has no caustics")
        return "\n".join(lines)

    def __repr__(self) -> str:
        return (f"Scene(path={str(self.path) if self.path else None!r}, {len(self.lights)} light(s), "
                f"objects={[o.name for o in self.objects]}, photons={self.photons!r})")


# --------------------------------------------------------------------------- meshes

def _check_mesh(mesh: trimesh.Trimesh, key: str) -> None:
    if len(mesh.faces) == 0:
        raise _FieldError(key, "the mesh is empty (0 triangles); expected at least one triangle")
    if not np.isfinite(mesh.vertices).all():
        raise _FieldError(key, "the mesh has NaN or infinite vertex coordinates; fix the mesh")


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
    _check_mesh(mesh, key)
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
    _keys(t, "camera", ("eye", "target", "fov_y_deg", "width", "height"), ("up",),
          what="the camera")
    with _under("camera"):
        return Camera(eye=t["eye"], target=t["target"], up=t.get("up", [0.0, 1.0, 0.0]),
                      fov_y_deg=t["fov_y_deg"], width=t["width"], height=t["height"])


def _parse_materials(t) -> dict:
    if not isinstance(t, dict) or not t:
        raise _FieldError("materials", "expected at least one [materials.NAME] table; got "
                          + ("none" if isinstance(t, dict) else _got(t)))
    out = {}
    for name, m in t.items():
        key = f"materials.{name}"
        if not isinstance(m, dict):
            raise _FieldError(key, f"expected a table [materials.{name}] with kind = \"phong\" or "
                              f"\"mirror\"; got {_got(m)}")
        if "kind" not in m:
            raise _FieldError(f"{key}.kind", "missing required key; expected \"phong\" or \"mirror\"")
        kind = _choice(m["kind"], f"{key}.kind", ("phong", "mirror"))
        with _under(key):
            if kind == "phong":
                _keys(m, "", ("kind", "kd"), ("ks", "n"), what="a phong material")
                ks = _rgb(m.get("ks", 0.0), "ks", what="ks")
                if "n" not in m and ks.any():
                    raise _FieldError("n", "missing required key; a phong material with ks > 0 needs "
                                      "the exponent n (e.g. n = 20)")
                out[name] = PhongMaterial(kd=m["kd"], ks=ks, n=m.get("n", 0.0))
            else:
                _keys(m, "", ("kind", "reflectance"), what="a mirror material")
                out[name] = MirrorMaterial(reflectance=m["reflectance"])
    return out


def _parse_light(t, i: int):
    key = f"lights[{i}]"
    if "kind" not in t:
        raise _FieldError(f"{key}.kind", "missing required key; expected \"point\" or \"spot\"")
    kind = _choice(t["kind"], f"{key}.kind", ("point", "spot"))
    with _under(key):
        if kind == "point":
            _keys(t, "", ("kind", "position", "power"), what="a point light")
            return PointLight(position=t["position"], power=t["power"])
        _keys(t, "", ("kind", "position", "direction", "power", "cone_deg"), what="a spot light")
        return SpotLight(position=t["position"], direction=t["direction"], power=t["power"],
                         cone_deg=t["cone_deg"])


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
    "bust": {
        "center": (_vector, [0.0, 0.0, 0.0]),
        "segments": (lambda v, k: _integer(v, k, lo=8, hi=4096), 384),
        "rings": (lambda v, k: _integer(v, k, lo=4, hi=4096), 200)},
}
_BUILDERS = {"rectangle": meshes.rectangle, "ring": meshes.ring, "bust": meshes.bust}


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


def _parse_object(t, i: int, materials: dict, base: Path) -> SceneObject:
    key = f"objects[{i}]"
    _keys(t, key, ("name", "material"),
          ("mesh", "shape", "normals", "scale", "rotate_deg", "translate"), what="an object")
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
        return SceneObject(name=name, mesh=meshes.placed(mesh, scale=scale, rotate_deg=rotate,
                                                          translate=translate),
                           material=materials[mat])


def _parse_photons(t) -> PhotonSettings:
    fields = ("count", "k", "A", "seed", "max_bounces")
    _keys(t, "photons", (), fields, what="the photon settings")
    with _under("photons"):
        return PhotonSettings(**{k: t[k] for k in fields if k in t})


def _parse(data: dict, base: Path, path: Path | None) -> Scene:
    _keys(data, "", ("camera", "materials", "lights", "objects"), ("photons", "description"),
          what="a scene file")
    description = _string(data["description"], "description", what="a one-line description") \
        if "description" in data else ""
    camera = _parse_camera(data["camera"])
    materials = _parse_materials(data["materials"])
    lights = [_parse_light(t, i) for i, t in enumerate(
        _array_of_tables(data["lights"], "lights", what="a light"))]
    objects, seen = [], {}
    for i, t in enumerate(_array_of_tables(data["objects"], "objects", what="an object")):
        obj = _parse_object(t, i, materials, base)
        if obj.name in seen:
            raise _FieldError(f"objects[{i}].name", f"duplicate object name {obj.name!r} (also "
                              f"objects[{seen[obj.name]}]); expected unique names; rename one")
        seen[obj.name] = i
        objects.append(obj)
    photons = _parse_photons(data.get("photons", {}))
    return Scene(camera=camera, lights=tuple(lights), objects=tuple(objects), photons=photons,
                 path=path, description=description)


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


def load_scene(path: Path | str) -> Scene:
    """Load the scene file at ``path`` (TOML, see the module docstring)."""
    p = Path(path)
    if not p.is_file():
        where = f" (resolved to {str(p.resolve())!r})" if not p.is_absolute() else ""
        what = "is a directory, not a scene file" if p.is_dir() else "scene file not found"
        raise InputError(f"{path}: {what}{where}; give the path of a .toml scene, "
                         "e.g. scenes/ring.toml")
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the scene file: {exc}; check its permissions and "
                         "that it is UTF-8 text") from None
    return parse_scene(text, path=p)
