"""The scene model: camera, materials, lights, objects and photon settings.

Frozen dataclasses that validate their own values (every error an
:class:`~blockhash.errors.InputError` naming the key path); :mod:`.loader`
reads them from a TOML file and documents that format.  Units are metres and
watts, y is up, the frame is right-handed.

The dataclasses are frozen and their arrays read-only; all but
``PhotonSettings`` compare by identity (numpy arrays have no single truth value).
Do not modify an object's mesh in place: trimesh would recompute its vertex
normals from the faces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import trimesh

from blockhash.errors import InputError
from blockhash.scene.materials import SPECULAR_MATERIALS, DielectricMaterial, MirrorMaterial, PhongMaterial  # noqa: F401
from blockhash.scene.values import FieldError as _FieldError
from blockhash.scene.values import fmt as _fmt
from blockhash.scene.values import integer as _integer
from blockhash.scene.values import number as _number
from blockhash.scene.values import owned as _owned
from blockhash.scene.values import readonly as _readonly
from blockhash.scene.values import rgb as _rgb
from blockhash.scene.values import string as _string
from blockhash.scene.values import vector as _vector

#: Largest image side: GL_MAX_TEXTURE_SIZE on llvmpipe (16,384), so a
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
    parallel to it.  ``spp``: samples per pixel, a square number (None: the
    renderer's default, :data:`blockhash.scene.camera.DEFAULT_SPP`).
    """

    eye: np.ndarray
    target: np.ndarray
    up: np.ndarray
    fov_y_deg: float
    width: int
    height: int
    spp: int | None = None

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
            if self.spp is not None:
                from blockhash.scene.camera import MAX_SPP, spp_side
                spp = _integer(self.spp, "spp", lo=1, hi=MAX_SPP,
                               hint="give a square number of samples per pixel: 1, 4, 9, 16, ...")
                try:
                    spp_side(spp)
                except InputError as exc:
                    raise _FieldError("spp", str(exc)) from None
                set_(self, "spp", spp)
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
class AreaLight:
    """A diffuse (Lambertian) emitter: the object named ``object`` emits ``radiance`` (3,)
    W m^-2 sr^-1 RGB from the front of each face (where its face normal points, the
    counter-clockwise winding), as Mitsuba's ``area`` emitter.  ``mesh`` is that object's
    mesh (the :class:`Scene` checks that it is the object's); the power is
    ``pi * radiance * area``.  Built by the loader from an object's ``emission``."""

    object: str
    mesh: trimesh.Trimesh
    radiance: np.ndarray

    def __post_init__(self):
        with _owned(f"AreaLight {self.object!r}" if isinstance(self.object, str) else "AreaLight"):
            _string(self.object, "object", what="the emitting object's name")
            if not isinstance(self.mesh, trimesh.Trimesh):
                raise _FieldError("mesh", f"expected a trimesh.Trimesh; got {type(self.mesh).__name__}")
            check_mesh(self.mesh, "mesh")
            radiance = _rgb(self.radiance, "emission", what="emitted radiance in W m^-2 sr^-1")
            if not radiance.any():
                raise _FieldError("emission", "the light emits nothing (radiance 0 in every "
                                  "channel); expected W m^-2 sr^-1 > 0 in at least one channel, "
                                  "or leave emission out for an object that does not emit")
            object.__setattr__(self, "radiance", radiance)
            tri = np.asarray(self.mesh.triangles, dtype=np.float64)
            cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            areas = 0.5 * np.linalg.norm(cross, axis=1)
            total = float(areas.sum())
            if not total > 0.0 or not math.isfinite(total):
                raise _FieldError("mesh", f"the emitting mesh has zero area ({len(areas):,} "
                                  "degenerate triangles); an area light needs triangles of "
                                  "positive area: fix the mesh or its scale")
            live = areas > 0.0
            normals = np.zeros_like(cross)
            normals[live] = cross[live] / (2.0 * areas[live, None])
            object.__setattr__(self, "_triangles", _readonly(tri))
            object.__setattr__(self, "_areas", _readonly(areas))
            object.__setattr__(self, "_normals", _readonly(normals))

    @property
    def triangles(self) -> np.ndarray:
        """(n, 3, 3) float64: the emitting triangles' corners."""
        return self._triangles

    @property
    def face_areas(self) -> np.ndarray:
        """(n,) float64 square metres (0 for a degenerate triangle, which emits nothing)."""
        return self._areas

    @property
    def face_normals(self) -> np.ndarray:
        """(n, 3) unit front-face normals (zeros for a degenerate triangle)."""
        return self._normals

    @property
    def area(self) -> float:
        return float(self._areas.sum())

    @property
    def power(self) -> np.ndarray:
        """(3,) watts: pi * radiance * area (Lambertian emission from one face)."""
        return math.pi * self.radiance * self.area

    def __repr__(self) -> str:
        return (f"AreaLight(object={self.object!r}, radiance={_fmt(self.radiance)}, "
                f"area={self.area:.6g} m^2)")


@dataclass(frozen=True, eq=False)
class DirectionalLight:
    """Sunlight: parallel light travelling along ``direction`` (3,) (normalised), of
    ``irradiance`` (3,) W m^-2 RGB on a surface perpendicular to it, as Mitsuba's
    ``directional`` emitter."""

    direction: np.ndarray
    irradiance: np.ndarray

    def __post_init__(self):
        with _owned("DirectionalLight"):
            d = _vector(self.direction, "direction", unit="a direction")
            length = float(np.linalg.norm(d))
            if length == 0.0:
                raise _FieldError("direction", "expected a non-zero direction the light travels "
                                  "along; got (0, 0, 0); e.g. [0, -1, 0] for light from straight "
                                  "above")
            object.__setattr__(self, "direction", _readonly(d / length))
            e = _rgb(self.irradiance, "irradiance", what="irradiance in W m^-2")
            if not e.any():
                raise _FieldError("irradiance", "the light emits nothing (irradiance 0 in every "
                                  "channel); expected W m^-2 > 0 in at least one channel")
            object.__setattr__(self, "irradiance", e)

    def __repr__(self) -> str:
        return (f"DirectionalLight(direction={_fmt(self.direction)}, "
                f"irradiance={_fmt(self.irradiance)})")


#: The light classes a :class:`Scene` takes.
LIGHTS = (PointLight, SpotLight, AreaLight, DirectionalLight)


@dataclass(frozen=True, eq=False)
class SceneObject:
    """A named triangle mesh with a material.  ``mesh.vertex_normals`` are the
    normals to shade with (smooth radial ones on the ring's walls, flat on
    planes, the smooth surface's on the bust)."""

    name: str
    mesh: trimesh.Trimesh
    material: PhongMaterial | MirrorMaterial | DielectricMaterial

    def __post_init__(self):
        with _owned("SceneObject"):
            _string(self.name, "name", what="the object's name")
            if not isinstance(self.mesh, trimesh.Trimesh):
                raise _FieldError("mesh", f"expected a trimesh.Trimesh; got {type(self.mesh).__name__}")
            check_mesh(self.mesh, "mesh")
            if not isinstance(self.material, (PhongMaterial, *SPECULAR_MATERIALS)):
                raise _FieldError("material", "expected a PhongMaterial, MirrorMaterial or "
                                  f"DielectricMaterial; got {type(self.material).__name__}")

    @property
    def is_specular(self) -> bool:
        return isinstance(self.material, SPECULAR_MATERIALS)

    @property
    def is_dielectric(self) -> bool:
        return isinstance(self.material, DielectricMaterial)

    def __repr__(self) -> str:
        return (f"SceneObject(name={self.name!r}, mesh=<{len(self.mesh.vertices):,} vertices, "
                f"{len(self.mesh.faces):,} triangles>, material={self.material!r})")


#: Specular events a photon follows unless the scene says: 4, or 8 in a scene that holds a
#: dielectric (a path through a glass ball is already two events; internal reflections
#: add more).
MAX_BOUNCES = 4
DIELECTRIC_MAX_BOUNCES = 8


@dataclass(frozen=True)
class PhotonSettings:
    """Photon tracing and lookup settings: ``count`` photons to store (a
    target), ``k`` photons per estimate, accuracy multiplier ``A`` (section
    4.3), ``seed``, and ``max_bounces`` specular events (mirror bounces, glass
    reflections and refractions) followed per photon; None lets the
    :class:`Scene` choose: :data:`MAX_BOUNCES`, or :data:`DIELECTRIC_MAX_BOUNCES`
    when it holds a dielectric."""

    count: int = 200_000
    k: int = 50
    A: int = 8
    seed: int = 1
    max_bounces: int | None = None

    def __post_init__(self):
        with _owned("PhotonSettings"):
            _integer(self.count, "count", lo=1)
            _integer(self.k, "k", lo=1, hi=self.count,
                     hint="k cannot exceed the photon count; lower k or raise count")
            _integer(self.A, "A", lo=1)
            _integer(self.seed, "seed", lo=0, hi=2**63 - 1)
            names = ["count", "k", "A", "seed"]
            if self.max_bounces is not None:
                _integer(self.max_bounces, "max_bounces", lo=1)
                names.append("max_bounces")
            for name in names:
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
                raise _FieldError("lights", "the scene has no light; add a [[lights]] table "
                                  "or an object with emission = [r, g, b]")
            if not self.objects:
                raise _FieldError("objects", "the scene has no object; add an [[objects]] table")
            names = [o.name for o in self.objects]
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise _FieldError("objects", f"object names must be unique; {dup} used more than once")
            _check_lights(self.lights, self.objects)
            if self.photons.max_bounces is None:
                glass = any(o.is_dielectric for o in self.objects)
                object.__setattr__(self, "photons", replace(
                    self.photons, max_bounces=DIELECTRIC_MAX_BOUNCES if glass else MAX_BOUNCES))

    @property
    def specular_objects(self) -> tuple[SceneObject, ...]:
        """Objects with a :class:`MirrorMaterial` or :class:`DielectricMaterial` (they cast
        the caustics)."""
        return tuple(o for o in self.objects if o.is_specular)

    @property
    def diffuse_objects(self) -> tuple[SceneObject, ...]:
        """Objects with a :class:`PhongMaterial` (they receive the caustics)."""
        return tuple(o for o in self.objects if isinstance(o.material, PhongMaterial))

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float64: the box around every object's mesh, [min, max]."""
        boxes = np.array([o.mesh.bounds for o in self.objects])
        return np.stack([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])

    def with_size(self, width: int, height: int) -> "Scene":
        """The same scene with the camera's image ``width`` x ``height`` (Camera checks them)."""
        return replace(self, camera=replace(self.camera, width=width, height=height))

    def summary(self) -> str:
        """A few lines describing the scene, for the command line."""
        c = self.camera
        lines = [f"scene {self.path if self.path else '(from text)'}"
                 + (f": {self.description}" if self.description else ""),
                 f"  camera  eye {_fmt(c.eye)} -> target {_fmt(c.target)}, up {_fmt(c.up)}, "
                 f"fov {c.fov_y_deg:g} deg, {c.width} x {c.height}"]
        for light in self.lights:
            if isinstance(light, AreaLight):
                lines.append(f"  light   area on {light.object!r}, radiance {_fmt(light.radiance)} "
                             f"W/m^2/sr, {light.area:.4g} m^2, power {_fmt(light.power)} W")
            elif isinstance(light, DirectionalLight):
                lines.append(f"  light   directional along {_fmt(light.direction)}, irradiance "
                             f"{_fmt(light.irradiance)} W/m^2")
            elif isinstance(light, SpotLight):
                lines.append(f"  light   spot at {_fmt(light.position)} along {_fmt(light.direction)}, "
                             f"cone {light.cone_deg:g} deg, power {_fmt(light.power)} W")
            else:
                lines.append(f"  light   point at {_fmt(light.position)}, power {_fmt(light.power)} W")
        width = max(len(o.name) for o in self.objects)
        for o in self.objects:
            m = o.material
            mat = (f"mirror, reflectance {_fmt(m.reflectance)}" if isinstance(m, MirrorMaterial)
                   else f"dielectric, ior {m.ior:g}, tint {_fmt(m.tint)}"
                   if isinstance(m, DielectricMaterial)
                   else f"phong, kd {_fmt(m.kd)}, ks {_fmt(m.ks)}, n {m.n:g}"
                   + (", one-sided" if m.one_sided else ""))
            lines.append(f"  object  {o.name:<{width}}  {len(o.mesh.faces):>9,} triangles  {mat}")
        p = self.photons
        lines.append(f"  photons {p.count:,} stored, k {p.k}, A {p.A}, seed {p.seed}, "
                     f"max {p.max_bounces} bounces")
        lo, hi = self.bounds
        lines.append(f"  bounds  {_fmt(lo)} .. {_fmt(hi)} m")
        if not self.specular_objects:
            lines.append("  note    no specular (mirror or glass) object: the scene has no caustics")
        return "\n".join(lines)

    def __repr__(self) -> str:
        return (f"Scene(path={str(self.path) if self.path else None!r}, {len(self.lights)} light(s), "
                f"objects={[o.name for o in self.objects]}, photons={self.photons!r})")


def _check_lights(lights, objects) -> None:
    """Each light one of :data:`LIGHTS`; an area light's object in the scene, with its mesh,
    and not a mirror or glass (blockhash's emitters are diffuse surfaces)."""
    by_name = {o.name: o for o in objects}
    emitting = set()
    for i, light in enumerate(lights):
        if not isinstance(light, LIGHTS):
            raise _FieldError(f"lights[{i}]", "expected a PointLight, SpotLight, AreaLight or "
                              f"DirectionalLight; got {type(light).__name__}")
        if not isinstance(light, AreaLight):
            continue
        obj = by_name.get(light.object)
        if obj is None:
            raise _FieldError(f"lights[{i}]", f"area light on object {light.object!r}, which the "
                              f"scene does not hold (objects: {sorted(by_name)}); add the object "
                              "or name one of those")
        if obj.is_specular:
            kind = "glass" if obj.is_dielectric else "mirror"
            raise _FieldError(f"lights[{i}]", f"area light on object {light.object!r}, a {kind}: "
                              "blockhash's emitters are diffuse surfaces; give the emitting "
                              "object a phong material, or put the light on another object")
        if light.mesh is not obj.mesh:
            raise _FieldError(f"lights[{i}]", f"area light on object {light.object!r} with a mesh "
                              "other than the object's; build it with AreaLight(object, "
                              "obj.mesh, radiance)")
        if light.object in emitting:
            raise _FieldError(f"lights[{i}]", f"object {light.object!r} carries two area lights; "
                              "give it one emission")
        emitting.add(light.object)


# --------------------------------------------------------------------------- meshes

def check_mesh(mesh: trimesh.Trimesh, key: str) -> None:
    if len(mesh.faces) == 0:
        raise _FieldError(key, "the mesh is empty (0 triangles); expected at least one triangle")
    if not np.isfinite(mesh.vertices).all():
        raise _FieldError(key, "the mesh has NaN or infinite vertex coordinates; fix the mesh")
